"""The batch fork server (grader.boundary.forkserver): one sandboxed interpreter forks a child per learner.
Nothing of one learner's run (files, processes) reaches the next, and a learner who kills the
server ends only their own run. Real processes and, where installed, real bubblewrap."""

from __future__ import annotations

import json
import os
import shutil
import time
from pathlib import Path

import pytest

from grader import boundary
from grader.model import Status
from tests.support import BWRAP, grade_checks, processes_with, replace_function

try:
    import fcntl
except ImportError:  # not POSIX
    fcntl = None

MARKER = "271.828"  # sleep duration of the learner's background process, to find it in /proc
LIMITS = boundary.Limits(import_seconds=3.0, call_seconds=3.0, chapter_seconds=10.0)


@pytest.fixture
def server(monkeypatch):
    """A resident fork server, sandboxed where bubblewrap is installed (CI has it)."""
    if not BWRAP and os.environ.get("CI"):
        pytest.fail("CI must have bubblewrap (.ci/run installs it)")
    with monkeypatch.context() as env:  # whatever the environment says about fork servers
        env.setenv("GRADER_LAUNCHER", "fork-server")
        forks = boundary.choose("required" if BWRAP else "off", resident=True)
    assert forks.launch is boundary.Launch.FORK_SERVER, forks.launch
    yield forks
    forks.close()


def test_after_a_chunk_the_next_lines_get_a_moment_to_gather_but_never_near_a_deadline():
    """A worker reads a run's lines a few dozen times per learner, not once for every two or three of them: after a
    read that returned lines it pauses before the next. Never where the deadline is close: a line that came in
    time is never turned into a timeout by the pause."""
    from grader.boundary import forkserver

    read_fd, write_fd = os.pipe()
    child = forkserver.ForkedChild(None, -1, read_fd, -1, "", True)
    try:
        os.write(write_fd, b"1\n")
        assert child.read(5.0) == b"1\n"  # the first read: at once
        os.write(write_fd, b"2\n")
        started = time.monotonic()
        assert child.read(5.0) == b"2\n"
        assert time.monotonic() - started >= forkserver._PAUSE_SECONDS
        os.write(write_fd, b"3\n")
        assert child.read(forkserver._PAUSE_SECONDS) == b"3\n"  # the deadline as near as the pause is long
    finally:
        os.close(read_fd)
        os.close(write_fd)


@pytest.mark.skipif(not hasattr(fcntl, "F_GETPIPE_SZ"), reason="pipe sizes are Linux's")
def test_a_full_chunk_is_followed_at_once(monkeypatch):
    """Where a read filled its chunk, more lines are waiting: the next read takes them without the pause."""
    from grader.boundary import forkserver
    from grader.system import CHUNK_BYTES

    pauses: list[float] = []
    monkeypatch.setattr(forkserver.time, "sleep", pauses.append)
    read_fd, write_fd = os.pipe()
    forkserver._widen(write_fd)
    child = forkserver.ForkedChild(None, -1, read_fd, -1, "", True)
    try:
        if fcntl.fcntl(write_fd, fcntl.F_GETPIPE_SZ) < 2 * CHUNK_BYTES:
            pytest.skip("this system caps pipes below two chunks")
        os.write(write_fd, b"x" * (CHUNK_BYTES + 10) + b"\n")
        assert len(child.read(5.0)) == CHUNK_BYTES
        assert len(child.read(5.0)) == 11 and pauses == []
        os.write(write_fd, b"y\n")
        assert child.read(5.0) == b"y\n" and pauses == [forkserver._PAUSE_SECONDS]
    finally:
        os.close(read_fd)
        os.close(write_fd)


@pytest.mark.skipif(not hasattr(fcntl, "F_GETPIPE_SZ"), reason="pipe sizes are Linux's")
def test_a_runs_result_pipe_holds_its_lines_while_the_worker_pauses(server):
    """The lines a child writes while the worker pauses wait in the pipe; the child is never blocked on a full one
    (a chapter's lines can be hundreds of kB: the Monte Carlo samples)."""
    from grader.boundary import forkserver

    wanted = min(forkserver._RESULT_PIPE_BYTES, int(Path("/proc/sys/fs/pipe-max-size").read_text()))
    child = server.start_child()
    try:
        assert fcntl.fcntl(child.read_fd, fcntl.F_GETPIPE_SZ) >= wanted
    finally:
        child.stop(0)


@pytest.mark.slow
def test_background_processes_of_a_run_are_killed_before_the_next(server, submission_factory):
    spawner = submission_factory({"ch06_measurement": replace_function(
        "ch06_measurement", "H_jacobian", "def H_jacobian(x, y):\n    import subprocess, sys\n"
        f"    sleep = [sys.executable, '-c', 'import time; time.sleep({MARKER})']\n"
        "    subprocess.Popen(sleep, start_new_session=True)\n"
        "    subprocess.Popen(sleep)\n    return np.eye(2)\n")})
    spawned = grade_checks(spawner, "ch06", seed=3, limits=LIMITS, boundary=server)
    assert "entries differ" in spawned["H_worked_example"].message  # it returned: both processes started
    time.sleep(0.2)
    assert processes_with(MARKER) == []
    good = grade_checks(submission_factory(), "ch06", seed=3, limits=LIMITS, boundary=server)
    assert all(c.status == Status.PASS for c in good.values())


@pytest.mark.skipif(BWRAP is None and not os.environ.get("CI"), reason="wiping /tmp needs the sandbox's own /tmp")
def test_files_a_run_leaves_in_tmp_are_gone_for_the_next(server, submission_factory):
    leaver = submission_factory({"ch06_measurement": replace_function(
        "ch06_measurement", "H_jacobian", "def H_jacobian(x, y):\n    import os\n"
        "    os.makedirs('/tmp/left/deeper', exist_ok=True)\n    open('/tmp/left/deeper/answers.txt', 'w').write('x')\n"
        "    open('/tmp/left-behind.txt', 'w').write('x')\n    os.chmod('/tmp/left', 0o500)\n    return np.eye(2)\n")})
    grade_checks(leaver, "ch06", seed=3, limits=LIMITS, boundary=server)
    looker = submission_factory({"ch06_measurement": replace_function(
        "ch06_measurement", "range_bearing", "def range_bearing(x, y):\n    import os\n"
        "    if os.path.exists('/tmp/left-behind.txt') or os.path.exists('/tmp/left'):\n"
        "        raise RuntimeError('the last learner left files in /tmp')\n"
        "    return np.array([np.hypot(x, y), np.arctan2(y, x)])\n")})
    checks = grade_checks(looker, "ch06", seed=3, limits=LIMITS, boundary=server)
    assert checks["range_bearing_worked_example"].status == Status.PASS, checks["range_bearing_worked_example"].message


def test_learner_code_of_a_forked_run_has_the_collector_on_and_the_servers_objects_frozen(server, submission_factory):
    """The server imports with the collector off and freezes what it made before it forks; each run's child turns
    the collector on for learner code."""
    from tests.boundary.test_session import GC_STATE

    checks = grade_checks(submission_factory({"ch06_measurement": GC_STATE}), "ch06", seed=3, limits=LIMITS,
                          boundary=server)
    enabled, frozen = checks["range_bearing_worked_example"].got
    assert enabled == 1.0 and frozen > 10_000, (enabled, frozen)


def test_a_learner_who_kills_the_server_ends_only_their_own_run(server, submission_factory):
    killer = submission_factory({"ch06_measurement": replace_function(
        "ch06_measurement", "H_jacobian",
        "def H_jacobian(x, y):\n    import os, signal\n    os.kill(os.getppid(), signal.SIGKILL)\n"
        "    return np.eye(2)\n")})
    checks = grade_checks(killer, "ch06", seed=3, limits=LIMITS, boundary=server)
    h_checks = [c for c in checks.values() if c.function == "H_jacobian" and c.id != "H_raises_at_origin"]
    assert h_checks and all(c.status != Status.PASS and c.message for c in h_checks)
    good = grade_checks(submission_factory(), "ch06", seed=3, limits=LIMITS, boundary=server)
    assert all(c.status == Status.PASS for c in good.values()), [(c.id, c.message) for c in good.values()
                                                                   if c.status != Status.PASS]


@pytest.mark.slow
@pytest.mark.skipif(BWRAP is None and not os.environ.get("CI"), reason="hiding folders needs the bubblewrap sandbox")
def test_batch_hides_the_submissions_and_output_folders_wherever_they_are(tmp_path):
    """Outside /tmp (which the sandbox replaces anyway): a folder in the project itself."""
    import tempfile

    from grader.course.batch import run_batch
    from tests.support import build_submission

    base = Path(tempfile.mkdtemp(prefix=".pytest-batch-", dir=Path(__file__).resolve().parents[2]))
    base.chmod(0o755)  # readable to anyone: only the sandbox's hiding can stop the thief
    try:
        submissions, out = base / "submissions", base / "out"
        build_submission(submissions / "a_victim")
        targets = [submissions / "a_victim" / "exercises" / "ch06_measurement.py",
                   out / ".staging" / "a_victim" / "exercises" / "ch06_measurement.py"]
        build_submission(submissions / "thief", {"ch06_measurement": replace_function(
            "ch06_measurement", "H_jacobian", "def H_jacobian(x, y):\n    seen = []\n"
            f"    for path in {[str(t) for t in targets]!r}:\n        try:\n            open(path).read()\n"
            "            seen.append('read')\n        except OSError as exc:\n"
            "            seen.append(type(exc).__name__)\n    raise RuntimeError(' and '.join(seen))\n")})
        run_batch(submissions, out, chapters=["ch06"], jobs=1, seed=2, html=False)
        report = json.loads((out / "thief" / "report.json").read_text())
        check = next(c for c in report["chapters"][0]["checks"] if c["id"] == "H_worked_example")
        assert "RuntimeError: FileNotFoundError and FileNotFoundError" in check["message"], check["message"]
    finally:
        shutil.rmtree(base, ignore_errors=True)
