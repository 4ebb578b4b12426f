"""grade regrade OUT: a real batch graded, then graded again from its stored submissions by today's grader; it
lists exactly the learners whose verdicts move (a key's tolerance changed in a copy of the project), changes
nothing until --apply, which records a run with its reason; a grader that did not change changes nothing."""

from __future__ import annotations

import csv
import hashlib
import json
import os
import re
import shutil
import sqlite3
from pathlib import Path

import pytest

from tests.support import REPO, build_submission, run_grade

QUESTION = "bearing_variance"  # key: 1 / r^2 for the learner's own r, to 3 significant digits (rtol 5e-3)


def _key(learner: str) -> float:
    from grader.quiz import bank

    question = next(q for q in bank.questions("ch06") if q.id == QUESTION)
    return 1 / question.values_for(learner, "ch06")["r"] ** 2


def _learner(folder: Path, learner: str, answer: str | None) -> None:
    """A submission of the reference code with learner.yaml naming `learner` and, where given, their answer."""
    build_submission(folder / learner)
    answers = folder / learner / "exercises" / "answers"
    answers.mkdir(parents=True, exist_ok=True)
    (answers / "learner.yaml").write_text(f"learner: {learner}\n", encoding="utf-8")
    if answer is not None:
        (answers / "ch06.yaml").write_text(f"{QUESTION}: {answer}\n", encoding="utf-8")


def _class(folder: Path) -> Path:
    """ann answers to 4 digits (right under any tolerance), bo 1% off (wrong at 3 significant digits, right at
    2), cy the reciprocal (wrong), dee nothing."""
    _learner(folder, "ann", f"{_key('ann'):.4g}")
    _learner(folder, "bo", f"{_key('bo') * 1.01:.4g}")
    _learner(folder, "cy", f"{1 / _key('cy'):.4g}")
    _learner(folder, "dee", None)
    return folder


def _files(out: Path) -> dict[str, str]:
    """Every file in OUT but regrade.csv, by path: its SHA-256 (the history's database by its rows)."""
    found = {}
    for path in sorted(out.rglob("*")):
        if path.is_file() and path.name != "regrade.csv" and not path.name.startswith("gradebook.db"):
            found[path.relative_to(out).as_posix()] = hashlib.sha256(path.read_bytes()).hexdigest()
    found["gradebook.db"] = repr(_rows(out, "SELECT * FROM runs") + _rows(out, "SELECT * FROM results"))
    return found


def _rows(out: Path, query: str) -> list:
    with sqlite3.connect(out / "gradebook.db") as db:
        return db.execute(query).fetchall()


def _regrade_rows(out: Path) -> list[dict]:
    with (out / "regrade.csv").open(newline="", encoding="utf-8") as handle:
        return list(csv.DictReader(handle))


def test_a_learners_comparison_names_each_check_that_moves_and_nothing_else():
    from grader.course.regrade import compare
    from grader.model import ChapterResult, CheckResult, Report, Status

    def report(status: Status, points: float, grader: str, extra: bool = False) -> Report:
        checks = [CheckResult("quiz_bearing_variance", "bearing_variance", "", status, points, 1, kind="quiz"),
                  CheckResult("H_worked_example", "H_jacobian", "", Status.PASS, 2, 2)]
        if extra:
            checks.append(CheckResult("H_new", "H_jacobian", "", Status.FAIL, 0, 1))
        return Report("bo", [ChapterResult("ch06", "", checks)], grader=grader)

    same = compare("bo", 2, report(Status.FAIL, 0, "g1"), report(Status.FAIL, 0, "g2"))
    assert not same.moves and same.checks == [] and same.why == ""  # another grader, the same verdicts
    moved = compare("bo", 2, report(Status.FAIL, 0, "g1"), report(Status.PASS, 1, "g2", extra=True))
    assert moved.moves and moved.new_score == 3 and moved.checks == ["ch06/quiz_bearing_variance", "ch06/H_new"]
    assert moved.why == "ch06/quiz_bearing_variance fail -> pass (+1); ch06/H_new graded now: fail (0); grader g1 -> g2"
    failed = compare("bo", 2, report(Status.FAIL, 0, "g1"), None, "the sandbox did not start")
    assert failed.moves and failed.new_score is None and "could not be graded again" in failed.why


@pytest.mark.slow
def test_a_regrade_with_an_unchanged_grader_changes_nothing(tmp_path):
    submissions = _class(tmp_path / "submissions")
    out = tmp_path / "out"
    done = run_grade("batch", submissions, "--out", out, "--chapters", "ch06", "--no-html")
    assert done.returncode == 0, done.stderr[-3000:]
    before = _files(out)
    done = run_grade("regrade", out)
    assert done.returncode == 0, done.stderr[-3000:]
    assert "Graded 4 learners of run 1 again" in done.stdout
    assert "No learner's grade, check verdict or adjustment would change." in done.stdout
    assert _regrade_rows(out) == [] and (out / "regrade.csv").read_text(encoding="utf-8").startswith(
        "learner,old_score,new_score,checks_changed,why")
    assert _files(out) == before  # not a byte of the batch's outputs, not a row of its history
    done = run_grade("regrade", out, "--apply")
    assert done.returncode == 2 and "--reason" in done.stderr  # --apply says why, always
    assert _files(out) == before


@pytest.mark.slow
def test_a_changed_tolerance_lists_exactly_the_learners_whose_verdicts_move_and_apply_records_it(tmp_path):
    project = tmp_path / "project"  # a copy of the grader, its references and its keys: the one changed here
    for part in ("grader", "solutions", "quizzes"):
        shutil.copytree(REPO / part, project / part, ignore=shutil.ignore_patterns("__pycache__"))
    env = dict(os.environ, PYTHONPATH=str(project))
    submissions = _class(tmp_path / "submissions")
    out = tmp_path / "out"
    (out).mkdir()
    (out / "overrides.csv").write_text("learner,target,points,reason,who\ncy,total,1,extra credit,the instructor\n",
                                       encoding="utf-8")
    done = run_grade("batch", submissions, "--out", out, "--chapters", "ch06", "--no-html", cwd=project, env=env)
    assert done.returncode == 0, done.stderr[-3000:]
    old = {row[0]: row[1] for row in _rows(out, "SELECT learner, score FROM results WHERE run = 1")}
    keys = project / "quizzes" / "keys" / "ch06.yaml"
    text = keys.read_text(encoding="utf-8")
    widened = re.sub(rf"({QUESTION}:\n(?:  .*\n)*?  rtol: )5\.0e-3", r"\g<1>2.0e-2", text)
    assert widened != text
    keys.write_text(widened, encoding="utf-8")  # the instructor widens the tolerance to 2 significant digits
    before = _files(out)

    done = run_grade("regrade", out, cwd=project, env=env)
    assert done.returncode == 0, done.stderr[-3000:]
    rows = _regrade_rows(out)
    assert [row["learner"] for row in rows] == ["bo"], done.stdout
    assert float(rows[0]["new_score"]) == float(rows[0]["old_score"]) + 1 == old["bo"] + 1
    assert rows[0]["checks_changed"] == f"ch06/quiz_{QUESTION}"
    assert f"ch06/quiz_{QUESTION} fail -> pass (+1)" in rows[0]["why"] and "grader 0.1.0+" in rows[0]["why"]
    assert "1 learner's grade would change:\n  bo: " in done.stdout
    assert _files(out) == before  # nothing but regrade.csv

    done = run_grade("regrade", out, "--apply", "--reason", "bearing_variance to 2 significant digits", cwd=project,
                     env=env)
    assert done.returncode == 0, done.stderr[-3000:]
    assert [row["learner"] for row in _regrade_rows(out)] == ["bo"]
    runs = _rows(out, "SELECT id, reason, finished IS NOT NULL FROM runs")
    assert runs == [(1, None, 1), (2, "bearing_variance to 2 significant digits", 1)]
    new = {row[0]: row[1] for row in _rows(out, "SELECT learner, score FROM results WHERE run = 2")}
    assert new == {**old, "bo": old["bo"] + 1}  # cy keeps the override's point
    graders = [row[0] for row in _rows(out, "SELECT grader FROM runs ORDER BY id")]
    why = f"regrade (bearing_variance to 2 significant digits); grader {graders[0]} -> {graders[1]}"
    assert _rows(out, "SELECT learner, delta, why FROM changes WHERE run = 2") == [("bo", 1.0, why)]
    report = json.loads((out / "bo" / "report.json").read_text(encoding="utf-8"))
    check = next(c for ch in report["chapters"] for c in ch["checks"] if c["id"] == f"quiz_{QUESTION}")
    assert check["status"] == "pass" and report["score"] == old["bo"] + 1
    with (out / "gradebook.csv").open(newline="", encoding="utf-8") as handle:
        gradebook = {row["learner"]: row for row in csv.DictReader(handle)}
    assert float(gradebook["bo"]["total"]) == old["bo"] + 1 and float(gradebook["cy"]["total"]) == old["cy"]
    assert json.loads((out / "bo" / "results.json").read_text(encoding="utf-8"))["score"] == old["bo"] + 1
    unchanged = {k: v for k, v in _files(out).items() if k.startswith(("ann/", "cy/", "dee/", ".staging/"))}
    assert unchanged == {k: v for k, v in before.items() if k.startswith(("ann/", "cy/", "dee/", ".staging/"))}

    done = run_grade("regrade", out, cwd=project, env=env)  # the applied grades are today's: nothing moves now
    assert done.returncode == 0 and _regrade_rows(out) == [], done.stdout
    done = run_grade("batch", submissions, "--out", out, "--chapters", "ch06", "--no-html", cwd=project, env=env)
    assert done.returncode == 0 and "1 unchanged" in done.stdout, done.stdout  # bo's regrade is today's grade


# ------------------------------------------------------------------------------------ what a regrade grades with

DEADLINE_COURSE = """\
course: regrade-course
seed: 424242
deadline: "2026-05-01T23:59:00+00:00"
late_penalty: {per_day: 0.1, max: 0.5}
"""


def _late_class(tmp_path: Path) -> tuple[Path, Path, Path]:
    """ann on time and dee two days late, each handing in ch00; a roster with their times, a course file with the
    deadline and an overrides file waiving dee's penalty, all outside OUT: (submissions, roster, course file)."""
    from tests.support import chapter_submission

    submissions = tmp_path / "submissions"
    for learner in ("ann", "dee"):
        chapter_submission(submissions / learner, learner)
    roster = tmp_path / "roster.csv"
    roster.write_text("submission,learner,submitted\nann,ann,2026-05-01T12:00:00+00:00\n"
                      "dee,dee,2026-05-03T12:00:00+00:00\n", encoding="utf-8")
    course = tmp_path / "course.yaml"
    course.write_text(DEADLINE_COURSE, encoding="utf-8")
    (tmp_path / "overrides.csv").write_text("learner,target,points,factor,reason,who\n"
                                            "dee,late,,0,accommodation: extension to Friday,the instructor\n",
                                            encoding="utf-8")
    (tmp_path / "overrides-nodee.csv").write_text("learner,target,points,factor,reason,who\n", encoding="utf-8")
    return submissions, roster, course


def _invoke(*args: object):
    from click.testing import CliRunner

    from grader.faces.cli import main

    return CliRunner().invoke(main, [str(a) for a in args])


def _totals(out: Path) -> dict[str, dict[str, str]]:
    """Each learner's total in gradebook.csv, Moodle's and Canvas' gradebooks (Canvas': its late penalty column)."""
    def rows(name: str) -> list[dict]:
        with (out / name).open(newline="", encoding="utf-8") as handle:
            return list(csv.DictReader(handle))

    totals: dict[str, dict[str, str]] = {}
    for row in rows("gradebook.csv"):
        totals.setdefault(row["learner"], {})["gradebook"] = row["total"]
    for row in rows("gradebook-moodle.csv"):
        totals[row["Learner id"]]["moodle"] = next(v for k, v in row.items() if k.startswith("Total"))
    for row in rows("gradebook-canvas.csv")[1:]:
        totals[row["SIS Login ID"]]["canvas late"] = row["Late penalty and total overrides"]
    return totals


def test_after_regrade_apply_canvas_and_moodle_show_the_new_grades_too(tmp_path):
    """A batch for Canvas and Moodle with dee's late penalty waived; the waiver withdrawn by a regrade that names the
    overrides without it, applied: every gradebook shows dee's penalty (the class outputs are rebuilt, all of them)."""
    submissions, roster, course = _late_class(tmp_path)
    out = tmp_path / "out"
    done = _invoke("batch", submissions, "--out", out, "--chapters", "ch00", "--roster", roster, "--course", course,
                   "--overrides", tmp_path / "overrides.csv", "--lms", "canvas", "--lms", "moodle", "--no-html")
    assert done.exit_code == 0, done.output
    before = _totals(out)
    full = float(before["dee"]["gradebook"])  # not late, as waived
    assert before["dee"] == {"gradebook": f"{full:g}", "moodle": f"{full:g}", "canvas late": "0"}
    done = _invoke("regrade", out, "--course", course, "--overrides", tmp_path / "overrides-nodee.csv", "--apply",
                   "--reason", "dee's extension withdrawn")
    assert done.exit_code == 0, done.output
    assert "overrides: " in done.output and "1 row fewer" in done.output  # the difference named, and shown
    after = _totals(out)
    assert after["dee"] == {"gradebook": f"{0.8 * full:g}", "moodle": f"{0.8 * full:g}",
                            "canvas late": f"{-0.2 * full:g}"}
    assert after["ann"] == before["ann"]


def test_a_regrade_grades_with_what_the_batch_ran_with_unless_told_otherwise(tmp_path):
    """The batch read a course file and an overrides file outside OUT; `grade regrade OUT` with nothing named grades
    with them (as the history keeps them) and moves nobody, also after those files changed on disk; --apply records
    a run that moves nobody."""
    submissions, roster, course = _late_class(tmp_path)
    out = tmp_path / "out"
    done = _invoke("batch", submissions, "--out", out, "--chapters", "ch00", "--roster", roster, "--course", course,
                   "--overrides", tmp_path / "overrides.csv", "--no-html")
    assert done.exit_code == 0, done.output
    (tmp_path / "overrides.csv").write_text("learner,target,points,factor,reason,who\n", encoding="utf-8")
    course.write_text(DEADLINE_COURSE.replace("per_day: 0.1", "per_day: 0.3"), encoding="utf-8")
    done = _invoke("regrade", out)
    assert done.exit_code == 0, done.output
    assert "With what run 1 graded with" in done.output and "No learner's grade" in done.output, done.output
    assert "changed since run 1 read it" in done.output  # the edited overrides file is not used, and that is said
    done = _invoke("regrade", out, "--apply", "--reason", "nothing changed")
    assert done.exit_code == 0, done.output
    assert _rows(out, "SELECT learner FROM changes WHERE run = 2") == []
    [(who, applied)] = _rows(out, "SELECT learner, applied FROM overrides WHERE run = 2")
    assert who == "dee" and applied.startswith("waived a late penalty of -")  # the run kept what the waiver did
    done = _invoke("regrade", out, "--course", course)  # named: graded with it, and the difference shown
    assert done.exit_code == 0 and "deadline and late penalty" in done.output, done.output
