"""Answers worked out with another learner id's numbers.

A per-learner question (its numbers, or the letters of its options, drawn from the learner id) that
fails for the id it is graded as may be right for another id: "anonymous" (what `grade` uses while
learner.yaml names nobody), the id in the submission's learner.yaml, or the id its archive was packed
as. Then the learner did the work with the wrong numbers: the message says so, instead of "not
within the tolerance of the right value", and how to fix it. Nothing is graded differently: the
points stay those of the graded id.
"""

from __future__ import annotations

from pathlib import Path

from grader.model import Report, Status
from grader.quiz import DEFAULT_LEARNER, bank, grade_quiz

MARK = "other_id"  # CheckResult.details key: the id whose numbers the answer fits


def _why(other: str) -> str:
    if other == DEFAULT_LEARNER:
        return f"'{DEFAULT_LEARNER}' (the id `grade` uses while learner.yaml names nobody)"
    return f"{other!r}"


def explain(report: Report, answers_folder: Path, shown_folder: str, graded: str, others: list[str]) -> list[str]:
    """Rewrite the message of every failed per-learner question of `report` that is right for one of `others`
    (learner ids); returns one line per chapter saying which questions, for flags."""
    others = [o for o in dict.fromkeys(others) if o and o != graded]
    found = []
    for chapter in report.chapters:
        try:
            per_learner = {q.id for q in bank.questions(chapter.chapter) if q.params or q.options}
        except (FileNotFoundError, bank.BankError):
            continue
        failed = {c.function: c for c in chapter.checks
                  if c.kind == "quiz" and c.status == Status.FAIL and c.function in per_learner and c.got is not None}
        fits: dict[str, str] = {}
        for other in others:
            wanted = frozenset(failed) - set(fits)
            if not wanted:
                break
            try:
                results, _ = grade_quiz(chapter.chapter, answers_folder, other, shown_folder, only=wanted)
            except Exception:  # noqa: BLE001  an explanation never costs the report
                continue
            fits.update({r.function: other for r in results if r.status == Status.PASS})
        for question, other in fits.items():
            check = failed[question]
            check.details[MARK] = other
            check.message = (f"{shown_folder}/{chapter.chapter}.yaml, question {question}: this is the right answer "
                             f"for the numbers of learner {_why(other)}, not for {graded!r}, whose quiz this is: the "
                             f"numbers and option letters depend on the learner id. Set `learner: {graded}` in "
                             f"{shown_folder}/learner.yaml; `grade quiz {chapter.chapter} --show` shows your own.")
        if fits:
            by_id: dict[str, list[str]] = {}
            for question, other in fits.items():
                by_id.setdefault(other, []).append(question)
            found += [f"{chapter.chapter} quiz: {', '.join(sorted(qs))} answered with the numbers of {_why(other)}, "
                      f"not with those of {graded!r}, as graded" for other, qs in by_id.items()]
    return found
