"""grader.notebook.relocate: a traceback of a module made of cells points at "cell N, line M"; an error raised while
the cells run names the top-level statement that raised (the cell that ran it) and where, further in, it happened."""

from __future__ import annotations

from grader.notebook import module_from_cells, relocate

MODULE = "exercises/ch06_measurement.py"
CELLS = [("cell 2", "import numpy as np"), ("cell 3", "def boom(x):\n    y = x - x\n    return 1 / y"),
         ("cell 5", "z = 3\nboom(z)")]


def _error(*frames: tuple[str, int, str]) -> dict:
    trace = "\n".join(f'  File "{file}", line {line}, in {name}\n    code' for file, line, name in frames)
    return {"exception": "ZeroDivisionError", "message": "division by zero", "line": frames[-1][1],
            "traceback": f"{trace}\nZeroDivisionError: division by zero"}


def _sources():
    source = module_from_cells(CELLS, "exercises/ch06_measurement.ipynb")
    lines = source.text.splitlines()
    return {MODULE: source}, lines.index("boom(z)") + 1, lines.index("    return 1 / y") + 1


def test_an_import_error_names_the_statement_that_raised_and_where_it_happened():
    sources, call, division = _sources()
    error = _error((MODULE, call, "<module>"), (MODULE, division, "boom"))
    relocate(error, sources)
    assert error["statement"] == "exercises/ch06_measurement.ipynb, cell 5, line 2"
    assert error["inside"] == "boom, cell 3, line 3"
    assert error["where"] == "exercises/ch06_measurement.ipynb, cell 3, line 3"
    assert 'File "exercises/ch06_measurement.ipynb", cell 5, line 2, in <module>' in error["traceback"]


def test_an_error_in_another_file_is_named_with_its_file():
    sources, call, _ = _sources()
    error = _error((MODULE, call, "<module>"), ("exercises/helpers.py", 7, "boom"))
    relocate(error, sources)
    assert error["statement"] == "exercises/ch06_measurement.ipynb, cell 5, line 2"
    assert error["inside"] == "boom, exercises/helpers.py, line 7"
    assert "where" not in error


def test_a_statement_that_raised_itself_or_a_call_of_a_function_has_no_statement():
    sources, call, division = _sources()
    alone = _error((MODULE, call, "<module>"))
    relocate(alone, sources)
    assert alone["where"] == "exercises/ch06_measurement.ipynb, cell 5, line 2" and "statement" not in alone
    called = _error((MODULE, division - 1, "H_jacobian"), (MODULE, division, "boom"))  # a check's call
    relocate(called, sources)
    assert called["where"] == "exercises/ch06_measurement.ipynb, cell 3, line 3" and "statement" not in called


def test_a_chapter_file_made_of_no_cells_names_its_statement_by_file_and_line():
    error = _error((MODULE, 12, "<module>"), (MODULE, 5, "boom"))
    relocate(error, {})
    assert (error["statement"], error["inside"]) == ("exercises/ch06_measurement.py, line 12", "boom, line 5")
    assert "where" not in error and error["traceback"].startswith('  File "exercises/ch06_measurement.py", line 12')


def test_an_error_on_the_statements_own_line_names_that_line_alone():
    sources, call, _ = _sources()
    error = _error((MODULE, call, "<module>"), (MODULE, call, "<listcomp>"))  # a comprehension's frame (Python 3.11)
    relocate(error, sources)
    assert "statement" not in error and error["where"] == "exercises/ch06_measurement.ipynb, cell 5, line 2"
