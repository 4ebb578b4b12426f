"""`grade release OUT`: the learners' handout, which grades at home and holds no answer.

OUT gets the stubs and answer templates (`exercises/`), the grader as a wheel and a README for
learners. The wheel is the grader package as it is, minus nothing it needs and plus what replaces
the references: the expected value of every question the checks (and the report's plots) ask,
recorded at the public seed (grader/data/expected/chNN.json, see grader.judging.expected), the question
banks, and the course's public settings (grader/data/handout.json: public seed, quiz feedback,
which checks are hidden). Reference solutions, the oracle, quiz keys (but practice keys of an
immediate-feedback course), reference answers and the course seed never enter it; `scan` checks
every file and every wheel member for their text before the release is called done.
"""

from __future__ import annotations

import ast
import hashlib
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import zipfile
from dataclasses import dataclass, field
from pathlib import Path

from grader import course_config as courses
from grader.chapters import CHAPTERS
from grader.judging import expected

GRADER_DIR = Path(__file__).resolve().parents[1]
DISTRIBUTION = "jacobians-grader"
DEPENDENCIES = ["numpy>=1.24", "click>=8.1", "pyyaml>=6.0", "sympy>=1.12", "jinja2>=3.1", "matplotlib>=3.7"]


class ReleaseError(RuntimeError):
    """The release cannot be built, or would hold an answer; the message says which and where."""


class OutNotEmpty(ReleaseError):
    """The folder asked for is not empty (a usage error: choose another, or --force)."""


@dataclass
class Release:
    folder: Path
    wheel: Path
    version: str
    hidden: dict = field(default_factory=dict)


# ------------------------------------------------------------------------------ what replaces the references

def record(course: courses.Course) -> expected.Recording:
    """Plan every public check and plot of every chapter at the public seed with the live references,
    keeping each expected value they ask for (no learner code runs: planning needs none)."""
    from grader import checks as check_registry
    from grader.core.pipeline import switched_off
    from grader.core.planning import ChapterPlan, plots_of

    recording = expected.Recording(seed=course.public_seed)
    broken = []
    with expected.using(recording):
        for info in CHAPTERS:
            chapter = check_registry.load(info.id)
            exclude = frozenset(f"{info.id}/{i}" for i in _hidden_ids(course, info.id)) | switched_off(course, (info.id,))
            plan = ChapterPlan(chapter, course.public_seed, plots_of(info.id), exclude)
            broken += [f"{info.id} {name}: {p.unavailable or p.setup_error}"
                       for name, p in [(c.id, p) for c, p in plan.pending] + plan.plot_pending if p.generator is None]
    if broken:
        raise ReleaseError("checks could not be planned with the references:\n" + "\n".join(broken))
    return recording


def _hidden_ids(course: courses.Course, chapter: str) -> list[str]:
    """The ids of `chapter`'s checks the course hides (a check it leaves out altogether is not hidden)."""
    from grader import checks as check_registry
    from grader.core.pipeline import switched_off

    known = {c.id for c in check_registry.load(chapter).checks}
    return [h.split("/", 1)[1] for h in sorted(course.hidden - switched_off(course, (chapter,)))
            if h.split("/", 1)[0] == chapter and h.split("/", 1)[1] in known]


def hidden_summary(course: courses.Course) -> dict:
    """Per chapter: how many checks and points the handout leaves to the submission, and their ids."""
    from grader import checks as check_registry

    out = {}  # the course's file named existing checks only (grader.course_config validates it, for every command)
    for info in CHAPTERS:
        ids = _hidden_ids(course, info.id)
        if ids:
            points = sum(c.points for c in check_registry.load(info.id).checks if c.id in ids)
            out[info.id] = {"checks": len(ids), "points": points, "ids": ids}
    return out


# ------------------------------------------------------------------------------ the handout

def _project_exercises() -> Path:
    """The stubs to hand out: exercises/ of the checkout this grader runs from, or of the current folder."""
    for candidate in (GRADER_DIR.parent / "exercises", Path.cwd() / "exercises"):
        if (candidate / "ch06_measurement.py").is_file():
            return candidate
    raise ReleaseError("no exercises/ folder with the stubs beside the grader or in the current folder; run "
                       "`grade release` in the lesson's project")


def _copy_grader(stage: Path) -> None:
    def ignore(folder: str, names: list[str]) -> set[str]:
        skip = {n for n in names if n == "__pycache__" or n.endswith((".pyc", ".pyo"))}
        if Path(folder).resolve() == GRADER_DIR:
            skip |= {"data", "quizzes"} & set(names)  # written fresh below
        return skip

    shutil.copytree(GRADER_DIR, stage / "grader", ignore=ignore)


def _write_banks(stage: Path, course: courses.Course) -> None:
    import yaml

    from grader.quiz import bank

    target = stage / "grader" / "quizzes"
    target.mkdir(parents=True)
    for info in CHAPTERS:
        source = bank.QUIZ_DIR / f"{info.id}.yaml"
        if source.is_file():
            shutil.copyfile(source, target / source.name)
        if course.practice(info.id):
            keys = bank.public_keys(info.id)
            if keys:
                (target / "practice").mkdir(exist_ok=True)
                (target / "practice" / f"{info.id}.yaml").write_text(
                    yaml.safe_dump(keys, sort_keys=False, allow_unicode=True), encoding="utf-8")


def _now() -> str:
    """The time of the release, UTC, to the second (handout.json's `released`)."""
    from datetime import datetime, timezone

    return datetime.now(timezone.utc).replace(microsecond=0).isoformat()


def _version(stage: Path) -> str:
    """The grader's version with a local label: a hash of everything the handout grades with."""
    from grader.provenance import base_version

    base = base_version()
    digest = hashlib.sha256()
    for path in sorted((stage / "grader").rglob("*")):
        if path.is_file():
            digest.update(path.relative_to(stage).as_posix().encode() + b"\0" + path.read_bytes())
    return f"{base}+handout.{digest.hexdigest()[:12]}"


# The handout's packages: the grader's own, every one (the instructor's also has the references and the keys).
HANDOUT_PACKAGES = tuple(sorted(".".join(("grader", *p.parent.relative_to(GRADER_DIR).parts))
                                for p in GRADER_DIR.rglob("__init__.py") if "__pycache__" not in p.parts))
_PYPROJECT = """[build-system]
requires = ["setuptools>=61"]
build-backend = "setuptools.build_meta"

[project]
name = "{name}"
version = "{version}"
description = "The grader of the lesson 'Jacobians & Linearization', as handed out to learners (no answers)."
readme = "README.md"
requires-python = ">=3.10"
dependencies = {dependencies}

[project.optional-dependencies]
notebook = ["ipython>=8", "nbformat>=5"]

[project.scripts]
grade = "grader.faces.launch:main"

[tool.setuptools]
packages = {packages}

[tool.setuptools.package-data]
grader = ["data/*.json", "data/expected/*.json", "quizzes/*.yaml", "quizzes/practice/*.yaml"]
"""


def _build_wheel(stage: Path, out: Path) -> Path:
    """pip's PEP 517 build of the staged tree (isolated; without isolation where the build backend is
    already installed, e.g. offline)."""
    before = set(out.glob("*.whl"))
    command = [sys.executable, "-m", "pip", "wheel", "--no-deps", "--quiet", "--disable-pip-version-check",
               "-w", str(out), str(stage)]
    result = subprocess.run(command, capture_output=True, text=True, encoding="utf-8", errors="replace")
    if result.returncode != 0:
        result = subprocess.run(command[:4] + ["--no-build-isolation"] + command[4:], capture_output=True, text=True,
                                encoding="utf-8", errors="replace")
    built = sorted(set(out.glob("*.whl")) - before)
    if result.returncode != 0 or len(built) != 1:
        raise ReleaseError(f"building the wheel failed:\n{result.stdout[-2000:]}\n{result.stderr[-2000:]}")
    return built[0]


def _copy_exercises(out: Path) -> None:
    source = _project_exercises()
    target = out / "exercises"
    (target / "answers").mkdir(parents=True)
    for path in sorted(source.glob("*.py")):
        shutil.copyfile(path, target / path.name)
    for path in sorted((source / "answers").glob("ch*.yaml")):
        shutil.copyfile(path, target / "answers" / path.name)
    (target / "answers" / "learner.yaml").write_text(
        "# Your learner id, exactly as your course lists you: it chooses your own quiz numbers and the order of\n"
        "# the options. For example:  learner: ada.lovelace\nlearner:\n", encoding="utf-8")


LEARNER_README = """# Jacobians & Linearization: your exercises and the `grade` command

This folder is your handout for the lesson's exercises: the stubs you fill in (`exercises/`), your
quiz answer files (`exercises/answers/`) and the grader ({wheel}).

## Install (once)

```sh
python3 -m venv .venv && . .venv/bin/activate      # Windows: .venv\\Scripts\\activate
pip install "{wheel}{{extra}}"
```

## Work and grade

{work}

In a terminal, in this folder:

| command | what it does |
|---|---|
| `grade ch06` | grade chapter 6: which functions are right and, for the wrong ones, where and why |
| `grade all` | every chapter |
| `grade list` | chapters, functions and points |
| `grade ch06 -v` | also tracebacks and what your code printed |
| `grade quiz ch06 --show` | the quiz questions with your own numbers and option letters |
| `grade all --html report.html` | a report with plots made from your own functions |

Put your id in `exercises/answers/learner.yaml` first (`learner: your-id`, as your course lists
you): your quiz numbers and the order of the options are your own.

## What is graded here, and what when you submit

At home your code is checked at the public seed: the lesson's worked examples and fixed random
inputs, with the same messages it gets when your submission is graded. When you submit, the same
checks run at other inputs (a course seed this handout does not hold){hidden}, so hard-coding the
values you see here earns nothing. Quiz answers are {quiz}. The output says what was checked here
and what is left for your submission: "All public checks pass" is not a final grade.

This handout holds no reference solution and no quiz key: it grades from recorded expected values.

## Submit

```sh
grade submit
```

packs your `exercises/` into `<your id>.zip`, the archive your course grades: every chapter file (`chNN_*.py`, or `.ipynb`) and
the files in `exercises/answers/`, and a manifest (this handout's version, a hash of each file, your
score at home, the time). It will not pack without your learner id (it asks for one on a terminal),
and it grades the packed archive again, so the score it prints is that of what you hand in. Hand in
that file as it is: a file changed after packing is noticed.
"""


SCRIPT_WORK = "Fill in a function in `exercises/chNN_*.py` (each stub says what it computes), then grade it."
NOTEBOOK_WORK = """Each chapter is a Jupyter notebook, `exercises/chNN_*.ipynb` (Jupyter, JupyterLab, VS Code or Colab): its
text says what each function computes, a cell per function holds the stub to fill in. Its first cell installs
this grader where it is missing (`pip install "{wheel}[notebook]"` by hand does the same) and loads `%grade`;
run the chapter's cells, then its last cell:

```python
%grade ch06             # also %grade all, %grade ch06 H_jacobian, and the options below (--no-quiz, -v, ...)
```

The report shows in the notebook. `%grade` grades the code the kernel ran where the notebook defines the
chapter's functions; `grade ch06` in a terminal and `grade submit` grade the saved notebook, so save it before
you submit (`%grade` says so when the two differ)."""


def _write_readme(out: Path, wheel: Path, course: courses.Course, hidden: dict, notebooks: bool = False) -> None:
    from grader.render import plural

    checks = sum(h["checks"] for h in hidden.values())
    points = sum(h["points"] for h in hidden.values())
    hidden_text = f", plus {plural(checks, 'hidden check')} worth {plural(points, 'point')}" if checks else ""
    practice = [info.id for info in CHAPTERS if course.practice(info.id)]
    recorded = "read and format-checked here, and graded when you submit"
    quiz = (recorded if not practice else
            f"{recorded}, but those of {', '.join(practice)}: practice, graded here where the question is the same "
            "for everyone and never counted" if len(practice) < len(CHAPTERS) else
            "practice: graded here where the question is the same for everyone, and never counted")
    work = NOTEBOOK_WORK if notebooks else SCRIPT_WORK
    text = LEARNER_README.format(wheel=wheel.name, hidden=hidden_text, quiz=quiz,
                                 work=work.format(wheel=wheel.name)).replace("{extra}", "[notebook]" if notebooks else "")
    (out / "README.md").write_text(text, encoding="utf-8")


def build(out: Path, course: courses.Course, *, force: bool = False, notebooks: bool = False,
          pip_source: str | None = None, classroom: bool = True) -> Release:
    """Build the handout into `out` (which must be empty or new, or is replaced with force): with `notebooks`, each
    chapter's stub is a notebook (write_notebooks) whose first cell installs the grader from `pip_source` (default:
    the wheel beside exercises/); with `classroom`, the GitHub Classroom workflow (grader.course.classroom). The
    handout is built in a folder beside `out` and moved into place only once it passes its checks (no answer in
    any file or wheel member): a release refused leaves `out` as it was."""
    if out.exists() and any(out.iterdir()) and not force:
        raise OutNotEmpty(f"{out} is not empty; choose a new folder (or --force to replace its contents)")
    out.parent.mkdir(parents=True, exist_ok=True)
    building = Path(tempfile.mkdtemp(prefix=f".{out.name}.building-", dir=out.parent))
    mask = os.umask(0)
    os.umask(mask)
    building.chmod(0o777 & ~mask)  # as a folder made here would be (mkdtemp's is private)
    try:
        built = _build_into(building, course, notebooks, pip_source, classroom)
        _move_into_place(building, out)
    finally:
        shutil.rmtree(building, ignore_errors=True)
    return Release(out, out / built.wheel.name, built.version, built.hidden)


def _build_into(folder: Path, course: courses.Course, notebooks: bool, pip_source: str | None,
                classroom: bool) -> Release:
    """The whole handout in `folder`, checked (ReleaseError where it would hold an answer)."""
    hidden = hidden_summary(course)
    recording = record(course)
    with tempfile.TemporaryDirectory(prefix="handout-") as temporary:
        stage = Path(temporary)
        _copy_grader(stage)
        data = stage / "grader" / "data"
        recording.write(data / "expected")
        _write_banks(stage, course)
        version = _version(stage)
        handout = {"course": course.id, "version": version, "public_seed": course.public_seed,
                   "quiz_feedback": course.quiz_feedback, "quiz_feedback_by": course.quiz_feedback_by or {},
                   "exact_derivatives": course.exact_derivatives, "hidden": hidden, "released": _now()}
        (data / "handout.json").write_text(json.dumps(handout, indent=1), encoding="utf-8")
        # the same public settings beside the handout, for the instructor: `grade batch --handout OUT` reads it
        (folder / "handout.json").write_text(json.dumps(handout, indent=1) + "\n", encoding="utf-8")
        (stage / "README.md").write_text(f"The handout grader of the course {course.id}.\n", encoding="utf-8")
        (stage / "pyproject.toml").write_text(_PYPROJECT.format(
            name=DISTRIBUTION, version=version, dependencies=json.dumps(DEPENDENCIES),
            packages=json.dumps(list(HANDOUT_PACKAGES))), encoding="utf-8")
        wheel = _build_wheel(stage, folder)
    _copy_exercises(folder)
    if notebooks:
        write_notebooks(folder / "exercises", pip_source or f"../{wheel.name}")
    _write_readme(folder, wheel, course, hidden, notebooks)
    if classroom:
        from grader.course import classroom as workflows

        workflows.write_template(folder, wheel.name)
    leaks = scan(folder)
    if leaks:
        raise ReleaseError("the handout would hold answers; nothing is handed out:\n  " + "\n  ".join(leaks[:20]))
    return Release(folder, wheel, version, hidden)


def _move_into_place(built: Path, out: Path) -> None:
    """Put the folder `built` where `out` is, in renames on one file system: what `out` held is moved aside first,
    and removed only once the new handout is in place."""
    aside = None
    if out.exists():
        aside = out.with_name(f".{out.name}.replaced-{os.getpid()}")
        os.replace(out, aside)
    try:
        os.replace(built, out)
    except OSError:
        if aside is not None:
            os.replace(aside, out)
        raise
    if aside is not None:
        shutil.rmtree(aside, ignore_errors=True)


# ------------------------------------------------------------------------------ the notebook handout

INSTALL_CELL = """# Installs the course's grader where it is missing (Colab, a new environment); elsewhere it does nothing.
from importlib import metadata

try:
    metadata.version("{distribution}")
except metadata.PackageNotFoundError:
    %pip install --quiet "{source}[notebook]"
%load_ext grader"""


def _cell(kind: str, source: str) -> dict:
    cell = {"cell_type": kind, "metadata": {}, "source": source.strip("\n")}
    if kind == "code":
        cell.update(execution_count=None, outputs=[])
    return cell


def stub_notebook(stub: str, chapter: str, pip_source: str) -> dict:
    """A chapter's stub as a notebook (nbformat 4): a cell installing the grader where it is missing, the
    stub's text as markdown, its other module code (imports) in one cell, each function's docstring as
    markdown and the function in a code cell of its own, a cell that tries the worked example (the stub's
    `if __name__ == "__main__":` block) and a last cell `%grade chNN`."""
    tree = ast.parse(stub)
    lines = stub.splitlines()
    cells = [_cell("code", INSTALL_CELL.format(distribution=DISTRIBUTION, source=pip_source))]
    doc = ast.get_docstring(tree) or ""
    title, _, rest = doc.partition("\n")
    cells.append(_cell("markdown", f"# {title}\n\n{rest.strip()}\n\nRun each cell, fill in the functions, then "
                                   f"run the last cell: `%grade {chapter}` grades them (`%grade {chapter} NAME` one "
                                   "function)."))
    module_code, tail = [], None
    for node in tree.body:
        segment = "\n".join(lines[node.lineno - 1 - len(getattr(node, "decorator_list", [])):node.end_lineno])
        if node is tree.body[0] and isinstance(node, ast.Expr) and isinstance(node.value, ast.Constant):
            continue
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            if module_code:
                cells.append(_cell("code", "\n\n".join(module_code)))
                module_code = []
            docstring = ast.get_docstring(node) or ""
            signature = f"{node.name}({ast.unparse(node.args)})"
            cells.append(_cell("markdown", f"## `{signature}`\n\n" + "\n".join(
                f"    {line}" if line.strip() else "" for line in docstring.splitlines())))
            cells.append(_cell("code", segment))
        elif isinstance(node, ast.If) and "__main__" in ast.unparse(node.test):
            tail = segment  # kept under its `if`: it runs in the kernel, never when the notebook is graded
        else:
            module_code.append(segment)
    if module_code:
        cells.append(_cell("code", "\n\n".join(module_code)))
    if tail:
        cells.append(_cell("markdown", "Try it: the lesson's worked example with your functions."))
        cells.append(_cell("code", tail))
    cells.append(_cell("code", f"%grade {chapter}"))
    return {"cells": cells, "metadata": {"kernelspec": {"display_name": "Python 3", "language": "python",
                                                         "name": "python3"},
                                          "language_info": {"name": "python"}},
            "nbformat": 4, "nbformat_minor": 5}


def write_notebooks(exercises: Path, pip_source: str) -> None:
    """Each chapter's stub in `exercises` as a notebook of the same name instead (stub_notebook): a
    notebook is graded where there is no .py of its name."""
    for info in CHAPTERS:
        stub = exercises / f"{info.module}.py"
        notebook = stub_notebook(stub.read_text(encoding="utf-8"), info.id, pip_source)
        for index, cell in enumerate(notebook["cells"]):
            cell["id"] = f"{info.id}-{index:02d}"
        (exercises / f"{info.module}.ipynb").write_text(json.dumps(notebook, indent=1, ensure_ascii=False) + "\n",
                                                       encoding="utf-8")
        stub.unlink()


# ------------------------------------------------------------------------------ no answer in it

@dataclass(frozen=True)
class Secrets:
    """Text that must not appear in a handout: reference code lines, key texts, reference answers."""

    code_lines: frozenset[str]  # whitespace-free lines of reference function bodies
    function_bodies: frozenset[str]  # ast dumps of reference function bodies
    texts: frozenset[str]  # key answers, explanations, feedback; reference answers (whitespace-free)
    names: tuple[str, ...] = ("solutions/", "oracle/", "quizzes/keys/", "course.yaml")


def _squeeze(text: str) -> str:
    return re.sub(r"\s+", "", text)


def _bodies(tree: ast.AST) -> list[list[ast.stmt]]:
    found = []
    for node in ast.walk(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            body = node.body[1:] if (node.body and isinstance(node.body[0], ast.Expr)
                                     and isinstance(getattr(node.body[0], "value", None), ast.Constant)) else node.body
            if body:
                found.append(body)
    return found


def _dump(body: list[ast.stmt]) -> str:
    return "\n".join(ast.dump(statement) for statement in body)


def reference_secrets(project: Path | None = None) -> Secrets:
    """What a handout must not hold, read from the instructor's references and keys."""
    import yaml

    from grader.quiz import bank

    root = project or Path(expected.reference_function("ch06", "H_jacobian").__code__.co_filename).parents[1]
    lines, bodies, texts = set(), set(), set()
    for path in sorted((root / "solutions").rglob("*.py")):
        source = path.read_text(encoding="utf-8")
        tree = ast.parse(source)
        for body in _bodies(tree):
            if len(body) >= 2 or len(ast.unparse(body[0])) >= 40:
                bodies.add(_dump(body))
            for statement in body:
                for line in ast.unparse(statement).splitlines():
                    squeezed = _squeeze(line)
                    # shorter lines are too generic to identify a reference: x = np.asarray(x, dtype=float)
                    if len(squeezed) >= 32 and not squeezed.startswith(("import", "from", "if", "for", "else")):
                        lines.add(squeezed)
    from grader.judging import mutants

    for source in mutants.every_source():  # every slip of a reference is as secret as the reference
        for body in _bodies(ast.parse(source)):
            if len(body) >= 2 or len(ast.unparse(body[0])) >= 40:
                bodies.add(_dump(body))
            lines.update(squeezed for statement in body for squeezed in map(_squeeze, ast.unparse(statement).splitlines())
                         if len(squeezed) >= 32 and not squeezed.startswith(("import", "from", "if", "for", "else")))
    for path in sorted((bank.QUIZ_DIR / "keys").glob("*.yaml")):
        for key in (yaml.safe_load(path.read_text(encoding="utf-8")) or {}).values():
            answer = key.get("answer")
            if isinstance(answer, str) and len(_squeeze(answer)) >= 4:
                texts.add(_squeeze(answer))
            for text in [key.get("explanation", ""), *(key.get("feedback") or {}).values(),
                         *(w.get("feedback", "") for w in key.get("wrong") or [])]:
                if len(_squeeze(str(text))) >= 16:
                    texts.add(_squeeze(str(text)))
    for path in sorted((root / "solutions" / "answers").glob("ch*.yaml")):
        for value in (yaml.safe_load(path.read_text(encoding="utf-8")) or {}).values():
            for number in re.findall(r"-?\d+\.\d{5,}", json.dumps(value)):
                texts.add(number)
    return Secrets(frozenset(lines), frozenset(bodies), frozenset(texts))


def _members(folder: Path):
    """(name, text) of every file in `folder` and of every member of its wheels and zips."""
    for path in sorted(folder.rglob("*")):
        if not path.is_file():
            continue
        name = path.relative_to(folder).as_posix()
        if path.suffix in (".whl", ".zip"):
            with zipfile.ZipFile(path) as archive:
                for member in archive.namelist():
                    yield f"{name}!{member}", archive.read(member)
        else:
            yield name, path.read_bytes()


def _notebook_text(data: bytes) -> tuple[str, str | None]:
    """A notebook's text to scan: every string in it (cells' sources, markdown and code, outputs, metadata)
    unescaped, and its code cells as the module the grader makes of them (None if it is not a notebook)."""
    from grader import notebook

    def strings(value: object) -> list[str]:
        if isinstance(value, str):
            return [value]
        items = value.values() if isinstance(value, dict) else value if isinstance(value, list) else []
        return [text for item in items for text in strings(item)]

    try:
        everything = "".join(strings(json.loads(data.decode("utf-8-sig"))))
        return everything, notebook.convert(data, "notebook").text
    except (ValueError, RecursionError, notebook.NotebookError):
        return data.decode("utf-8", "replace"), None


def scan(folder: Path, secrets: Secrets | None = None, allow_practice_keys: bool = True) -> list[str]:
    """Every place in `folder` (wheel members included) that holds reference or key text, or bytecode."""
    secrets = secrets or reference_secrets()
    found = []
    for name, data in _members(folder):
        lowered = name.lower()
        if any(part in lowered for part in secrets.names) or lowered.endswith((".pyc", ".pyo")):
            found.append(f"{name}: must not be in a handout")
            continue
        text, code = data.decode("utf-8", "replace"), None
        if name.endswith(".ipynb"):  # cells are JSON strings: scan their sources, and the code as a module
            text, code = _notebook_text(data)
        elif name.endswith(".py"):
            code = text
        squeezed = _squeeze(text)
        found += [f"{name}: reference code `{line[:60]}`" for line in secrets.code_lines if line in squeezed]
        if code is not None:
            try:
                tree = ast.parse(code)
            except SyntaxError:
                tree = None
            if tree is not None:
                found += [f"{name}: a reference function's body" for body in _bodies(tree)
                          if _dump(body) in secrets.function_bodies]
        if "/practice/" in name and allow_practice_keys:
            continue  # an immediate-feedback course ships these keys on purpose
        found += [f"{name}: key or reference answer `{text_[:60]}`" for text_ in secrets.texts if text_ in squeezed]
    return found


def describe(release: Release) -> str:
    from grader.render import plural

    size = release.wheel.stat().st_size
    files = sum(1 for p in release.folder.rglob("*") if p.is_file())
    hidden = sum(h["checks"] for h in release.hidden.values())
    return (f"Handout {release.version} in {release.folder}: {files} files, the grader {release.wheel.name} "
            f"({size / 1024:.0f} KiB); {plural(hidden, 'hidden check')}. Checked: no reference code, quiz key or reference "
            f"answer in any file or wheel member.\nPut `handout: {release.version}` in the course config (or pass "
            f"--handout {release.folder} to grade batch): archives packed with another handout are then flagged.")

