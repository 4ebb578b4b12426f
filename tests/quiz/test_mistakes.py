"""A wrong quiz answer that matches a known transform of the key is named (CheckResult.mistake) in one
sentence that says what to change: the generic slips of any vector or matrix (grader.judging.diagnose.generic,
with the question's own entry names), a sign of any number, degrees for an angle, minus or a constant
multiple of an expression, and each key's own named wrong answers. A diagnosis holds only when the
answer equals that transform within the tolerance, and never for a right answer. Driven through real
answer files and the real CLI."""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml

from grader.chapters import CHAPTERS
from grader.model import Status
from grader.quiz import bank, grade_quiz
from grader.quiz.judge import right_numbers
from grader.quiz.templates import reference_answers
from tests.support import REPO, question_of, run_grade


def _right(chapter, qid, learner="alice"):
    key = bank.keys(chapter)[qid]
    values = question_of(chapter, qid).values_for(learner, chapter)
    return right_numbers(key.value_for(chapter, values), key, values)


def _written(value: np.ndarray, decimals: int = 2) -> str:
    """A value as a learner writes it, to the hint's precision."""
    return json.dumps(np.round(value, decimals).tolist())


def _sign(matrix, rows=slice(None), cols=slice(None)):
    out = np.array(matrix, dtype=float)
    out[rows, cols] = -out[rows, cols]
    return out


H = ("ch06", "H_at_point")
# (name, question, the slip applied to the right value, the sentence that leads the message)
GENERIC = [
    ("transpose", ("ch04", "pipeline"), lambda m: m.T,
     "Your J is transposed: rows are the outputs (g1, g2), columns the inputs (r, theta)."),
    ("row sign", H, lambda m: _sign(m, rows=1), "Row 1 (bearing) of H has the wrong sign."),
    ("column sign", H, lambda m: _sign(m, cols=0), "Column 0 (d/d x) of H has the wrong sign."),
    ("entry sign", H, lambda m: _sign(m, rows=1, cols=0), "H[1,0] = d bearing/d x has the wrong sign."),
    ("rows swapped", H, lambda m: m[::-1], "The rows of H are swapped: row 0 is range."),
    ("columns swapped", H, lambda m: m[:, ::-1], "The columns of H are swapped: column 0 is d/d x."),
    ("every sign", ("ch04", "pipeline"), lambda m: -m, "Every entry of J has the wrong sign."),
    ("entry sign", ("ch07", "F_at_state"), lambda m: _sign(m, rows=1, cols=2),
     "F[1,2] = d y'/d theta has the wrong sign."),
    ("entries swapped", ("ch09", "gradient_value"), lambda v: v[::-1], "The two entries of grad f are swapped."),
    ("entry sign", ("ch02", "bowl_gradient"), lambda v: v * [1, -1], "grad g[1] (d g/d y) has the wrong sign."),
    ("every sign", ("ch03", "area_scale"), lambda v: -v, "Your answer has the wrong sign."),
    ("degrees", ("ch08", "wrapped_innovation"), np.degrees,
     "The answer is in degrees: give the angle in radians (times pi/180)."),
]


@pytest.mark.parametrize("name, where, slip, sentence", GENERIC, ids=[f"{g[0]}-{g[1][1]}" for g in GENERIC])
def test_a_generic_slip_is_named_and_a_near_miss_of_it_is_not(quiz, name, where, slip, sentence):
    chapter, qid = where
    right = _right(chapter, qid)
    wrong = slip(right)
    result = quiz.one(chapter, qid, _written(wrong, 3))
    assert (result.status, result.points, result.mistake) == (Status.FAIL, 0, name), result.message
    assert result.message.splitlines()[0] == sentence
    assert result.message.splitlines()[1].startswith("not within the tolerance of the right value (tolerance |got")
    assert result.expected is None
    near = np.array(wrong, dtype=float)
    near.flat[0] += 0.05 + 0.05 * abs(near.flat[0])  # outside the tolerance of the slip, and of the key
    result = quiz.one(chapter, qid, _written(near, 3))
    assert result.status == Status.FAIL and result.mistake == ""
    assert result.message.startswith("not within the tolerance of the right value")


@pytest.mark.parametrize("text, name, sentence", [
    ("-6xy^2", "every sign", "Your expression has the wrong sign: it is minus the right one."),
    ("3x y^2", "constant factor", "Your expression is 0.5 times the right one: look for a constant factor that is "
                                  "missing or one too many."),
    ("12 x y^2", "constant factor", "Your expression is 2 times the right one"),
    ("6xy^2 + 1", "", "not equivalent to the right expression"),
    ("6 x^2 y", "", "not equivalent to the right expression"),
])
def test_an_expression_that_is_minus_or_a_multiple_of_the_key_is_named(quiz, text, name, sentence):
    result = quiz.one("ch09", "mixed_partial", text)
    assert result.status == Status.FAIL and result.mistake == name
    assert result.message.startswith(sentence)


@pytest.mark.parametrize("chapter, qid, text, name", [
    ("ch06", "dbearing_dx", "-y/r", "bearing over r"),
    ("ch06", "dbearing_dx", "-y/sqrt(x^2 + y^2)", "bearing over r"),
    ("ch06", "dbearing_dx", "x/(x^2 + y^2)", "d/dy"),
    ("ch07", "dx_dtheta", "-v sin(theta)", "missing dt"),
    ("ch01", "tangent_of_square", "9 + 2x(x - 3)", "slope at x"),
    ("ch06", "bearing_variance", "1/2.3", "r for r^2"),
    ("ch07", "propagated_entry", "-0.004", "F^T P F"),
    ("ch05", "forward_value", "5.68", "exact derivative"),
    ("ch03", "polar_jacobian", "[[0.88, -0.48], [0.48, 0.88]]", "missing r"),
])
def test_a_keys_own_mistake_is_named_with_its_feedback(quiz, chapter, qid, text, name):
    result = quiz.one(chapter, qid, text)
    feedback = next(w["feedback"] for w in bank.keys(chapter)[qid].wrong if w["name"] == name)
    assert (result.status, result.mistake) == (Status.FAIL, name)
    assert result.message.splitlines()[0] == feedback


def test_a_known_mistake_is_named_only_within_the_tolerance(quiz, tmp_path):
    # alice: r = 2.3; 1/r = 0.4348 is "r for r^2"; within 3 significant digits, and no further
    assert quiz.one("ch06", "bearing_variance", "0.435").mistake == "r for r^2"
    assert quiz.one("ch06", "bearing_variance", "0.44").mistake == ""
    # a slip that makes no difference for this learner is never named: area_scale is r = 0.6 for alice, and
    # for a learner with r = 1 "missing r" (det J = 1) is the right answer (the bank's `avoid` draws such numbers
    # again since grade selftest found them: here a bank without it)
    banks = tmp_path / "banks"
    banks.mkdir()
    (banks / "keys").mkdir()
    (banks / "keys" / "ch03.yaml").write_bytes((bank.QUIZ_DIR / "keys" / "ch03.yaml").read_bytes())
    text = (bank.QUIZ_DIR / "ch03.yaml").read_text(encoding="utf-8")
    (banks / "ch03.yaml").write_text(text.replace('avoid: {"r - 1": 0}', "avoid: {}"), encoding="utf-8")
    area_scale = next(q for q in bank.questions("ch03", banks) if q.id == "area_scale")
    who = next(f"learner{i}" for i in range(500) if area_scale.values_for(f"learner{i}", "ch03")["r"] == 1.0)
    result = quiz.one("ch03", "area_scale", "1", learner=who, quiz_dir=banks)
    assert result.status == Status.PASS and result.mistake == ""


LEARNERS = ["reference", "alice", "bob", *(f"learner{i}" for i in range(12))]


@pytest.mark.parametrize("chapter", [c.id for c in CHAPTERS])
def test_no_diagnosis_on_a_right_answer(tmp_path, chapter):
    folder = tmp_path / "answers"
    folder.mkdir()
    for learner in LEARNERS:
        (folder / f"{chapter}.yaml").write_text(reference_answers(chapter, learner))
        results, _ = grade_quiz(chapter, folder, learner, "exercises/answers")
        assert all(r.status == Status.PASS and r.mistake == "" for r in results), \
            [(r.function, r.mistake, r.message) for r in results if r.mistake or r.status != Status.PASS]


def test_every_known_wrong_answer_has_a_name_and_a_key_without_one_is_refused(tmp_path):
    for info in CHAPTERS:
        for key in bank.keys(info.id).values():
            assert all(w["name"].strip() and w["feedback"].strip() for w in key.wrong)
    quiz_dir = tmp_path / "quizzes"
    (quiz_dir / "keys").mkdir(parents=True)
    (quiz_dir / "ch06.yaml").write_text((bank.QUIZ_DIR / "ch06.yaml").read_text())
    raw = yaml.safe_load((bank.QUIZ_DIR / "keys" / "ch06.yaml").read_text())
    del raw["H_at_point"]["wrong"][0]["name"]
    (quiz_dir / "keys" / "ch06.yaml").write_text(yaml.safe_dump(raw))
    with pytest.raises(bank.BankError, match="question H_at_point, wrong answer 1: needs a `name`"):
        bank.keys("ch06", quiz_dir)


def test_cli_reports_the_mistake_in_json_and_text(tmp_path):
    answers = tmp_path / "exercises" / "answers"
    answers.mkdir(parents=True)
    right = _right(*H)
    (answers / "ch06.yaml").write_text(f"H_at_point: {_written(right.T)}\ndbearing_dx: x/r^2\nbearing_variance: 0.189\n")
    proc = run_grade("quiz", "ch06", "--submission", tmp_path, "--learner", "alice", "--format", "json")
    assert proc.returncode == 1, proc.stderr
    checks = {c["function"]: c for c in json.loads(proc.stdout)["chapters"][0]["checks"]}
    assert checks["H_at_point"]["mistake"] == "transpose" and checks["dbearing_dx"]["mistake"] == "d/dy"
    assert checks["bearing_variance"]["status"] == "pass" and checks["bearing_variance"]["mistake"] is None
    assert checks["H_at_point"]["message"].startswith("That is H transposed")
    text = run_grade("quiz", "ch06", "--submission", tmp_path, "--learner", "alice").stdout
    assert "      That is H transposed; rows are the outputs (range, bearing), columns the inputs (x, y)." in text
    assert "      That is d bearing / d y; d bearing / d x is -y / r^2." in text


def test_degrees_is_named_only_where_the_key_is_an_angle(quiz):
    assert bank.keys("ch08")["wrapped_innovation"].angle
    assert not any(key.angle for info in CHAPTERS for qid, key in bank.keys(info.id).items()
                   if qid != "wrapped_innovation")
    gap = _right("ch00", "superposition_gap")
    assert quiz.one("ch00", "superposition_gap", f"{math.degrees(gap):.2f}").mistake == ""


def test_the_quiz_path_imports_no_sympy_for_diagnoses(tmp_path):
    """Diagnosing wrong expressions is decided by the numbers alone."""
    import subprocess
    import sys

    folder = tmp_path / "answers"
    folder.mkdir()
    (folder / "ch06.yaml").write_text("dbearing_dx: -y/r\n")
    (folder / "ch09.yaml").write_text("mixed_partial: 3xy^2\n")
    code = ("import sys; from pathlib import Path; from grader.quiz import grade_quiz; "
            "names = [r.mistake for c in ('ch06', 'ch09') for r in grade_quiz(c, Path(sys.argv[1]), 'alice', 'x')[0] "
            "if r.got]; print(names, 'sympy' in sys.modules)")
    repo = Path(__file__).resolve().parents[2]
    done = subprocess.run([sys.executable, "-c", code, str(folder)], capture_output=True, text=True, cwd=repo,
                          timeout=60)
    assert done.stdout.strip() == "['bearing over r', 'constant factor'] False", done.stderr[-2000:]


# ------------------------------------------------------------- the misconception corpus (benchmarks)

sys.path.insert(0, str(REPO / "benchmarks"))
from misconceptions import QUIZ, grade_quiz_answer  # noqa: E402


def test_the_corpus_is_realistic_in_size_and_spread():
    assert len(QUIZ) >= 20
    assert {chapter for chapter, *_ in QUIZ} == {c.id for c in CHAPTERS}
    kinds = {question_of(chapter, qid).kind for chapter, qid, *_ in QUIZ}
    assert kinds == {"numeric", "vector", "matrix", "symbolic"}
    for chapter, qid, _, learner, _ in QUIZ:
        assert (learner is not None) == bool(question_of(chapter, qid).params), (chapter, qid)
    derivations = {(c.id, q.id) for c in CHAPTERS for q in bank.questions(c.id) if q.kind == "symbolic" and q.params}
    assert len(derivations) >= 5 and derivations <= {(chapter, qid) for chapter, qid, *_ in QUIZ}


@pytest.mark.parametrize("chapter, question, text, learner, wanted", QUIZ,
                         ids=[f"{q}-{t}" for _, q, t, _, _ in QUIZ])
def test_a_wrong_answer_of_the_corpus_gets_its_mistake_named(tmp_path, chapter, question, text, learner, wanted):
    result = grade_quiz_answer(tmp_path / "answers", chapter, question, text, learner)
    assert (result.status, result.points, result.mistake) == (Status.FAIL, 0, wanted), result.message
    assert result.expected is None and result.message.strip()
