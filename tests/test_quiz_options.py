"""Choice and multi options: right answers spread over the letters of the bank."""

from __future__ import annotations

from collections import Counter

from grader.chapters import CHAPTERS
from grader.quiz import bank

CHOICES = [(c.id, q) for c in CHAPTERS for q in bank.questions(c.id) if q.kind == "choice"]


def test_the_right_options_are_spread_over_the_letters_of_the_bank():
    letters = Counter(str(bank.keys(chapter)[question.id].answer) for chapter, question in CHOICES)
    assert len(CHOICES) >= 10
    assert max(letters.values()) <= len(CHOICES) / 3, letters
    assert len(letters) >= 4, letters
