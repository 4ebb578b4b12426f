"""A chapter kept as a notebook, graded: messages name the notebook, the file that exists, never the .py made of
its cells; one that is not a notebook is said once; an error raised while its cells run names the cell of the
top-level statement that raised (the cell the kernel ran it in) and where, further in, the error happened."""

from __future__ import annotations

import json
import re
from pathlib import Path

from tests.support import build_submission, grade_code


def _notebook(cells: list[str]) -> str:
    """A notebook of nbformat 4 whose code cells are `cells`, after a markdown cell (cell 1)."""
    code = [{"cell_type": "code", "metadata": {}, "execution_count": None, "outputs": [], "source": c} for c in cells]
    markdown = {"cell_type": "markdown", "metadata": {}, "source": "# My chapter"}
    return json.dumps({"nbformat": 4, "nbformat_minor": 5, "metadata": {}, "cells": [markdown, *code]})


def _as_notebook(root: Path, text: str) -> Path:
    """root's ch06 chapter kept as ch06_measurement.ipynb holding `text`, and no .py of its name."""
    package = root / "exercises"
    (package / "ch06_measurement.py").unlink()
    (package / "ch06_measurement.ipynb").write_text(text, encoding="utf-8")
    return root


def test_a_notebook_that_is_not_one_is_named_in_every_message_and_said_once(tmp_path):
    root = _as_notebook(build_submission(tmp_path), '{"cells": [')
    chapter = grade_code(root, ["ch06"]).chapters[0]
    notebook = str(Path("exercises/ch06_measurement.ipynb"))
    assert chapter.source == "exercises/ch06_measurement.ipynb"
    assert len(chapter.problems) == 1, chapter.problems
    assert chapter.problems[0].startswith("exercises/ch06_measurement.ipynb could not be read: not a Jupyter "
                                          "notebook: not valid JSON"), chapter.problems
    messages = {c.message for c in chapter.checks}
    assert messages == {f"not graded: {notebook} could not be read (see the chapter's message)"}, messages
    said = [*chapter.problems, *chapter.notes, *messages]
    assert not any("ch06_measurement.py" in m for m in said), said  # no file that does not exist
    assert sum("not valid JSON" in m for m in said) == 1, said


def test_a_notebook_that_could_not_be_read_is_not_said_to_be_graded(tmp_path):
    from grader.model import ChapterResult, Report
    from grader.render import html, text

    unread = grade_code(_as_notebook(build_submission(tmp_path / "unread"), '{"cells": ['), ["ch06"])
    root = build_submission(tmp_path / "read")
    read = grade_code(_as_notebook(root, _notebook([(root / "exercises" / "ch06_measurement.py").read_text(
        encoding="utf-8")])), ["ch06"])
    assert unread.chapters[0].unread and not read.chapters[0].unread
    kept = ChapterResult.from_dict(unread.chapters[0].to_kept())  # as the memo and the history keep it
    for report, graded in ((unread, False), (read, True), (Report(unread.submission, [kept]), False)):
        said = {"text": text.render(report), "html": html.render_fragment(report)}
        for kind, page in said.items():
            shown = re.search(r"(^|>) *graded: exercises/ch06_measurement\.ipynb", page, re.MULTILINE)  # its own line
            assert bool(shown) == graded, (kind, page)
            assert ("exercises/ch06_measurement.ipynb could not be read: not a Jupyter notebook" in page) != graded, \
                (kind, page)


BOOM = "def boom(x):\n    y = x - x\n    return 1 / y\n"


def test_an_error_raised_while_the_cells_run_names_the_statement_that_raised_and_where(tmp_path):
    root = build_submission(tmp_path)
    module = (root / "exercises" / "ch06_measurement.py").read_text(encoding="utf-8")
    _as_notebook(root, _notebook([module, BOOM, "# try it\nz = 3\nboom(z)\n"]))
    chapter = grade_code(root, ["ch06"]).chapters[0]
    problem = chapter.problems[0]
    # the call at the top level of cell 4 raised, in boom, which cell 3 defines
    assert problem.startswith("exercises/ch06_measurement.ipynb, cell 4, line 3 raised ZeroDivisionError while being "
                              "imported (in boom, cell 3, line 3): division by zero"), problem
    assert 'File "exercises/ch06_measurement.ipynb", cell 4, line 3, in <module>' in problem, problem
    assert 'File "exercises/ch06_measurement.ipynb", cell 3, line 3, in boom' in problem, problem


def test_an_error_at_the_top_level_of_a_cell_names_that_cell_alone(tmp_path):
    root = build_submission(tmp_path)
    module = (root / "exercises" / "ch06_measurement.py").read_text(encoding="utf-8")
    _as_notebook(root, _notebook([module, "z = 3\nz / (z - z)\n"]))
    problem = grade_code(root, ["ch06"]).chapters[0].problems[0]
    assert problem.startswith("exercises/ch06_measurement.ipynb, cell 3, line 2 raised ZeroDivisionError while being "
                              "imported: division by zero"), problem
