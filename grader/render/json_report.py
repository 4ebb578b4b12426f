"""The JSON renderer: the stable schema instructor tooling relies on (docs/pages/json.md)."""

from __future__ import annotations

from grader import safe_text
from grader.model import Report


def render(report: Report) -> str:
    """The report as JSON that is valid UTF-8 whatever learner text it holds."""
    return safe_text.json_text(report.to_dict(), indent=2) + "\n"
