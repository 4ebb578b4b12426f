"""Notebook chapters, `%grade` and one function at a time, tried as learners work: real files, real
`grade` processes, a real IPython shell and a real Jupyter kernel (ipykernel through nbclient).

- a chapter kept as exercises/chNN_*.ipynb grades exactly as the same code in a .py (right, buggy and
  hostile submissions, verdict by verdict), with messages at "cell N, line M"; a .py beside it wins and
  the output says so; batch grading takes zipped notebooks;
- `%grade ch06` in IPython shows the score `grade ch06` gives, also for code only the kernel ran;
- `grade ch06 H_jacobian` grades that function alone and says what it left out;
- the stubs run as scripts, and an import error names the accepted import forms;
- `grade release --notebooks` hands out notebooks that hold no answer and grade in a Jupyter kernel.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
import textwrap
import zipfile
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest

from grader.chapters import CHAPTERS
from tests.support import (
    REPO,
    build_submission,
    code_points,
    replace_function,
    run_grade,
)

nbformat = pytest.importorskip("nbformat")

SPLIT = re.compile(r"(?m)^(?=def |class |if __name__)")


def _as_notebook(source: str, path: Path) -> list[tuple[int, int, int]]:
    """Write `source` as a notebook at `path`: a markdown cell, IPython's own lines (a magic, a shell line, a
    %%bash cell that is not Python), then the module in code cells, one per top-level function. Returns
    (cell number, first line in the .py, line count) of each code cell holding module lines."""
    notebook = nbformat.v4.new_notebook()
    notebook.cells.append(nbformat.v4.new_markdown_cell("# My chapter\n\n`%grade` checks it."))
    notebook.cells.append(nbformat.v4.new_code_cell("%load_ext grader\n%matplotlib inline\n!echo hello"))
    notebook.cells.append(nbformat.v4.new_code_cell("%%bash\necho 'not Python: ( ]'"))
    where, line = [], 1
    for part in SPLIT.split(source):
        if not part:
            continue
        notebook.cells.append(nbformat.v4.new_code_cell(part.rstrip("\n")))
        where.append((len(notebook.cells), line, part.count("\n")))
        line += part.count("\n")
    notebook.cells.append(nbformat.v4.new_code_cell("H_jacobian?\n%grade ch06"))
    nbformat.write(notebook, str(path))
    return where


def _notebook_twin(submission: Path, root: Path, modules: list[str] | None = None) -> Path:
    """A copy of a submission with its chapter files (or `modules`) as notebooks instead."""
    shutil.copytree(submission, root)
    for path in sorted((root / "exercises").glob("ch*.py")):
        if modules is None or path.stem in modules:
            _as_notebook(path.read_text(encoding="utf-8"), path.with_suffix(".ipynb"))
            path.unlink()
    return root


def _verdicts(report: dict) -> dict:
    """Each check's verdict with locations taken out of messages (they differ: line N, cell N line M)."""
    def plain(message: str) -> str:
        message = re.sub(r"exercises/(ch\d\d_\w+)\.(py|ipynb)", r"exercises/\1", message)
        message = re.sub(r"(, )?(cell \d+, )?line \d+", " LINE", message)
        return re.sub(r"\(exercises/ch\d\d_\w+ LINE\)", "( LINE)", message)

    return {(ch["chapter"], c["id"]): (c["status"], c["points"], plain(c["message"]), c["expected"], c["got"])
            for ch in report["chapters"] for c in ch["checks"]}


FORGED = ("import os, json\nlines = b''.join((json.dumps({'event': 'returned', 'chapter': 'ch06', 'index': i, "
          "'value': {'t': 'scalar', 'type': 'float', 'data': 1.0}}) + '\\n').encode() for i in range(50))\n"
          "for fd in range(3, 64):\n    try:\n        os.write(fd, lines)\n    except OSError:\n        pass\n")

CASES = {
    "right": {},
    "buggy": {
        "ch06_measurement": replace_function("ch06_measurement", "H_jacobian", """
            def H_jacobian(x, y):
                r2 = float(x) ** 2 + float(y) ** 2
                r = r2 ** 0.5
                return np.array([[x / r, -y / r2], [y / r, x / r2]]) / (x - 3)
            """),
        "ch07_dynamics": replace_function("ch07_dynamics", "F_jacobian", """
            def F_jacobian(state, v, omega, dt):
                th = float(np.asarray(state, dtype=float)[2])
                return np.array([[1.0, 0.0, v * np.sin(th) * dt], [0.0, 1.0, v * np.cos(th) * dt], [0.0, 0.0, 1.0]])
            """),
        "ch02_gradient": "import numpy as np\n\ndef example_f(x, y):\n    return x * x + x * y\n\n"
                         "def example_gradient(x, y)\n    return 0\n",
    },
    "hostile": {
        "ch06_measurement": replace_function("ch06_measurement", "H_jacobian", """
            def H_jacobian(x, y):
                class Yes(np.ndarray):
                    def __eq__(self, other):
                        return True
                return np.zeros((2, 2)).view(Yes)
            """) + "\n" + FORGED,
        "ch03_jacobian": "import sys\nprint('x' * 100000)\nsys.exit(0)\n",
        "ch05_finite_differences": "while True:\n    pass\n",
    },
}


@pytest.mark.slow
@pytest.mark.parametrize("case", sorted(CASES))
def test_a_notebook_chapter_grades_exactly_as_its_py(tmp_path, case):
    submission = build_submission(tmp_path / "py", CASES[case])
    twin = _notebook_twin(submission, tmp_path / "notebooks")
    with ThreadPoolExecutor(2) as both:  # side by side: the hostile case waits out its time limits
        as_py, as_notebook = both.map(
            lambda root: json.loads(run_grade("all", "--submission", str(root), "--format", "json", "--no-quiz").stdout),
            (submission, twin))
    assert _verdicts(as_notebook) == _verdicts(as_py)
    assert as_notebook["score"] == as_py["score"]
    assert {ch["source"] for ch in as_notebook["chapters"]} == {f"exercises/{c.module}.ipynb" for c in CHAPTERS}
    if case == "right":
        assert as_notebook["score"] == as_notebook["max_score"] > 0


def test_messages_and_tracebacks_point_at_cell_and_line(tmp_path):
    source = replace_function("ch06_measurement", "H_jacobian", """
        def H_jacobian(x, y):
            scale = 1.0 / (float(x) - float(x))
            return np.eye(2) * scale
        """)
    submission = build_submission(tmp_path / "py", {"ch06_measurement": source,
                                                    "ch02_gradient": "import numpy as np\n\nx = (1,\n"})
    twin = tmp_path / "nb"
    shutil.copytree(submission, twin)
    where = _as_notebook(source, twin / "exercises" / "ch06_measurement.ipynb")
    (twin / "exercises" / "ch06_measurement.py").unlink()
    _as_notebook((submission / "exercises" / "ch02_gradient.py").read_text(encoding="utf-8"),
                 twin / "exercises" / "ch02_gradient.ipynb")
    (twin / "exercises" / "ch02_gradient.py").unlink()
    # where the .py raises, in the notebook's cell of H_jacobian
    line = source.splitlines().index("    scale = 1.0 / (float(x) - float(x))") + 1
    cell, first, _ = next(w for w in where if w[1] <= line < w[1] + w[2])
    report = json.loads(run_grade("ch06", "ch02", "--submission", str(twin), "--format", "json", "--no-quiz",
                               "-v").stdout)
    ch06 = next(c for c in report["chapters"] if c["chapter"] == "ch06")
    message = next(c["message"] for c in ch06["checks"] if c["id"] == "H_worked_example")
    assert f"(exercises/ch06_measurement.ipynb, cell {cell}, line {line - first + 1})" in message, message
    text = run_grade("ch06", "--submission", str(twin), "--no-quiz", "-v").stdout
    assert f'File "exercises/ch06_measurement.ipynb", cell {cell}, line {line - first + 1}, in H_jacobian' in text
    ch02 = next(c for c in report["chapters"] if c["chapter"] == "ch02")
    assert ch02["problems"][0].startswith("exercises/ch02_gradient.ipynb, cell 4, line 3: SyntaxError"), ch02["problems"]


def test_a_py_beside_the_notebook_is_graded_and_the_output_says_so(tmp_path):
    submission = build_submission(tmp_path / "both")
    _as_notebook("def range_bearing(x, y):\n    return 0\n", submission / "exercises" / "ch06_measurement.ipynb")
    report = json.loads(run_grade("ch06", "--submission", str(submission), "--format", "json", "--no-quiz").stdout)
    chapter = report["chapters"][0]
    assert chapter["source"] == "exercises/ch06_measurement.py" and chapter["score"] == chapter["max_score"]
    assert "both exercises/ch06_measurement.py and ch06_measurement.ipynb exist: graded exercises/ch06_measurement.py" \
        in chapter["notes"][0]
    assert "note: both exercises/ch06_measurement.py" in run_grade("ch06", "--submission", str(submission),
                                                               "--no-quiz").stdout


def test_a_notebook_that_is_not_one_is_said(tmp_path):
    submission = build_submission(tmp_path / "broken")
    (submission / "exercises" / "ch06_measurement.py").unlink()
    (submission / "exercises" / "ch06_measurement.ipynb").write_text("{not json", encoding="utf-8")
    report = json.loads(run_grade("ch06", "--submission", str(submission), "--format", "json", "--no-quiz").stdout)
    chapter = report["chapters"][0]
    assert chapter["problems"][0].startswith("exercises/ch06_measurement.ipynb could not be read: not a Jupyter "
                                             "notebook: not valid JSON")
    assert chapter["score"] == 0 and {c["status"] for c in chapter["checks"]} == {"error"}


def test_ipython_lines_are_left_out_and_python_is_kept():
    from grader.notebook import module_from_cells, python_lines

    assert python_lines("%pip install x\nimport numpy as np") == ["", "import numpy as np"]
    assert python_lines("%%time\nx = 1") == ["", ""]
    assert python_lines("if True:\n    %matplotlib inline\n    x = 1") == ["if True:", "    pass", "    x = 1"]
    assert python_lines("!ls \\\n  -l\ny = 2") == ["", "", "y = 2"]
    assert python_lines("files = !ls\nH_jacobian?\n??np.sum") == ["", "", ""]
    for python in ("x = (1\n  % 2)", 's = """\n%not a magic\n!nor a shell line\n"""', "a = b % c", "a != b",
                   "print(1)  # why?"):
        assert python_lines(python) == python.splitlines(), python
    module = module_from_cells([("cell 2", "import numpy"), ("cell 3", "from __future__ import annotations\nx = 1")],
                               "nb")
    compile(module.text, "module", "exec")  # a future import a kernel takes in any cell moves first
    assert module.where(module.text.splitlines().index("x = 1") + 1) == "cell 3, line 2"


@pytest.mark.slow
def test_batch_grades_zipped_notebooks_as_their_py(tmp_path):
    from grader.course.batch import run_batch

    submissions = tmp_path / "submissions"
    submissions.mkdir()
    buggy = build_submission(tmp_path / "buggy", CASES["buggy"])
    twin = _notebook_twin(buggy, tmp_path / "twin", ["ch06_measurement", "ch07_dynamics"])
    for name, folder in (("as_py", buggy), ("as_notebook", twin)):
        with zipfile.ZipFile(submissions / f"{name}.zip", "w") as archive:
            for path in sorted((folder / "exercises").rglob("*")):
                if path.is_file():
                    archive.write(path, path.relative_to(folder).as_posix())
    sandboxed = shutil.which("bwrap") is not None and os.environ.get("GRADER_SANDBOX") != "off"
    result = run_batch(submissions, tmp_path / "out", chapters=["ch06", "ch07"], jobs=1, seed=7, html=False,
                       sandboxed=sandboxed)
    assert result.statuses == {"as_py": "graded", "as_notebook": "graded"}
    reports = {n: json.loads((tmp_path / "out" / n / "report.json").read_text(encoding="utf-8"))
               for n in ("as_py", "as_notebook")}
    assert _verdicts(reports["as_notebook"]) == _verdicts(reports["as_py"])
    assert 0 < reports["as_notebook"]["score"] < reports["as_notebook"]["max_score"]
    with open(tmp_path / "out" / "gradebook.csv", encoding="utf-8") as handle:
        rows = {row[0]: row[1:] for row in __import__("csv").reader(handle)}
    assert rows["as_py"] == rows["as_notebook"]


# ------------------------------------------------------------------------------ one function at a time

@pytest.mark.slow
def test_grade_one_function_grades_it_alone_and_says_what_it_left_out():
    whole = json.loads(run_grade("ch06", "--solutions", "--format", "json", "--no-quiz").stdout)
    alone = run_grade("ch06", "H_jacobian", "--solutions", "--format", "json")
    assert alone.returncode == 0, alone.stderr
    chapter = json.loads(alone.stdout)["chapters"][0]
    assert {c["function"] for c in chapter["checks"]} == {"H_jacobian"}
    assert [c["id"] for c in chapter["checks"]] == [c["id"] for c in whole["chapters"][0]["checks"]
                                                   if c["function"] == "H_jacobian"]
    assert chapter["score"] == sum(c["max_points"] for c in whole["chapters"][0]["checks"]
                                   if c["function"] == "H_jacobian")
    left = len([c for c in whole["chapters"][0]["checks"] if c["function"] != "H_jacobian"])
    assert chapter["notes"] == [f"graded H_jacobian only; left out {left} checks "
                                f"({whole['chapters'][0]['max_score'] - chapter['max_score']:g} points) of "
                                "range_bearing, measurement_covariance, range_bearing_elevation, H3_jacobian, and the "
                                "quiz: `grade ch06` grades the whole chapter"]
    assert json.loads(run_grade("H_jacobian", "--solutions", "--format", "json").stdout)["chapters"] == \
        json.loads(alone.stdout)["chapters"]
    wrong = run_grade("ch06", "H_jacobain", "--solutions")
    assert wrong.returncode == 2 and "did you mean H_jacobian?" in wrong.stderr
    elsewhere = run_grade("ch03", "H_jacobian", "--solutions")
    assert elsewhere.returncode == 2 and "H_jacobian is a function of ch06, not of ch03" in elsewhere.stderr


# ------------------------------------------------------------------------------ files that run, import forms

@pytest.mark.slow
def test_every_stub_runs_as_a_script_and_prints_its_worked_example(tmp_path):
    for info in CHAPTERS:
        done = subprocess.run([sys.executable, str(REPO / "exercises" / f"{info.module}.py")], cwd=tmp_path,
                              capture_output=True, text=True, encoding="utf-8", timeout=120)
        assert done.returncode == 0, (info.module, done.stderr)
        assert "= not written yet" in done.stdout and f"`grade {info.id}`" in done.stdout, done.stdout
    # written functions print their worked example; chapter 4 imports chapter 3 when run as a script
    package = tmp_path / "exercises"
    shutil.copytree(REPO / "exercises", package)
    for module in ("ch03_jacobian", "ch04_chain_rule"):
        stub = (package / f"{module}.py").read_text(encoding="utf-8")
        reference = (REPO / "solutions" / f"{module}.py").read_text(encoding="utf-8")
        functions = {m.group(1): m.group(0) for m in re.finditer(r"(?ms)^def (\w+)\(.*?(?=^\S)", reference + "\n#")}
        for name, body in functions.items():
            if name.startswith("_"):  # a reference's helper goes in too
                stub = stub.replace('\nif __name__ == "__main__":', f'\n{body}\n\nif __name__ == "__main__":')
            stub = re.sub(rf"(?ms)^def {name}\(.*?(?=^\S)", lambda _, body=body: body + "\n\n", stub)
        (package / f"{module}.py").write_text(stub, encoding="utf-8")
    done = subprocess.run([sys.executable, "exercises/ch04_chain_rule.py"], cwd=tmp_path, capture_output=True,
                          text=True, encoding="utf-8", timeout=120)
    assert done.returncode == 0, done.stderr
    assert re.search(r"pipeline_jacobian\(4, np.pi / 3\) = \[\[ *2\.866\d* +-11\.85\d*\]", done.stdout), done.stdout
    imported = subprocess.run([sys.executable, "-c", "import ch04_chain_rule as m; print(m.pipeline_jacobian(4, 1))"],
                              cwd=package, capture_output=True, text=True, timeout=120)  # a notebook in exercises/
    assert imported.returncode == 0, imported.stderr
    graded = json.loads(run_grade("ch03", "ch04", "--submission", str(tmp_path), "--format", "json",
                               "--no-quiz").stdout)
    assert graded["score"] == graded["max_score"] > 0  # the stubs' import form grades too


def test_an_import_error_names_the_accepted_forms(tmp_path):
    source = (REPO / "solutions" / "ch04_chain_rule.py").read_text(encoding="utf-8")
    submission = build_submission(tmp_path, {"ch04_chain_rule": source.replace("from .ch03_jacobian", "from ch03")})
    report = json.loads(run_grade("ch04", "--submission", str(submission), "--format", "json", "--no-quiz").stdout)
    problem = report["chapters"][0]["problems"][0]
    assert "No module named 'ch03'" in problem
    assert ("How to import: an earlier chapter's file is imported in one of three forms, all graded alike: "
            "`from .ch03_jacobian import polar_to_cartesian` (relative), `from exercises.ch03_jacobian import "
            "polar_to_cartesian` or `from ch03_jacobian import polar_to_cartesian`") in problem


# ------------------------------------------------------------------------------ %grade in IPython

IPYTHON_SCRIPT = r'''
import json, sys
from IPython.terminal.interactiveshell import TerminalInteractiveShell

shell = TerminalInteractiveShell.instance()
out = {}

def run(code):
    result = shell.run_cell(code, store_history=True)
    return result.result

run("%load_ext grader")
for step in json.loads(sys.argv[1]):
    value = run(step)
    if step.startswith("%grade"):
        from grader.faces import magic  # the resident grading process that answered
        out.setdefault("grades", []).append({"score": value.score, "max_score": value.max_score, "text": value.text,
                                             "html": value._repr_html_(), "repr": repr(value),
                                             "server": magic._PROCESS.process.pid})
print("RESULT" + json.dumps(out))
'''


def _ipython(cells: list[str], cwd: Path) -> list[dict]:
    pytest.importorskip("IPython")
    done = subprocess.run([sys.executable, "-c", IPYTHON_SCRIPT, json.dumps(cells)], cwd=cwd, capture_output=True,
                          text=True, encoding="utf-8", timeout=600)
    assert done.returncode == 0, done.stderr[-3000:]
    return json.loads(done.stdout.split("RESULT", 1)[1])["grades"]


@pytest.mark.slow
def test_percent_grade_shows_the_score_grade_shows(tmp_path):
    submission = build_submission(tmp_path / "project", {"ch06_measurement": CASES["buggy"]["ch06_measurement"]})
    grades = _ipython(["%grade ch06", "%grade ch06 --no-quiz", "%grade ch06 H_jacobian", "%grade all --no-quiz"],
                      cwd=submission / "exercises")
    for grade, args in zip(grades, (["ch06"], ["ch06", "--no-quiz"], ["ch06", "H_jacobian"], ["all", "--no-quiz"])):
        report = json.loads(run_grade(*args, "--format", "json", cwd=submission).stdout)
        assert (grade["score"], grade["max_score"]) == (report["score"], report["max_score"]), args
        assert grade["html"] is None and grade["repr"] == grade["text"].rstrip("\n")  # a terminal: text
        assert f"ch06 total: {report['chapters'][-4]['score'] if args[0] == 'all' else report['score']:g}/" \
            in grade["text"]
    assert 0 < grades[1]["score"] < grades[1]["max_score"]


def test_the_notebook_grading_process_grades_the_cells_the_kernel_ran(tmp_path, monkeypatch):
    """grader.faces.notebook_server's Server, in this process, given what grader.faces.magic gathers in a kernel (the functions
    the notebook defined, the cells it ran): the references typed into cells get the marks the file gets. (The
    whole route, IPython and the resident process included: the two tests around this one.)"""
    from grader.faces import magic, notebook_server

    source = (REPO / "solutions" / "ch06_measurement.py").read_text(encoding="utf-8")
    cells = [part for part in SPLIT.split(source) if part.strip()]
    namespace = {"__name__": "__main__"}
    for cell in cells:
        exec(compile(cell, "<cell>", "exec"), namespace)  # noqa: S102  (the references, as a kernel runs them)
    shell = type("Shell", (), {"history_manager": type("History", (), {"input_hist_raw": ["", *cells]})()})()
    monkeypatch.chdir(tmp_path)  # the server works in the kernel's folder: here an empty one, as in Colab
    server = notebook_server.Server()
    try:
        answer = server.handle({"args": ["ch06", "--no-quiz"], "cwd": str(tmp_path), "html": False,
                                "defined": magic.defined_functions(namespace), "cells": magic.kernel_cells(shell)})
    finally:
        server.close()
    assert "graded: the code this notebook's kernel ran" in answer["text"], answer
    assert answer["score"] == answer["max_score"] == float(code_points("ch06")), answer["text"]


@pytest.mark.slow
def test_percent_grade_grades_the_code_the_kernel_ran(tmp_path):
    """No exercises/ folder (as in Colab): the notebook's own cells are graded, in the order they ran, a cell that
    raised in the kernel included; after an edit the same resident process grades again (no interpreter to start)."""
    source = CASES["buggy"]["ch06_measurement"]
    cells = [part for part in SPLIT.split(textwrap.dedent(source)) if part.strip()]
    fixed = replace_function("ch06_measurement", "H_jacobian", """
        def H_jacobian(x, y):
            r2 = float(x) ** 2 + float(y) ** 2
            if r2 == 0:
                raise ValueError("r = 0")
            r = r2 ** 0.5
            return np.array([[x / r, y / r], [-y / r2, x / r2]])
        """)
    fixed_cell = next(part for part in SPLIT.split(fixed) if part.startswith("def H_jacobian"))
    colab = tmp_path / "content"
    colab.mkdir()
    grades = _ipython([*cells, "H_jacobian(3, 0)", "%grade ch06 --no-quiz", fixed_cell, "%grade ch06 --no-quiz"],
                      cwd=colab)
    for grade, code in zip(grades, (source, fixed)):
        submission = build_submission(tmp_path / f"as_file_{grade is grades[1]}", {"ch06_measurement": code})
        report = json.loads(run_grade("ch06", "--no-quiz", "--format", "json", cwd=submission).stdout)
        assert (grade["score"], grade["max_score"]) == (report["score"], report["max_score"])
        assert "graded: the code this notebook's kernel ran" in grade["text"]
    assert grades[0]["score"] < grades[1]["score"] == grades[1]["max_score"]
    assert grades[1]["server"] == grades[0]["server"]  # the same resident process: no interpreter, no imports


def test_the_grade_command_never_imports_ipython_or_nbformat():
    done = subprocess.run([sys.executable, "-X", "importtime", "-m", "grader", "ch06", "--solutions", "--no-quiz"],
                          cwd=REPO, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0
    imported = {line.split("|")[-1].strip() for line in done.stderr.splitlines() if "|" in line}
    assert "grader.submission" in imported and "grader.notebook" in imported
    assert not {m for m in imported if m.split(".")[0] in ("IPython", "nbformat", "ipykernel", "jupyter_client")
                or m == "grader.faces.magic"}


# ------------------------------------------------------------------------------ the notebook handout

@pytest.fixture(scope="module")
def notebook_handout(tmp_path_factory):
    out = tmp_path_factory.mktemp("handout") / "out"
    done = run_grade("release", str(out), "--notebooks", "--no-classroom")
    assert done.returncode == 0, done.stderr
    return out


@pytest.mark.slow
def test_the_notebook_handout_holds_notebooks_and_no_answer(notebook_handout):
    from grader import checks
    from grader.course import release

    exercises = notebook_handout / "exercises"
    assert sorted(p.name for p in exercises.glob("ch*")) == sorted(f"{c.module}.ipynb" for c in CHAPTERS)
    for info in CHAPTERS:
        notebook = nbformat.read(str(exercises / f"{info.module}.ipynb"), as_version=4)
        nbformat.validate(notebook)
        code = [c.source for c in notebook.cells if c.cell_type == "code"]
        assert "%pip install" in code[0] and f"../{next(notebook_handout.glob('*.whl')).name}[notebook]" in code[0]
        assert code[-1] == f"%grade {info.id}"
        functions = {c.function for c in checks.load(info.id).checks}
        defined = [re.match(r"def (\w+)", c).group(1) for c in code if c.startswith("def ")]
        assert sorted(defined) == sorted(functions) and all(c.count("\ndef ") == 0 for c in code)
        assert any(c.cell_type == "markdown" and f"## `{defined[0]}(" in c.source for c in notebook.cells)
    assert release.scan(notebook_handout) == []


@pytest.mark.slow
def test_the_scan_finds_a_reference_planted_in_a_notebook(notebook_handout, tmp_path):
    from grader.course import release

    planted = tmp_path / "out"
    shutil.copytree(notebook_handout, planted)
    path = planted / "exercises" / "ch06_measurement.ipynb"
    notebook = nbformat.read(str(path), as_version=4)
    reference = (REPO / "solutions" / "ch06_measurement.py").read_text(encoding="utf-8")
    notebook.cells.insert(3, nbformat.v4.new_code_cell(
        re.search(r"(?ms)^def H_jacobian\(.*?(?=^\S)", reference).group(0).replace("H_jacobian", "helper")))
    nbformat.write(notebook, str(path))
    assert any(f.startswith("exercises/ch06_measurement.ipynb: a reference function's body") for f in
               release.scan(planted))


@pytest.mark.slow
def test_a_handout_notebook_grades_in_a_jupyter_kernel(notebook_handout, tmp_path):
    """The handout's ch06 notebook, filled in, run by a real Jupyter kernel (ipykernel, through nbclient) in a
    folder of its own: its last cell shows the report as HTML with plots, and the score `grade` gives."""
    nbclient = pytest.importorskip("nbclient")
    pytest.importorskip("ipykernel")
    notebook = nbformat.read(str(notebook_handout / "exercises" / "ch06_measurement.ipynb"), as_version=4)
    reference = (REPO / "solutions" / "ch06_measurement.py").read_text(encoding="utf-8")
    for cell in notebook.cells:
        name = re.match(r"def (\w+)", cell.source) if cell.cell_type == "code" else None
        if name:
            cell.source = re.search(rf"(?ms)^def {name.group(1)}\(.*?(?=^\S)", reference + "\n#").group(0)
    notebook.cells[-1].source = "%grade ch06 --no-quiz"
    folder = tmp_path / "colab"
    folder.mkdir()
    nbclient.NotebookClient(notebook, timeout=600, kernel_name="python3",
                            resources={"metadata": {"path": str(folder)}}).execute()
    errors = [o for c in notebook.cells if c.cell_type == "code" for o in c.outputs if o.output_type == "error"]
    assert not errors, errors
    shown = notebook.cells[-1].outputs[0]["data"]
    expected = json.loads(run_grade("ch06", "--solutions", "--no-quiz", "--format", "json").stdout)["score"]
    assert f"ch06 total: {expected:g}/{expected:g}" in shown["text/plain"]
    assert 'class="jl-report fragment"' in shown["text/html"] and "<img" in shown["text/html"]
    assert f"{expected:g} / {expected:g}" in shown["text/html"]
