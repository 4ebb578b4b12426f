"""Your answers to the lesson "Jacobians & Linearization": fill in each chapter's functions."""
