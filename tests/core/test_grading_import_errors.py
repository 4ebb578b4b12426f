"""A chapter file (.py) that raises while it is imported: the message names the top-level statement of the chapter's
file that raised and, when that is elsewhere, where the error happened (a function it calls, an earlier chapter's
file it imports), as a notebook's names its cells (tests/core/test_grading_notebooks.py)."""

from __future__ import annotations

from pathlib import Path

from tests.support import REPO, build_submission, grade_code

BOOM = "\n\ndef boom(x):\n    y = x - x\n    return 1 / y\n\n\nz = 3\nboom(z)\n"


def _line_of(text: str, wanted: str) -> int:
    """The (1-based) number of the line of `text` that is `wanted`, stripped."""
    return [line.strip() for line in text.splitlines()].index(wanted) + 1


def _reference(module: str) -> str:
    return (REPO / "solutions" / f"{module}.py").read_text(encoding="utf-8").replace("solutions.", "exercises.")


def test_a_call_at_the_top_level_that_raises_names_the_statement_and_where_it_happened(tmp_path):
    text = _reference("ch06_measurement") + BOOM
    root = build_submission(tmp_path, {"ch06_measurement": text})
    chapter = grade_code(root, ["ch06"]).chapters[0]
    problem = chapter.problems[0]
    call, division = _line_of(text, "boom(z)"), _line_of(text, "return 1 / y")
    assert problem.startswith(f"{Path('exercises/ch06_measurement.py')}, line {call} raised ZeroDivisionError while "
                              f"being imported (in boom, line {division}): division by zero"), problem
    assert f'File "{Path("exercises/ch06_measurement.py")}", line {division}, in boom' in problem, problem


def test_an_earlier_chapters_file_that_raises_is_named_after_the_import_that_ran_it(tmp_path):
    text = _reference("ch06_measurement") + "\n\nz = 3\nz / (z - z)\n"
    root = build_submission(tmp_path, {"ch06_measurement": text})
    ch06, ch08 = grade_code(root, ["ch06", "ch08"]).chapters
    division = _line_of(text, "z / (z - z)")
    assert ch06.problems[0].startswith(f"{Path('exercises/ch06_measurement.py')}, line {division} raised "
                                       "ZeroDivisionError while being imported: division by zero"), ch06.problems
    imported = _line_of(_reference("ch08_lab"), "from .ch06_measurement import H_jacobian, range_bearing")
    assert ch08.problems[0].startswith(
        f"{Path('exercises/ch08_lab.py')}, line {imported} raised ZeroDivisionError while being imported (in "
        f"{Path('exercises/ch06_measurement.py')}, line {division}): division by zero"), ch08.problems
