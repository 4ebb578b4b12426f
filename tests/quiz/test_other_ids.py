"""Answers worked out with another learner id's numbers (grader.quiz.other_ids): named where the evidence holds (a
question with numbers fits the other id, or several letters do), never on one wrong letter that happens to be
another id's right one."""

from __future__ import annotations

import yaml

from grader.chapters import BY_ID
from grader.model import ChapterResult, Report
from grader.quiz import DEFAULT_LEARNER, bank, grade_quiz
from grader.quiz.other_ids import MARK, explain
from grader.quiz.templates import reference_answers


def _explained(tmp_path, chapter: str, answers: dict) -> tuple[Report, list[str]]:
    (tmp_path / f"{chapter}.yaml").write_text(yaml.safe_dump(answers, sort_keys=False), encoding="utf-8")
    results, _ = grade_quiz(chapter, tmp_path, "ann", "answers")
    report = Report("ann", [ChapterResult(chapter, BY_ID[chapter].title, results)], seed=1)
    return report, explain(report, tmp_path, "answers", "ann", [DEFAULT_LEARNER])


def _letter_question(chapter: str, own: dict, other: dict) -> str:
    return next(q.id for q in bank.questions(chapter) if q.options and not q.params and own[q.id] != other[q.id])


def test_one_wrong_letter_that_is_another_ids_right_one_is_no_evidence(tmp_path):
    own = yaml.safe_load(reference_answers("ch06", "ann"))
    other = yaml.safe_load(reference_answers("ch06", DEFAULT_LEARNER))
    question = _letter_question("ch06", own, other)
    report, said = _explained(tmp_path, "ch06", {**own, question: other[question]})
    failed = [c for c in report.chapters[0].checks if c.status.value == "fail"]
    assert [c.function for c in failed] == [question]
    assert said == [] and MARK not in failed[0].details and "numbers of learner" not in failed[0].message


def test_answers_with_another_ids_numbers_are_named_so(tmp_path):
    other = yaml.safe_load(reference_answers("ch06", DEFAULT_LEARNER))
    report, said = _explained(tmp_path, "ch06", other)
    fitted = [c for c in report.chapters[0].checks if MARK in c.details]
    assert fitted and any(bank.questions("ch06")[[q.id for q in bank.questions("ch06")].index(c.function)].params
                          for c in fitted)
    assert said and "answered with the numbers of 'anonymous'" in said[0]
    assert all("the right answer for the numbers of learner 'anonymous'" in c.message for c in fitted)
