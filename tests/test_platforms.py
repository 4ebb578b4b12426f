"""The same verdicts on every system: `grade` run as Windows runs it (no POSIX-only API: the "portable"
process boundary) and as macOS runs it (no fork after numpy, no bubblewrap) gives, check by check, the
verdicts the Linux route gives, on right, buggy and hostile submissions. The emulation is
tests/platforms.py; real subprocesses throughout."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from tests.conftest import REPO, build_submission, code_points, replace_function
from tests.platforms import MACOS, WINDOWS, grade_command
from tests.test_watch import RIGHT_H, WRONG_H, Watching, _save

CHAPTERS = ["ch03", "ch05", "ch06", "ch07", "ch09"]

BUGGY = {
    "ch06_measurement": replace_function("ch06_measurement", "H_jacobian", "def H_jacobian(x, y):\n"
                                         "    r2 = x * x + y * y\n    r = np.sqrt(r2)\n" + WRONG_H + "\n"),
    "ch05_finite_differences": replace_function(
        "ch05_finite_differences", "jacobian_fd",
        "def jacobian_fd(f, x, h=1e-5):\n    x = np.asarray(x, dtype=float)\n    fx = np.atleast_1d(f(x))\n"
        "    J = np.zeros((fx.size, x.size))\n    for j in range(x.size):\n        step = np.zeros_like(x)\n"
        "        step[j] = h\n        J[:, j] = (np.atleast_1d(f(x + step)) - fx) / h\n    return J\n"),
}
HOSTILE = {
    # an endless loop, killed at the call's time limit; the chapter's other functions are still graded
    "ch06_measurement": replace_function("ch06_measurement", "H_jacobian", "def H_jacobian(x, y):\n"
                                         "    while True:\n        pass\n"),
    # prints characters no code page has, then leaves the process in the middle of a check
    "ch07_dynamics": replace_function("ch07_dynamics", "F_jacobian", "def F_jacobian(state, v, omega, dt):\n"
                                      "    print('σ ✓ 日本 \\x1b[31m')\n    import os\n    os._exit(3)\n"),
    # forged "right answer" lines written to every descriptor, the result channel among them
    "ch03_jacobian": (REPO / "solutions" / "ch03_jacobian.py").read_text(encoding="utf-8") + (
        "\nimport os, json\nfor fd in range(1, 64):\n    try:\n"
        "        os.write(fd, (json.dumps({'event': 'done'}) + '\\n').encode())\n    except OSError:\n        pass\n"),
    "ch05_finite_differences": "import sys\nsys.exit(0)\n",
}


def _with_answers(root: Path) -> Path:
    shutil.copytree(REPO / "solutions" / "answers", root / "exercises" / "answers")
    return root


def _verdicts(route: str, root: Path) -> dict:
    done = subprocess.run(grade_command(route, *CHAPTERS, "--submission", str(root), "--format", "json"),
                          cwd=REPO, capture_output=True, text=True, encoding="utf-8", timeout=300)
    assert done.returncode in (0, 1), done.stderr[-3000:]
    report = json.loads(done.stdout)
    return {"score": (report["score"], report["max_score"]), "infrastructure": report["infrastructure"],
            "chapters": {c["chapter"]: {"problems": c["problems"], "checks": [
                (k["id"], k["status"], k["points"], k["message"], k["mistake"]) for k in c["checks"]]}
                for c in report["chapters"]}}


@pytest.fixture(scope="module")
def submissions(tmp_path_factory) -> dict[str, Path]:
    base = tmp_path_factory.mktemp("platforms")
    return {"right": _with_answers(build_submission(base / "right")),
            "buggy": _with_answers(build_submission(base / "buggy", BUGGY)),
            "hostile": _with_answers(build_submission(base / "hostile", HOSTILE))}


@pytest.fixture(scope="module")
def linux(submissions) -> dict:
    return {name: _verdicts("linux", root) for name, root in submissions.items()}


@pytest.mark.parametrize("route", ["windows", "macos"])
@pytest.mark.parametrize("kind", ["right", "buggy", "hostile"])
def test_verdicts_are_those_of_linux(route, kind, submissions, linux):
    assert _verdicts(route, submissions[kind]) == linux[kind]


def test_the_submissions_show_what_they_should(linux):
    """The comparison means something: full marks, named bugs, and each hostile act caught."""
    assert linux["right"]["score"][0] == linux["right"]["score"][1]
    buggy = {k[0]: k for c in linux["buggy"]["chapters"].values() for k in c["checks"]}
    assert buggy["H_worked_example"][1] == "fail" and "sign" in buggy["H_worked_example"][3]
    assert any(k[1] == "fail" and k[0].startswith("jacobian_fd") for k in buggy.values())
    hostile = linux["hostile"]["chapters"]
    h_checks = [k for k in hostile["ch06"]["checks"] if k[0].startswith("H_")]
    assert h_checks and all(k[1] != "pass" for k in h_checks)
    assert any("time" in k[3] for k in h_checks)
    assert any(k[1] == "pass" and k[0].startswith("range_bearing") for k in hostile["ch06"]["checks"])
    f_checks = [k for k in hostile["ch07"]["checks"] if k[0].startswith("F_")]
    assert f_checks and all(k[1] != "pass" for k in f_checks)
    assert not any(k[1] == "pass" for k in hostile["ch05"]["checks"] if k[0].startswith("jacobian_fd"))
    assert "sys.exit" in " ".join(hostile["ch05"]["problems"]) or any(
        "sys.exit" in k[3] for k in hostile["ch05"]["checks"])


def _emulated(prelude: str, code: str) -> str:
    done = subprocess.run([sys.executable, "-c", f"EMULATION = {prelude!r}\nexec(EMULATION)\n{code}"], cwd=REPO,
                          capture_output=True, text=True, encoding="utf-8", timeout=60)
    assert done.returncode == 0, done.stderr[-3000:]
    return done.stdout.strip()


def test_each_route_takes_its_own_mechanism():
    """What the emulations exercise: Windows gets the portable boundary and no sandbox, macOS no fork."""
    probe = ("from grader.spawn import strategy, fork_is_safe\nfrom grader.boundary.sandbox import Sandbox\n"
             "print(strategy(), fork_is_safe(), Sandbox().available)")
    assert _emulated(WINDOWS, probe) == "portable False False"
    assert _emulated(MACOS, probe) == "posix False False"
    line = _emulated(WINDOWS, "from grader.boundary.sandbox import Sandbox\nprint(Sandbox().describe())")
    assert "killed on a timeout" in line and "no sandbox" in line


@pytest.mark.parametrize("route", ["windows", "macos"])
def test_html_report_and_quiz(route, submissions, tmp_path):
    page = tmp_path / "report.html"
    done = subprocess.run(grade_command(route, "ch06", "ch07", "--submission", str(submissions["buggy"]),
                                        "--html", str(page)),
                          cwd=REPO, capture_output=True, text=True, encoding="utf-8", timeout=300)
    assert done.returncode == 1, done.stderr[-3000:]
    html = page.read_text(encoding="utf-8")
    assert "H at the lesson&#39;s point (3, 4)" in html and "wrong sign" in html
    assert html.count("<img") >= 2  # plots drawn from the learner's functions, serially on these routes
    quiz = subprocess.run(grade_command(route, "quiz", "ch06", "--submission", str(submissions["right"])),
                          cwd=REPO, capture_output=True, text=True, encoding="utf-8", timeout=300)
    assert quiz.returncode == 0, quiz.stdout[-2000:] + quiz.stderr[-2000:]


@pytest.mark.parametrize("encoding", ["cp1252", "ascii"])
def test_a_console_without_the_marks_gets_plain_text(encoding, submissions):
    """Output redirected in a Windows code page: no UnicodeEncodeError, learner text shown as far as it can be."""
    env = {"PATH": "/usr/bin:/bin", "PYTHONIOENCODING": encoding}
    done = subprocess.run(grade_command("windows", "ch07", "ch06", "-v", "--submission", str(submissions["hostile"])),
                          cwd=REPO, capture_output=True, env=env, timeout=300)
    out = done.stdout.decode(encoding)
    assert done.returncode == 1, done.stderr.decode(encoding, "replace")[-3000:]
    assert "Traceback" not in done.stderr.decode(encoding, "replace")
    assert "ch07 total" in out and "ch06 total" in out
    assert "\x1b" not in out
    assert "✓" not in out


@pytest.mark.parametrize("route", ["windows", "macos"])
def test_watch_runs_on_the_route(route, tmp_path):
    root = build_submission(tmp_path)
    chapter = root / "exercises" / "ch06_measurement.py"
    command = grade_command(route, "ch06", "--watch", "--no-quiz", "--submission", str(root))
    watcher = Watching(root, command)
    try:
        first = watcher.until(r"watching for saves")
        assert any(f"ch06 total: {code_points('ch06')}/{code_points('ch06')}" in line for line in first)
        right = chapter.read_text(encoding="utf-8")
        _save(chapter, right.replace(RIGHT_H, WRONG_H))
        after = watcher.until(r"watching for saves")
        assert any(line.startswith("ch06: newly failing: H_worked_example") for line in after)
    finally:
        watcher.stop()


@pytest.mark.parametrize("prelude", [WINDOWS, MACOS], ids=["windows", "macos"])
def test_sympy_decides_in_its_own_process_on_the_route(prelude):
    """What only sympy can decide (undefined at every real point) is decided in its worker process, read
    and stopped without poll or process groups on Windows; sympy never enters the grading process."""
    code = ("import sys\nfrom grader.quiz.symbolic import equivalent\n"
            "print(equivalent('sqrt(-1 - x^2)*2', '2*sqrt(-1 - x^2)', ('x',)), "
            "equivalent('sqrt(-1 - x^2)*3', '2*sqrt(-1 - x^2)', ('x',)), 'sympy' in sys.modules)")
    assert _emulated(prelude, code).split() == ["True", "False", "False"]
