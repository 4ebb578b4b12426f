"""Where expected values come from (grader.judging.expected): the memo of the live references gives what the
references give, run after run; a check that asks the reference outside its planning is refused."""

from __future__ import annotations

import pytest

from grader.chapters import CHAPTERS
from grader.judging import expected
from tests.support import build_submission, grade_code, replace_function

BUGGY = {"ch07_dynamics": replace_function("ch07_dynamics", "propagate_covariance", """
    def propagate_covariance(P, F, Q=None):
        return np.asarray(F).T @ np.asarray(P) @ np.asarray(F)
    """)}


def _results(report) -> list:
    return [(ch.chapter, c.id, c.status, c.points, c.message, c.mistake) for ch in report.chapters for c in ch.checks]


def test_the_memo_answers_as_the_references_do_and_again_the_same(tmp_path):
    root = build_submission(tmp_path, BUGGY)
    ids = [c.id for c in CHAPTERS]
    with expected.using(expected.Live()):
        plain = _results(grade_code(root, ids, seed=9))
    memo = expected.Live(memo=True)
    with expected.using(memo):
        first = _results(grade_code(root, ids, seed=9))
        asked = len(memo.memo)
        again = _results(grade_code(root, ids, seed=9))
    assert first == plain and again == plain
    assert asked > 500 and len(memo.memo) == asked  # the second run computed nothing new


def test_asking_the_reference_outside_planning_is_refused():
    with pytest.raises(RuntimeError, match="outside a check's planning"):
        expected.reference("ch06").H_jacobian(3, 4)
