"""Format hints never show an answer: every example in a hint (in backticks) is read as the
learner's file would read it and judged with the quiz's own judging (numeric tolerance, matrix
shape, symbolic equivalence) against the key, the known wrong answers and the diagnosed slips of
the key (grader.quiz.mistakes), for several learners' numbers; letter answers have no example at
all, since every letter is right for some learner."""

from __future__ import annotations

import re

import pytest
import yaml

from grader.chapters import CHAPTERS
from grader.quiz import bank
from grader.quiz.judge import judge, read_answer
from grader.quiz.symbolic import AnswerError
from grader.quiz.templates import FORMATS, hint

QUESTIONS = [(c.id, q) for c in CHAPTERS for q in bank.questions(c.id)]
LEARNERS = ["reference", "anonymous", "alice", "bob", *(f"learner{i}" for i in range(21))]
EXAMPLE = re.compile(r"`([^`]*)`")


def _as_read(example: str) -> object:
    """The example as an answer file line `id: example` gives it to the judge."""
    return yaml.safe_load(f"answer: {example}")["answer"]


def _accepted(chapter: str, question: bank.Question, value: object) -> str | None:
    """Which learner's key, known wrong answer or diagnosed slip of the key (a transpose, a sign, ...)
    `value` matches, or None."""
    key = bank.keys(chapter)[question.id]
    for learner in LEARNERS if question.params else LEARNERS[:1]:
        values = question.values_for(learner, chapter)
        right = key.value_for(chapter, values)
        verdict = judge(question, key, value, right, seed=bank.variant_seed(learner, chapter, question.id),
                        values=values)
        if verdict.right:
            return f"the key of {learner}"
        if verdict.mistake:
            return f"a known wrong answer for {learner} ({verdict.mistake}: {verdict.feedback})"
    return None


@pytest.mark.parametrize("chapter, question", QUESTIONS, ids=lambda v: getattr(v, "id", v))
def test_every_hint_example_is_well_formed_and_neither_a_key_nor_a_known_wrong_answer(chapter, question):
    text = hint(question)
    examples = EXAMPLE.findall(text)
    if question.kind in ("choice", "multi"):
        assert not examples and "e.g." not in text and "such as" not in text, text
        return
    assert examples, f"{question.id}: give an example of the format"
    assert not re.search(r"(e\.g\.|such as)\s+[^`\s]", text), f"{question.id}: examples go in backticks"
    for example in examples:
        value = _as_read(example)
        read_answer(question, value)  # a hint's example is a well-formed answer to its question
        assert _accepted(chapter, question, value) is None, (question.id, example)


@pytest.mark.parametrize("kind", [k for k in bank.KINDS if k not in ("choice", "multi")])
def test_default_format_examples_give_away_no_answer_of_their_kind(kind):
    examples = EXAMPLE.findall(FORMATS[kind])
    assert examples
    of_kind = [(c, q) for c, q in QUESTIONS if q.kind == kind]
    for example in examples:
        readable = 0
        for chapter, question in of_kind:
            try:
                read_answer(question, _as_read(example))
            except AnswerError:
                continue  # not even an answer to this question (another shape or other symbols)
            readable += 1
            assert _accepted(chapter, question, _as_read(example)) is None, (question.id, example)
        assert readable, f"{example!r} is an answer to no {kind} question"


def test_the_check_catches_an_example_that_is_a_key():
    question = next(q for q in bank.questions("ch06") if q.id == "dbearing_dx")
    assert _accepted("ch06", question, _as_read("-y/(y^2 + x^2)")) == "the key of reference"
    assert _accepted("ch06", question, _as_read("x/sqrt(x^2 + y^2)")).startswith("a known wrong answer")
    variance = next(q for q in bank.questions("ch06") if q.id == "bearing_variance")
    r = variance.values_for("learner7", "ch06")["r"]
    assert _accepted("ch06", variance, _as_read(f"1/{r}^2")) == "the key of learner7"
