"""`grade gradescope`: the autograder zip, run end to end on Gradescope's layout simulated under a
temporary root: unzipped into ROOT/source as Gradescope does, setup.sh run for real (a fresh venv with the
grader's wheel and its dependencies), run_autograder copied to ROOT and run once per submission, with
ROOT/submission and ROOT/submission_metadata.json as Gradescope writes them. A right, a buggy, an empty
and a hostile submission; bubblewrap that cannot start (grading goes on and says so, or with --sandbox
required nothing is graded and the run says NOT GRADED). Every results.json is checked against the
published schema."""

from __future__ import annotations

import io
import json
import os
import shutil
import subprocess
import tempfile
import zipfile
from pathlib import Path

import pytest

from grader.render import lms
from tests.support import (
    REAL_BWRAP,
    FakeBwrap,
    build_submission,
    hostile_module,
    replace_function,
    run_grade,
)

jsonschema = pytest.importorskip("jsonschema")
needs_bwrap = pytest.mark.skipif(REAL_BWRAP is None and not os.environ.get("CI"), reason="bubblewrap is not installed")

COURSE_SEED = 424242
HIDDEN = "ch06/H_rows_orthogonal"
COURSE = f"course: gs-course\nseed: {COURSE_SEED}\nquiz_feedback: recorded\nhidden: [{HIDDEN}]\n"
WRONG_H = ("def H_jacobian(x, y):\n    r2 = x * x + y * y\n    r = np.sqrt(r2)\n"
           "    return np.array([[x / r, y / r], [y / r2, x / r2]])\n")


def _unzip(archive: Path, target: Path) -> None:
    """Extract as `unzip` does: with each member's permission bits."""
    with zipfile.ZipFile(archive) as opened:
        for info in opened.infolist():
            path = Path(opened.extract(info, target))
            mode = (info.external_attr >> 16) & 0o777
            if mode:
                path.chmod(mode)


@pytest.fixture(scope="module")
def autograder():
    """The zip as `grade gradescope` builds it, and ROOT after setup.sh ran in ROOT/source."""
    base = Path(tempfile.mkdtemp(prefix="gradescope-"))
    base.chmod(0o755)
    try:
        (base / "course.yaml").write_text(COURSE, encoding="utf-8")
        built = run_grade("gradescope", base / "autograder.zip", "--course", base / "course.yaml")
        assert built.returncode == 0, built.stderr
        root = base / "autograder"
        _unzip(base / "autograder.zip", root / "source")
        setup = subprocess.run(["bash", str(root / "source" / "setup.sh")], cwd=root / "source", capture_output=True,
                               text=True, timeout=600)
        assert setup.returncode == 0, setup.stdout[-3000:] + setup.stderr[-3000:]
        shutil.copy2(root / "source" / "run_autograder", root / "run_autograder")
        yield base / "autograder.zip", root, setup
    finally:
        shutil.rmtree(base, ignore_errors=True)


def _validate(data: dict) -> None:
    jsonschema.Draft202012Validator(lms.schema("gradescope-results")).validate(data)


def _grade(root: Path, make_submission, metadata: dict | None, env: dict | None = None) -> tuple[dict, subprocess.CompletedProcess]:
    """Put a submission where Gradescope puts it, run ROOT/run_autograder; (results.json, the run)."""
    for name in ("submission", "results"):
        shutil.rmtree(root / name, ignore_errors=True)
    (root / "submission").mkdir()
    (root / "submission_metadata.json").unlink(missing_ok=True)
    make_submission(root / "submission")
    if metadata is not None:
        (root / "submission_metadata.json").write_text(json.dumps(metadata), encoding="utf-8")
    run = subprocess.run([str(root / "run_autograder")], cwd=root, capture_output=True, text=True, timeout=300,
                         env=env)
    results = json.loads((root / "results" / "results.json").read_bytes().decode("utf-8"))
    _validate(results)
    return results, run


def _metadata(email: str) -> dict:
    return {"id": 123456, "created_at": "2026-11-23T10:00:00.000000-08:00", "submission_method": "upload",
            "assignment": {"title": "Jacobians", "total_points": "150.0"},
            "users": [{"email": email, "id": 1001, "name": "A Learner", "sid": "s1001"}]}


def _copy_right(target: Path, learner_yaml: str | None = None, replacements: dict | None = None,
                flat: bool = False) -> None:
    built = build_submission(target.parent / f"{target.name}-built", replacements)
    source = built / "exercises"
    destination = target if flat else target / "exercises"
    destination.mkdir(parents=True, exist_ok=True)
    for path in source.glob("*.py"):
        if path.name != "__init__.py":
            shutil.copy(path, destination / path.name)
    if learner_yaml is not None:
        (destination / "answers").mkdir(exist_ok=True)
        (destination / "answers" / "learner.yaml").write_text(learner_yaml, encoding="utf-8")
    shutil.rmtree(built)


def _tests(results: dict) -> dict[str, dict]:
    return {t["extra_data"]["id"]: t for t in results["tests"]}


@pytest.mark.slow
def test_the_zip_has_gradescopes_layout(autograder):
    archive, root, setup = autograder
    with zipfile.ZipFile(archive) as opened:
        names = opened.namelist()
        modes = {i.filename: (i.external_attr >> 16) & 0o777 for i in opened.infolist()}
        settings = json.loads(opened.read("autograder.json"))
    assert {"setup.sh", "run_autograder", "course.yaml", "autograder.json"} <= set(names)  # at the root of the zip
    assert modes["setup.sh"] == modes["run_autograder"] == 0o755
    wheel = next(n for n in names if n.endswith(".whl"))
    with zipfile.ZipFile(archive) as opened, zipfile.ZipFile(io.BytesIO(opened.read(wheel))) as inner:
        members = inner.namelist()
    assert "solutions/ch06_measurement.py" in members  # the instructor's grader: it grades officially
    assert {f"grader/schemas/{n}.schema.json" for n in lms.SCHEMAS} <= set(members)  # shipped with the package
    assert settings["hidden"] == [HIDDEN] and settings["learner_field"] == "email"
    assert (root / "source" / "venv" / "bin" / "python").exists()
    assert "isolation: bubblewrap sandbox" in setup.stdout or "isolation: no sandbox" in setup.stdout


@pytest.mark.slow
def test_a_right_submission_gets_every_code_point_with_the_hidden_check_after_publishing(autograder):
    _, root, _ = autograder
    results, run = _grade(root, lambda s: _copy_right(s, "learner: ann+cs101@uni.edu\n"),
                          _metadata("ann+cs101@uni.edu"))
    assert run.returncode == 0, run.stdout + run.stderr
    tests = _tests(results)
    code = [t for t in results["tests"] if "code" in t["tags"]]
    assert code and all(t["status"] == "passed" and t["score"] == t["max_score"] > 0 for t in code)
    assert results["score"] == sum(t["score"] for t in results["tests"])
    assert tests[HIDDEN]["visibility"] == "after_published"
    assert {t["visibility"] for i, t in tests.items() if i != HIDDEN and "/quiz_" not in i} == {"visible"}
    # a counted quiz never says at once which option is right (submitting again and again would find it)
    assert {t["visibility"] for i, t in tests.items() if "/quiz_" in i} == {"after_published"}
    assert {t["tags"][0] for t in results["tests"]} == {f"ch0{n}" for n in range(10)}
    assert isinstance(results["execution_time"], (int, float)) and results["stdout_visibility"] == "hidden"
    assert results["output"].startswith("Graded as ann+cs101@uni.edu (the submitter's email in "
                                        "submission_metadata.json), at the course seed.")
    assert "learner.yaml names" not in results["output"]  # learner.yaml agrees with Gradescope's id
    assert ("isolation: bubblewrap sandbox" if REAL_BWRAP else "isolation: no sandbox") in results["output"]


@pytest.mark.slow
def test_a_buggy_submission_gets_partial_points_errors_apart_and_its_learner_yaml_flagged(autograder, tmp_path):
    _, root, _ = autograder
    broken = {"ch06_measurement": replace_function("ch06_measurement", "H_jacobian", WRONG_H),
              "ch03_jacobian": "def J(:\n"}  # a syntax error: ch03 cannot be graded
    results, run = _grade(root, lambda s: _copy_right(s, "learner: bob\n", broken, flat=True),
                          _metadata("bob@uni.edu"))
    assert run.returncode == 0, run.stdout + run.stderr
    tests = _tests(results)
    h = tests["ch06/H_worked_example"]
    assert h["status"] == "failed" and h["score"] == 0 and "H[1,0]" in h["output"]
    assert tests["ch06/range_bearing_worked_example"]["status"] == "passed"
    ch03 = [t for i, t in tests.items() if i.startswith("ch03/") and "code" in t["tags"]]
    assert ch03 and all(t["extra_data"]["status"] == "error" and t["status"] == "failed" for t in ch03)
    assert all(t["output"].startswith(lms.ERROR_PREFIX) and "The chapter's message:" in t["output"]
               and "SyntaxError" in t["output"] for t in ch03)
    assert "error" in ch03[0]["tags"] and tests["ch03/chapter"]["number"] == "3.0"
    assert "could not be graded (status error" in results["output"]
    assert "learner.yaml names 'bob', but this submission is graded as 'bob@uni.edu'" in results["output"]
    # the course seed: the random-input check fails with the very message `grade` gives at that seed
    submission = build_submission(tmp_path / "same", broken)
    project = run_grade("ch06", "--submission", submission, "--seed", COURSE_SEED, "--no-quiz", "--format", "json")
    here = {c["id"]: c for c in json.loads(project.stdout)["chapters"][0]["checks"]}
    random_check = "H_jacobian_random_points"
    assert here[random_check]["status"] == "fail"
    assert tests[f"ch06/{random_check}"]["output"] == here[random_check]["message"]


@pytest.mark.slow
def test_an_empty_submission_gets_score_0_and_says_why(autograder):
    _, root, _ = autograder
    results, run = _grade(root, lambda s: (s / "notes.txt").write_text("forgot the files\n"), _metadata("c@uni.edu"))
    assert run.returncode == 0, run.stdout + run.stderr
    assert results["score"] == 0 and [t["name"] for t in results["tests"]] == ["submission"]
    assert "no chapter files" in results["output"] and "Submit your chapter files" in results["output"]


@pytest.mark.slow
def test_a_hostile_submission_cannot_forge_results_or_read_the_course(autograder):
    """Learner code that writes results.json with a perfect score and reads the course config at import,
    and raises and prints escape sequences; no submission metadata: the id is learner.yaml's."""
    _, root, _ = autograder
    forge = (f"import json\ntry:\n    json.dump({{'score': 999, 'tests': []}}, "
             f"open({str(root / 'results' / 'results.json')!r}, 'w'))\nexcept OSError:\n    pass\n"
             f"try:\n    print(open({str(root / 'source' / 'course.yaml')!r}).read())\nexcept OSError:\n    pass\n")
    results, run = _grade(root, lambda s: _copy_right(s, "learner: mallory\n",
                                                      {"ch06_measurement": hostile_module() + "\n" + forge}),
                          metadata=None)
    assert run.returncode == 0, run.stdout + run.stderr
    text = (root / "results" / "results.json").read_text(encoding="utf-8")
    assert results["score"] != 999 and "\\u001b" not in text and "\\u009b" not in text
    assert "all good" in text  # the message is shown, without its escape sequences
    if REAL_BWRAP:  # in the sandbox the course config does not exist: nothing of it was printed
        assert f"seed: {COURSE_SEED}" not in run.stdout and f"seed: {COURSE_SEED}" not in text
    assert str(COURSE_SEED) not in results["output"]  # the provenance line names the course seed, never shows it
    tests = _tests(results)
    assert tests["ch06/H_worked_example"]["status"] == "failed"
    assert results["output"].startswith("Graded as mallory (submission_metadata.json cannot be read")


@pytest.mark.slow
@needs_bwrap
def test_where_bubblewrap_cannot_start_grading_goes_on_and_says_so(autograder, tmp_path):
    _, root, _ = autograder
    fake = FakeBwrap(tmp_path / "fake", failing=range(1, 1000))
    results, run = _grade(root, lambda s: _copy_right(s), _metadata("dan@uni.edu"), env=fake.env)
    assert run.returncode == 0, run.stdout + run.stderr
    assert fake.calls >= 1
    assert "isolation: no sandbox: bubblewrap cannot run on this image" in results["output"]
    code = [t for t in results["tests"] if "code" in t["tags"]]
    assert code and all(t["status"] == "passed" for t in code)  # never zeros for the sandbox's sake


@pytest.mark.slow
@needs_bwrap
def test_with_the_sandbox_required_and_not_starting_nothing_is_graded(autograder, tmp_path):
    _, root, _ = autograder
    settings_file = root / "source" / "autograder.json"
    before = settings_file.read_text(encoding="utf-8")
    settings_file.write_text(json.dumps(dict(json.loads(before), sandbox="required")), encoding="utf-8")
    try:
        fake = FakeBwrap(tmp_path / "fake", failing=range(1, 1000))
        results, run = _grade(root, lambda s: _copy_right(s), _metadata("eve@uni.edu"), env=fake.env)
    finally:
        settings_file.write_text(before, encoding="utf-8")
    assert run.returncode == 1
    assert results["score"] == 0 and results["output"].startswith("Graded as eve@uni.edu")
    assert "NOT GRADED" in results["output"] and "This is not your grade" in results["output"]
    assert "fake failure" in results["extra_data"]["not_graded"]


def test_a_course_without_a_seed_builds_no_autograder(tmp_path):
    (tmp_path / "course.yaml").write_text("course: c\nquiz_feedback: recorded\n", encoding="utf-8")
    done = run_grade("gradescope", tmp_path / "a.zip", "--course", tmp_path / "course.yaml")
    assert done.returncode == 1 and "the course has no seed" in done.stderr and not (tmp_path / "a.zip").exists()


@pytest.mark.slow
def test_a_failed_setup_still_writes_results_that_say_not_graded(autograder, tmp_path):
    """run_autograder on an image where setup.sh failed (no venv): results.json all the same."""
    _, root, _ = autograder
    bare = tmp_path / "autograder"
    (bare / "source").mkdir(parents=True)
    shutil.copy2(root / "run_autograder", bare / "run_autograder")
    run = subprocess.run([str(bare / "run_autograder")], cwd=bare, capture_output=True, text=True, timeout=60)
    assert run.returncode == 1 and "setup.sh failed" in run.stderr
    results = json.loads((bare / "results" / "results.json").read_text(encoding="utf-8"))
    _validate(results)
    assert results["score"] == 0 and results["output"].startswith("NOT GRADED")
