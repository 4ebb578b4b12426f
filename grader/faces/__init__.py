"""The grader's faces: the `grade` command (its launcher and click layer), the watch, the notebook's
`%grade` and its grading process. They parse what a person asks and print what the layers below decide."""
