"""The course file's parse is kept by its text's hash for the commands that grade one submission: one that reads an
unchanged course file again does not import yaml, and reads exactly the course it read the first time; a parse JSON
would change (a date) is not kept; the instructor's commands never read a kept parse."""

from __future__ import annotations

import json
import subprocess
import sys

from tests.support import REPO

_READ = """import json, sys
from grader import course_config
course = course_config.from_text(open(sys.argv[1], encoding="utf-8").read(), sys.argv[1], sys.argv[2] == "kept")
print(json.dumps([repr(course), course.where("seed"), "yaml" in sys.modules]))
"""


def _read(path, cache, kept: bool = True) -> list:
    done = subprocess.run([sys.executable, "-c", _READ, str(path), "kept" if kept else "parsed"], cwd=REPO,
                          capture_output=True, text=True,
                          env={"GRADER_CACHE_DIR": str(cache), "PATH": "/usr/bin:/bin"}, check=True)
    return json.loads(done.stdout)


def test_an_unchanged_course_file_is_read_again_without_yaml_and_alike(tmp_path):
    course = tmp_path / "course.yaml"
    course.write_text("# a comment\ncourse: c\nseed: 5\nhidden: [ch06/H_rows_orthogonal]\n", encoding="utf-8")
    first = _read(course, tmp_path / "cache")
    again = _read(course, tmp_path / "cache")
    assert first[:2] == again[:2] and first[1].endswith("line 3")
    assert first[2] and not again[2]  # parsed once with yaml, then read from the kept parse
    course.write_text("course: c\n\nseed: 6\n", encoding="utf-8")  # another text: parsed again
    changed = _read(course, tmp_path / "cache")
    assert changed[2] and "seed=6" in changed[0] and changed[1].endswith("line 3")


def test_a_parse_json_would_change_is_not_kept(tmp_path):
    course = tmp_path / "course.yaml"
    course.write_text("seed: 5\ndeadline: 2026-05-01T23:59:00+00:00\n", encoding="utf-8")  # yaml reads a datetime
    assert _read(course, tmp_path / "cache")[2] and _read(course, tmp_path / "cache")[2]
    assert not list((tmp_path / "cache").glob("course/*.json"))


def test_a_command_of_the_instructors_parses_the_file_and_trusts_no_kept_parse(tmp_path):
    course = tmp_path / "course.yaml"
    course.write_text("course: c\nseed: 5\n", encoding="utf-8")
    _read(course, tmp_path / "cache")
    (kept,) = (tmp_path / "cache" / "course").glob("*.json")
    kept.write_text(json.dumps([{"course": "c", "seed": 6}, {"course": 1, "seed": 2}]), encoding="utf-8")  # forged
    assert "seed=6" in _read(course, tmp_path / "cache")[0]  # what a one-submission command reads: its own cache
    instructors = _read(course, tmp_path / "cache", kept=False)
    assert "seed=5" in instructors[0] and instructors[2]
