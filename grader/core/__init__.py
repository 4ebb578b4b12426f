"""The core: one transaction grades one submission (the boundary, the report, overrides and the late
penalty), built on the pipeline, the grading of code checks, their planning and the verdict memo."""
