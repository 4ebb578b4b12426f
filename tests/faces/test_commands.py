"""One command table (grader.faces.commands), read by the launcher and by the click layer: `grade --help` lists exactly
its commands, each defined where it says, and the launcher starts a learner's child first only for a command that
grades one submission at once (never for regrade, selftest or batch, which choose their own boundary)."""

from __future__ import annotations

import os
import time

import pytest
from click.testing import CliRunner

from grader.faces.cli import main
from grader.faces.commands import COMMANDS, grades_at_once
from tests.support import run_grade


def test_the_click_layer_has_exactly_the_tables_commands():
    context = main.make_context("grade", ["--help"], resilient_parsing=True)
    assert main.list_commands(context) == sorted(COMMANDS)
    for name, entry in COMMANDS.items():
        command = main.get_command(context, name)
        assert command.name == name and command.callback.__module__ == entry.module, name
    listed = CliRunner().invoke(main, ["--help"]).output
    assert all(f"  {name} " in listed for name in COMMANDS if name != "run"), listed


@pytest.mark.parametrize("args, at_once", [
    (["ch06"], True), (["run", "all"], True), (["6", "--html", "r.html"], True), (["list"], False),
    (["regrade", "out"], False), (["selftest"], False), (["batch", "subs", "--out", "o"], False),
    (["classroom", "all"], False), (["ch06", "--help"], False), (["--version"], False), ([], False)])
def test_the_launcher_starts_a_child_first_only_for_a_command_that_grades_at_once(args, at_once):
    assert grades_at_once(args) is at_once


def _traced(*args: str) -> list[str]:
    done = run_grade(*args, env={**os.environ, "GRADER_TRACE": repr(time.time())})
    assert done.returncode in (0, 1), done.stderr[-2000:]
    return [line.split(" ms  ", 1)[-1] for line in done.stderr.splitlines() if line.startswith("trace")]


def test_grade_ch06_starts_its_child_first_and_grade_list_none():
    assert "child started" in _traced("ch06", "--solutions", "--no-quiz")
    points = _traced("list")
    assert points and "child started" not in points, points
