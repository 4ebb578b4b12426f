"""GitHub Classroom: `grade release` writes the learners' workflow; its grading step, run as GitHub's runner
runs it (bash, $GITHUB_OUTPUT), gives every check its own points in the format the classroom reporter
reads, and the reporter's sum of those points is the grader's score. Where bubblewrap cannot start the
grading goes on and says so (or, with --sandbox required, stops with a usage error)."""

from __future__ import annotations

import base64
import json
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import pytest
import yaml
from click.testing import CliRunner

from grader.course import release
from grader.faces.cli import main
from grader.judging import expected
from grader.render import lms
from tests.support import (
    REAL_BWRAP,
    FakeBwrap,
    build_submission,
    not_root,
    replace_function,
    run_grade,
)

jsonschema = pytest.importorskip("jsonschema")

WHEEL = "jacobians_grader-0.1.0+handout.0123456789ab-py3-none-any.whl"
WRONG_H = ("def H_jacobian(x, y):\n    r2 = x * x + y * y\n    r = np.sqrt(r2)\n"
           "    return np.array([[x / r, y / r], [y / r2, x / r2]])\n")


@pytest.fixture(scope="module")
def workflow(tmp_path_factory):
    """The workflow `grade release` writes into the handout (the handout's recorded values, its wheel and its scan
    stubbed: they are test_release's)."""
    out = tmp_path_factory.mktemp("release") / "handout"
    patch = pytest.MonkeyPatch()

    def build_wheel(stage: Path, folder: Path) -> Path:
        (folder / WHEEL).write_bytes(b"")
        return folder / WHEEL

    patch.setattr(release, "record", lambda course: expected.Recording(seed=course.public_seed))
    patch.setattr(release, "_build_wheel", build_wheel)
    patch.setattr(release, "scan", lambda folder: [])
    patch.setattr(release, "describe", lambda built: "Handout built.")
    try:
        result = CliRunner().invoke(main, ["release", str(out)])
    finally:
        patch.undo()
    assert result.exit_code == 0, result.output
    path = out / ".github" / "workflows" / "classroom.yml"
    assert f"GitHub Classroom: {path}" in result.output
    return yaml.safe_load(path.read_text(encoding="utf-8"))


def _step(workflow: dict, name: str) -> dict:
    steps = workflow["jobs"]["run-autograding-tests"]["steps"]
    return next(s for s in steps if s.get("name") == name)


def _run_grade_step(workflow: dict, cwd: Path, tmp_path: Path, env_extra: dict | None = None,
                    as_runner: bool = False):
    """The workflow's Grade step as GitHub runs it: `bash -e -c`, with $GITHUB_OUTPUT a file and the
    installed grader's `grade` on PATH; `as_runner`: as GitHub's runner user, who is not root (not_root: where
    bubblewrap is not started); (the process, the reporter's results decoded)."""
    outputs = tmp_path / "github_output"
    outputs.write_text("", encoding="utf-8")
    env = dict(os.environ, GITHUB_OUTPUT=str(outputs), **(env_extra or {}))
    env["PATH"] = f"{Path(sys.executable).parent}{os.pathsep}{env['PATH']}"
    command = ["bash", "-e", "-c", _step(workflow, "Grade")["run"]]
    done = subprocess.run(not_root(command, real=True) if as_runner else command, cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=300)
    line = next((x for x in outputs.read_text(encoding="utf-8").splitlines() if x.startswith("result=")), None)
    results = None if line is None else json.loads(base64.b64decode(line.removeprefix("result=")).decode("utf-8"))
    return done, results


def _reporter_total(results: dict) -> tuple[float, float]:
    """What autograding-grading-reporter tells Classroom: the sum of the tests' score out of max_score."""
    return sum(t["score"] for t in results["tests"]), results["max_score"]


def test_the_workflow_installs_the_handout_grades_and_hands_the_results_to_the_reporter(workflow):
    assert workflow["name"] == "Autograding Tests" and workflow["permissions"]["checks"] == "write"
    assert "push" in workflow["on"]
    install = _step(workflow, "Install the grader and its sandbox")["run"]
    assert f'pip install --quiet --disable-pip-version-check "./{WHEEL}"' in install
    assert "bubblewrap" in install and "apparmor_restrict_unprivileged_userns=0" in install
    grade = _step(workflow, "Grade")
    assert grade["id"] == "grader" and grade["run"].startswith("grade classroom all ")
    reporter = _step(workflow, "Autograding Reporter")
    assert reporter["uses"].startswith("classroom-resources/autograding-grading-reporter@")
    assert reporter["with"]["runners"] == "grader"
    assert reporter["env"]["GRADER_RESULTS"] == "${{ steps.grader.outputs.result }}"


@pytest.mark.slow
def test_the_grade_step_gives_each_check_its_points_as_the_reporter_reads_them(workflow, tmp_path):
    root = build_submission(tmp_path / "learner-repo", {"ch06_measurement": replace_function(
        "ch06_measurement", "H_jacobian", WRONG_H)})
    done, results = _run_grade_step(workflow, root, tmp_path)
    assert done.returncode == 0, done.stderr[-3000:]  # whatever the checks say: the reporter gives the points
    assert results is not None, done.stdout[-2000:]
    jsonschema.Draft202012Validator(lms.schema("classroom")).validate(results)
    project = run_grade("all", "--submission", root, "--format", "json")
    report = json.loads(project.stdout)
    assert _reporter_total(results) == (report["score"], report["max_score"])
    ch06 = [t for t in results["tests"] if t["name"].startswith("ch06 code:")]
    earned = sum(t["score"] for t in ch06)
    assert 0 < earned < sum(t["max_score"] for t in ch06)  # not all-or-nothing per chapter
    assert results["status"] == "fail" and {t["status"] for t in ch06} == {"pass", "fail"}
    failed = next(t for t in ch06 if t["status"] == "fail" and "H[1,0]" in t["message"])
    assert failed["filename"] == "exercises/ch06_measurement.py"
    assert "ch06 total" in done.stderr  # the learner reads the usual report in the job's log


@pytest.mark.slow
@pytest.mark.skipif(REAL_BWRAP is None and not os.environ.get("CI"), reason="bubblewrap is not installed")
def test_where_bubblewrap_cannot_start_the_step_grades_without_it_and_says_so(workflow):
    """As GitHub's runner user (not root), in a folder it can reach."""
    reachable = Path(tempfile.mkdtemp(prefix="runner-"))
    try:
        root = build_submission(reachable / "learner-repo")
        fake = FakeBwrap(reachable / "fake", failing=range(1, 1000))
        for path in [reachable, *reachable.rglob("*")]:
            path.chmod(0o777 if path.is_dir() else 0o755)
        done, results = _run_grade_step(workflow, root, reachable, {"PATH": fake.env["PATH"]}, as_runner=True)
        assert done.returncode == 0, done.stderr[-3000:]
        assert "isolation: no sandbox: bubblewrap cannot run here" in results["message"]
        assert "isolation: no sandbox" in done.stderr
        code = [t for t in results["tests"] if " code: " in t["name"]]
        assert code and all(t["status"] == "pass" for t in code)
        required = run_grade("classroom", "ch06", "--submission", root, "--sandbox", "required", env=fake.env)
        assert required.returncode == 2 and "the sandbox is required and does not start here" in required.stderr
        assert required.stdout == ""
    finally:
        shutil.rmtree(reachable, ignore_errors=True)
