"""`python -m grader` is the `grade` command."""

from grader.faces.launch import main

main()
