"""Writing a file so that no reader ever sees half of it: UTF-8, the system's line ends, nothing left beside it."""

from __future__ import annotations

import os

import pytest

from grader import files


def test_a_text_is_written_whole_in_utf8_and_nothing_is_left_beside_it(tmp_path):
    target = tmp_path / "report.json"
    target.write_text("an older report, longer than the new one\n" * 50, encoding="utf-8")
    files.write_atomically(target, '{"message": "σ ✓ 日本"}\n')
    assert target.read_bytes() == '{"message": "σ ✓ 日本"}\n'.encode()
    assert [p.name for p in tmp_path.iterdir()] == ["report.json"]


def test_line_ends_are_the_systems_as_a_text_file_writes_them(tmp_path, monkeypatch):
    monkeypatch.setattr(os, "linesep", "\r\n")  # as on Windows, where a text file writes \r\n for \n
    files.write_atomically(tmp_path / "a.csv", "learner,score\nbo,3\n")
    assert (tmp_path / "a.csv").read_bytes() == b"learner,score\r\nbo,3\r\n"


def test_a_text_that_is_not_utf8_raises_before_any_file_is_made(tmp_path):
    with pytest.raises(UnicodeEncodeError):
        files.write_atomically(tmp_path / "report.html", "a lone surrogate \udcff")
    assert list(tmp_path.iterdir()) == []
