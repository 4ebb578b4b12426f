"""Choice and multi options: right answers spread over the letters of the bank, and every learner
sees the options in their own order, answers with those letters and gets the feedback of the option
they picked."""

from __future__ import annotations

import json
import re
from collections import Counter

import pytest

from grader.chapters import CHAPTERS
from grader.model import Status, rounded_points
from grader.quiz import bank
from grader.quiz.templates import template
from tests.support import run_grade

CHOICES = [(c.id, q) for c in CHAPTERS for q in bank.questions(c.id) if q.kind == "choice"]
LETTERED = [(c.id, q) for c in CHAPTERS for q in bank.questions(c.id) if q.options]
LEARNERS = [f"learner{i}" for i in range(40)]


def _letter_of(question, chapter, learner):
    """Canonical letter -> the letter `learner` sees."""
    return {canonical: shown for shown, canonical in question.lettering(learner, chapter).items()}


def test_the_right_options_are_spread_over_the_letters_of_the_bank():
    letters = Counter(str(bank.keys(chapter)[question.id].answer) for chapter, question in CHOICES)
    assert len(CHOICES) >= 10
    assert max(letters.values()) <= len(CHOICES) / 3, letters
    assert len(letters) >= 4, letters


@pytest.mark.parametrize("chapter, question", CHOICES, ids=lambda v: getattr(v, "id", v))
def test_the_shown_letter_of_the_right_option_varies_between_learners(chapter, question):
    right = bank.keys(chapter)[question.id].answer
    letters = Counter(_letter_of(question, chapter, learner)[right] for learner in LEARNERS)
    assert len(letters) >= 3 and max(letters.values()) <= len(LEARNERS) / 2, letters


@pytest.mark.parametrize("chapter, question", LETTERED, ids=lambda v: getattr(v, "id", v))
def test_each_learner_sees_a_stable_permutation_lettered_from_a(chapter, question):
    lettering = question.lettering("alice", chapter)
    assert list(lettering) == [chr(ord("a") + i) for i in range(len(question.options))]
    assert sorted(lettering.values()) == sorted(question.options)
    assert lettering == question.lettering("alice", chapter)
    assert len({tuple(question.lettering(learner, chapter).values()) for learner in LEARNERS}) > 5


def test_the_option_order_is_pinned_to_its_own_sha256_seed():
    question = next(q for q in bank.questions("ch06") if q.id == "bearing_near_dish")
    assert bank.variant_seed("alice", "ch06", "bearing_near_dish", bank.OPTIONS_SALT) != \
        bank.variant_seed("alice", "ch06", "bearing_near_dish")
    assert question.lettering("alice", "ch06") == {"a": "d", "b": "a", "c": "c", "d": "b", "e": "e"}


@pytest.mark.parametrize("chapter, question", CHOICES, ids=lambda v: getattr(v, "id", v))
def test_a_shown_letter_is_graded_as_the_option_it_labels_with_that_options_feedback(quiz, chapter, question):
    key = bank.keys(chapter)[question.id]
    learner = next(who for who in LEARNERS if _letter_of(question, chapter, who)[key.answer] != key.answer)
    for shown, canonical in question.lettering(learner, chapter).items():
        results, problems = quiz(chapter, f"{question.id}: {shown}\n", learner=learner)
        result = results[question.id]
        assert not problems
        if canonical == key.answer:
            assert result.status == Status.PASS and result.points == question.points
            assert result.expected == shown  # the learner's own letter, not the bank's
        else:
            assert result.status == Status.FAIL and result.points == 0
            assert result.message == key.feedback[canonical] and result.expected is None
    results, _ = quiz(chapter, f"{question.id}: {key.answer}\n", learner=learner)
    assert results[question.id].status == Status.FAIL  # the bank's letter is not this learner's


def test_multi_select_reads_the_learners_letters_and_names_wrong_picks_by_them(quiz):
    question = next(q for q in bank.questions("ch06") if q.id == "H_facts")
    key = bank.keys("ch06")["H_facts"]
    learner = next(who for who in LEARNERS
                   if {_letter_of(question, "ch06", who)[c] for c in key.answer} != set(key.answer))
    letter_of = _letter_of(question, "ch06", learner)
    right = [letter_of[c] for c in key.answer]
    wrong = letter_of["d"]
    results, _ = quiz("ch06", f"H_facts: {', '.join(right)}\n", learner=learner)
    assert results["H_facts"].status == Status.PASS and results["H_facts"].expected == sorted(right)
    results, _ = quiz("ch06", f"H_facts: {right[0]}, {right[1]}, {wrong}\n", learner=learner)
    assert results["H_facts"].points == rounded_points(1 / 3)  # rounded once, where set
    assert f"{wrong}) {key.feedback['d']}" in results["H_facts"].message
    results, _ = quiz("ch06", f"H_facts: {', '.join(key.answer)}\n", learner=learner)
    assert results["H_facts"].status == Status.FAIL  # the bank's letters are not this learner's


def test_cli_show_prints_the_options_in_the_learners_order_and_grades_those_letters(tmp_path):
    question = next(q for q in bank.questions("ch06") if q.id == "bearing_near_dish")
    outputs = {}
    for learner in ("alice", "bob"):
        proc = run_grade("quiz", "ch06", "--show", "--learner", learner)
        assert proc.returncode == 0, proc.stderr
        listed = re.findall(r"^      ([a-e])\) (.*)$", proc.stdout, re.M)[:len(question.options)]
        assert listed == [(s, question.options[c]) for s, c in question.lettering(learner, "ch06").items()]
        outputs[learner] = listed
    assert outputs["alice"] != outputs["bob"]
    answers = tmp_path / "exercises" / "answers"
    answers.mkdir(parents=True)
    right = _letter_of(question, "ch06", "alice")[bank.keys("ch06")["bearing_near_dish"].answer]
    (answers / "ch06.yaml").write_text(f"bearing_near_dish: {right}\n")
    proc = run_grade("quiz", "ch06", "--submission", tmp_path, "--learner", "alice", "--format", "json")
    checks = {c["function"]: c for c in json.loads(proc.stdout)["chapters"][0]["checks"]}
    assert checks["bearing_near_dish"]["status"] == "pass" and checks["bearing_near_dish"]["expected"] == right


@pytest.mark.parametrize("chapter", [c.id for c in CHAPTERS])
def test_templates_list_options_without_letters_and_point_to_show(chapter):
    text = template(chapter)
    for question in bank.questions(chapter):
        for option in question.options.values():
            assert f"#   - {option[:40]}" in text
    assert not re.search(r"^#\s+[a-e]\) ", text, re.M)
    assert f"grade quiz {chapter} --show" in text
