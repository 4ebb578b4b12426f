"""The JSON renderer: the stable schema instructor tooling relies on (see README)."""

from __future__ import annotations

import json

from grader import safe_text
from grader.model import Report


def render(report: Report) -> str:
    """The report as JSON that is valid UTF-8 whatever learner text it holds."""
    return json.dumps(safe_text.for_json(report.to_dict()), indent=2, allow_nan=False) + "\n"
