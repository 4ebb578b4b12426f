"""One module per chapter (`chNN.py`), each defining `CHECKS`, a ChapterChecks."""

from __future__ import annotations

import importlib

from grader.checks.base import ChapterChecks


def load(chapter_id: str) -> ChapterChecks:
    """The checks of chapter `chapter_id` ('ch06')."""
    return importlib.import_module(f"grader.checks.{chapter_id}").CHECKS
