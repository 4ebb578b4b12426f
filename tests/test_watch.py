"""`grade ch06 --watch`, run as a learner runs it: it grades at once, then again after every save of the
chapter's file, says which checks newly pass or fail, reports a syntax error or an endless loop and
goes on watching. A real subprocess with a real (sandboxed where installed) resident fork server."""

from __future__ import annotations

import queue
import re
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from tests.conftest import REPO, build_submission, code_points, replace_function

RIGHT_H = "    return np.array([[x / r, y / r], [-y / r2, x / r2]])"
WRONG_H = "    return np.array([[x / r, y / r], [y / r2, x / r2]])"


class Watching:
    def __init__(self, root: Path, command: list[str] | None = None) -> None:
        command = command or [sys.executable, "-m", "grader", "ch06", "--watch", "--no-quiz", "--submission", str(root)]
        self.process = subprocess.Popen(command, cwd=REPO, stdout=subprocess.PIPE,
                                        stderr=subprocess.STDOUT, text=True, encoding="utf-8")
        self.lines: queue.Queue = queue.Queue()
        self.reader = threading.Thread(target=self._read, daemon=True)
        self.reader.start()

    def _read(self) -> None:
        for line in self.process.stdout:
            self.lines.put(line.rstrip("\n"))

    def until(self, pattern: str, timeout: float = 30.0) -> list[str]:
        """Every line up to and including the first that matches `pattern`."""
        seen, end = [], time.monotonic() + timeout
        while time.monotonic() < end:
            try:
                line = self.lines.get(timeout=0.1)
            except queue.Empty:
                continue
            seen.append(line)
            if re.search(pattern, line):
                return seen
        raise AssertionError(f"no line matching {pattern!r} in {timeout} s; saw:\n" + "\n".join(seen[-30:]))

    def stop(self) -> None:
        self.process.terminate()
        self.process.wait(timeout=10)
        self.reader.join(timeout=10)
        self.process.stdout.close()


@pytest.fixture
def watching(tmp_path):
    root = build_submission(tmp_path)
    watcher = Watching(root)
    yield watcher, root / "exercises" / "ch06_measurement.py"
    watcher.stop()


def _save(path: Path, text: str) -> None:
    path.write_text(text, encoding="utf-8")


def test_each_save_grades_again_and_says_what_changed(watching):
    watcher, chapter = watching
    first = watcher.until(r"watching for saves")
    assert any(f"ch06 total: {code_points('ch06')}/{code_points('ch06')}" in line for line in first)
    right = chapter.read_text(encoding="utf-8")
    assert RIGHT_H in right
    _save(chapter, right.replace(RIGHT_H, WRONG_H))
    after = watcher.until(r"watching for saves")
    assert any(re.search(r"graded ch06 in \d+ ms after saving ch06_measurement.py", line) for line in after)
    assert any(line.startswith("ch06: newly failing: H_worked_example") for line in after)
    assert any("has the wrong sign" in line for line in after)
    _save(chapter, right + "\ndef broken(:\n")
    broken = watcher.until(r"watching for saves")
    assert any("SyntaxError" in line for line in broken)
    _save(chapter, right)
    fixed = watcher.until(r"watching for saves")
    assert any(f"ch06 total: {code_points('ch06')}/{code_points('ch06')}" in line for line in fixed)
    assert any(line.startswith("ch06: newly passing:") for line in fixed)
    assert watcher.process.poll() is None  # still watching


def test_an_endless_loop_is_reported_and_the_watch_goes_on(watching):
    watcher, chapter = watching
    watcher.until(r"watching for saves")
    right = chapter.read_text(encoding="utf-8")
    _save(chapter, replace_function("ch06_measurement", "range_bearing",
                                    "def range_bearing(x, y):\n    while True:\n        pass\n"))
    looping = watcher.until(r"watching for saves", timeout=60)
    assert any("did not return in time" in line for line in looping)
    _save(chapter, right)
    assert any(f"ch06 total: {code_points('ch06')}/{code_points('ch06')}" in line for line in watcher.until(r"watching for saves"))
