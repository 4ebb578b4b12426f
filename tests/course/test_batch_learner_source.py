"""A batch's report says where the learner id whose quiz numbers it graded came from: the roster's row, or the
submission's own name; never --learner, which grade batch does not have."""

from __future__ import annotations

import json

from click.testing import CliRunner

from grader.faces.cli import main
from tests.support import chapter_submission


def test_the_report_names_the_true_source_of_the_learner_id(tmp_path):
    submissions = tmp_path / "submissions"
    for name in ("ann-smith", "cy"):
        chapter_submission(submissions / name, name)
    roster = tmp_path / "roster.csv"
    roster.write_text("submission,learner\nann-smith,ann\n", encoding="utf-8")
    out = tmp_path / "out"
    done = CliRunner().invoke(main, ["batch", str(submissions), "--out", str(out), "--roster", str(roster),
                                     "--chapters", "ch00", "--no-html"])
    assert (out / "ann" / "report.json").is_file(), done.output
    said = {who: json.loads((out / who / "report.json").read_text(encoding="utf-8"))["learner"]
            for who in ("ann", "cy")}
    assert said == {"ann": "ann (from the roster roster.csv, line 2)", "cy": "cy (from the name of cy)"}
