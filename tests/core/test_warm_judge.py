"""The judge kept warm between one learner's runs (grader.core.warm_judge): the next run's changed checks are judged
there, numpy never imported in the command, with the verdicts the command would give; a judge that is gone, stale or
of another grader is never used; and a judge ends when its socket is no longer its own."""

from __future__ import annotations

import contextlib
import json
import os
import signal
import socket
import struct
import threading
import time
from pathlib import Path

import pytest

from tests.core.test_memo import WRONG_BEARING
from tests.support import BWRAP, WRONG_H, build_submission, replace_functions, run_grade

pytestmark = pytest.mark.skipif(BWRAP is None, reason="the memo and its judge are used only behind a wall")


def _run(root: Path, cache: Path | str, *args: str) -> tuple[dict, list[str], set[str]]:
    """(the report, the trace lines about judging, the modules the command imported) of one `grade ch06` run."""
    env = {**os.environ, "GRADER_CACHE_DIR": str(cache), "GRADER_WARM_JUDGE": "on", "GRADER_TRACE": repr(time.time())}
    done = run_grade("ch06", "--submission", root, "--format", "json", *args, env=env, flags=("-X", "importtime"))
    assert done.returncode in (0, 1), done.stderr[-3000:]
    lines = done.stderr.splitlines()
    imported = {line.rsplit("|", 1)[1].strip() for line in lines if line.startswith("import time:")}
    return json.loads(done.stdout), [line for line in lines if line.startswith("trace") and "judge" in line], imported


def _judge_pid(cache: Path, wait: float = 5.0) -> int | None:
    """The pid of the judge listening on the cache's socket (from the socket's peer; a judge forked as a command
    ended is given `wait` seconds to be listening), or None."""
    path = cache / "launch" / "judge"
    deadline = time.monotonic() + wait
    while not path.exists() and time.monotonic() < deadline:
        time.sleep(0.05)
    if not path.exists():
        return None
    with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as probe:
        try:
            probe.connect(str(path))
        except OSError:
            return None
        return struct.unpack("3i", probe.getsockopt(socket.SOL_SOCKET, socket.SO_PEERCRED, struct.calcsize("3i")))[0]


def _gone(pid: int, seconds: float = 10.0) -> bool:
    """Whether process `pid` ends within `seconds` (a zombie has ended: a test process that adopted it may never
    reap it)."""
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        try:
            os.waitpid(pid, os.WNOHANG)
        except ChildProcessError:
            pass
        try:
            with open(f"/proc/{pid}/stat", "rb") as stat:
                if stat.read().rsplit(b")", 1)[1].split()[0] == b"Z":
                    return True
        except OSError:
            return True
        time.sleep(0.1)
    return False


def _afresh(root: Path) -> dict:
    return json.loads(run_grade("ch06", "--submission", root, "--format", "json",
                                env={**os.environ, "GRADER_CACHE_DIR": ""}).stdout)


@pytest.fixture
def learner(tmp_path):
    """A learner's submission, its cache folder, and the judges its runs keep (ended after the test)."""
    root, cache = build_submission(tmp_path / "sub"), tmp_path / "cache"
    yield root, cache
    pid = _judge_pid(cache)
    if pid is not None:
        try:
            os.kill(pid, signal.SIGKILL)
        except ProcessLookupError:
            pass


def _edit(root: Path, replaced: dict[str, str]) -> None:
    (root / "exercises" / "ch06_measurement.py").write_text(replace_functions("ch06_measurement", replaced),
                                                            encoding="utf-8")


def test_the_judge_kept_warm_judges_the_next_edits_as_the_command_would_without_numpy(learner):
    """Two functions changed in turn, then a syntax error (the file cannot be imported)."""
    root, cache = learner
    _run(root, cache)  # judged here, then a judge kept warm
    first = _judge_pid(cache)
    assert first is not None
    for replaced in ({"range_bearing": WRONG_BEARING}, {"range_bearing": WRONG_BEARING,
                                                         "H_jacobian": f"def H_jacobian(x, y):\n{WRONG_H}\n"},
                     {"range_bearing": "def range_bearing(x, y):\n    return np.array([np.hypot(x, y) 0])\n"}):
        _edit(root, replaced)
        report, judged, imported = _run(root, cache)
        assert any("judged by the warm judge" in line for line in judged), judged
        assert "numpy" not in imported and "grader.checks" not in imported
        assert report == _afresh(root)
    assert _judge_pid(cache) == first  # the same judge, still warm


def test_a_judge_that_died_is_replaced_and_the_command_judges_itself_meanwhile(learner):
    root, cache = learner
    _run(root, cache)
    pid = _judge_pid(cache)
    os.kill(pid, signal.SIGKILL)
    assert _gone(pid)
    _edit(root, {"range_bearing": WRONG_BEARING})
    report, judged, imported = _run(root, cache)
    assert not any("warm judge" in line for line in judged) and "numpy" in imported
    assert report == _afresh(root)
    assert _judge_pid(cache) not in (None, pid)  # a new one kept warm


@contextlib.contextmanager
def _false_judge(cache: Path, stamp: str, replies: list[bytes]):
    """In place of the judge the first run kept: a process of the user's on the judge's socket that greets every
    command with `stamp` and answers each question with the next of `replies`; yields what it was sent."""
    os.kill(_judge_pid(cache), signal.SIGKILL)
    path = cache / "launch" / "judge"
    path.unlink()
    sent: list[str] = []
    answers = iter(replies)
    listener = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    listener.bind(str(path))
    listener.listen(1)

    def answer() -> None:
        while True:
            try:
                connection, _ = listener.accept()
            except OSError:
                return
            with connection:
                reader = connection.makefile("rb")
                sent.append(reader.readline().decode())
                connection.sendall(json.dumps({"stamp": stamp}).encode() + b"\n")
                for line in reader:
                    sent.append(line.decode())
                    connection.sendall(next(answers, b"{}\n"))

    threading.Thread(target=answer, daemon=True).start()
    try:
        yield sent
    finally:
        listener.close()


def test_a_judge_of_another_grader_is_never_asked(learner):
    root, cache = learner
    _run(root, cache)
    with _false_judge(cache, "another grader", [b'{"checks": [], "entered": {}}\n']) as sent:  # would pass all
        _edit(root, {"range_bearing": WRONG_BEARING})
        report, judged, imported = _run(root, cache)
    assert len(sent) == 1 and "stamp" in sent[0]  # greeted, never asked to judge
    assert not any("warm judge" in line for line in judged) and "numpy" in imported
    assert report == _afresh(root)


def test_a_judge_that_answers_other_checks_or_nonsense_is_not_believed(learner):
    """A judge of this grader (any process of the user can say the stamp) whose answers leave out a check, or are not
    answers: the command judges itself."""
    from grader.core.memo import grader_stamp

    root, cache = learner
    _run(root, cache)
    with _false_judge(cache, grader_stamp(), [b'{"checks": [], "entered": {}}\n', b'"not an answer"\n']) as sent:
        for replaced in ({"range_bearing": WRONG_BEARING},
                         {"range_bearing": "def range_bearing(x, y):\n    return np.array([np.hypot(x, y) 0])\n"}):
            _edit(root, replaced)
            report, judged, imported = _run(root, cache)
            assert not any("warm judge" in line for line in judged) and "numpy" in imported
            assert report == _afresh(root)
    assert len(sent) == 4  # two greetings, two questions: asked, and not believed


def test_a_judge_ends_when_its_socket_is_gone_and_none_is_kept_where_turned_off(learner):
    root, cache = learner
    _run(root, cache)
    pid = _judge_pid(cache)
    (cache / "launch" / "judge").unlink()
    assert _gone(pid)
    env = {**os.environ, "GRADER_CACHE_DIR": str(cache), "GRADER_WARM_JUDGE": "off"}
    _edit(root, {"range_bearing": WRONG_BEARING})
    assert run_grade("ch06", "--submission", root, env=env).returncode in (0, 1)
    assert _judge_pid(cache, wait=1.0) is None


_HOLD = """import os, sys, time
from grader.core import memo, warm_judge
stamp = memo.grader_stamp()
assert warm_judge.available(stamp)
if sys.argv[1] == "release":
    warm_judge.release()
print("ready", flush=True)
time.sleep(60)
"""


@pytest.mark.parametrize("releases", [True, False])
def test_a_process_that_grades_again_lets_the_judge_go_between_grades(learner, releases):
    """The judge answers one command at a time: a process that keeps running (--watch, a notebook's kernel) lets it go
    after each grade, so that a command in another terminal is answered; one that held it would make that command
    judge itself."""
    import subprocess
    import sys

    from tests.support import REPO

    root, cache = learner
    _run(root, cache)
    env = {**os.environ, "GRADER_CACHE_DIR": str(cache), "GRADER_WARM_JUDGE": "on"}
    holder = subprocess.Popen([sys.executable, "-c", _HOLD, "release" if releases else "hold"], cwd=REPO, env=env,
                              stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout.readline().strip() == "ready"
        _edit(root, {"range_bearing": WRONG_BEARING})
        report, judged, _ = _run(root, cache)
    finally:
        holder.kill()
        holder.wait()
        holder.stdout.close()
    assert any("judged by the warm judge" in line for line in judged) == releases, judged
    assert report == _afresh(root)
