"""Quiz answers that would stall or crash the grader cost only their own question: integers too large
for a float (OverflowError at 310 digits, ValueError at 4301), values YAML cannot build, a symbolic
answer that sympy would chew on for many seconds (decided in a process of its own, killed at its time
limit), and the learner's time running out (`add_quiz_results(..., deadline=...)`). The learner's code
scores stay, in `grade chNN` and in `grade batch`."""

from __future__ import annotations

import csv
import json
import shutil
import subprocess
import sys
import time

import pytest

from grader.chapters import BY_ID
from grader.model import ChapterResult, Report, Status
from grader.quiz import OUT_OF_TIME, add_quiz_results, symbolic
from tests.support import (
    REPO,
    RIGHT_CHOICE,
    RIGHT_FACTS,
    build_submission,
    code_points,
    run_grade,
    sympy_workers,
    watch_simplifiers,
    write_answers,
)

# Allowed, and undefined (overflowing) at every point, so numbers cannot decide; sympy's simplify of it
# minus ch06's dbearing_dx key runs for many seconds in code no thread can interrupt (always: some other
# such expressions, exp(exp(exp(exp(exp(100))))) among them, make sympy give up at once on some runs).
SLOW = "x*exp(exp(exp(exp(exp(1)))))"
HUGE_ANSWERS = (f"bearing_near_dish: {RIGHT_CHOICE}\n"
                f"H_at_point: [[{'9' * 4400}, 1], [1, 1]]\n"
                f"bearing_variance: {'9' * 320}\n"
                f"dbearing_dx: 0x{'f' * 4400}\n"
                f"H_facts: {RIGHT_FACTS}\n")


def test_integers_too_large_for_a_float_fail_their_question_with_file_and_line(quiz):
    results, _ = quiz("ch06", HUGE_ANSWERS + "dbearing_dy: 2001-13-01\n")
    for line, qid in ((2, "H_at_point"), (3, "bearing_variance"), (4, "dbearing_dx")):
        assert results[qid].status == Status.FAIL and results[qid].points == 0
        assert results[qid].message == (f"exercises/answers/ch06.yaml, line {line}, question {qid}: "
                                        "the number is too large")
    assert results["bearing_near_dish"].status == Status.PASS and results["H_facts"].status == Status.PASS


def test_a_number_within_float_range_is_still_read(quiz):
    results, _ = quiz("ch06", f"bearing_variance: {'9' * 300}\n")
    assert "too large" not in results["bearing_variance"].message  # read, and judged wrong
    assert results["bearing_variance"].message == ("not within the tolerance of the right value "
                                                   "(tolerance |got - expected| <= 1e-06 + 0.005*|expected|)")


@pytest.mark.slow
def test_sympy_runs_in_a_process_that_is_killed_at_its_time_limit(quiz, monkeypatch):
    monkeypatch.setattr(symbolic, "SIMPLIFY_SECONDS", 0.5)
    simplifiers = watch_simplifiers(monkeypatch)
    results, _ = quiz("ch06", f"bearing_near_dish: {RIGHT_CHOICE}\ndbearing_dx: {SLOW}\nH_facts: {RIGHT_FACTS}\n")
    # sympy's process started, then was killed without an answer at its time limit (no learner deadline here)
    assert [(s.started, s.stopped, s.out_of_time) for s in simplifiers] == [(True, True, False)]
    assert results["dbearing_dx"].status == Status.FAIL
    assert results["dbearing_dx"].message.startswith("could not be decided in time")
    assert results["bearing_near_dish"].status == Status.PASS and results["H_facts"].status == Status.PASS
    assert sympy_workers() == []
    cpu = time.process_time()
    time.sleep(0.5)
    assert time.process_time() - cpu < 0.2


@pytest.mark.slow
def test_sympy_still_decides_what_only_it_can_and_never_in_the_grading_process():
    # undefined at every real point, so numbers cannot decide: sympy does, in its own process
    code = ("import sys; from grader.quiz.symbolic import equivalent; "
            "print(equivalent('sqrt(-1 - x^2)*2', '2*sqrt(-1 - x^2)', ('x',)), "
            "equivalent('sqrt(-1 - x^2)*3', '2*sqrt(-1 - x^2)', ('x',)), 'sympy' in sys.modules)")
    done = subprocess.run([sys.executable, "-c", code], cwd=REPO, capture_output=True, text=True, timeout=60)
    assert done.stdout.split() == ["True", "False", "False"], done.stderr


def _quiz_only_report():
    return Report("x", [ChapterResult("ch06", BY_ID["ch06"].title)])


def test_questions_after_the_deadline_say_the_learners_time_ran_out(quiz, tmp_path):
    quiz.write("ch06", f"bearing_near_dish: {RIGHT_CHOICE}\nH_facts: {RIGHT_FACTS}\n")
    report = _quiz_only_report()
    add_quiz_results(report, tmp_path, "exercises", "alice", deadline=time.monotonic() - 1)
    checks = {c.function: c for c in report.chapters[0].checks}
    for qid in ("bearing_near_dish", "H_facts"):
        assert checks[qid].status == Status.SKIP and checks[qid].points == 0
        assert "the time for this learner ran out" in checks[qid].message and checks[qid].message == OUT_OF_TIME
    assert checks["H_at_point"].message == "not answered yet"


def test_answers_with_no_key_here_are_recorded_even_after_the_deadline(quiz, keyless_banks):
    """A handout has no keys: its answers are only read and format-checked (quick), never 'out of time'."""
    results, _ = quiz("ch06", f"bearing_near_dish: {RIGHT_CHOICE}\nbearing_variance: 0.1\n",
                        quiz_dir=keyless_banks, deadline=time.monotonic() - 1)
    assert results["bearing_near_dish"].status == results["bearing_variance"].status == Status.RECORDED


def test_the_deadline_stops_sympy_too(quiz, tmp_path, monkeypatch):
    quiz.write("ch06", f"bearing_near_dish: {RIGHT_CHOICE}\ndbearing_dx: {SLOW}\nH_facts: {RIGHT_FACTS}\n")
    report = _quiz_only_report()
    simplifiers = watch_simplifiers(monkeypatch)
    add_quiz_results(report, tmp_path, "exercises", "alice", deadline=time.monotonic() + 1.0)  # before SIMPLIFY_SECONDS
    # sympy's process was stopped without an answer because the learner's deadline came first
    assert [(s.stopped, s.out_of_time) for s in simplifiers] == [(True, True)]
    checks = {c.function: c for c in report.chapters[0].checks}
    assert checks["bearing_near_dish"].status == Status.PASS
    assert checks["dbearing_dx"].status == Status.SKIP and checks["dbearing_dx"].message == OUT_OF_TIME
    assert checks["H_facts"].status == Status.SKIP
    assert sympy_workers() == []


@pytest.fixture(scope="module")
def hostile_learner(tmp_path_factory):
    """alice: right code, and answers with huge numbers and an expression sympy cannot decide in time."""
    root = build_submission(tmp_path_factory.mktemp("quiz") / "alice")
    write_answers(root / "exercises" / "answers", "ch06",
                  HUGE_ANSWERS.replace(f"dbearing_dx: 0x{'f' * 4400}", f"dbearing_dx: {SLOW}"))
    return root


@pytest.mark.slow
def test_grade_chapter_reports_each_answer_and_keeps_the_code_score(hostile_learner):
    done = run_grade("ch06", "--submission", hostile_learner, "--learner", "alice", "--format", "json")
    assert done.returncode == 1 and "Traceback" not in done.stderr, done.stderr[-2000:]
    chapter = json.loads(done.stdout)["chapters"][0]
    assert chapter["code_score"] == chapter["code_max_score"] == float(code_points("ch06"))
    checks = {c["function"]: c for c in chapter["checks"] if c["kind"] == "quiz"}
    assert checks["H_at_point"]["message"].endswith("line 2, question H_at_point: the number is too large")
    assert checks["bearing_variance"]["message"].endswith("question bearing_variance: the number is too large")
    assert checks["dbearing_dx"]["message"].startswith("could not be decided in time")
    assert checks["bearing_near_dish"]["status"] == checks["H_facts"]["status"] == "pass"


@pytest.mark.slow
def test_batch_grades_the_learner_with_their_code_scores(hostile_learner, tmp_path):
    submissions = tmp_path / "submissions"
    submissions.mkdir()
    shutil.copytree(hostile_learner, submissions / "alice")
    build_submission(submissions / "bob")
    done = run_grade("batch", submissions, "--out", tmp_path / "out", "--chapters", "ch06", "--jobs", "2", "--no-html")
    assert done.returncode == 0 and "Traceback" not in done.stderr, done.stdout + done.stderr[-2000:]
    with open(tmp_path / "out" / "gradebook.csv", newline="", encoding="utf-8") as handle:
        rows = {row["learner"]: row for row in csv.DictReader(handle)}
    assert rows["alice"]["status"] == rows["bob"]["status"] == "graded"
    assert rows["alice"]["ch06_code"] == rows["bob"]["ch06_code"] == code_points("ch06")
    assert float(rows["alice"]["ch06_quiz"]) > 0  # the right answers count
