"""A chapter file that is not UTF-8 (Windows-1252, as an editor saves `# café` there) and declares no other encoding:
`python FILE` refuses it, so the grader says so at the file and line of the first such byte and how to fix it (save it
as UTF-8), and grades it as Python imports it, as it grades UTF-16 and byte-order-mark files with a note. A file that
declares its encoding (PEP 263) gets no note."""

from __future__ import annotations

import subprocess
import sys

from grader.submission import Submission
from tests.support import build_submission, code_points, grade_code

CHAPTER = "exercises/ch06_measurement.py"


def _with_comment(root, comment: str, encoding: str, first: str = "") -> int:
    """root's ch06 file with `comment` on a line of its own after the docstring, saved in `encoding`: that line."""
    path = root / CHAPTER
    lines = path.read_text(encoding="utf-8").splitlines(True)
    at = next(i for i, line in enumerate(lines) if line.startswith("import"))
    lines.insert(at, f"{comment}\n")
    path.write_bytes((first + "".join(lines)).encode(encoding))
    return at + 1 + bool(first)


def test_a_chapter_file_in_windows_1252_is_graded_with_a_note_at_its_line(tmp_path):
    root = build_submission(tmp_path)
    line = _with_comment(root, "# café au lait", "cp1252")
    python = subprocess.run([sys.executable, str(root / CHAPTER)], capture_output=True, text=True, timeout=60)
    assert python.returncode != 0 and "Non-UTF-8 code starting with '\\xe9'" in python.stderr, python.stderr
    assert f"on line {line}," in python.stderr, python.stderr  # the line Python names is the one the note names
    chapter = grade_code(root, ["ch06"]).chapters[0]
    assert chapter.notes == [f'{CHAPTER}, line {line} is not UTF-8 (byte 0xE9, "é" in Windows-1252): `python` '
                             "refuses such a file; save it as UTF-8 (in Notepad: Save as, Encoding: UTF-8)"]
    assert chapter.score == float(code_points("ch06")), [c.message for c in chapter.checks if c.message]


def test_a_chapter_file_that_declares_its_encoding_gets_no_note(tmp_path):
    for name, encoding, first in (("declared", "cp1252", "# -*- coding: cp1252 -*-\n"), ("utf8", "utf-8", "")):
        root = build_submission(tmp_path / name)
        _with_comment(root, "# café au lait", encoding, first)
        assert Submission(root).prepare().notes == {}, name
