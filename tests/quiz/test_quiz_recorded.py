"""Quizzes where the keys are not installed (a learner's handout): every answer is still read and
format-checked, without sympy; a well-formed one is recorded (graded on submission, not counted
here), an ill-formed one fails with the file, line, question and reason, an empty one is not
answered yet. Driven through real answer files and, where it matters, the real CLI."""

from __future__ import annotations

import json

import pytest
import yaml

from grader.judging import expected
from grader.model import ChapterResult, Status
from grader.quiz import RECORDED_MESSAGE, bank
from grader.quiz.templates import template
from tests.support import run_grade

SHOWN = "exercises/answers/ch06.yaml"
# well-formed answers of every kind, right or wrong: nothing here says which
WELL_FORMED = {
    "bearing_near_dish": "e",
    "H_at_point": "[[1, 2], [3, 4.5]]",
    "dbearing_dx": "x*sqrt(y^2 + 1)",
    "bearing_variance": "sqrt(2)/4",
    "H_facts": "b, d",
    "dish_dbearing_dx": "(x - 1)/((x - 2)^2 + y^2)",
}


def _file(answers: dict[str, str]) -> str:
    """An answer file holding `answers` ({question id: answer as written}), in that order."""
    return "".join(f"{qid}: {text}\n" for qid, text in answers.items())


def test_well_formed_answers_are_recorded_with_their_points_pending(quiz, keyless_banks):
    results, problems = quiz("ch06", _file(WELL_FORMED), quiz_dir=keyless_banks)
    assert problems == []  # no chapter-level "keys not installed" problem: the results say it
    for question in bank.questions("ch06", keyless_banks):
        result = results[question.id]
        assert (result.status, result.points, result.max_points, result.message) == \
            (Status.RECORDED, 0, question.points, RECORDED_MESSAGE), question.id
        assert result.got == WELL_FORMED[question.id] and result.expected is None
    chapter = ChapterResult("ch06", "", list(results.values()))
    assert chapter.max_score_of("quiz") == 0
    assert chapter.recorded_score_of("quiz") == sum(q.points for q in bank.questions("ch06"))


@pytest.mark.parametrize("qid, answer, reason", [
    ("bearing_near_dish", "z", "choose from a, b, c, d, e (got 'z')"),
    ("bearing_near_dish", "a, b", "choose exactly one option"),
    ("H_facts", "a, q", "choose from a, b, c, d, e"),
    ("H_at_point", "[1, 2, 3]", "expected 2x2 numbers, got shape (3,)"),
    ("H_at_point", "[[1, 2], [3]]", "rows of different lengths"),
    ("H_at_point", "[[1, 2], [3, x]]", "unknown name 'x'"),
    ("bearing_variance", "one half", "unknown name 'one' (symbols allowed here: none)"),
    ("bearing_variance", "0.5 0.25", "cannot read it as a formula"),
    ("bearing_variance", "[1, 2]", "expected one number, got a list"),
    ("bearing_variance", "1/0", "division by zero"),
    ("dbearing_dx", "-y/z^2", "unknown name 'z' (symbols allowed here: x, y, r)"),
    ("dbearing_dx", "1/2x", "`1/2x` is ambiguous: write 1/(2*x) or (1/2)*x"),
    ("dbearing_dx", "\n  - y/(x^2 + y^2)", "YAML reads an answer that starts with '- ' as a list: put it in "
                                         "quotes, e.g. dbearing_dx: \"- y/(x^2 + y^2)\""),
    ("dbearing_dx", "\"__import__('os')\"", "only these functions may be called"),
    ("dbearing_dx", "x^y", "an exponent must be a number"),
])
def test_ill_formed_answers_fail_with_file_line_question_and_reason(quiz, keyless_banks, qid, answer, reason):
    answers = dict(WELL_FORMED, **{qid: answer})
    results, _ = quiz("ch06", _file(answers), quiz_dir=keyless_banks)
    line = list(answers).index(qid) + 1
    result = results[qid]
    assert result.status == Status.FAIL and result.points == 0 and result.max_points > 0
    assert result.message.startswith(f"{SHOWN}, line {line}, question {qid}: ") and reason in result.message
    assert all(r.status == Status.RECORDED for q, r in results.items() if q != qid)


def test_unanswered_questions_stay_not_answered_yet(quiz, keyless_banks):
    results, problems = quiz("ch06", template("ch06"), quiz_dir=keyless_banks)
    assert not problems
    assert results and all(r.status == Status.FAIL and r.message == "not answered yet" for r in results.values())


def test_letters_are_checked_against_the_learners_own_letters(quiz, keyless_banks):
    question = next(q for q in bank.questions("ch06") if q.id == "bearing_near_dish")
    assert set(question.lettering("alice", "ch06")) == {"a", "b", "c", "d", "e"}
    results, _ = quiz("ch06", _file({"bearing_near_dish": "f"}), quiz_dir=keyless_banks)
    assert "choose from a, b, c, d, e" in results["bearing_near_dish"].message


def test_a_question_missing_from_the_keys_is_recorded_the_others_judged(quiz, keyless_banks):
    (keyless_banks / "keys").mkdir()
    full = yaml.safe_load((bank.QUIZ_DIR / "keys" / "ch06.yaml").read_text())
    (keyless_banks / "keys" / "ch06.yaml").write_text(yaml.safe_dump({"dbearing_dx": full["dbearing_dx"]}))
    results, problems = quiz("ch06", _file(dict(WELL_FORMED, dbearing_dx="-y/(y^2 + x^2)")),
                             quiz_dir=keyless_banks)
    assert not problems
    assert results["dbearing_dx"].status == Status.PASS and results["dbearing_dx"].points == 2
    assert {q for q, r in results.items() if r.status == Status.RECORDED} == set(WELL_FORMED) - {"dbearing_dx"}


def test_a_key_the_references_cannot_compute_here_is_recorded(quiz, monkeypatch):
    def not_installed(chapter, name):
        raise expected.ReferenceUnavailable(f"the reference {chapter}.{name} is not installed here")

    monkeypatch.setattr(expected, "reference_function", not_installed)
    results, problems = quiz("ch06", _file(dict(WELL_FORMED, dbearing_dx="x/(x^2 + y^2)")), quiz_dir=None)
    assert not problems
    computed = {q.id for q in bank.questions("ch06") if bank.keys("ch06")[q.id].compute}
    assert computed == {"H_at_point", "bearing_variance"}
    assert all(results[q].status == Status.RECORDED for q in computed)
    assert results["dbearing_dx"].status == Status.FAIL  # stored keys are still judged
    assert results["dbearing_dx"].message.startswith("That is d bearing / d y")


def test_cli_in_a_handout_without_keys_records_exits_zero_and_imports_no_sympy(quiz, tmp_path, keyless_banks):
    quiz.write("ch06", _file(WELL_FORMED))
    proc = run_grade("quiz", "ch06", "--submission", tmp_path, "--learner", "alice", "--format", "json",
                     quiz_dir=keyless_banks, flags=("-X", "importtime"))
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "sympy" not in proc.stderr  # -X importtime lists every module imported
    assert "grader.quiz.judge" in proc.stderr  # ... and the answers were format-checked
    data = json.loads(proc.stdout)
    chapter = data["chapters"][0]
    assert chapter["problems"] == []
    assert {c["status"] for c in chapter["checks"]} == {"recorded"}
    assert (data["score"], data["max_score"]) == (0, 0)
    assert data["pending_score"] == sum(q.points for q in bank.questions("ch06"))


def test_cli_in_a_handout_without_keys_fails_an_ill_formed_answer(quiz, tmp_path, keyless_banks):
    quiz.write("ch06", _file(dict(WELL_FORMED, H_at_point="[[1, 2], [3]]")))
    proc = run_grade("quiz", "ch06", "--submission", tmp_path, "--learner", "alice", "--format", "json",
                     quiz_dir=keyless_banks)
    assert proc.returncode == 1, proc.stdout + proc.stderr
    checks = {c["function"]: c for c in json.loads(proc.stdout)["chapters"][0]["checks"]}
    assert checks["H_at_point"]["status"] == "fail"
    assert checks["H_at_point"]["message"] == f"{SHOWN}, line 2, question H_at_point: rows of different lengths"
    assert {c["status"] for q, c in checks.items() if q != "H_at_point"} == {"recorded"}
