"""The same verdicts on every system. Each learner and instructor command, run as Windows' and macOS's CPython
would run it (tests/platforms.py: the standard library's surface from typeshed's stubs, the platforms'
behaviours), gives check by check the verdicts Linux gives, on right, buggy and hostile submissions; only the
isolation line says what each system really offers. Real subprocesses throughout."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
import zipfile
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest

from tests.platforms import environment, grade_command, python_code, surface
from tests.support import (
    REPO,
    RIGHT_H,
    WRONG_H,
    Watching,
    build_submission,
    code_points,
    not_root,
    replace_function,
    replace_functions,
    save,
    slow_but_the_first,
)

ROUTES = ["windows", "macos"]
CHAPTERS = ["ch03", "ch05", "ch06", "ch07", "ch09"]

RIGHT = {
    # a right function that prints what no code page has (UTF-8 in the child on every system)
    "ch06_measurement": replace_function("ch06_measurement", "range_bearing", "def range_bearing(x, y):\n"
                                         "    print('σ ✓ 日本')\n"
                                         "    return np.array([np.hypot(x, y), np.arctan2(y, x)])\n"),
}
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
    # an endless loop, killed at the call's time limit; the chapter's other functions are still graded, among
    # them a right one that leaves a grandchild process running (killed with the learner's run)
    "ch06_measurement": replace_functions("ch06_measurement", {
        "H_jacobian": "def H_jacobian(x, y):\n    while True:\n        pass\n",
        "range_bearing": "def range_bearing(x, y):\n    import subprocess, sys\n"
                         "    subprocess.Popen([sys.executable, '-c', 'import time; time.sleep(20)  # grandchild-marker'])\n"
                         "    return np.array([np.hypot(x, y), np.arctan2(y, x)])\n"}),
    # prints characters no code page has and escape sequences, then leaves the process in the middle of a check
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


def _run(route: str, *arguments: str, cwd: Path = REPO, timeout: float = 300) -> subprocess.CompletedProcess:
    """`grade ARGUMENTS` as on `route`; on Linux with --no-sandbox as a user who is not root (as root the grader never
    runs learner code without a barrier), the user such a run is for."""
    command = grade_command(route, *arguments)
    if route == "linux" and "--no-sandbox" in arguments:
        command = not_root(command)
    return subprocess.run(command, cwd=cwd, env=environment(route), capture_output=True,
                          text=True, encoding="utf-8", errors="replace", timeout=timeout)


def _checks(report: dict) -> dict:
    return {c["chapter"]: {"problems": c["problems"], "checks": [
        (k["id"], k["status"], k["points"], k["message"], k["mistake"], k.get("help")) for k in c["checks"]]}
        for c in report["chapters"]}


def _verdicts(route: str, root: Path, *extra: str) -> dict:
    done = _run(route, *CHAPTERS, "--submission", str(root), "--format", "json", *extra)
    assert done.returncode in (0, 1), done.stderr[-3000:]
    report = json.loads(done.stdout)
    return {"score": (report["score"], report["max_score"]), "infrastructure": report["infrastructure"],
            "chapters": _checks(report)}


@pytest.fixture(scope="module")
def submissions(tmp_path_factory) -> dict[str, Path]:
    base = tmp_path_factory.mktemp("platforms")
    return {"right": _with_answers(build_submission(base / "right", RIGHT)),
            "buggy": _with_answers(build_submission(base / "buggy", BUGGY)),
            "hostile": _with_answers(build_submission(base / "hostile", HOSTILE))}


@pytest.fixture(scope="module")
def linux(submissions) -> dict:
    with ThreadPoolExecutor(3) as each:  # side by side: the hostile one waits out its time limits
        return dict(zip(submissions, each.map(lambda root: _verdicts("linux", root, "--no-sandbox"),
                                              submissions.values())))


# ------------------------------------------------------------------------------ the emulation itself

def test_the_emulated_surfaces_come_from_typeshed():
    """What each system lacks is read from typeshed's stubs: the facts the grader's choices depend on."""
    windows, windows_absent = surface("windows")
    macos, macos_absent = surface("macos")
    assert {"fork", "killpg", "setsid", "geteuid", "O_TMPFILE", "pread"} <= set(windows["os"])
    assert {"AF_UNIX", "send_fds", "recv_fds"} <= set(windows["socket"])
    assert "poll" in windows["select"] and "SIGKILL" in windows["signal"]
    assert {"resource", "fcntl", "pwd", "termios"} <= set(windows_absent)
    assert {"O_TMPFILE", "pidfd_open"} <= set(macos["os"]) and "fork" not in macos["os"]
    assert "epoll" in macos["select"] and "poll" not in macos["select"] and not macos_absent


@pytest.mark.parametrize("route", ROUTES)
def test_the_view_and_the_behaviours_are_the_platforms(route):
    code = ("import os, select, socket, multiprocessing, shutil, sys\n"
            "print(hasattr(os, 'fork'), hasattr(os, 'O_TMPFILE'), hasattr(select, 'poll'), hasattr(socket, 'AF_UNIX'),"
            " multiprocessing.get_start_method(), shutil.which('bwrap'), os.path.isdir('/proc/self'))\n"
            "try:\n    import resource\n    print('resource')\nexcept ImportError:\n    print('no resource')\n"
            "import numpy\nprint(numpy.ones(2).sum())\n")  # the libraries keep Linux's names: numpy imports
    done = subprocess.run(python_code(route, code), capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr[-3000:]
    first, second, third = done.stdout.split("\n")[:3]
    expected = {"windows": "False False False False spawn None False",
                "macos": "True False True True spawn None False"}[route]
    assert first == expected
    assert second == ("no resource" if route == "windows" else "resource") and third == "2.0"


@pytest.mark.parametrize("route", ROUTES)
def test_each_route_takes_its_own_mechanism(route):
    """Windows gets the portable launcher, macOS a fresh interpreter per session (no fork after numpy), neither
    bubblewrap; the isolation line says so, and a required sandbox is refused with the reason."""
    code = ("from grader import boundary\nchosen = boundary.choose(resident=True)\n"
            "print(chosen.launch.name, chosen.sandboxed)\nprint(chosen.isolation)\n"
            "try:\n    boundary.choose('required')\nexcept boundary.BoundaryUnavailable as exc:\n    print('refused:', exc)\n")
    done = subprocess.run(python_code(route, code), cwd=REPO, capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr[-3000:]
    launch, isolation, refused = done.stdout.strip().split("\n")
    assert launch == {"windows": "PORTABLE False", "macos": "SPAWN False"}[route]
    assert "no sandbox" in isolation and "this system has no bubblewrap" in isolation
    assert refused.startswith("refused: ")


# ------------------------------------------------------------------------------ each command, as the learner runs it

@pytest.mark.slow
@pytest.mark.parametrize("route", ROUTES)
@pytest.mark.parametrize("kind", ["right", "buggy", "hostile"])
def test_verdicts_are_those_of_linux(route, kind, submissions, linux):
    assert _verdicts(route, submissions[kind]) == linux[kind]


@pytest.mark.slow
def test_the_submissions_show_what_they_should(linux):
    """The comparison means something: full marks (the printing function included), named bugs, and each
    hostile act caught."""
    assert linux["right"]["score"][0] == linux["right"]["score"][1]
    buggy = {k[0]: k for c in linux["buggy"]["chapters"].values() for k in c["checks"]}
    assert buggy["H_worked_example"][1] == "fail" and "sign" in buggy["H_worked_example"][5]
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


@pytest.mark.parametrize("route", ROUTES)
def test_a_function_printing_what_no_code_page_has_passes(route, submissions):
    done = _run(route, "ch06", "--submission", str(submissions["right"]), "--format", "json", "--no-quiz")
    report = json.loads(done.stdout)
    assert report["score"] == report["max_score"], done.stdout[-3000:]


@pytest.mark.slow
@pytest.mark.parametrize("route", ROUTES)
def test_html_report_one_function_and_the_quiz(route, submissions, tmp_path):
    page = tmp_path / "report.html"
    done = _run(route, "ch06", "ch07", "--submission", str(submissions["buggy"]), "--html", str(page))
    assert done.returncode == 1, done.stderr[-3000:]
    html = page.read_text(encoding="utf-8")
    assert "H at the lesson&#39;s point (3, 4)" in html and "wrong sign" in html
    assert html.count("<img") >= 2  # plots drawn from the learner's functions, in this process on these routes
    one = _run(route, "ch06", "H_jacobian", "--submission", str(submissions["buggy"]), "--format", "json")
    linux_one = _run("linux", "ch06", "H_jacobian", "--submission", str(submissions["buggy"]), "--format", "json",
                     "--no-sandbox")
    assert _checks(json.loads(one.stdout)) == _checks(json.loads(linux_one.stdout))
    quiz = _run(route, "quiz", "ch06", "--submission", str(submissions["right"]))
    assert quiz.returncode == 0, quiz.stdout[-2000:] + quiz.stderr[-2000:]
    shown = _run(route, "quiz", "ch06", "--show", "--submission", str(submissions["right"]))
    assert shown.returncode == 0 and "H_at_point" in shown.stdout, shown.stderr[-2000:]


@pytest.mark.parametrize("encoding", ["cp1252", "ascii"])
def test_a_console_without_the_marks_gets_plain_text(encoding, submissions):
    """Output redirected in a Windows code page: the marks the code page lacks are never written (a
    UnicodeEncodeError would end the run with a traceback), nor escape sequences."""
    env = environment("windows", {"PATH": "/usr/bin:/bin", "PYTHONIOENCODING": encoding})
    done = subprocess.run(grade_command("windows", "ch07", "-v", "--submission", str(submissions["hostile"])),
                          cwd=REPO, capture_output=True, env=env, timeout=300)
    out = done.stdout.decode(encoding)
    assert done.returncode == 1, done.stderr.decode(encoding, "replace")[-3000:]
    assert "Traceback" not in done.stderr.decode(encoding, "replace")
    assert "ch07 total" in out
    assert "\x1b" not in out


@pytest.mark.slow
@pytest.mark.parametrize("route", ROUTES)
def test_watch_runs_on_the_route(route, tmp_path):
    root = build_submission(tmp_path)
    chapter = root / "exercises" / "ch06_measurement.py"
    command = grade_command(route, "ch06", "--watch", "--no-quiz", "--submission", str(root))
    watcher = Watching(root, command, env=environment(route))
    try:
        first = watcher.until(r"watching for saves")
        assert any(f"ch06 total: {code_points('ch06')}/{code_points('ch06')}" in line for line in first)
        right = chapter.read_text(encoding="utf-8")
        save(chapter, right.replace(RIGHT_H, WRONG_H))
        after = watcher.until(r"watching for saves")
        assert any(line.startswith("ch06: newly failing: H_worked_example") for line in after)
    finally:
        watcher.stop()


@pytest.mark.slow
@pytest.mark.parametrize("route", ROUTES)
def test_submit_packs_and_grades_the_archive_again(route, submissions, tmp_path):
    project = tmp_path / "project"
    shutil.copytree(submissions["buggy"], project)
    done = _run(route, "submit", "--learner", "reference", cwd=project)
    assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-2000:]
    assert "The archive, graded again: Total:" in done.stdout
    with zipfile.ZipFile(project / "reference.zip") as archive:
        assert "exercises/submission-manifest.json" in archive.namelist()


@pytest.mark.slow
@pytest.mark.parametrize("route", ROUTES)
def test_percent_grade_twice_through_the_notebook_grading_process(route, submissions):
    """%grade in an IPython shell: the kernel's client and the resident grading process, both emulated; the
    second %grade after the first (a reader per call lost the next answer where pipes cannot be polled)."""
    pytest.importorskip("IPython")
    code = ("import os, sys\nos.chdir(sys.argv[1])\nfrom IPython.testing.globalipapp import start_ipython\n"
            "ip = start_ipython()\nip.run_line_magic('load_ext', 'grader')\n"
            "for _ in range(2):\n    r = ip.run_line_magic('grade', 'ch06 --no-quiz')\n    print('SCORE', r.score, r.max_score)\n")
    done = subprocess.run([*python_code(route, code), str(submissions["buggy"])], cwd=REPO, env=environment(route),
                          capture_output=True, text=True, encoding="utf-8", errors="replace", timeout=300)
    scores = [line for line in done.stdout.splitlines() if line.startswith("SCORE")]
    linux = json.loads(_run("linux", "ch06", "--no-quiz", "--no-sandbox", "--format", "json", "--submission",
                            str(submissions["buggy"])).stdout)
    expected = f"SCORE {linux['score']:g} {linux['max_score']:g}"
    assert scores == [expected, expected], done.stdout[-2000:] + done.stderr[-3000:]


def _batch(where: str, folder: Path, out: Path, names) -> tuple[list[str], dict]:
    """grade batch FOLDER with two workers and no sandbox on `where`: (the gradebook's rows without the grader's
    version, each learner's per-check verdicts)."""
    done = _run(where, "batch", str(folder), "--out", str(out), "--jobs", "2", "--no-sandbox", "--no-html")
    assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-3000:]
    rows = (out / "gradebook.csv").read_text(encoding="utf-8").splitlines()
    return ([",".join(r.split(",")[:-3]) for r in rows],
            {n: _checks(json.loads((out / n / "report.json").read_text(encoding="utf-8"))) for n in names})


@pytest.fixture(scope="module")
def batch_folder(submissions, tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("batch") / "submissions"
    for name, root in submissions.items():
        shutil.copytree(root, folder / name)
    return folder


@pytest.fixture(scope="module")
def linux_batch(batch_folder, submissions, tmp_path_factory) -> tuple[list[str], dict]:
    return _batch("linux", batch_folder, tmp_path_factory.mktemp("linux-batch") / "out", submissions)


@pytest.mark.slow
@pytest.mark.parametrize("route", ROUTES)
def test_batch_with_two_workers_gives_linuxs_gradebook(route, submissions, batch_folder, linux_batch, tmp_path):
    """grade batch grades without bubblewrap only when told to (--no-sandbox), then exactly as on Linux."""
    refused = _run(route, "batch", str(batch_folder), "--out", str(tmp_path / "refused"), "--jobs", "2")
    assert refused.returncode == 2 and "--no-sandbox" in refused.stderr, refused.stderr[-2000:]
    assert _batch(route, batch_folder, tmp_path / "out", submissions) == linux_batch


@pytest.mark.parametrize("route", slow_but_the_first(ROUTES))
def test_a_batch_refused_for_want_of_a_barrier_says_what_this_system_offers(route, tmp_path):
    """Windows and macOS have no bubblewrap: a batch that refuses to grade without a barrier says so, and names
    grading on Linux, never a bubblewrap to install or fix there."""
    build_submission(tmp_path / "submissions" / "ann")
    refused = _run(route, "batch", str(tmp_path / "submissions"), "--out", str(tmp_path / "out"), "--chapters", "ch00")
    assert refused.returncode == 2, refused.stderr[-2000:]
    assert "this system has no bubblewrap (it exists on Linux only): grade a course on Linux" in refused.stderr
    assert "apt-get" not in refused.stderr and "bwrap --version" not in refused.stderr


def test_gradescope_says_who_learner_code_runs_as_without_uids(tmp_path):
    """Windows has no uids: the Gradescope runner neither asks for one nor grades without a barrier; it says why."""
    code = "from grader.course import gradescope\nprint(gradescope._door('barrier')[1])\n"
    done = subprocess.run(python_code("windows", code), cwd=REPO, capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr[-3000:]
    assert "no barrier stands here" in done.stdout and "no user ids" in done.stdout, done.stdout


@pytest.mark.slow
@pytest.mark.parametrize("route", ROUTES)
def test_sympy_decides_in_its_own_process_on_the_route(route):
    """What only sympy can decide (undefined at every real point) is decided in its worker process, read
    and stopped without poll or process groups on Windows; sympy never enters the grading process."""
    code = ("import sys\nfrom grader.quiz.symbolic import equivalent\n"
            "print(equivalent('sqrt(-1 - x^2)*2', '2*sqrt(-1 - x^2)', ('x',)), "
            "equivalent('sqrt(-1 - x^2)*3', '2*sqrt(-1 - x^2)', ('x',)), 'sympy' in sys.modules)")
    done = subprocess.run(python_code(route, code), cwd=REPO, capture_output=True, text=True, timeout=120)
    assert done.stdout.split() == ["True", "False", "False"], done.stderr[-3000:]


@pytest.mark.slow
def test_a_handout_built_and_installed_grades_on_each_route(tmp_path):
    """grade release as an instructor on Windows runs it, its wheel installed in a fresh virtual environment,
    and `grade` of that environment in an empty folder with the stubs, as on Windows and on macOS."""
    out = tmp_path / "handout"
    built = _run("windows", "release", str(out), "--no-classroom", timeout=600)
    assert built.returncode == 0, built.stdout[-2000:] + built.stderr[-3000:]
    venv = tmp_path / "venv"
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(venv)], check=True)
    installed = subprocess.run([sys.executable, "-m", "pip", "--python", str(venv / "bin" / "python"), "install",
                                "--quiet", "--disable-pip-version-check", str(next(out.glob("*.whl")))],
                               capture_output=True, text=True)
    assert installed.returncode == 0, installed.stderr[-3000:]
    for route in ROUTES:
        folder = tmp_path / f"learner-{route}"
        shutil.copytree(out / "exercises", folder / "exercises")
        env = environment(route, {"PATH": "/usr/bin:/bin", "HOME": str(folder), "LANG": "C.UTF-8"})
        done = subprocess.run([str(venv / "bin" / "grade"), "ch06", "--format", "json"], cwd=folder, env=env,
                              capture_output=True, text=True, timeout=300)
        report = json.loads(done.stdout)
        code = [k for c in report["chapters"] for k in c["checks"] if k["kind"] == "code"]
        assert code and all(k["status"] == "fail" and "not implemented yet" in k["message"] for k in code), route
