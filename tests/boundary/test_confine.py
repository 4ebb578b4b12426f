"""One learner can never cost another a mark (grader.boundary.confine, grader.boundary.session): each learner's
run has its own user, mount, IPC and PID namespaces, a fresh /tmp, a cap on its processes and on the memory of all
of them together, and one time budget; nothing it leaves (a process, a file, a SysV message queue or
shared-memory segment, a key in the user's keyring) reaches the next learner on the same fork server
or a later, separate run. A malformed result line is a protocol violation, never an exception.
Real processes, real bubblewrap (CI has it)."""

from __future__ import annotations

import json
import os
import resource
import sys
import time
from pathlib import Path

import pytest

from grader import boundary
from grader.boundary import Limits
from grader.boundary.wire import MAX_LINE, clean_error
from tests.support import (
    BWRAP,
    REPO,
    build_submission,
    grade_checks,
    grade_code,
    processes_with,
    replace_function,
    run_grade,
)

pytestmark = pytest.mark.skipif(BWRAP is None and not os.environ.get("CI"),
                                reason="per-learner containment is the bubblewrap sandbox's")
MARKER = "161.803"  # in the command line of every process a hostile learner leaves, to find strays
QUEUE_KEY, SEGMENT_KEY = 0x5EED01, 0x5EED02

# Learner A leaves one of everything; learner B looks for each and says what it found.
LEAVES = """
def H_jacobian(x, y):
    import ctypes, os, platform, sys
    libc = ctypes.CDLL(None, use_errno=True)
    assert libc.msgget(QUEUE_KEY, 0o1666) >= 0, 'no message queue'
    assert libc.shmget(SEGMENT_KEY, 64 << 20, 0o1666) >= 0, 'no shared memory'
    add_key = {'x86_64': 248, 'aarch64': 217}[platform.machine()]
    assert libc.syscall(add_key, b'user', b'left-by-a', b'secret', 6, -4) > 0, 'no key'
    os.chdir('/tmp')
    for _ in range(60):  # a path far longer than PATH_MAX
        os.mkdir('d' * 100)
        os.chdir('d' * 100)
    open('left.txt', 'w').write('x')
    open('/dev/shm/left', 'w').write('x')
    return np.eye(2)
""".replace("QUEUE_KEY", str(QUEUE_KEY)).replace("SEGMENT_KEY", str(SEGMENT_KEY))

LOOKS = """
def H_jacobian(x, y):
    import ctypes, os, platform
    libc = ctypes.CDLL(None, use_errno=True)
    keyctl = {'x86_64': 250, 'aarch64': 219}[platform.machine()]
    found = []
    if libc.msgget(QUEUE_KEY, 0) >= 0:
        found.append('message queue')
    if libc.shmget(SEGMENT_KEY, 0, 0) >= 0:
        found.append('shared memory')
    if libc.syscall(keyctl, 10, -4, b'user', b'left-by-a', 0) > 0:
        found.append('key')
    found += [f'/tmp/{name}' for name in os.listdir('/tmp') if name.startswith('d')]
    found += [f'/dev/shm/{name}' for name in os.listdir('/dev/shm')]
    raise ValueError('found ' + repr(found))
""".replace("QUEUE_KEY", str(QUEUE_KEY)).replace("SEGMENT_KEY", str(SEGMENT_KEY))


def _h(tmp_path: Path, name: str, source: str) -> Path:
    return build_submission(tmp_path / name, {"ch06_measurement": replace_function("ch06_measurement", "H_jacobian",
                                                                                    source)})


def _fork_server(monkeypatch):
    """A resident sandboxed fork server: every learner graded by it is forked from one interpreter."""
    with monkeypatch.context() as env:  # whatever the environment says about fork servers
        env.setenv("GRADER_LAUNCHER", "fork-server")
        server = boundary.choose("required", resident=True)
    assert server.launch is boundary.Launch.FORK_SERVER, server.launch
    return server


def _host_ipc_keys() -> set[int]:
    keys = set()
    for table in ("msg", "shm"):
        try:
            rows = Path(f"/proc/sysvipc/{table}").read_text().splitlines()[1:]
        except OSError:
            continue
        keys |= {int(row.split()[0]) for row in rows if row.split()}
    return keys


def test_nothing_a_learner_leaves_reaches_the_next_learner_or_a_later_run(tmp_path, monkeypatch):
    server = _fork_server(monkeypatch)
    try:
        left = grade_checks(_h(tmp_path, "a", LEAVES), "ch06", seed=3, boundary=server)
        assert "entries differ" in left["H_worked_example"].message, left["H_worked_example"].message  # all made
        after = grade_checks(_h(tmp_path, "b", LOOKS), "ch06", seed=3, boundary=server)
    finally:
        server.close()
    assert "found []" in after["H_worked_example"].message, after["H_worked_example"].message
    later = run_grade("ch06", "--no-quiz", "--format", "json", "--submission", _h(tmp_path, "c", LOOKS))
    message = next(c["message"] for c in json.loads(later.stdout)["chapters"][0]["checks"]
                   if c["id"] == "H_worked_example")
    assert "found []" in message, message
    assert not {QUEUE_KEY, SEGMENT_KEY} & _host_ipc_keys()  # gone with the learner's IPC namespace


def test_replacing_one_fork_server_leaves_the_workers_other_server_running(tmp_path, monkeypatch):
    """A worker keeps a lean fork server and one that holds sympy (grader.boundary.forkserver.preloads_for). Closing
    one (it died, or did not answer, and is replaced) clears the worker's orphans: the other server is no orphan,
    and its next learner is still forked from it, not from a server started afresh."""
    server = _fork_server(monkeypatch)
    try:
        grade_checks(_h(tmp_path, "plain", "def H_jacobian(x, y):\n    return np.eye(2)\n"), "ch06", seed=3,
                     boundary=server)
        lean = server._fork_server()
        with_sympy = server._fork_server(("sympy",))
        with_sympy.launch()
        lean_pid = lean.process.pid
        with_sympy.close()
        state = Path(f"/proc/{lean_pid}/stat").read_text().rsplit(")", 1)[1].split()[0]  # gone: FileNotFoundError
        assert state != "Z", "the lean server was killed with the other"
        grade_checks(_h(tmp_path, "again", "def H_jacobian(x, y):\n    return np.eye(2)\n"), "ch06", seed=3,
                     boundary=server)
        assert lean.process is not None and lean.process.pid == lean_pid
    finally:
        server.close()


MEMORY_HOG = f"""
def H_jacobian(x, y):
    import subprocess, sys, time
    grab = 'import numpy, time; block = numpy.ones(300 << 17); time.sleep({MARKER})'  # 300 MiB each
    for _ in range(3):
        subprocess.Popen([sys.executable, '-c', grab])
    block = np.ones(300 << 17)
    time.sleep(10)
    return np.eye(2)
"""


@pytest.mark.slow
def test_the_memory_of_all_of_a_learners_processes_together_is_capped(tmp_path, monkeypatch):
    limits = Limits(memory_bytes=512 << 20, call_seconds=8.0)
    server = _fork_server(monkeypatch)
    try:
        hog = grade_checks(_h(tmp_path, "hog", MEMORY_HOG), "ch06", seed=3, limits=limits, boundary=server)
        good = grade_checks(build_submission(tmp_path / "good"), "ch06", seed=3, limits=limits, boundary=server)
    finally:
        server.close()
    message = hog["H_worked_example"].message
    assert "ran out of memory: all its processes together may use at most 512 MiB" in message, message
    assert "did not return in time" not in message  # stopped when it crossed the cap, not when its time ran out
    assert all(c.status.value == "pass" for c in good.values())
    time.sleep(0.2)
    assert processes_with(MARKER) == []


# at import: takes every process slot it can, and any that comes free, for 4 s
PROCESS_HOG = f"""import os, time
HELD, _end = 0, time.monotonic() + 4
while time.monotonic() < _end:
    try:
        _pid = os.fork()
    except OSError:
        time.sleep(0.005)
        continue
    if _pid == 0:
        time.sleep({MARKER})
        os._exit(0)
    HELD += 1


def range_bearing(x, y):
    raise ValueError(f'held {{HELD}} processes')
"""


@pytest.mark.slow
def test_a_learner_holding_every_process_slot_costs_no_one_else(tmp_path):
    """`ulimit -u 300` stands in for the machine's limit; 40 learners are graded in the other worker while
    the hog holds what it can. Its own cap (64 processes) leaves the rest to them."""
    submissions = tmp_path / "submissions"
    submissions.mkdir()
    build_submission(submissions / "hog", {"ch06_measurement": PROCESS_HOG})
    for n in range(40):
        build_submission(submissions / f"innocent{n:02d}")
    done = run_grade("batch", submissions, "--out", tmp_path / "out", "--chapters", "ch06", "--jobs", "2", "--no-html",
                     preexec_fn=lambda: resource.setrlimit(resource.RLIMIT_NPROC, (300, 300)))
    assert done.returncode in (0, 1), done.stderr
    for n in range(40):
        report = json.loads((tmp_path / "out" / f"innocent{n:02d}" / "report.json").read_text(encoding="utf-8"))
        chapter = report["chapters"][0]
        assert chapter["code_score"] == chapter["code_max_score"], (n, chapter["problems"])
    hog = json.loads((tmp_path / "out" / "hog" / "report.json").read_text(encoding="utf-8"))
    message = next(c["message"] for c in hog["chapters"][0]["checks"] if c["id"] == "range_bearing_worked_example")
    held = int(message.split("held ")[1].split()[0])
    assert 30 <= held < 64, message  # it got its own processes, up to its cap, never more
    time.sleep(0.2)
    assert processes_with(MARKER) == []


@pytest.mark.slow
def test_one_time_budget_for_all_of_a_learners_chapters(tmp_path):
    functions = {"ch03_jacobian": ["polar_to_cartesian", "polar_to_cartesian_jacobian", "area_scale"],
                 "ch06_measurement": ["range_bearing", "H_jacobian", "measurement_covariance"],
                 "ch07_dynamics": ["motion_model", "F_jacobian", "propagate_covariance"]}
    hanging = {module: "import time\ntime.sleep(1.5)\n\n" + "".join(
        f"def {name}(*args, **kwargs):\n    while True:\n        pass\n\n" for name in names)
        for module, names in functions.items()}
    limits = Limits(learner_seconds=6.0, import_seconds=3.0, call_seconds=2.0, chapter_seconds=20.0)
    report = grade_code(build_submission(tmp_path / "slow", hanging), ["ch03", "ch06", "ch07"], seed=3, limits=limits)
    messages = {ch.chapter: [c.message for c in ch.checks] for ch in report.chapters}
    # ch03's import (1.5 s) and first call (stopped after 2 s), then ch06's import: ch06's first call cannot reach its
    # own 2 s before the learner's 6 s run out, and ch07 is never called: the budget, not the call limits, stops them
    # (without it: three imports and three hung calls of 2 s, and more), however busy the machine
    stopped = [m for chapter in messages.values() for m in chapter if "stopped after 2 s" in m]
    assert len(stopped) == 1 and any("stopped after 2 s" in m for m in messages["ch03"]), messages
    assert any("6 s for all chapters ran out" in m for m in messages["ch06"]), messages["ch06"]
    assert messages["ch07"] and all("6 s for all chapters ran out" in m for m in messages["ch07"]), messages["ch07"]
    assert all(c.status.value != "pass" for ch in report.chapters for c in ch.checks)


def test_a_malformed_or_forged_result_line_is_a_protocol_violation_not_an_exception(tmp_path):
    nested = ("import os\nfor fd in range(3, 64):\n    try:\n        os.write(fd, b'[' * 200000 + b'\\n')\n"
              "    except OSError:\n        pass\n")
    forged = ("import os, json\nline = json.dumps({'event': 'import-failed', 'chapter': 'ch06', 'error': "
              "{'exception': 7, 'message': 5, 'line': 'x', 'traceback': ['no']}}).encode() + b'\\n'\n"
              "for fd in range(3, 64):\n    try:\n        os.write(fd, line)\n    except OSError:\n        pass\n")
    for name, module in (("nested", nested), ("forged", forged)):
        root = build_submission(tmp_path / name, {"ch06_measurement": (REPO / "solutions" / "ch06_measurement.py")
                                                  .read_text(encoding="utf-8") + "\n" + module})
        report = grade_code(root, ["ch03", "ch06", "ch07"], seed=3)
        by_chapter = {c.chapter: c for c in report.chapters}
        assert by_chapter["ch03"].score == by_chapter["ch03"].max_score, name  # the rest is graded normally
        assert by_chapter["ch07"].score == by_chapter["ch07"].max_score, name
        ch06 = by_chapter["ch06"]
        assert ch06.score == 0 and ch06.problems, (name, ch06.problems)
        if name == "nested":
            assert "broke the grading protocol" in ch06.problems[0], ch06.problems


def test_result_lines_are_read_without_trusting_their_types():
    from grader.boundary.session import MALFORMED, _parse

    assert _parse(b"[" * 200_000) is MALFORMED and _parse(b"3") is MALFORMED
    assert _parse(b"x" * (MAX_LINE + 1)) is MALFORMED
    assert clean_error({"exception": 7, "message": 5, "line": True, "traceback": ["x"], "bases": [1, "A"],
                        "file": ["x"]}) == {"exception": "", "message": "", "traceback": "", "line": None, "file": None,
                                            "not_implemented": False, "bases": ["A"]}


def test_a_child_that_cannot_start_is_an_infrastructure_failure_never_a_grade(tmp_path):
    from grader.boundary.sandbox import Sandbox
    from grader.boundary.session import Session
    from grader.boundary.spawn import start_child
    from grader.core.grading import judge_chapters
    from grader.submission import Submission

    class Broken(Sandbox):
        def __call__(self, command):
            return [sys.executable, "-c", "raise SystemExit(3)"]

    broken = Broken(BWRAP)
    session = Session(Submission(build_submission(tmp_path / "any"), "exercises"), lambda: start_child(broken))
    report = judge_chapters(session, ["ch06"])
    assert "failed to start" in report.infrastructure
    assert all(c.status.value == "error" for c in report.chapters[0].checks)


def test_the_isolation_line_says_which_guarantees_hold_here():
    from grader.boundary.sandbox import user_namespaces

    line = boundary.choose("required").isolation
    assert "an allow-list" in line
    if user_namespaces():
        assert "each learner in namespaces of its own" in line and "at most 64 processes and 1024 MiB" in line
    else:
        assert "allows no user namespaces" in line
