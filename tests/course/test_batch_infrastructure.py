"""An infrastructure failure is never a grade. A sandbox that does not start stops `grade batch` before
any learner (exit status 2, unless --no-sandbox); a learner whose child fails to start once is graded
on the retry; one whose child never starts is `error` with empty score cells, keeps no grade file and
is graded by the next run. The failures are real: a `bwrap` first on PATH that fails on the calls a
file names and otherwise runs the real bubblewrap."""

from __future__ import annotations

import csv
import json
import os
import subprocess
from pathlib import Path

import pytest

from tests.support import (
    REAL_BWRAP,
    FakeBwrap,
    build_submission,
    code_points,
    run_grade,
)

pytestmark = pytest.mark.skipif(REAL_BWRAP is None and not os.environ.get("CI"),
                                reason="bubblewrap (bwrap) is not installed")


def _batch(submissions: Path, out: Path, *extra: str, env: dict | None = None) -> subprocess.CompletedProcess:
    return run_grade("batch", submissions, "--out", out, "--chapters", "ch06", "--jobs", "1", "--no-html", *extra,
                     env=env)


def _rows(out: Path) -> dict[str, dict]:
    with open(out / "gradebook.csv", newline="", encoding="utf-8") as handle:
        return {row["learner"]: row for row in csv.DictReader(handle)}


@pytest.fixture
def submissions(tmp_path):
    folder = tmp_path / "submissions"
    build_submission(folder / "alice")
    return folder


@pytest.mark.slow
def test_a_sandbox_that_does_not_start_stops_the_batch_before_any_learner(submissions, tmp_path):
    fake = FakeBwrap(tmp_path / "fake", failing=range(1, 100))
    out = tmp_path / "out"
    done = _batch(submissions, out, env=fake.env)
    assert done.returncode == 2, done.stdout + done.stderr
    assert "no learner was graded" in done.stderr and "fake failure 1" in done.stderr
    assert "--no-sandbox" in done.stderr and "Traceback" not in done.stderr
    assert fake.calls == 1  # the probe, and nothing after it
    assert not out.exists() or not any(out.rglob("report.json")) and not (out / "gradebook.csv").exists()
    # the instructor's explicit choice: no sandbox, and every line says so
    done = _batch(submissions, out, "--no-sandbox", env=fake.env)
    assert done.returncode == 0, done.stdout + done.stderr
    assert fake.calls == 1
    assert done.stderr.count("no sandbox (turned off with --no-sandbox)") == 2
    assert "turned off with --no-sandbox" in (out / "summary.html").read_text(encoding="utf-8")
    assert _rows(out)["alice"]["ch06_code"] == code_points("ch06")


@pytest.mark.slow
def test_a_child_that_fails_to_start_once_is_started_again_and_the_learner_graded(submissions, tmp_path):
    fake = FakeBwrap(tmp_path / "fake", failing=[2])  # 1: the probe; 2: the worker's fork server
    out = tmp_path / "out"
    done = _batch(submissions, out, env=fake.env)
    assert done.returncode == 0, done.stdout + done.stderr
    assert fake.calls == 3
    row = _rows(out)["alice"]
    assert row["status"] == "graded" and row["ch06_code"] == code_points("ch06") and row["message"] == ""


@pytest.mark.slow
def test_a_child_that_never_starts_is_an_error_never_a_zero_and_the_next_run_grades_it(submissions, tmp_path):
    fake = FakeBwrap(tmp_path / "fake", failing=range(2, 100))
    out = tmp_path / "out"
    done = _batch(submissions, out, env=fake.env)
    assert done.returncode == 1, done.stdout + done.stderr
    assert fake.calls == 3  # the probe, the first attempt and the retry
    row = _rows(out)["alice"]
    assert row["status"] == "error" and "failed to start" in row["message"], row
    assert row["ch06_code"] == row["ch06_quiz"] == row["total"] == row["max_total"] == ""
    assert "alice: not graded" in done.stderr
    report = json.loads((out / "alice" / "report.json").read_text(encoding="utf-8"))
    assert "failed to start" in report["infrastructure"] and "hash" not in report["batch"]
    assert not (out / "alice" / "results.json").exists()  # nothing that looks like a grade
    assert "alice" not in (out / "junit.xml").read_text(encoding="utf-8")
    assert "failed to start" in (out / "summary.html").read_text(encoding="utf-8")
    # the next run (the sandbox works again) grades alice: a failure is never kept as "unchanged"
    done = _batch(submissions, out)
    assert done.returncode == 0 and "graded 1" in done.stdout, done.stdout + done.stderr
    row = _rows(out)["alice"]
    assert row["status"] == "graded" and row["ch06_code"] == code_points("ch06") and row["message"] == ""
    assert (out / "alice" / "results.json").exists()
