"""A derivation per learner: each derivative chapter (2, 3, 4, 6, 7) asks a symbolic question whose map
holds the learner's own numbers (drawn from learner id, chapter and question like every per-learner
number), judged by equivalence with the key filled in with those numbers. Two learners see different
maps; one learner's right answer, written in another form than the key, is right for them and wrong for
another; the lesson's own derivative (the map without the learner's numbers) is named; the key never
ships. Through real answer files and the real CLI."""

from __future__ import annotations

import json
import re
import shutil

import pytest
import yaml

from grader.model import Status
from grader.quiz import bank
from grader.quiz.judge import right_answer
from grader.quiz.symbolic import AnswerError, check_text, equivalent, substitute
from tests.support import REPO, run_grade

# chapter -> (question, a right answer written unlike the key, the lesson's own derivative, its mistake's name);
# {name} stands for the learner's number of that parameter
DERIVATIONS = {
    "ch02": ("obstacle_cost_dy", "2y + 2({b} - y)/((x - {a})^2 + (y - {b})^2)^2",
             "2*y - 2*y/(x^2 + y^2)^2", "obstacle at the origin"),
    "ch03": ("geared_dx_dtheta", "-{k} r sin({k} θ + {c})", "-r sin(theta)", "ungeared map"),
    "ch04": ("stage_dg1_dtheta", "r cos(theta) ({q} - 2*{p} r sin(theta))",
             "-r^2 sin(2 theta) + r cos(theta)", "the lesson's g"),
    "ch06": ("dish_dbearing_dx", "({b} - y)/(x^2 - 2*{a}*x + {a}^2 + (y - {b})^2)", "-y/(x^2 + y^2)",
             "dish at the origin"),
    "ch07": ("steering_dtheta_dsteer", "v dt (1 + tan(steer/{k})^2)/({k}*{L})", "v*dt/({L}*cos(steer)^2)",
             "steering ratio dropped"),
}
CHAPTERS = sorted(DERIVATIONS)
LEARNERS = ["reference", "alice", "bob", *(f"learner{i}" for i in range(12))]


def _question(chapter: str) -> bank.Question:
    qid = DERIVATIONS[chapter][0]
    return next(q for q in bank.questions(chapter) if q.id == qid)


def _written(template: str, values: dict[str, float]) -> str:
    """A template of DERIVATIONS in one learner's numbers, as they read them in their prompt."""
    return template.format(**{name: f"{value:g}" for name, value in values.items()})


def _derivation(quiz, chapter: str, text: str, learner: str, quiz_dir=None):
    """The result of the chapter's derivation question answered with `text` (quoted)."""
    return quiz.one(chapter, DERIVATIONS[chapter][0], f'"{text}"', learner, quiz_dir=quiz_dir)


@pytest.mark.parametrize("chapter", CHAPTERS)
def test_every_derivative_chapter_asks_a_symbolic_question_of_a_map_with_the_learners_numbers(chapter):
    question = _question(chapter)
    assert question.kind == "symbolic" and question.params and question.points >= 2
    assert all("{" + name + "}" in question.prompt for name in question.params)
    drawn = {learner: question.values_for(learner, chapter) for learner in LEARNERS}
    assert len({tuple(values.values()) for values in drawn.values()}) >= len(LEARNERS) - 2  # nearly all differ
    key = bank.keys(chapter)[question.id]
    keys = {right_answer(question, key, key.value_for(chapter, values), values) for values in drawn.values()}
    assert len(keys) == len({tuple(values.values()) for values in drawn.values()})
    for text in keys:  # each learner's key is an expression in the question's symbols alone
        check_text(text, question.symbols)


def _shown(output: str) -> dict[str, str]:
    """question id -> its text in the output of `grade quiz ... --show`."""
    return dict(re.findall(r"\[(\w+)\] \(symbolic, [\d.]+ points\)\n    (.+)\n", output))


def test_two_learners_see_different_maps_in_every_derivative_chapter():
    shown = {}
    for learner in ("alice", "bob"):
        done = run_grade("quiz", *CHAPTERS, "--show", "--learner", learner)
        assert done.returncode == 0, done.stderr
        shown[learner] = _shown(done.stdout)
    for chapter in CHAPTERS:
        question = _question(chapter)
        texts = {learner: shown[learner][question.id] for learner in shown}
        assert texts["alice"] != texts["bob"], chapter
        for learner, text in texts.items():
            assert "{" not in text and "<" not in text
            for value in question.values_for(learner, chapter).values():
                assert f"{value:g}" in text, (chapter, learner, value, text)


@pytest.mark.parametrize("chapter", CHAPTERS)
def test_a_right_answer_in_another_form_is_right_for_its_learner_and_wrong_for_another(quiz, chapter):
    question, right = _question(chapter), DERIVATIONS[chapter][1]
    alice, bob = question.values_for("alice", chapter), question.values_for("bob", chapter)
    assert alice != bob
    for learner, values, other in (("alice", alice, "bob"), ("bob", bob, "alice")):
        text = _written(right, values)
        result = _derivation(quiz, chapter, text, learner)
        assert result.status == Status.PASS and result.points == result.max_points == question.points, result.message
        key = bank.keys(chapter)[question.id]
        assert result.expected == right_answer(question, key, key.value_for(chapter, values), values)
        assert not set(question.params) & set(re.findall(r"[A-Za-z_]\w*", result.expected))  # numbers, not names
        result = _derivation(quiz, chapter, text, other)
        assert result.status == Status.FAIL and result.points == 0 and result.expected is None, result.message


@pytest.mark.parametrize("chapter", CHAPTERS)
def test_the_lessons_own_derivative_is_named_for_every_learner(quiz, chapter):
    question, lesson, name = _question(chapter), DERIVATIONS[chapter][2], DERIVATIONS[chapter][3]
    feedback = next(w["feedback"] for w in bank.keys(chapter)[question.id].wrong if w["name"] == name)
    for learner in LEARNERS:
        result = _derivation(quiz, chapter, _written(lesson, question.values_for(learner, chapter)), learner)
        assert (result.status, result.points, result.mistake) == (Status.FAIL, 0, name), (learner, result.message)
        assert result.message.splitlines()[0] == feedback


def test_the_cli_names_the_lessons_derivative_and_passes_the_learners_own(tmp_path):
    answers = tmp_path / "exercises" / "answers"
    answers.mkdir(parents=True)
    for chapter in CHAPTERS:
        question, right, lesson, _ = DERIVATIONS[chapter]
        values = _question(chapter).values_for("carol", chapter)
        lines = [f'{question}: "{_written(lesson, values)}"',  # answered twice: the later one counts
                 f'{question}: "{_written(right, values)}"'] if chapter == "ch06" else \
            [f'{question}: "{_written(lesson, values)}"']
        (answers / f"{chapter}.yaml").write_text("\n".join(lines) + "\n", encoding="utf-8")
    done = run_grade("quiz", *CHAPTERS, "--submission", tmp_path, "--learner", "carol", "--format", "json")
    assert done.returncode == 1, done.stderr
    report = json.loads(done.stdout)
    for chapter in report["chapters"]:
        check = next(c for c in chapter["checks"] if c["function"] == DERIVATIONS[chapter["chapter"]][0])
        if chapter["chapter"] == "ch06":
            assert (check["status"], check["mistake"]) == ("pass", None), check
        else:
            assert (check["status"], check["mistake"]) == ("fail", DERIVATIONS[chapter["chapter"]][3]), check


@pytest.mark.parametrize("chapter", CHAPTERS)
def test_the_reference_answers_are_right_for_the_reference_learner_only(quiz, chapter):
    """solutions/answers/ holds the key with the numbers of learner `reference`."""
    qid = DERIVATIONS[chapter][0]
    stored = yaml.safe_load((REPO / "solutions" / "answers" / f"{chapter}.yaml").read_text(encoding="utf-8"))[qid]
    assert _derivation(quiz, chapter, stored, "reference").status == Status.PASS
    assert _derivation(quiz, chapter, stored, "alice").status == Status.FAIL


@pytest.fixture
def handouts(tmp_path):
    """The banks as a recorded-feedback handout ships them (no keys) and as an immediate one does (practice keys)."""
    recorded, immediate = tmp_path / "recorded", tmp_path / "immediate"
    for folder in (recorded, immediate):
        folder.mkdir()
        for chapter in CHAPTERS:
            shutil.copy(bank.QUIZ_DIR / f"{chapter}.yaml", folder)
    (immediate / "practice").mkdir()
    for chapter in CHAPTERS:
        (immediate / "practice" / f"{chapter}.yaml").write_text(
            yaml.safe_dump(bank.public_keys(chapter), sort_keys=False, allow_unicode=True), encoding="utf-8")
    return recorded, immediate


@pytest.mark.parametrize("chapter", CHAPTERS)
def test_a_handout_records_the_derivation_whatever_its_feedback(quiz, handouts, chapter):
    question, right = _question(chapter), DERIVATIONS[chapter][1]
    values = question.values_for("alice", chapter)
    for quiz_dir in handouts:
        shipped = "\n".join(p.read_text(encoding="utf-8") for p in quiz_dir.rglob("*.yaml"))
        assert str(bank.keys(chapter)[question.id].answer) not in shipped
        for text in (_written(right, values), _written(DERIVATIONS[chapter][2], values)):
            result = _derivation(quiz, chapter, text, "alice", quiz_dir=quiz_dir)
            assert (result.status, result.points, result.expected, result.mistake) == \
                (Status.RECORDED, 0, None, ""), (quiz_dir.name, result.message)
        assert _derivation(quiz, chapter, "x^", "alice", quiz_dir=quiz_dir).status == Status.FAIL  # still read


def test_substitute_puts_the_numbers_in_and_reads_back_in_the_symbols_alone():
    key = "-(y - b)/((x - a)^2 + (y - b)^2)"
    written = substitute(key, {"a": 2.5, "b": -1.0}, ("x", "y"))
    assert written == "-(y - -1)/((x - 2.5)^2 + (y - -1)^2)"
    assert equivalent(written, "-(y + 1)/((x - 2.5)^2 + (y + 1)^2)", ("x", "y"), decide=False)
    assert substitute("k r sin(k θ)", {"k": 3.0}, ("r", "theta")) == "3*r*sin(3*theta)"  # read as typed
    assert substitute("a*x^2", {"a": -0.5}, ("x",)) == "-0.5*x^2"
    assert substitute(key, {}, ("x", "y")) == key  # a fixed question's key is left as it is
    for hostile in ("__import__('os')", "a.__class__", "x^a"):  # an exponent is a number, never a parameter
        with pytest.raises(AnswerError):
            substitute(hostile, {"a": 2.0}, ("x",))
