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

    from grader.batch import run_batch
    from tests.support import build_submission

    base = Path(tempfile.mkdtemp(prefix=".pytest-batch-", dir=Path(__file__).resolve().parents[1]))
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


# ------------------------------------------------------------------ the lines in shared memory (grader.boundary.wire)

HANGS_ON_ITS_FOURTH_CALL = """_calls = [0]


def range_bearing(x, y):
    _calls[0] += 1
    if _calls[0] == 4:
        sum(range(10 ** 13))  # a loop in C that holds the interpreter: nothing of this process runs meanwhile
    return np.array([np.hypot(x, y), np.arctan2(y, x)])
"""


def _as_told(report) -> list[tuple]:
    """Each check's verdict and message, the seconds a timeout note quotes left out (they are measured)."""
    import re

    return [(ch.chapter, c.id, c.status, re.sub(r"within [0-9.e-]+ s", "within N s", c.message), str(c.got))
            for ch in report.chapters for c in ch.checks]


def test_a_forked_childs_lines_in_shared_memory_tell_what_its_lines_down_a_pipe_tell(server, submission_factory,
                                                                                      monkeypatch):
    """A forked child writes its lines into memory it shares with the parent, which a pipe only wakes a chapter at
    a time: the report is the one a spawned child's lines, one per call down the pipe, give. Also where a call
    hangs after three returned (the hanging call is the one timed out, the three keep their values, nothing is
    lost when the child is killed), and where the memory is too small for the lines (the rest go down the pipe)."""
    from grader.boundary import forkserver
    from tests.support import grade_code

    forked = server.start_child()
    try:
        assert forked.shared is not None  # its lines go into shared memory here (Linux has memfd_create)
    finally:
        forked.stop(0)
    limits = boundary.Limits(import_seconds=3.0, call_seconds=1.0, chapter_seconds=20.0)
    hangs = submission_factory({"ch06_measurement": replace_function("ch06_measurement", "range_bearing",
                                                                     HANGS_ON_ITS_FOURTH_CALL)})
    right = submission_factory()
    with monkeypatch.context() as env:
        env.setenv("GRADER_LAUNCHER", "spawn")
        spawned = boundary.choose("required" if BWRAP else "off")
    assert spawned.launch is boundary.Launch.SPAWN
    told = {}
    for root in (hangs, right):
        told[root] = _as_told(grade_code(root, ["ch00", "ch06"], seed=3, limits=limits, boundary=spawned))
        assert _as_told(grade_code(root, ["ch00", "ch06"], seed=3, limits=limits, boundary=server)) == told[root]
    timed_out = [c for c in told[hangs] if "did not return in time: stopped after 1 s" in c[3]]
    assert [c[1] for c in timed_out] == ["range_bearing_all_quadrants"], told[hangs]  # its 4th call, as in a pipe
    assert [c[2] for c in told[hangs] if c[1] == "range_bearing_worked_example"] == [Status.PASS]  # calls 1 to 3
    # each of its first four calls takes 0.35 s: within the second a call has, but not four of them together
    slow = submission_factory({"ch06_measurement": replace_function(
        "ch06_measurement", "range_bearing", HANGS_ON_ITS_FOURTH_CALL.replace(
            "    if _calls[0] == 4:\n        sum(range(10 ** 13))", "    if _calls[0] <= 4:\n        __import__('time').sleep(0.35)"))})
    with monkeypatch.context() as env:  # the shared memory holds a few lines only: the others come down the pipe
        env.setattr(forkserver, "SHARED_BYTES", 4096)
        small = boundary.choose("required" if BWRAP else "off", resident=True)
        try:
            for root in (right, slow, hangs):
                told_small = _as_told(grade_code(root, ["ch00", "ch06"], seed=3, limits=limits, boundary=small))
                assert told_small == (told.get(root) or _as_told(
                    grade_code(root, ["ch00", "ch06"], seed=3, limits=limits, boundary=spawned)))
                if root == slow:  # no call timed out, though the memory's last word on a call start is long past
                    assert not any("stopped after" in c[3] for c in told_small), told_small
        finally:
            small.close()


def test_a_learner_who_forges_the_shared_memory_breaks_the_protocol_of_their_own_run_only(server,
                                                                                         submission_factory):
    """Learner code can write the memory its lines go into (as it can write the pipe): a line it spoils is a line
    no child of ours writes, and the run ends there, as for a line forged down the pipe; the next run is whole."""
    forger = submission_factory({"ch06_measurement": replace_function(
        "ch06_measurement", "range_bearing", "def range_bearing(x, y):\n    import ctypes\n"
        "    for line in open('/proc/self/maps'):\n"
        "        if 'grade-results' in line:  # the shared memory: the last line written, made no JSON\n"
        "            start = int(line.split('-')[0], 16)\n"
        "            end = int.from_bytes(ctypes.string_at(start, 8), 'little')\n"
        "            ctypes.memmove(start + end - 2, b'x', 1)\n"
        "    return np.array([np.hypot(x, y), np.arctan2(y, x)])\n")})
    from tests.support import grade_code

    forged = grade_code(forger, ["ch00", "ch06"], seed=3, limits=LIMITS, boundary=server)
    told = [m for ch in forged.chapters for m in ch.problems + [c.message for c in ch.checks]]
    assert any("broke the grading protocol" in m for m in told), told
    assert forged.chapters[0].score == forged.chapters[0].max_score  # ch00, before it, as ever
    good = grade_checks(submission_factory(), "ch06", seed=3, limits=LIMITS, boundary=server)
    assert all(c.status == Status.PASS for c in good.values())
