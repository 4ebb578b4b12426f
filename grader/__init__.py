"""Auto-grader for the lesson "Jacobians & Linearization"."""

__version__ = "0.1.0"  # pyproject.toml reads it (a handout's wheel adds its own local label)


def load_ipython_extension(ipython) -> None:
    """`%load_ext grader` in IPython or Jupyter: the `%grade` magic (grader.faces.magic)."""
    from grader.faces.magic import load

    load(ipython)


def unload_ipython_extension(ipython) -> None:
    from grader.faces.magic import unload

    unload(ipython)
