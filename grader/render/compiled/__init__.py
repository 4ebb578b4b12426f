"""The report's templates compiled by jinja2, one module each, written by `python -m grader.render.html` and used
only where they match the templates' text (grader.render.precompiled)."""
