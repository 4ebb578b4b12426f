"""A gradebook.db an earlier grader wrote (no settings kept per run, no reports kept) is read on: its columns are added
when it is opened, a regrade compares with the report.json files that grader wrote, and the next batch grades every
learner once and keeps what it graded from then on."""

from __future__ import annotations

import sqlite3

from click.testing import CliRunner

from grader.faces.cli import main
from tests.support import chapter_submission


def test_a_history_from_an_earlier_grader_is_read_on(tmp_path):
    for learner in ("ann", "bo"):
        chapter_submission(tmp_path / "submissions" / learner, learner)
    out = tmp_path / "out"
    arguments = ["batch", str(tmp_path / "submissions"), "--out", str(out), "--chapters", "ch00", "--no-html"]
    assert CliRunner().invoke(main, arguments).exit_code == 0
    with sqlite3.connect(out / "gradebook.db") as db:  # as the earlier grader left it
        db.execute("DROP TABLE reports")
        for table, column in (("runs", "settings"), ("results", "report"), ("results", "manifest"),
                              ("results", "seconds"), ("results", "time_from")):
            db.execute(f"ALTER TABLE {table} DROP COLUMN {column}")
    done = CliRunner().invoke(main, ["regrade", str(out)])
    assert done.exit_code == 0, done.output
    assert "kept no record of what it graded with" in done.output and "No learner's grade" in done.output
    done = CliRunner().invoke(main, arguments)
    assert done.exit_code == 0 and "2 graded" in done.output, done.output  # nothing kept to reuse: graded once
    done = CliRunner().invoke(main, arguments)
    assert done.exit_code == 0 and "2 unchanged" in done.output, done.output
