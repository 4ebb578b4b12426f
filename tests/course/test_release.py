"""The learners' handout (`grade release`): built as an instructor builds it, installed from its wheel
in a fresh virtual environment outside the project, used in an empty folder that holds only the
exercises, as a learner would. It grades exactly as the project does at the public seed, holds no
answer in any file or wheel member, and hard-coding what it shows fails where submissions are graded
(the course seed, hidden checks)."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import tempfile
import zipfile
from pathlib import Path

import pytest

from grader.course import release
from tests.support import (
    REPO,
    build_submission,
    code_points,
    replace_function,
    run_grade,
)

COURSE_SEED = 987654321
HIDDEN = "ch06/H_rows_orthogonal"
COURSE = f"course: test-course\nseed: {COURSE_SEED}\nquiz_feedback: recorded\nhidden: [{HIDDEN}]\n"


def _readable_folder(prefix: str) -> Path:
    """A folder every user can read (pytest's own tmp folders are private to root)."""
    folder = Path(tempfile.mkdtemp(prefix=prefix))
    folder.chmod(0o755)
    return folder


@pytest.fixture(scope="session")
def handout():
    base = _readable_folder("handout-")
    (base / "course.yaml").write_text(COURSE, encoding="utf-8")
    done = run_grade("release", str(base / "out"), "--course", str(base / "course.yaml"))
    assert done.returncode == 0, done.stderr
    assert "Checked: no reference code" in done.stdout
    yield base / "out"
    shutil.rmtree(base, ignore_errors=True)


def _interpreter() -> str:
    """The system's python of our version if there is one (an ordinary user can run it), else ours."""
    system = shutil.which("python3", path="/usr/bin")
    if system:
        version = subprocess.run([system, "-c", "import sys; print(sys.version_info[:2])"], capture_output=True,
                                 text=True).stdout.strip()
        if version == str(tuple(sys.version_info[:2])):
            return system
    return sys.executable


@pytest.fixture(scope="session")
def learner_grade(handout):
    """`grade` of a fresh venv with only the handout's wheel (and its dependencies) installed."""
    base = _readable_folder("learner-venv-")
    venv = base / "venv"
    subprocess.run([_interpreter(), "-m", "venv", "--without-pip", str(venv)], check=True)
    wheel = next(handout.glob("*.whl"))
    done = subprocess.run([sys.executable, "-m", "pip", "--python", str(venv / "bin" / "python"), "install",
                           "--quiet", "--disable-pip-version-check", str(wheel)], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr[-3000:]
    subprocess.run(["chmod", "-R", "a+rX", str(base)], check=True)
    yield venv / "bin" / "grade"
    shutil.rmtree(base, ignore_errors=True)


def _learner(grade: Path, *args: str, cwd: Path, user: int | None = None) -> subprocess.CompletedProcess:
    env = {"PATH": "/usr/bin:/bin", "HOME": str(cwd), "LANG": "C.UTF-8"}
    command = [str(grade), *args]
    if user is not None:
        command = ["setpriv", f"--reuid={user}", f"--regid={user}", "--clear-groups", *command]
    return subprocess.run(command, cwd=cwd, env=env, capture_output=True, text=True, timeout=300)


def _code_checks(report: dict) -> dict:
    return {(ch["chapter"], c["id"]): (c["status"], c["points"], c["message"], c["expected"], c["got"])
            for ch in report["chapters"] for c in ch["checks"] if c["kind"] == "code"}


# ------------------------------------------------------------------------------ what the handout holds

@pytest.mark.slow
def test_the_handout_is_stubs_templates_a_wheel_and_a_readme(handout):
    names = sorted(p.relative_to(handout).as_posix() for p in handout.rglob("*") if p.is_file())
    assert "README.md" in names and len([n for n in names if n.endswith(".whl")]) == 1
    assert {n for n in names if n.startswith("exercises/ch")} == {f"exercises/{p.name}" for p in (REPO / "exercises").glob("ch*.py")}
    assert "exercises/answers/learner.yaml" in names and "exercises/answers/ch06.yaml" in names
    readme = (handout / "README.md").read_text(encoding="utf-8")
    assert 'pip install "jacobians_grader-' in readme and "1 hidden check" in readme


@pytest.mark.slow
def test_no_answer_in_any_file_or_wheel_member(handout):
    members = []
    for path in handout.rglob("*"):
        if path.suffix == ".whl":
            with zipfile.ZipFile(path) as wheel:
                members += [(f"{path.name}!{n}", wheel.read(n)) for n in wheel.namelist()]
        elif path.is_file():
            members.append((path.relative_to(handout).as_posix(), path.read_bytes()))
    names = [name for name, _ in members]
    assert not [n for n in names if "solutions/" in n or "keys/" in n or "oracle" in n or n.endswith((".pyc", ".pyo"))]
    assert not [n for n, data in members if str(COURSE_SEED).encode() in data]  # the course seed stays home
    handout_json = json.loads(dict(members)[next(n for n in names if n.endswith("grader/data/handout.json"))])
    assert handout_json["hidden"] == {"ch06": {"checks": 1, "points": 1.0, "ids": ["H_rows_orthogonal"]}}
    # every function body and distinctive line of the references, every key text and reference answer
    assert release.scan(handout) == []


@pytest.mark.slow
def test_the_scan_finds_a_planted_reference_and_key(tmp_path, handout):
    planted = tmp_path / "out"
    shutil.copytree(handout, planted)
    source = (REPO / "solutions" / "ch06_measurement.py").read_text(encoding="utf-8")
    (planted / "exercises" / "helper.py").write_text(source.replace("def H_jacobian", "def helper"), encoding="utf-8")
    key_feedback = "That is H transposed; rows are the outputs (range, bearing), columns the inputs (x, y)."
    (planted / "notes.txt").write_text(f"hint: {key_feedback}\n", encoding="utf-8")
    found = release.scan(planted)
    assert any(f.startswith("exercises/helper.py: a reference function's body") for f in found)
    assert any(f.startswith("notes.txt: key or reference answer") for f in found)


def test_release_refuses_a_folder_that_is_not_empty(tmp_path):
    (tmp_path / "out").mkdir()
    (tmp_path / "out" / "keep.txt").write_text("mine", encoding="utf-8")
    done = run_grade("release", str(tmp_path / "out"))
    assert done.returncode == 2 and "is not empty" in done.stderr  # a usage error
    assert (tmp_path / "out" / "keep.txt").read_text(encoding="utf-8") == "mine"


# ------------------------------------------------------------------------------ a learner with the handout

@pytest.mark.slow
def test_a_learner_grades_the_stubs_in_an_empty_folder(handout, learner_grade, tmp_path):
    shutil.copytree(handout / "exercises", tmp_path / "exercises")
    listed = _learner(learner_grade, "list", cwd=tmp_path)
    assert listed.returncode == 0 and listed.stdout.count("exercises/ch0") == 10
    assert "+ 1 in hidden checks" in listed.stdout
    graded = _learner(learner_grade, "all", cwd=tmp_path)
    assert graded.returncode == 1 and "not implemented yet" in graded.stdout
    assert "Total of the public checks: 0/" in graded.stdout  # at home the total says what it is
    assert "ch06 public checks: 0/" in graded.stdout and "1 hidden check (1 point) runs when you submit" in graded.stdout
    assert "Graded by grader 0.1.0+handout." in graded.stdout and "handout 0.1.0+handout." in graded.stdout
    shown = _learner(learner_grade, "quiz", "ch06", "--show", cwd=tmp_path)
    assert shown.returncode == 0 and "[H_at_point]" in shown.stdout
    other_seed = _learner(learner_grade, "ch06", "--seed", "3", cwd=tmp_path)
    assert other_seed.returncode == 2 and "public seed" in other_seed.stderr


def _submissions(root: Path) -> dict[str, Path]:
    """Right, buggy and hostile submissions, each a folder holding exercises/."""
    forged = ("import os, json\nlines = b''.join((json.dumps({'event': 'returned', 'chapter': 'ch06', 'index': i, "
              "'value': {'t': 'scalar', 'type': 'float', 'data': 1.0}}) + '\\n').encode() for i in range(50))\n"
              "for fd in range(3, 64):\n    try:\n        os.write(fd, lines)\n    except OSError:\n        pass\n")
    cases = {
        "right": {},
        "H_transposed": {"ch06_measurement": replace_function("ch06_measurement", "H_jacobian", """
            def H_jacobian(x, y):
                r2 = float(x) ** 2 + float(y) ** 2
                if r2 == 0:
                    raise ValueError("r = 0")
                r = r2 ** 0.5
                return np.array([[x / r, -y / r2], [y / r, x / r2]])
            """)},
        "F_sign": {"ch07_dynamics": replace_function("ch07_dynamics", "F_jacobian", """
            def F_jacobian(state, v, omega, dt):
                th = float(np.asarray(state, dtype=float)[2])
                return np.array([[1.0, 0.0, v * np.sin(th) * dt], [0.0, 1.0, v * np.cos(th) * dt], [0.0, 0.0, 1.0]])
            """)},
        "central_is_forward": {"ch05_finite_differences": replace_function("ch05_finite_differences",
                                                                           "central_difference", """
            def central_difference(f, x, h):
                return float((f(x + h) - f(x)) / h)
            """)},
        "hostile": {
            "ch06_measurement": replace_function("ch06_measurement", "H_jacobian", """
                def H_jacobian(x, y):
                    class Yes(np.ndarray):
                        def __eq__(self, other):
                            return True
                    return np.zeros((2, 2)).view(Yes)
                """) + "\n" + forged,
            "ch03_jacobian": "import sys\nprint('x' * 100000)\nsys.exit(0)\n",
        },
    }
    return {name: build_submission(root / name, files) for name, files in cases.items()}


@pytest.mark.slow
def test_the_installed_handout_grades_exactly_as_the_project(handout, learner_grade):
    base = _readable_folder("equivalence-")
    try:
        for name, submission in _submissions(base).items():
            subprocess.run(["chmod", "-R", "a+rX", str(base)], check=True)
            mine = run_grade("all", "--submission", str(submission), "--format", "json", "--no-quiz")
            theirs = _learner(learner_grade, "all", "--submission", str(submission), "--format", "json", "--no-quiz",
                              cwd=submission)
            project, handed_out = _code_checks(json.loads(mine.stdout)), _code_checks(json.loads(theirs.stdout))
            assert set(project) - set(handed_out) == {tuple(HIDDEN.split("/"))}, name
            assert {k: v for k, v in project.items() if k in handed_out} == handed_out, name
            ch06 = next(c for c in json.loads(theirs.stdout)["chapters"] if c["chapter"] == "ch06")
            assert (ch06["hidden_checks"], ch06["hidden_points"]) == (1, 1), name
            if name == "right":
                code = sum(c["code_score"] for c in json.loads(theirs.stdout)["chapters"])
                assert code == json.loads(run_grade("all", "--solutions", "--format", "json", "--no-quiz").stdout)["score"] - 1
                assert "All public checks pass" in _learner(learner_grade, "all", "--submission", str(submission),
                                                            "--no-quiz", cwd=submission).stdout
    finally:
        shutil.rmtree(base, ignore_errors=True)


@pytest.mark.slow
@pytest.mark.skipif(os.geteuid() != 0, reason="switching to an ordinary user needs root")
def test_an_ordinary_user_grades_with_the_handout_as_root_does(handout, learner_grade):
    base = _readable_folder("ordinary-user-")
    try:
        submission = build_submission(base / "right")
        subprocess.run(["chmod", "-R", "a+rX", str(base)], check=True)
        as_root = _learner(learner_grade, "ch06", "--no-quiz", "--format", "json", cwd=submission)
        as_user = _learner(learner_grade, "ch06", "--no-quiz", "--format", "json", cwd=submission, user=65534)
        assert as_user.returncode == 0, as_user.stderr
        assert _code_checks(json.loads(as_user.stdout)) == _code_checks(json.loads(as_root.stdout))
        assert json.loads(as_user.stdout)["score"] == float(code_points("ch06")) - 1  # one point hidden
    finally:
        shutil.rmtree(base, ignore_errors=True)


# ------------------------------------------------------------------------------ hard-coded public values

def _lookup_module(handout: Path) -> str:
    """A ch06 that answers from a table harvested out of the handout's check data, zeros elsewhere."""
    wheel = next(handout.glob("*.whl"))
    with zipfile.ZipFile(wheel) as archive:
        data = json.loads(archive.read("grader/data/expected/ch06.json"))
    table: dict[str, dict] = {"range_bearing": {}, "H_jacobian": {}, "measurement_covariance": {}}
    for entries in data["checks"].values():
        for entry in entries:
            function = entry["name"].split(".", 1)[1]
            if function in table and all(isinstance(a, (int, float)) for a in entry["args"]):
                value = entry["value"]
                table[function][repr(tuple(round(float(a), 9) for a in entry["args"]))] = (
                    value["$a"] if isinstance(value, dict) else value, value.get("shape") if isinstance(value, dict) else None)
    return f'''import numpy as np

TABLE = {table!r}


def _look(name, *args):
    hit = TABLE[name].get(repr(tuple(round(float(a), 9) for a in args)))
    if hit is None:
        return np.zeros((2,) if name == "range_bearing" else (2, 2))
    values, shape = hit
    return np.array(values, dtype=float).reshape(shape)


def range_bearing(x, y):
    return _look("range_bearing", x, y)


def H_jacobian(x, y):
    if x == 0 and y == 0:
        raise ValueError("r = 0")
    return _look("H_jacobian", x, y)


def measurement_covariance(x, y, sigma):
    if x == 0 and y == 0:
        raise ValueError("r = 0")
    return _look("measurement_covariance", x, y, sigma)
'''


@pytest.mark.slow
def test_hard_coded_public_values_pass_at_home_and_fail_where_submissions_are_graded(handout, learner_grade, tmp_path):
    base = _readable_folder("hard-coded-")
    try:
        submission = build_submission(base / "copycat", {"ch06_measurement": _lookup_module(handout)})
        subprocess.run(["chmod", "-R", "a+rX", str(base)], check=True)
        at_home = _learner(learner_grade, "ch06", "--no-quiz", "--format", "json", cwd=submission)
        home = {c["id"]: c["status"] for c in json.loads(at_home.stdout)["chapters"][0]["checks"]}
        random_inputs = ["range_bearing_all_quadrants", "covariance_random_points"]  # the table has their values
        assert [home[c] for c in random_inputs] == ["pass"] * 2
        submissions = tmp_path / "submissions"
        submissions.mkdir()
        shutil.copytree(submission / "exercises", submissions / "copycat" / "exercises")
        (tmp_path / "course.yaml").write_text(COURSE, encoding="utf-8")
        done = run_grade("batch", str(submissions), "--out", str(tmp_path / "out"), "--chapters", "ch06",
                        "--course", str(tmp_path / "course.yaml"), "--no-html")
        assert done.returncode in (0, 1), done.stderr
        graded = json.loads((tmp_path / "out" / "copycat" / "report.json").read_text(encoding="utf-8"))
        assert graded["seed"] is None  # the learner reads report.json: the course seed is not in it
        gradebook = (tmp_path / "out" / "gradebook.csv").read_text(encoding="utf-8")
        assert gradebook.splitlines()[1].endswith(f",{COURSE_SEED}")  # graded at it: the instructor's gradebook says so
        batch = {c["id"]: c["status"] for c in graded["chapters"][0]["checks"]}
        assert [batch[c] for c in random_inputs] == ["fail"] * 2
        assert "H_rows_orthogonal" in batch  # the hidden check runs where submissions are graded
    finally:
        shutil.rmtree(base, ignore_errors=True)


@pytest.mark.slow
def test_an_immediate_feedback_course_ships_practice_keys_of_fixed_questions_only(tmp_path):
    import yaml

    (tmp_path / "course.yaml").write_text("course: practice\nseed: 5\nquiz_feedback: immediate\n", encoding="utf-8")
    done = run_grade("release", str(tmp_path / "out"), "--course", str(tmp_path / "course.yaml"))
    assert done.returncode == 0, done.stderr
    with zipfile.ZipFile(next((tmp_path / "out").glob("*.whl"))) as wheel:
        practice = {n: yaml.safe_load(wheel.read(n)) for n in wheel.namelist() if "/practice/" in n}
        assert not [n for n in wheel.namelist() if "/keys/" in n]
    keys = yaml.safe_load((REPO / "quizzes" / "keys" / "ch06.yaml").read_text(encoding="utf-8"))
    questions = yaml.safe_load((REPO / "quizzes" / "ch06.yaml").read_text(encoding="utf-8"))["questions"]
    fixed = {q["id"] for q in questions if not q.get("params")}
    shipped = practice["grader/quizzes/practice/ch06.yaml"]
    assert set(shipped) == {q for q, key in keys.items() if "compute" not in key and q in fixed}
    assert "H_at_point" not in shipped and "dish_dbearing_dx" not in shipped  # computed; per learner
    assert release.scan(tmp_path / "out") == []  # practice keys are allowed; nothing else is


@pytest.mark.slow
def test_the_project_installs_from_its_wheel_and_grades_in_an_empty_folder(tmp_path):
    """The instructor's own install (`pip install .`, not editable): question banks and keys are package
    data, the references come along, so grade list, grade all and grade quiz --show work anywhere."""
    wheels = tmp_path / "wheels"
    built = subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--quiet", "--disable-pip-version-check",
                            "-w", str(wheels), str(REPO)], capture_output=True, text=True)
    assert built.returncode == 0, built.stderr[-2000:]
    venv = tmp_path / "venv"
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(venv)], check=True)
    installed = subprocess.run([sys.executable, "-m", "pip", "--python", str(venv / "bin" / "python"), "install",
                                "--quiet", "--disable-pip-version-check", *map(str, wheels.glob("*.whl"))],
                               capture_output=True, text=True)
    assert installed.returncode == 0, installed.stderr[-2000:]
    folder = tmp_path / "course"
    shutil.copytree(REPO / "exercises", folder / "exercises")
    grade = venv / "bin" / "grade"
    assert _learner(grade, "list", cwd=folder).stdout.count("exercises/ch0") == 10
    project = json.loads(run_grade("all", "--solutions", "--format", "json").stdout)
    stubs = _learner(grade, "all", "--format", "json", cwd=folder)
    assert json.loads(stubs.stdout)["max_score"] == project["max_score"]  # code and quiz: the banks are installed
    assert sum(c["quiz_max_score"] for c in json.loads(stubs.stdout)["chapters"]) > 0
    shown = _learner(grade, "quiz", "ch06", "--show", cwd=folder)
    assert shown.returncode == 0 and "[dbearing_dx]" in shown.stdout
    references = json.loads(_learner(grade, "all", "--solutions", "--format", "json", cwd=folder).stdout)
    assert references["score"] == references["max_score"] == project["max_score"]


# ------------------------------------------------------------------------------ grade submit from the handout

@pytest.mark.slow
def test_a_learner_submits_from_the_handout_and_batch_knows_the_handout(handout, learner_grade, tmp_path):
    base = _readable_folder("submit-")
    try:
        folder = base / "ann"
        shutil.copytree(handout / "exercises", folder / "exercises")
        subprocess.run(["chmod", "-R", "a+rwX", str(base)], check=True)
        packed = _learner(learner_grade, "submit", "--learner", "ann", cwd=folder)
        assert packed.returncode == 0, packed.stdout + packed.stderr
        assert "Total of the public checks: 0/" in packed.stdout  # the stubs, graded again from the archive
        assert "learner: ann" in (folder / "exercises" / "answers" / "learner.yaml").read_text(encoding="utf-8")
        with zipfile.ZipFile(folder / "ann.zip") as archive:
            manifest = json.loads(archive.read("exercises/submission-manifest.json"))
        version = json.loads((handout / "handout.json").read_text(encoding="utf-8"))["version"]
        assert manifest["handout"] == version == manifest["grader"] and manifest["course"] == "test-course"
        assert manifest["local"]["hidden_checks"] == 1 and manifest["learner"] == "ann"
        submissions = tmp_path / "submissions"
        submissions.mkdir()
        shutil.copy(folder / "ann.zip", submissions / "ann.zip")
        (tmp_path / "course.yaml").write_text(COURSE, encoding="utf-8")
        for given, stale in ((str(handout), False), ("0.0.1+handout.000000000000", True)):
            out = tmp_path / f"out-{stale}"
            done = run_grade("batch", str(submissions), "--out", str(out), "--chapters", "ch06", "--course",
                            str(tmp_path / "course.yaml"), "--no-html", "--handout", given)
            assert done.returncode == 0, done.stderr
            warnings = json.loads((out / "ann" / "report.json").read_text(encoding="utf-8"))["batch"]["warnings"]
            assert any("packed with an older or other handout" in w for w in warnings) == stale, warnings
    finally:
        shutil.rmtree(base, ignore_errors=True)


@pytest.mark.parametrize("before", ["absent", "kept"])
def test_a_refused_release_leaves_out_as_it_was(tmp_path, monkeypatch, before):
    """A handout that would hold an answer is refused, and OUT is as it was: absent, or with what it held (even with
    --force); nothing is left beside it. The handout is built elsewhere and moved into OUT only once it passes."""
    from click.testing import CliRunner

    from grader.faces.cli import main
    from grader.judging import expected

    def build_wheel(stage: Path, folder: Path) -> Path:
        (folder / "jacobians_grader-0.1.0-py3-none-any.whl").write_bytes(b"")
        return folder / "jacobians_grader-0.1.0-py3-none-any.whl"

    monkeypatch.setattr(release, "record", lambda course: expected.Recording(seed=course.public_seed))
    monkeypatch.setattr(release, "_build_wheel", build_wheel)
    monkeypatch.setattr(release, "scan", lambda folder: ["exercises/ch06_measurement.py: reference code `r = ...`"])
    out = tmp_path / "handout"
    if before == "kept":
        out.mkdir()
        (out / "notes.txt").write_text("the instructor's own", encoding="utf-8")
    done = CliRunner().invoke(main, ["release", str(out), "--force"])
    assert done.exit_code == 1 and "would hold answers" in done.output and "left as it was" in done.output
    assert sorted(p.name for p in tmp_path.iterdir()) == (["handout"] if before == "kept" else [])
    if before == "kept":
        assert [p.name for p in out.iterdir()] == ["notes.txt"]
    monkeypatch.setattr(release, "scan", lambda folder: [])
    done = CliRunner().invoke(main, ["release", str(out), "--force"])
    assert done.exit_code == 0, done.output
    assert (out / "handout.json").is_file() and (out / ".github" / "workflows" / "classroom.yml").is_file()
    assert not (out / "notes.txt").exists() and sorted(p.name for p in tmp_path.iterdir()) == ["handout"]
