"""Renderers: each turns a Report (grader.model) into one output format, reading only the model."""
