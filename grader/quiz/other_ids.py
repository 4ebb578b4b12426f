"""Answers worked out with another learner id's numbers.

A per-learner question (its numbers, or the letters of its options, drawn from the learner id) that
fails for the id it is graded as may be right for another id: "anonymous" (what `grade` uses while
learner.yaml names nobody), the id in the submission's learner.yaml, or the id its archive was packed
as. Then the learner did the work with the wrong numbers: the message says so, instead of "not
within the tolerance of the right value", and how to fix it. Nothing is graded differently: the
points stay those of the graded id.

A fit on option letters alone is weak evidence: a wrong letter is another id's right one about one time in four.
So another id is named only where a question with numbers of its own fits it, or at least LETTERS_ALONE
questions of the chapter do; else the failures keep their own messages.
"""

from __future__ import annotations

from pathlib import Path

from grader.model import Report, Status
from grader.quiz import DEFAULT_LEARNER, bank, grade_quiz

MARK = "other_id"  # CheckResult.details key: the id whose numbers the answer fits
LETTERS_ALONE = 3  # questions whose letters alone fit another id, needed to name it without a fit on numbers


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
            asked = [q for q in bank.questions(chapter.chapter) if q.params or q.options]
        except (FileNotFoundError, bank.BankError):
            continue
        per_learner = {q.id for q in asked}
        by_numbers = {q.id for q in asked if q.params}
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
            fitted = {r.function for r in results if r.status == Status.PASS}
            if fitted & by_numbers or len(fitted) >= LETTERS_ALONE:  # else chance can explain it: not said
                fits.update(dict.fromkeys(fitted, other))
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
