"""Every chapter: the reference solutions get full marks (at several seeds), the untouched stubs
get zero with every check failing as "not implemented yet" (never an error)."""

from __future__ import annotations

import pytest

from grader.chapters import CHAPTERS
from grader.core.grading import DEFAULT_SEED
from grader.model import Status
from tests.support import (
    grade_code,
    slow_but_the_first,
)

ALL = [c.id for c in CHAPTERS]


@pytest.mark.parametrize("seed", [DEFAULT_SEED, 1, 2])
def test_reference_solutions_get_full_marks(repo_root, seed):
    report = grade_code(repo_root, ALL, "solutions", seed=seed)
    assert [c.chapter for c in report.chapters] == ALL
    for chapter in report.chapters:
        failed = [(c.id, c.message) for c in chapter.checks if c.status != Status.PASS]
        assert not failed, f"{chapter.chapter} (seed {seed}): {failed}"
        assert chapter.score == chapter.max_score > 0


def test_stubs_get_zero_and_every_check_fails_as_not_implemented(repo_root):
    report = grade_code(repo_root, ALL)
    for chapter in report.chapters:
        assert not chapter.problems, chapter.problems
        assert chapter.score == 0
        for check in chapter.checks:
            assert check.status == Status.FAIL, (chapter.chapter, check.id, check.status, check.message)
            assert "not implemented" in check.message, (chapter.chapter, check.id, check.message)


def _results(report) -> list:
    return [(ch.chapter, c.id, c.status, c.points, c.message) for ch in report.chapters for c in ch.checks]


@pytest.mark.parametrize("form", slow_but_the_first(["relative", "qualified", "plain", "stub"]))
def test_solution_files_copied_into_exercises_grade_as_the_references(repo_root, tmp_path, form):
    """The three import forms of an earlier chapter the contract allows: from .ch03_jacobian,
    from exercises.ch03_jacobian and the plain from ch03_jacobian; and the stubs' own form (relative,
    else plain: it also runs as a script)."""
    import re
    import shutil

    package = tmp_path / "exercises"
    package.mkdir()
    for source in (repo_root / "solutions").glob("ch*.py"):
        text = source.read_text(encoding="utf-8")
        replacement = {"relative": r"from .\1 import\2", "qualified": r"from exercises.\1 import\2",
                       "plain": r"from \1 import\2",
                       "stub": r"try:\n    from .\1 import\2\nexcept ImportError:\n    from \1 import\2"}[form]
        (package / source.name).write_text(re.sub(r"from \.(ch0\d_\w+) import(.*)", replacement, text),
                                           encoding="utf-8")
    shutil.copyfile(repo_root / "exercises" / "__init__.py", package / "__init__.py")
    copied = grade_code(tmp_path, ALL)
    references = grade_code(repo_root, ALL, "solutions")
    assert _results(copied) == _results(references)
    assert copied.score == copied.max_score
