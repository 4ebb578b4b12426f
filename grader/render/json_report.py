"""The JSON renderer: the stable schema instructor tooling relies on (see README)."""

from __future__ import annotations

import json

from grader.model import Report


def render(report: Report) -> str:
    return json.dumps(report.to_dict(), indent=2, allow_nan=False) + "\n"
