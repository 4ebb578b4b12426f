"""Shared fixtures: the repository root on sys.path, submissions built from real files, quiz answer files graded.
The plain helpers they use, which test modules import, are in tests/support.py."""

from __future__ import annotations

import os
import shutil
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
if str(REPO) not in sys.path:
    sys.path.insert(0, str(REPO))

# The HTML report's figure cache (grader.render.figure_cache) is off in tests: a figure kept by one test
# would be reused by the next, and tests never touch the tester's own cache. Its tests turn it on.
os.environ["GRADER_CACHE_DIR"] = ""
# Nor is a judge kept warm after a run (grader.core.warm_judge): it would outlive the test by minutes. Its tests
# turn it on, and end the judges they keep.
os.environ["GRADER_WARM_JUDGE"] = "off"

from tests.support import Quiz, build_submission  # noqa: E402


@pytest.fixture(scope="session")
def repo_root() -> Path:
    return REPO


@pytest.fixture
def submission_factory(tmp_path):
    """Build a submission under tmp_path from {module: source}; returns its root."""
    counter = iter(range(1000))

    def make(replacements: dict[str, str] | None = None) -> Path:
        return build_submission(tmp_path / f"sub{next(counter)}", replacements)

    return make


@pytest.fixture
def quiz(tmp_path) -> Quiz:
    """Grade quiz answer files: quiz(chapter, text, learner="alice", quiz_dir=..., deadline=...) gives
    ({question id: CheckResult}, problems); quiz.one(chapter, question, answer) one answer's CheckResult;
    quiz.write(chapter, text) only writes the file. The files are in quiz.folder, tmp_path/exercises/answers."""
    return Quiz(tmp_path / "exercises" / "answers")


@pytest.fixture
def keyless_banks(tmp_path) -> Path:
    """A copy of the question banks without keys/, as a handout with quiz_feedback: recorded ships them."""
    from grader.quiz import bank

    quiz_dir = tmp_path / "quizzes"
    quiz_dir.mkdir()
    for path in bank.QUIZ_DIR.glob("ch*.yaml"):
        shutil.copy(path, quiz_dir / path.name)
    return quiz_dir
