"""`grade gradescope`: the autograder zip, run end to end on Gradescope's layout simulated under a
temporary root: unzipped into ROOT/source as Gradescope does, setup.sh run for real (a fresh venv with the
grader's wheel and its dependencies), run_autograder copied to ROOT and run once per submission, with
ROOT/submission and ROOT/submission_metadata.json as Gradescope writes them. A right, a buggy, an empty
and a hostile submission; bubblewrap that cannot start (grading goes on as an unprivileged user and says
so, or with --sandbox required nothing is graded and the run says NOT GRADED); no metadata (NOT GRADED: no
id). The layout is tests.support.GradescopeLayout's. Every results.json is checked against the published
schema."""

from __future__ import annotations

import io
import itertools
import json
import os
import re
import shlex
import shutil
import subprocess
import tempfile
import zipfile
from pathlib import Path

import pytest

from grader.course import gradescope
from grader.render import lms
from tests.support import (
    REAL_BWRAP,
    SYSTEM_PATH,
    FakeBwrap,
    GradescopeLayout,
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


@pytest.fixture(scope="module")
def autograder():
    """The layout after setup.sh ran (tests.support.GradescopeLayout), for every chapter of the course."""
    layout = GradescopeLayout(COURSE)
    yield layout
    layout.close()


def _validate(data: dict) -> None:
    jsonschema.Draft202012Validator(lms.schema("gradescope-results")).validate(data)


def _grade(layout: GradescopeLayout, make_submission, metadata: dict | None,
           path: str = SYSTEM_PATH) -> tuple[dict, subprocess.CompletedProcess]:
    """results.json of one run of ROOT/run_autograder (validated against the published schema), and the run."""
    results, run = layout.grade(make_submission, metadata, path=path, timeout=300)
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
    archive, root, setup = autograder.archive, autograder.root, autograder.setup
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
    results, run = _grade(autograder, lambda s: _copy_right(s, "learner: ann+cs101@uni.edu\n"),
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
                                        "submission_metadata.json), at a seed of this submission's own")
    assert "learner.yaml names" not in results["output"]  # learner.yaml agrees with Gradescope's id
    assert ("isolation: bubblewrap sandbox" if REAL_BWRAP else "isolation: no sandbox") in results["output"]


@pytest.mark.slow
def test_a_buggy_submission_gets_partial_points_errors_apart_and_its_learner_yaml_flagged(autograder, tmp_path):
    broken = {"ch06_measurement": replace_function("ch06_measurement", "H_jacobian", WRONG_H),
              "ch03_jacobian": "def J(:\n"}  # a syntax error: ch03 cannot be graded
    results, run = _grade(autograder, lambda s: _copy_right(s, "learner: bob\n", broken, flat=True),
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
    # the submission's own seed: the random-input check fails with the very message `grade` gives at that seed
    seed = gradescope.submission_seed(COURSE_SEED, "bob@uni.edu", "123456")
    submission = build_submission(tmp_path / "same", broken)
    project = run_grade("ch06", "--submission", submission, "--seed", seed, "--no-quiz", "--format", "json")
    here = {c["id"]: c for c in json.loads(project.stdout)["chapters"][0]["checks"]}
    random_check = "H_jacobian_random_points"
    assert here[random_check]["status"] == "fail"
    hint = here[random_check].get("help")
    assert tests[f"ch06/{random_check}"]["output"] == here[random_check]["message"] + (f"\nhint: {hint}" if hint else "")


@pytest.mark.slow
def test_an_empty_submission_gets_score_0_and_says_why(autograder):
    results, run = _grade(autograder, lambda s: (s / "notes.txt").write_text("forgot the files\n"), _metadata("c@uni.edu"))
    assert run.returncode == 0, run.stdout + run.stderr
    assert results["score"] == 0 and [t["name"] for t in results["tests"]] == ["submission"]
    assert "no chapter files" in results["output"] and "Submit your chapter files" in results["output"]


@pytest.mark.slow
def test_a_hostile_submission_cannot_forge_results_or_read_the_course(autograder):
    """Learner code that writes results.json with a perfect score and reads the course config at import,
    and raises and prints escape sequences, and whose learner.yaml names someone else."""
    root = autograder.root
    forge = (f"import json\ntry:\n    json.dump({{'score': 999, 'tests': []}}, "
             f"open({str(root / 'results' / 'results.json')!r}, 'w'))\nexcept OSError:\n    pass\n"
             f"try:\n    print(open({str(root / 'source' / 'course.yaml')!r}).read())\nexcept OSError:\n    pass\n")
    results, run = _grade(autograder, lambda s: _copy_right(s, "learner: ann@uni.edu\n",
                                                            {"ch06_measurement": hostile_module() + "\n" + forge}),
                          _metadata("mallory@uni.edu"))
    assert run.returncode == 0, run.stdout + run.stderr
    text = (root / "results" / "results.json").read_text(encoding="utf-8")
    assert results["score"] != 999 and "\\u001b" not in text and "\\u009b" not in text
    assert "all good" in text  # the message is shown, without its escape sequences
    if REAL_BWRAP:  # in the sandbox the course config does not exist: nothing of it was printed
        assert f"seed: {COURSE_SEED}" not in run.stdout and f"seed: {COURSE_SEED}" not in text
    assert str(COURSE_SEED) not in results["output"]  # the provenance line names the course seed, never shows it
    tests = _tests(results)
    assert tests["ch06/H_worked_example"]["status"] == "failed"
    assert results["output"].startswith("Graded as mallory@uni.edu")  # Gradescope's id, never learner.yaml's
    assert "learner.yaml names 'ann@uni.edu'" in results["output"]


@pytest.mark.slow
def test_without_usable_metadata_nothing_is_graded(autograder):
    """No submission_metadata.json: no id to grade as, so NOT GRADED for the instructor, never learner.yaml's."""
    results, run = _grade(autograder, lambda s: _copy_right(s, "learner: mallory\n"), None)
    assert run.returncode == 1 and results["score"] == 0
    assert results["output"].startswith("NOT GRADED") and "no usable learner id" in results["output"]


@pytest.mark.slow
@needs_bwrap
def test_where_bubblewrap_cannot_start_grading_goes_on_as_an_unprivileged_user_and_says_so(autograder, tmp_path):
    fake = FakeBwrap(tmp_path / "fake", failing=range(1, 1000))
    results, run = _grade(autograder, lambda s: _copy_right(s), _metadata("dan@uni.edu"),
                          path=f"{fake.bin}:{SYSTEM_PATH}")
    assert run.returncode == 0, run.stdout + run.stderr
    assert fake.calls >= 1
    assert "unprivileged user" in results["output"], results["output"]
    code = [t for t in results["tests"] if "code" in t["tags"]]
    assert code and all(t["status"] == "passed" for t in code)  # never zeros for the sandbox's sake


@pytest.mark.slow
@needs_bwrap
def test_with_the_sandbox_required_and_not_starting_nothing_is_graded(autograder, tmp_path):
    settings_file = autograder.root / "source" / "autograder.json"
    before = settings_file.read_text(encoding="utf-8")
    settings_file.write_text(json.dumps(dict(json.loads(before), sandbox="required")), encoding="utf-8")
    try:
        fake = FakeBwrap(tmp_path / "fake", failing=range(1, 1000))
        results, run = _grade(autograder, lambda s: _copy_right(s), _metadata("eve@uni.edu"),
                              path=f"{fake.bin}:{SYSTEM_PATH}")
    finally:
        settings_file.write_text(before, encoding="utf-8")
    assert run.returncode == 1
    assert results["score"] == 0 and results["output"].startswith("NOT GRADED")
    assert "NOT GRADED" in results["output"] and "This is not your grade" in results["output"]
    assert "fake failure" in results["extra_data"]["not_graded"]


def _recipe(readme: str, ag: Path, sub: Path) -> str:
    """README.txt's try as a bash script, line by line as it stands, with AG and SUB set as it asks."""
    lines = readme.split("Try it", 1)[1].splitlines()
    block = [line[2:] for line in itertools.dropwhile(lambda line: not line.startswith("  "), lines)]
    block = list(itertools.takewhile(lambda line: line.strip(), block))
    assert re.fullmatch(r"AG=\S+; SUB=\S+", block[0]), block
    return "\n".join([f"AG={shlex.quote(str(ag))}; SUB={shlex.quote(str(sub))}", *block[1:]]) + "\n"


@pytest.mark.slow
def test_the_zips_readme_try_done_as_it_says_grades_the_submission(tmp_path):
    """The README.txt in the zip says how to try it: done as written (in bash, as root, beside the zip, with the
    system's python3), the submission is graded, as the submitter its metadata names, at a seed of its own."""
    if shutil.which("unzip", path=SYSTEM_PATH) is None or shutil.which("python3", path=SYSTEM_PATH) is None:
        pytest.skip("no unzip or system python3, as the README's try asks")
    base = Path(tempfile.mkdtemp(prefix="gradescope-readme-"))
    base.chmod(0o755)  # as /tmp is: learner code run as an unprivileged user reaches the interpreter
    try:
        (base / "course.yaml").write_text(COURSE + "deadline: '2026-05-01T23:59:00+00:00'\nlate_penalty: {per_day: 0.5}\n",
                                          encoding="utf-8")
        built = run_grade("gradescope", base / "autograder.zip", "--course", base / "course.yaml",
                          "--chapters", "ch00,ch06")
        assert built.returncode == 0, built.stderr
        with zipfile.ZipFile(base / "autograder.zip") as opened:
            readme = opened.read("README.txt").decode("utf-8")
        assert "graded at a seed of its own, drawn from the course seed" in readme and "at the course seed" not in readme
        script = base / "try.sh"
        script.write_text(_recipe(readme, base / "ag", build_submission(base / "sub")), encoding="utf-8")
        done = subprocess.run(["bash", str(script)], cwd=base, capture_output=True, text=True, timeout=900,
                              env={"PATH": SYSTEM_PATH, "HOME": str(base)})
        results = json.loads((base / "ag" / "results" / "results.json").read_text(encoding="utf-8"))
        _validate(results)
        assert results["output"].startswith("Graded as learner@example.edu (the submitter's email in "
                                            "submission_metadata.json), at a seed of this submission's own"), (
            results["output"][:2000] + done.stderr[-3000:])
        code = [t for t in results["tests"] if "code" in t["tags"]]
        assert code and all(t["status"] == "passed" for t in code), results["output"]
        assert results["score"] == sum(t["max_score"] for t in code) > 0  # on time: no late penalty
        assert done.stdout.rstrip().endswith("}")  # the recipe's last step shows results.json
    finally:
        shutil.rmtree(base, ignore_errors=True)


def test_a_course_without_a_seed_builds_no_autograder(tmp_path):
    (tmp_path / "course.yaml").write_text("course: c\nquiz_feedback: recorded\n", encoding="utf-8")
    done = run_grade("gradescope", tmp_path / "a.zip", "--course", tmp_path / "course.yaml")
    assert done.returncode == 1 and "the course has no seed" in done.stderr and not (tmp_path / "a.zip").exists()


@pytest.mark.slow
def test_a_failed_setup_still_writes_results_that_say_not_graded(autograder, tmp_path):
    """run_autograder on an image where setup.sh failed (no venv): results.json all the same."""
    root = autograder.root
    bare = tmp_path / "autograder"
    (bare / "source").mkdir(parents=True)
    shutil.copy2(root / "run_autograder", bare / "run_autograder")
    run = subprocess.run([str(bare / "run_autograder")], cwd=bare, capture_output=True, text=True, timeout=60)
    assert run.returncode == 1 and "setup.sh failed" in run.stderr
    results = json.loads((bare / "results" / "results.json").read_text(encoding="utf-8"))
    _validate(results)
    assert results["score"] == 0 and results["output"].startswith("NOT GRADED")
