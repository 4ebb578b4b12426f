"""Reference solutions of the lesson "Jacobians & Linearization" (the grader's references)."""
