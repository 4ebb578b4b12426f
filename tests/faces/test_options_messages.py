"""How `grade` reads chapter and function names (grader.faces.options): a mistyped function gets the function it
most likely means, case aside and of the chapter named first; an unknown chapter of --chapters is named, with the
valid ones, under the option's own name."""

from __future__ import annotations

import pytest
from click.testing import CliRunner

from grader.chapters import BY_ID
from grader.faces.cli import main
from grader.faces.options import chapters_option, closest_function


def _grade(*args: str):
    return CliRunner().invoke(main, list(args))


@pytest.mark.parametrize("args, meant", [
    (("ch06", "h_jacobian"), "did you mean H_jacobian?"),  # not ch04's g_jacobian
    (("h3_jacobian",), "did you mean H3_jacobian?"),
    (("ch06", "G_jacobian"), "did you mean g_jacobian (of ch04)?"),
])
def test_a_mistyped_function_gets_the_one_meant_case_aside(args, meant):
    result = _grade(*args)
    assert result.exit_code == 2
    assert meant in result.output, result.output


def test_did_you_mean_prefers_the_functions_of_the_chapter_named():
    owners = {"g_jacobian": "ch04", "H_jacobian": "ch06", "F_jacobian": "ch07"}
    assert closest_function("x_jacobian", owners, [BY_ID["ch07"]]) == "F_jacobian"
    assert closest_function("x_jacobian", owners, [BY_ID["ch04"]]) == "g_jacobian"
    assert closest_function("h_jacobian", owners, [BY_ID["ch04"]]) == "H_jacobian (of ch06)"  # case aside, first
    assert closest_function("h_jacobian", owners, []) == "H_jacobian"
    assert closest_function("nothing_like_it", owners, [BY_ID["ch06"]]) is None


@pytest.mark.parametrize("command", [["batch", "SUBMISSIONS", "--out", "OUT"], ["selftest"]])
def test_an_unknown_chapter_of_chapters_is_named_with_the_valid_ones(tmp_path, command):
    args = [str(tmp_path) if a == "SUBMISSIONS" else str(tmp_path / "out") if a == "OUT" else a for a in command]
    result = _grade(*args, "--chapters", "ch6,ch66")
    assert result.exit_code == 2
    assert "Invalid value for --chapters: unknown chapter 'ch66'; choose one of ch00, ch01" in result.output
    assert "CHAPTER" not in result.output.split("Error:")[1]


def test_chapters_takes_short_ids_numbers_and_stray_commas():
    assert [c.id for c in chapters_option("ch6,5,")] == ["ch05", "ch06"]
    assert [c.id for c in chapters_option(" CH07 , ch6")] == ["ch06", "ch07"]
    assert len(chapters_option("all")) == len(BY_ID)
