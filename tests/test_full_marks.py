"""Every chapter: the reference solutions get full marks (at several seeds), the untouched stubs
get zero with every check failing as "not implemented yet" (never an error)."""

from __future__ import annotations

import pytest

from grader.chapters import CHAPTERS
from grader.grading import DEFAULT_SEED, grade
from grader.model import Status
from grader.runner import Session
from grader.submission import Submission

ALL = [c.id for c in CHAPTERS]


@pytest.mark.parametrize("seed", [DEFAULT_SEED, 1, 2])
def test_reference_solutions_get_full_marks(repo_root, seed):
    report = grade(Session(Submission(repo_root, "solutions")), ALL, seed=seed)
    assert [c.chapter for c in report.chapters] == ALL
    for chapter in report.chapters:
        failed = [(c.id, c.message) for c in chapter.checks if c.status != Status.PASS]
        assert not failed, f"{chapter.chapter} (seed {seed}): {failed}"
        assert chapter.score == chapter.max_score > 0


def test_stubs_get_zero_and_every_check_fails_as_not_implemented(repo_root):
    report = grade(Session(Submission(repo_root, "exercises")), ALL)
    for chapter in report.chapters:
        assert not chapter.problems, chapter.problems
        assert chapter.score == 0
        for check in chapter.checks:
            assert check.status == Status.FAIL, (chapter.chapter, check.id, check.status, check.message)
            assert "not implemented" in check.message, (chapter.chapter, check.id, check.message)
