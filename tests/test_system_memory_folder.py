"""The folder in memory for small temporary files rewritten often (a batch worker's scratch folder): used where the
system has one with room, else the usual temporary folder."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

from grader import system


def _usable() -> bool:
    folder = system.MEMORY_FOLDER
    if not (hasattr(os, "statvfs") and os.path.isdir(folder) and os.access(folder, os.W_OK | os.X_OK)):
        return False
    found = os.statvfs(folder)
    return found.f_bavail * found.f_frsize >= system.MEMORY_FOLDER_FREE


@pytest.mark.skipif(not _usable(), reason="no folder in memory with room here")
def test_the_folder_in_memory_is_used_where_it_has_room_and_no_other_is_chosen(monkeypatch, tmp_path):
    for name in ("TMPDIR", "TEMP", "TMP"):
        monkeypatch.delenv(name, raising=False)
    assert system.memory_temp_dir() == system.MEMORY_FOLDER
    monkeypatch.setenv("TMPDIR", str(tmp_path))  # the machine's owner chose where temporary files go
    assert system.memory_temp_dir() == str(tmp_path)
    monkeypatch.delenv("TMPDIR")
    found = os.statvfs(system.MEMORY_FOLDER)
    monkeypatch.setattr(system, "MEMORY_FOLDER_FREE", found.f_bavail * found.f_frsize + (1 << 30))
    assert system.memory_temp_dir() == system.temp_dir()  # too small: a container's, say


def test_a_system_without_one_uses_the_temporary_folder(monkeypatch, tmp_path):
    for name in ("TMPDIR", "TEMP", "TMP"):  # none chosen: the folder in memory would be taken where there is one
        monkeypatch.delenv(name, raising=False)
    monkeypatch.setattr(system, "MEMORY_FOLDER", str(tmp_path / "no such folder"))
    assert system.memory_temp_dir() == system.temp_dir()
    monkeypatch.delattr(os, "statvfs", raising=False)  # Windows
    monkeypatch.setattr(system, "MEMORY_FOLDER", str(tmp_path))
    assert system.memory_temp_dir() == system.temp_dir()


def test_a_workers_scratch_folder_is_in_memory_private_and_gone_with_the_worker():
    """A worker's learner files are put in memory where there is room; the folder is the worker's alone (0700) and
    removed when it ends."""
    code = ("import os, stat\nfrom grader import system\nfrom grader.course import workers\n"
            "root = workers.scratch({'ch06_measurement.py': b'x = 1\\n', 'answers/ch06.yaml': b'a: 1\\n'})\n"
            "print(root.parent == __import__('pathlib').Path(system.memory_temp_dir()),"
            " stat.S_IMODE(root.stat().st_mode) == 0o700, (root / 'exercises' / 'ch06_measurement.py').read_bytes(),"
            " root)\nworkers.drop_scratch()\nprint(root.exists())")
    shown = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.split("\n")
    assert shown[0].startswith("True True b'x = 1\\n' ")
    assert shown[1] == "False"


def test_a_scratch_folder_removed_between_learners_is_made_anew_with_every_file():
    """The end of a login session empties /dev/shm (systemd-logind's RemoveIPC): the next learner's files are put into
    a new private folder, none of them taken as already there."""
    code = ("import shutil, stat\nfrom grader.course import workers\n"
            "files = {'ch06_measurement.py': b'x = 1\\n', 'answers/ch06.yaml': b'q1: a\\n'}\n"
            "first = workers.scratch(files)\nshutil.rmtree(first)\n"
            "again = workers.scratch(dict(files, **{'answers/ch06.yaml': b'q1: b\\n'}))\n"
            "print(sorted(p.relative_to(again).as_posix() for p in again.rglob('*') if p.is_file()),"
            " oct(stat.S_IMODE(again.stat().st_mode)))\nworkers.drop_scratch()")
    shown = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.strip()
    assert shown == "['exercises/answers/ch06.yaml', 'exercises/ch06_measurement.py'] 0o700"


def test_a_learner_whose_scratch_folder_was_removed_while_graded_is_not_graded(tmp_path):
    """What was read of a folder removed meanwhile may be missing: that learner is an error the next run grades again,
    never a grade (no results.json, no report.html), and the next learner is graded as ever."""
    from tests.support import build_submission

    build_submission(tmp_path / "subs" / "alice")
    build_submission(tmp_path / "subs" / "bob")
    (tmp_path / "out").mkdir()
    code = ("import shutil, sys\nfrom pathlib import Path\nfrom grader.course import workers\n"
            "from grader.course.staging import discover\nfrom grader.course_config import current\n"
            "grading = workers.Grading(('ch03',), 4, False, False, {}, 'required', frozenset(), current(None))\n"
            "alice, bob = discover(Path(sys.argv[1]))\ngrade = workers.grade_staged\n"
            "def removed_meanwhile(staged, *args, **kwargs):\n"
            "    outcome = grade(staged, *args, **kwargs)\n"
            "    shutil.rmtree(workers._worker_state['scratch'][1])\n    return outcome\n"
            "workers.grade_staged = removed_meanwhile\n"
            "first = workers._grade_one(alice, sys.argv[2], grading, (), None, False)\n"
            "workers.grade_staged = grade\n"
            "second = workers._grade_one(bob, sys.argv[2], grading, (), None, False)\n"
            "print(first.status, first.files['results.json'], 'removed from the grader' in first.message,"
            " second.status, second.report.chapters[0].score_of('code') == second.report.chapters[0].max_score_of('code'))")
    shown = subprocess.run([sys.executable, "-c", code, str(tmp_path / "subs"), str(tmp_path / "out")],
                           capture_output=True, text=True, check=True).stdout.strip()
    assert shown == "error None True graded True"
