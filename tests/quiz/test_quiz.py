"""Quizzes: keys accepted, distractors rejected with their own feedback, answers as people write
them, hostile input refused quickly, broken answer files reported by file and line."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest
from click.testing import CliRunner

from grader.chapters import CHAPTERS
from grader.faces.cli import main
from grader.model import Status, rounded_points
from grader.quiz import bank
from grader.quiz.judge import judge
from grader.quiz.symbolic import AnswerError, equivalent, number, parse
from grader.quiz.templates import reference_answers, template
from tests.support import (
    RIGHT_CHOICE,
    RIGHT_FACTS,
    CpuTime,
    right_value,
    run_grade,
    shown,
)

ALL = [c.id for c in CHAPTERS]
QUESTIONS = [(c, q) for c in ALL for q in bank.questions(c)]


def test_every_chapter_has_the_lesson_question_and_a_mix_of_kinds():
    kinds = set()
    for chapter in ALL:
        questions = bank.questions(chapter)
        assert len(questions) >= 4, chapter
        assert questions[0].kind == "choice" and 4 <= len(questions[0].options) <= 5, chapter
        assert any(q.params for q in questions), f"{chapter} has no per-learner question"
        kinds |= {q.kind for q in questions}
    assert kinds == set(bank.KINDS)


@pytest.mark.parametrize("chapter", ALL)
def test_reference_answers_for_another_learner_score_full_marks(quiz, chapter):
    results, problems = quiz(chapter, reference_answers(chapter, "bob"), learner="bob")
    assert not problems
    assert all(r.status == Status.PASS and r.points == r.max_points for r in results.values()), \
        [(r.function, r.message) for r in results.values() if r.status != Status.PASS]


@pytest.mark.parametrize("chapter, question", [(c, q) for c, q in QUESTIONS if q.kind in ("choice", "multi")],
                         ids=lambda v: getattr(v, "id", v))
def test_every_distractor_is_rejected_with_its_own_feedback(chapter, question):
    key = bank.keys(chapter)[question.id]
    right = key.answer if question.kind == "choice" else list(key.answer)
    distractors = [o for o in question.options if o not in (right if isinstance(right, list) else [right])]
    assert distractors and all(o in key.feedback for o in distractors), "every wrong option needs feedback"
    for option in distractors:
        answer = option if question.kind == "choice" else [right[0], option]
        verdict = judge(question, key, answer, key.answer, seed=1)
        assert not verdict.right
        assert key.feedback[option] in verdict.feedback


LEARNERS = ["alice", "bob", *(f"learner{i}" for i in range(10))]


def wrong_answer_text(question, key, wrong, learner, chapter):
    """(the answer text a learner making this known mistake writes, their numbers, the right value);
    None where the mistake makes no difference for this learner."""
    from grader.quiz.judge import right_numbers
    from grader.quiz.mistakes import learner_names, wrong_expression, wrong_value

    values = question.values_for(learner, chapter)
    right = key.value_for(chapter, values)
    if question.kind == "symbolic":  # with this learner's numbers, as they would write it
        return wrong_expression(question, wrong, values), values, right
    want = right_numbers(right, key, values)
    candidate = wrong_value(wrong, want, learner_names(key, values))
    if candidate is None or np.allclose(candidate, want, rtol=key.rtol, atol=key.atol):
        return None
    return json.dumps(np.round(candidate, 6).tolist()), values, right


@pytest.mark.parametrize("chapter, question", [(c, q) for c, q in QUESTIONS if bank.keys(c)[q.id].wrong],
                         ids=lambda v: getattr(v, "id", v))
def test_every_known_wrong_answer_is_named_with_its_targeted_feedback(chapter, question):
    """For the learners whose numbers tell it apart, each `wrong:` entry is named by its own name with its
    own feedback first; for the others only an earlier entry of the same value may take its place."""
    key = bank.keys(chapter)[question.id]
    for index, wrong in enumerate(key.wrong):
        named = 0
        for learner in LEARNERS if question.params else LEARNERS[:1]:
            case = wrong_answer_text(question, key, wrong, learner, chapter)
            if case is None:
                continue
            answer, values, right = case
            verdict = judge(question, key, answer, right, seed=bank.variant_seed("points", chapter, question.id),
                            values=values)
            assert not verdict.right and verdict.fraction == 0, (question.id, wrong["name"], learner)
            if verdict.mistake == wrong["name"]:
                assert verdict.feedback.splitlines()[0] == wrong["feedback"]
                named += 1
            else:
                assert verdict.mistake in [w["name"] for w in key.wrong[:index]], (wrong["name"], learner, verdict)
        assert named, f"{question.id}: {wrong['name']} is never named"


def test_multi_select_partial_credit_and_nothing_for_selecting_everything(quiz):
    results, _ = quiz("ch06", f"H_facts: {shown('ch06', 'H_facts', 'a, b')}\n")
    assert results["H_facts"].points == rounded_points(2 / 3)  # 0.6667: points are rounded once, where set
    results, _ = quiz("ch06", f"H_facts: {shown('ch06', 'H_facts', 'a, b, d')}\n")
    assert results["H_facts"].points == rounded_points(1 / 3)
    assert "perpendicular" not in results["H_facts"].message and "local linearization" in results["H_facts"].message
    results, _ = quiz("ch06", "H_facts: a, b, c, d, e\n")
    assert results["H_facts"].points == 0 and "every option" in results["H_facts"].message


@pytest.mark.parametrize("text, value", [
    ("4, 1", [4, 1]), ("[4, 1]", [4, 1]), ("(4,1)", [4, 1]), ("4 1", [4, 1]), ("[4, 2/2]", [4, 1]),
])
def test_vector_spellings(text, value):
    from grader.quiz.judge import _array

    assert _array(text, (2,)).tolist() == value


@pytest.mark.parametrize("text, value", [("0.6", 0.6), ("3/5", 0.6), (" -0.16", -0.16), ("1e-5", 1e-5),
                                         ("sqrt(3)/2", np.sqrt(3) / 2), ("1/64", 1 / 64), (0.25, 0.25)])
def test_number_spellings(text, value):
    assert number(text) == pytest.approx(value)


@pytest.mark.parametrize("answer, key, symbols", [
    ("1/r^2", "r**(-2)", ("r",)),
    ("-y/(x^2+y^2)", "-y/(x**2 + y**2)", ("x", "y")),
    ("x/sqrt(x**2+y**2)", "x*(x^2+y^2)^(-1/2)", ("x", "y")),
    ("2*x*cos(x^2)", "2*cos(x**2)*x", ("x",)),
    ("9 + 6*(x - 3)", "6*x - 9", ("x",)),
    ("-v*sin(theta)*dt", "-(dt*v)*sin(theta)", ("v", "theta", "dt")),
    ("atan2(y, x)", "atan2(y,x)", ("x", "y")),
])
def test_equivalent_spellings_are_accepted(answer, key, symbols):
    assert equivalent(answer, key, symbols)
    import sympy

    assert sympy.simplify(parse(answer, symbols) - parse(key, symbols)) == 0  # sympy agrees


@pytest.mark.parametrize("answer, key, symbols", [
    ("x/(x^2+y^2)", "-y/(x^2+y^2)", ("x", "y")),
    ("1/r", "1/r^2", ("r",)),
    ("x/sqrt(x^2+y^2)", "y/sqrt(x^2+y^2)", ("x", "y")),
    ("sqrt(x^2)", "x", ("x",)),
    ("cos(x^2)", "2*x*cos(x^2)", ("x",)),
])
def test_non_equivalent_spellings_are_rejected(answer, key, symbols):
    assert not equivalent(answer, key, symbols)


@pytest.mark.parametrize("hostile, says", [
    ("__import__('os').system('x')", "only these functions"),
    ("x.__class__", "Attribute"),
    ("().__class__.__bases__[0]", "is not allowed in an answer"),
    ("x[0]", "Subscript"),
    ("lambda: 1", "Lambda"),
    ("2**2**2**22", "power of a power"),
    ("x**99999", "exponents above"),
    ("x" * 10_000, "at most 200"),
    ("-\u0443/(x^2+y^2)", "not plain ASCII"),
    ("[c for c in x]", "not allowed"),
    ("exec('1')", "only these functions"),
    ("sqrt(x, key=1)", "plain arguments"),
    ("'abc'", "no strings"),
    ("z + 1", "unknown name 'z'"),
])
def test_hostile_answers_are_rejected_quickly_with_a_message(hostile, says):
    with CpuTime() as work, pytest.raises(AnswerError) as info:
        parse(hostile, ("x", "y"))
    assert work.seconds < 1.0  # refused by reading alone: milliseconds of this process's CPU, never an evaluation
    assert says in str(info.value)


def test_hostile_answer_in_a_file_is_reported_with_file_line_and_question(quiz, tmp_path):
    text = (f"bearing_near_dish: {RIGHT_CHOICE}\ndbearing_dx: \"__import__('os').system('touch pwned')\"\n"
            f"H_facts: {RIGHT_FACTS}\n")
    results, _ = quiz("ch06", text)
    message = results["dbearing_dx"].message
    assert "exercises/answers/ch06.yaml, line 2, question dbearing_dx" in message
    assert results["dbearing_dx"].status == Status.FAIL
    assert results["bearing_near_dish"].status == Status.PASS and results["H_facts"].status == Status.PASS
    assert not (tmp_path / "pwned").exists()


def test_malformed_yaml_costs_only_the_broken_answer(quiz):
    text = f"bearing_near_dish: {RIGHT_CHOICE}\nH_at_point: [[1, 2], [3, 4]\nH_facts: {RIGHT_FACTS}\n"
    results, problems = quiz("ch06", text)
    assert not problems  # said at the broken answer's own line, not for the whole file
    assert "not valid YAML" in results["H_at_point"].message
    assert results["bearing_near_dish"].status == Status.PASS
    assert results["H_facts"].status == Status.PASS
    assert "exercises/answers/ch06.yaml, line 2, question H_at_point" in results["H_at_point"].message
    assert results["H_at_point"].status == Status.FAIL and results["H_at_point"].points == 0


def test_unknown_question_id_and_unparsable_answer_name_file_and_line(quiz):
    text = f"bearing_near_dish: {RIGHT_CHOICE}\nbearing_near_dihs: b\nbearing_variance: one half\n"
    results, problems = quiz("ch06", text)
    assert any("line 2: unknown question id 'bearing_near_dihs'" in p for p in problems)
    assert "exercises/answers/ch06.yaml, line 3, question bearing_variance" in results["bearing_variance"].message
    assert results["bearing_near_dish"].status == Status.PASS


@pytest.mark.parametrize("chapter", ALL)
def test_templates_list_every_question_and_score_zero_without_error(quiz, repo_root, chapter):
    shipped = (repo_root / "exercises" / "answers" / f"{chapter}.yaml").read_text()
    assert shipped == template(chapter), "regenerate the template from the bank"
    results, problems = quiz(chapter, shipped)
    assert not problems
    assert set(results) == {q.id for q in bank.questions(chapter)}
    assert all(r.status == Status.FAIL and r.points == 0 and r.message == "not answered yet"
               for r in results.values())


@pytest.mark.parametrize("chapter", ALL)
def test_shipped_reference_answers_are_current(repo_root, chapter):
    assert (repo_root / "solutions" / "answers" / f"{chapter}.yaml").read_text() == reference_answers(chapter)


def test_parametrised_questions_differ_between_learners_and_are_stable():
    question = next(q for q in bank.questions("ch06") if q.id == "H_at_point")
    alice, bob = question.values_for("alice", "ch06"), question.values_for("bob", "ch06")
    assert alice != bob
    assert alice == question.values_for("alice", "ch06")
    assert not np.allclose(right_value("ch06", question, "alice"), right_value("ch06", question, "bob"))


def test_a_right_answer_for_another_learner_is_wrong(quiz):
    question = next(q for q in bank.questions("ch06") if q.id == "H_at_point")
    bobs = json.dumps(np.asarray(right_value("ch06", question, "bob")).tolist())
    results, _ = quiz("ch06", f"H_at_point: {bobs}\n", learner="alice")
    assert results["H_at_point"].status == Status.FAIL
    results, _ = quiz("ch06", f"H_at_point: {bobs}\n", learner="bob")
    assert results["H_at_point"].status == Status.PASS


def test_key_is_not_leaked_for_a_wrong_answer(quiz):
    results, _ = quiz("ch06", "dbearing_dx: x/(x^2+y^2)\n")
    assert results["dbearing_dx"].expected is None
    assert results["dbearing_dx"].message == "That is d bearing / d y; d bearing / d x is -y / r^2."


def test_check_text_needs_no_sympy():
    code = "import sys; from grader.quiz.symbolic import check_text; check_text('x/sqrt(x^2+y^2)', ('x','y')); " \
           "print('sympy' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


def test_cli_quiz_solutions_full_marks_and_show(monkeypatch):
    runner = CliRunner()
    result = runner.invoke(main, ["quiz", "all", "--solutions", "--format", "json"])
    assert result.exit_code == 0, result.output
    data = json.loads(result.output)
    assert data["score"] == data["max_score"] > 0
    assert data["learner"].startswith("reference")
    assert all(c["kind"] == "quiz" for ch in data["chapters"] for c in ch["checks"])
    shown = runner.invoke(main, ["quiz", "ch06", "--show", "--learner", "alice"])
    question = next(q for q in bank.questions("ch06") if q.id == "H_at_point")
    values = question.values_for("alice", "ch06")
    assert f"({values['x']:g}, {values['y']:g})" in shown.output


def test_grade_chapter_shows_code_and_quiz_apart(repo_root):
    proc = run_grade("ch06", "--format", "json", cwd=repo_root)
    data = json.loads(proc.stdout)
    chapter = data["chapters"][0]
    assert chapter["quiz_max_score"] > 0 and chapter["code_max_score"] > 0
    assert chapter["max_score"] == chapter["quiz_max_score"] + chapter["code_max_score"]
    assert {c["kind"] for c in chapter["checks"]} == {"code", "quiz"}
    assert all("error" != c["status"] for c in chapter["checks"])


def test_a_verdict_kept_for_one_learner_is_never_given_to_another():
    """judge keeps verdicts per process (a class answers alike): the same answer text is right for the learner
    whose numbers it was worked out with and wrong for one with other numbers, in whatever order they come."""
    from grader.quiz.judge import right_answer

    checked = 0
    for chapter, question in QUESTIONS:
        key = (bank.keys(chapter) or {}).get(question.id)
        if not question.params or key is None or question.kind not in ("numeric", "vector", "matrix", "symbolic"):
            continue
        seed = bank.variant_seed("points", chapter, question.id)

        def verdict(learner: str, answer: str) -> bool:
            values = question.values_for(learner, chapter)
            return judge(question, key, answer, key.value_for(chapter, values), seed,
                         question.lettering(learner, chapter), values=values, text=answer).right

        values = question.values_for("alice", chapter)
        right = right_answer(question, key, key.value_for(chapter, values), values)
        answer = right if question.kind == "symbolic" else json.dumps(np.asarray(right, dtype=float).tolist())
        if verdict("bob", answer):
            continue  # these numbers happen to give bob the same answer
        assert [verdict("alice", answer), verdict("bob", answer), verdict("alice", answer)] == [True, False, True], \
            f"{chapter} {question.id}"
        checked += 1
    assert checked >= 5  # the banks have per-learner questions of every kind
