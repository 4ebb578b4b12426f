"""Operations on a course: batch grading, its history and class outputs, regrades, overrides, statistics,
similarity, releases, submission archives, Gradescope, GitHub Classroom, a Dask cluster and the selftest."""
