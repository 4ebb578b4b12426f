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
def test_the_folder_in_memory_is_used_where_it_has_room(monkeypatch):
    assert system.memory_temp_dir() == system.MEMORY_FOLDER
    found = os.statvfs(system.MEMORY_FOLDER)
    monkeypatch.setattr(system, "MEMORY_FOLDER_FREE", found.f_bavail * found.f_frsize + (1 << 30))
    assert system.memory_temp_dir() == system.temp_dir()  # too small: a container's, say


def test_a_system_without_one_uses_the_temporary_folder(monkeypatch, tmp_path):
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
