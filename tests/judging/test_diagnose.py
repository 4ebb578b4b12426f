"""Every diagnosis is named on a submission that makes that mistake (the misconception corpus of
benchmarks/misconceptions.py), in the message of a failing check of that very function, and none
is ever offered on a right answer; every slip of the hand-written realistic corpus
(benchmarks/realistic_slips.py) loses points, and every right rewrite of it gets full marks and no diagnosis."""

from __future__ import annotations

import sys

import pytest

from grader.chapters import CHAPTERS
from tests.support import (
    REPO,
    build_submission,
    first_of_each,
    grade_code,
    replace_function,
)

sys.path.insert(0, str(REPO / "benchmarks"))
from misconceptions import CODE  # noqa: E402
from realistic_slips import RIGHT, SLIPS  # noqa: E402


@pytest.mark.parametrize("name", first_of_each(CODE, lambda name: CODE[name][0]))
def test_a_one_bug_submission_gets_its_mistake_named(tmp_path, name):
    module, function, source, wanted = CODE[name]
    root = build_submission(tmp_path / "bug", {module: replace_function(module, function, source)})
    chapter = grade_code(root, [module[:4]]).chapters[0]
    named = [c for c in chapter.checks if c.function == function and c.mistake == wanted]
    assert named, [(c.id, c.mistake) for c in chapter.checks if c.status.value != "pass"]
    assert all(c.status.value == "fail" and c.points == 0 for c in named)


def test_no_diagnosis_on_right_answers(repo_root):
    report = grade_code(repo_root, [c.id for c in CHAPTERS], "solutions", seed=7)
    assert [(ch.chapter, c.id, c.mistake) for ch in report.chapters for c in ch.checks if c.mistake] == []
    assert all(c.status.value == "pass" for ch in report.chapters for c in ch.checks)


@pytest.mark.parametrize("name", first_of_each(SLIPS, lambda name: SLIPS[name][0]))
def test_a_realistic_slip_loses_points_on_its_own_function(tmp_path, name):
    module, function, source, _ = SLIPS[name]
    root = build_submission(tmp_path / "slip", {module: replace_function(module, function, source)})
    checks = grade_code(root, [module[:4]]).chapters[0].checks
    assert any(c.function == function and c.points < c.max_points for c in checks)


@pytest.mark.parametrize("name", first_of_each(RIGHT, lambda name: RIGHT[name][0]))
def test_a_right_rewrite_gets_full_marks_and_no_diagnosis(tmp_path, name):
    module, function, source = RIGHT[name]
    root = build_submission(tmp_path / "right", {module: replace_function(module, function, source)})
    checks = grade_code(root, [module[:4]]).chapters[0].checks
    assert [(c.id, c.message) for c in checks if c.points < c.max_points] == []
    assert [(c.id, c.mistake) for c in checks if c.mistake or c.help] == []
