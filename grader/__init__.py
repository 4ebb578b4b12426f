"""Auto-grader for the lesson "Jacobians & Linearization"."""
