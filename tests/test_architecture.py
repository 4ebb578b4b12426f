"""The architecture is checked, not only described: the import contracts of pyproject.toml (import-linter)
hold, each fails when the import it forbids is planted, and how learner code starts is decided in one
module (grader/boundary/door.py)."""

from __future__ import annotations

import ast
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from tests.support import REPO, slow_but_the_first

# Each contract with one import that breaks it: (the file it is planted in, the line planted).
PLANTED = {
    "no-cycles": ("grader/system.py", "from grader.boundary import door"),
    "layers": ("grader/core/pipeline.py", "from grader.faces import cli"),
    "boundary-holds-no-answer": ("grader/boundary/door.py", "import solutions.ch06_measurement"),
    "sandboxed-side": ("grader/boundary/child.py", "from grader import course_config"),
    "renderers-only-read": ("grader/render/summary.py", "from grader.quiz import bank"),
    "checks-use-only-the-wire": ("grader/checks/ch06.py", "from grader.boundary.spawn import start_child"),
    "one-door": ("grader/faces/cli.py", "from grader.boundary.forkserver import ForkServer"),
}


def _lint(tree: Path, *contracts: str) -> subprocess.CompletedProcess:
    """import-linter on the grader at `tree` (its pyproject.toml's contracts), as the command-line tool runs."""
    arguments = [a for contract in contracts for a in ("--contract", contract)]
    code = "import sys; from importlinter.cli import lint_imports_command; sys.exit(lint_imports_command())"
    env = dict(os.environ, PYTHONPATH=str(tree))  # this tree's grader, not the installed one
    return subprocess.run([sys.executable, "-c", code, "--no-cache", *arguments], cwd=tree, env=env,
                          capture_output=True, text=True, timeout=120)


def test_every_import_contract_holds():
    done = _lint(REPO)
    assert done.returncode == 0, done.stdout + done.stderr
    assert f"{len(PLANTED)} kept, 0 broken" in done.stdout, done.stdout


def test_the_contracts_are_the_ones_planted_here():
    try:
        import tomllib
    except ImportError:  # Python 3.10: import-linter brings tomli
        import tomli as tomllib

    contracts = tomllib.loads((REPO / "pyproject.toml").read_text(encoding="utf-8"))["tool"]["importlinter"]["contracts"]
    assert sorted(c["id"] for c in contracts) == sorted(PLANTED)


@pytest.fixture(scope="module")
def tree(tmp_path_factory) -> Path:
    """A copy of the grader, the references and the contracts, whose files a test may plant an import in."""
    tree = tmp_path_factory.mktemp("architecture")
    shutil.copytree(REPO / "grader", tree / "grader", ignore=shutil.ignore_patterns("__pycache__"))
    shutil.copytree(REPO / "solutions", tree / "solutions", ignore=shutil.ignore_patterns("__pycache__"))
    shutil.copy(REPO / "pyproject.toml", tree / "pyproject.toml")
    return tree


@pytest.mark.parametrize("contract", slow_but_the_first(sorted(PLANTED)))
def test_each_contract_fails_when_its_import_is_planted(tree, contract):
    file, line = PLANTED[contract]
    original = (tree / file).read_text(encoding="utf-8")
    assert _lint(tree, contract).returncode == 0  # the copy keeps it
    (tree / file).write_text(f"{original}\n{line}  # planted\n", encoding="utf-8")
    try:
        done = _lint(tree, contract)
    finally:
        (tree / file).write_text(original, encoding="utf-8")
    assert done.returncode != 0, done.stdout
    assert "BROKEN" in done.stdout and "0 kept, 1 broken" in done.stdout, done.stdout


# What decides how learner code starts: making a launcher or a sandbox, and the environment overrides.
_LAUNCH_CALLS = {"ForkServer", "start_child", "Sandbox", "DroppedUser"}
_LAUNCH_VARIABLES = {"GRADER_SANDBOX", "GRADER_FORK_SERVER", "GRADER_LAUNCHER"}


def _launch_decisions(path: Path) -> list[str]:
    found = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Call):
            name = node.func.attr if isinstance(node.func, ast.Attribute) else getattr(node.func, "id", "")
            if name in _LAUNCH_CALLS:
                found.append(f"{name}(...) on line {node.lineno}")
        elif isinstance(node, ast.Constant) and node.value in _LAUNCH_VARIABLES:
            found.append(f"{node.value} on line {node.lineno}")
    return found


def test_the_launch_decision_is_made_in_one_module():
    """Sandbox or none, fork server, spawn or the portable child: only grader/boundary/door.py chooses. The one-off
    `grade` replays the door's kept decision (grader/boundary/kept.py): it starts a child behind the kept command
    prefix and decides nothing itself (no sandbox, launcher or environment override)."""
    deciding = {}
    for path in sorted((REPO / "grader").rglob("*.py")):
        found = _launch_decisions(path)
        if found:
            deciding[path.relative_to(REPO).as_posix()] = found
    replay = deciding.pop("grader/boundary/kept.py", [])
    assert [r.split("(")[0] for r in replay] == ["start_child"], replay
    assert list(deciding) == ["grader/boundary/door.py"], deciding


def test_every_package_of_the_grader_is_installed_and_released():
    """A package missing from pyproject.toml's list (or the handout's) is missing from the wheel: `grade` fails
    with an ImportError only where it was installed, never in the project."""
    try:
        import tomllib
    except ImportError:  # Python 3.10
        import tomli as tomllib

    from grader.course import release

    packages = {p.parent.relative_to(REPO).as_posix().replace("/", ".")
                for p in (REPO / "grader").rglob("__init__.py") if "__pycache__" not in p.parts}
    listed = set(tomllib.loads((REPO / "pyproject.toml").read_text(encoding="utf-8"))["tool"]["setuptools"]["packages"])
    assert packages <= listed, sorted(packages - listed)
    assert packages - {"grader.quizzes", "grader.quizzes.keys"} == set(release.HANDOUT_PACKAGES)


# Tests of the project as a whole, not of one module: its contracts, its platforms, the workflows it ships, the
# JSON schemas (grader/schemas/, data) and the benchmarks.
WHOLE_PROJECT_TESTS = {"test_architecture", "test_platforms", "test_workflows", "test_schemas", "test_benchmarks", "test_docs"}


def test_the_tests_mirror_the_package_so_a_modules_tests_are_found_from_its_name():
    """tests/<package>/test_<module>[_<topic>].py for grader/<package>/<module>.py (test_<package>... for the package
    itself), tests/test_<module>[_<topic>].py for a module at grader's top: a module's tests are where its name says."""
    misplaced = []
    for path in sorted((REPO / "tests").rglob("test_*.py")):
        folder = path.parent.relative_to(REPO / "tests")
        package = REPO / "grader" / folder
        if not (package / "__init__.py").is_file():
            misplaced.append(f"{path.relative_to(REPO)}: grader/{folder.as_posix()} is no package")
            continue
        if folder == Path(".") and path.stem in WHOLE_PROJECT_TESTS:
            continue
        modules = {p.stem for p in package.glob("*.py") if p.stem != "__init__"} | {package.name}
        if not any(path.stem == f"test_{m}" or path.stem.startswith(f"test_{m}_") for m in modules):
            misplaced.append(f"{path.relative_to(REPO)}: names no module of grader/{folder.as_posix()}")
    assert not misplaced, misplaced
