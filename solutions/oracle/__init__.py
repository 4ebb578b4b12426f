"""What the checks compare against beyond the reference solutions: the instructor-side oracle.

Each chNN module answers the questions grader/checks/chNN.py asks through grader.judging.expected (the
reference solution of the chapter answers the rest). Never part of a release.
"""
