"""`grade ch06 --watch`, run as a learner runs it: it grades at once, then again after every save of the
chapter's file, says which checks newly pass or fail, reports a syntax error or an endless loop and
goes on watching. A real subprocess with a real (sandboxed where installed) resident fork server."""

from __future__ import annotations

import re

import pytest

from tests.support import (
    RIGHT_H,
    WRONG_H,
    Watching,
    build_submission,
    code_points,
    replace_function,
    save,
)

_save = save  # the old name: tests/test_platforms.py imports RIGHT_H, WRONG_H, Watching and _save from here


@pytest.fixture
def watching(tmp_path):
    root = build_submission(tmp_path)
    watcher = Watching(root)
    yield watcher, root / "exercises" / "ch06_measurement.py"
    watcher.stop()


def test_each_save_grades_again_and_says_what_changed(watching):
    watcher, chapter = watching
    first = watcher.until(r"watching for saves")
    assert any(f"ch06 total: {code_points('ch06')}/{code_points('ch06')}" in line for line in first)
    right = chapter.read_text(encoding="utf-8")
    assert RIGHT_H in right
    save(chapter, right.replace(RIGHT_H, WRONG_H))
    after = watcher.until(r"watching for saves")
    assert any(re.search(r"graded ch06 in \d+ ms after saving ch06_measurement.py", line) for line in after)
    assert any(line.startswith("ch06: newly failing: H_worked_example") for line in after)
    assert any("has the wrong sign" in line for line in after)
    save(chapter, right + "\ndef broken(:\n")
    broken = watcher.until(r"watching for saves")
    assert any("SyntaxError" in line for line in broken)
    save(chapter, right)
    fixed = watcher.until(r"watching for saves")
    assert any(f"ch06 total: {code_points('ch06')}/{code_points('ch06')}" in line for line in fixed)
    assert any(line.startswith("ch06: newly passing:") for line in fixed)
    assert watcher.process.poll() is None  # still watching


@pytest.mark.slow
def test_an_endless_loop_is_reported_and_the_watch_goes_on(watching):
    watcher, chapter = watching
    watcher.until(r"watching for saves")
    right = chapter.read_text(encoding="utf-8")
    save(chapter, replace_function("ch06_measurement", "range_bearing",
                                    "def range_bearing(x, y):\n    while True:\n        pass\n"))
    looping = watcher.until(r"watching for saves", timeout=60)
    assert any("did not return in time" in line for line in looping)
    save(chapter, right)
    assert any(f"ch06 total: {code_points('ch06')}/{code_points('ch06')}" in line for line in watcher.until(r"watching for saves"))
