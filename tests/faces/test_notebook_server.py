"""grader.faces.notebook_server's note on a saved chapter file that differs from the cells the kernel ran: the two are
read alike (a saved notebook cell by cell, IPython's own lines left out as the module made of cells leaves them
out, line endings and trailing newlines not counted), so a notebook saved as the kernel ran it gets no note and one
with a function changed since gets it, naming that function."""

from __future__ import annotations

import json
import re
from pathlib import Path

from grader.course.release import stub_notebook
from grader.faces.notebook_server import _unsaved
from grader.submission import Submission
from tests.support import REPO

MODULE = "ch06_measurement"


def _handout_notebook(folder: Path) -> list[str]:
    """The ch06 notebook `grade release --notebooks` hands out, with the references in its cells (its install cell
    with `%pip` and `%load_ext grader`, a last cell `%grade ch06`), saved at folder/exercises as Jupyter on Windows
    saves it (each source a list of lines ending in CRLF); its code cells' sources as a kernel ran them."""
    source = re.sub(r"\bsolutions\.", "exercises.", (REPO / "solutions" / f"{MODULE}.py").read_text(encoding="utf-8"))
    notebook = stub_notebook(source, "ch06", "grader.whl")
    ran = [cell["source"] for cell in notebook["cells"] if cell["cell_type"] == "code"]
    for cell in notebook["cells"]:
        cell["source"] = [line.replace("\n", "\r\n") for line in cell["source"].splitlines(True)] + ["\r\n"]
    (folder / "exercises").mkdir(parents=True)
    (folder / "exercises" / f"{MODULE}.ipynb").write_text(json.dumps(notebook, indent=1), encoding="utf-8")
    return ran


def _kernel(folder: Path, ran: list[str]) -> Submission:
    cells = tuple((f"In [{n}]", code) for n, code in enumerate(ran, 1))
    return Submission(folder, "exercises", kernel=((MODULE, cells),))


def test_a_notebook_saved_as_the_kernel_ran_it_gets_no_note(tmp_path):
    ran = _handout_notebook(tmp_path)
    assert any("%grade ch06" in code for code in ran) and any("%pip" in code for code in ran)
    assert _unsaved(_kernel(tmp_path, ran), "ch06") == ""


def test_a_function_changed_since_the_notebook_was_saved_is_named(tmp_path):
    ran = _handout_notebook(tmp_path)
    edited = [code.replace("return", "return -1 *", 1) if code.startswith("def H_jacobian") else code for code in ran]
    assert edited != ran
    note = _unsaved(_kernel(tmp_path, edited), "ch06")
    assert "the saved ch06_measurement.ipynb has other code for H_jacobian:" in note, note


def test_a_py_saved_as_the_kernel_ran_it_gets_no_note(tmp_path):
    ran = _handout_notebook(tmp_path)
    (tmp_path / "exercises" / f"{MODULE}.ipynb").unlink()
    source = re.sub(r"\bsolutions\.", "exercises.", (REPO / "solutions" / f"{MODULE}.py").read_text(encoding="utf-8"))
    (tmp_path / "exercises" / f"{MODULE}.py").write_bytes(source.replace("\n", "\r\n").encode("utf-8-sig"))
    assert _unsaved(_kernel(tmp_path, ran), "ch06") == ""
