"""The GitHub workflows the project ships pass GitHub's workflow schema (check-jsonschema's vendored copy) and
actionlint: the project's own CI (.github/workflows/ci.yml, the README's test command on Linux, macOS and
Windows) and the GitHub Classroom workflow `grade release` writes into a handout. Neither can run here."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from grader.course import classroom
from tests.support import REPO

CI = REPO / ".github" / "workflows" / "ci.yml"
ACTIONLINT = shutil.which("actionlint", path=os.pathsep.join([str(Path(sys.executable).parent),
                                                              os.environ.get("PATH", "")]))
needs_actionlint = pytest.mark.skipif(ACTIONLINT is None and not (os.environ.get("CI") and sys.platform == "linux"),
                                      reason="actionlint is not installed (its wheel ships for Linux)")
BROKEN = "name: broken\non: push\njobs:\n  a:\n    runs-on: ubuntu-latest\n    steps:\n      - uses: actions/checkout@v5\n" \
         "        with: {fetch-depth: ${{ github.nonexistent }}}\n      - run: echo ${{ github.event.issue.title }}\n" \
         "    timeout-minutes: soon\n"


def _schema(path: Path) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "check_jsonschema", "--builtin-schema", "vendor.github-workflows",
                           str(path)], capture_output=True, text=True, timeout=120)


def _actionlint(path: Path) -> subprocess.CompletedProcess:
    return subprocess.run([ACTIONLINT, "-no-color", str(path)], capture_output=True, text=True, timeout=120)


@pytest.fixture(scope="module")
def workflows(tmp_path_factory) -> dict[str, Path]:
    folder = tmp_path_factory.mktemp("workflows")
    handout = folder / "classroom.yml"
    handout.write_text(classroom.workflow("jacobians_grader-0.1.0+handout.0123456789ab-py3-none-any.whl"),
                       encoding="utf-8")
    broken = folder / "broken.yml"
    broken.write_text(BROKEN, encoding="utf-8")
    return {"ci": CI, "classroom": handout, "broken": broken}


@pytest.mark.parametrize("name", ["ci", "classroom"])
def test_the_workflows_pass_githubs_schema(workflows, name):
    done = _schema(workflows[name])
    assert done.returncode == 0, done.stdout + done.stderr


@needs_actionlint
@pytest.mark.parametrize("name", ["ci", "classroom"])
def test_the_workflows_pass_actionlint(workflows, name):
    done = _actionlint(workflows[name])
    assert done.returncode == 0, done.stdout + done.stderr


@needs_actionlint
def test_the_checks_find_a_broken_workflow(workflows):
    assert _schema(workflows["broken"]).returncode != 0
    done = _actionlint(workflows["broken"])
    assert done.returncode != 0 and "nonexistent" in done.stdout, done.stdout


def test_ci_runs_the_readmes_test_command_on_three_systems_and_two_pythons():
    workflow = yaml.safe_load(CI.read_text(encoding="utf-8"))
    job = workflow["jobs"]["tests"]
    assert set(job["strategy"]["matrix"]["os"]) == {"ubuntu-latest", "macos-latest", "windows-latest"}
    pythons = job["strategy"]["matrix"]["python"]
    with open(REPO / "pyproject.toml", encoding="utf-8") as handle:
        oldest = next(line.split(">=")[1].strip().strip('"') for line in handle if line.startswith("requires-python"))
    assert oldest in pythons and len(pythons) == 2
    script = job["steps"][-1]["run"]
    readme = (REPO / "README.md").read_text(encoding="utf-8")
    for piece in ('pip install -e ".[test]"', "python -m pytest -n 2 --dist loadfile"):
        assert piece in script and piece in readme
