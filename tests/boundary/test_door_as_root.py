"""As root where the answers are installed, learner code never runs as uid 0: whatever a command asks (--no-sandbox, or
a sandbox where bubblewrap cannot start), it runs behind bubblewrap or as the dropped uid (grader-learner), or
nothing is graded and the message says why. Each learner function here writes the uid it runs as where the test
reads it."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import pytest

from tests.support import FakeBwrap, build_submission, replace_function

pytestmark = pytest.mark.skipif(not hasattr(os, "geteuid") or os.geteuid() != 0,
                                reason="what root may do: the suite runs as root in CI")

REFUSED = "Learner code never runs as root where the answers are installed"


def telling_submission(root: Path, seen: Path) -> Path:
    """The references, but range_reading writes the uid it runs as into a file in `seen` first."""
    spy = (f"def range_reading(x, y) -> float:\n    import os, uuid\n"
           f"    with open(os.path.join({str(seen)!r}, uuid.uuid4().hex), 'w') as f:\n"
           f"        f.write(str(os.getuid()))\n"
           f"    return float((x * x + y * y) ** 0.5)\n")
    return build_submission(root, {"ch00_range_sensor": replace_function("ch00_range_sensor", "range_reading", spy)})


def grade(env: dict, *args, cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "grader", *map(str, args)], env=env, cwd=cwd, capture_output=True,
                          text=True, encoding="utf-8", timeout=600, check=False)


@pytest.fixture
def seen():
    """A folder any user may write into (learner code as grader-learner too), outside the test's own."""
    folder = Path(tempfile.mkdtemp(prefix="uids-"))
    folder.chmod(0o1777)
    yield folder
    shutil.rmtree(folder, ignore_errors=True)


def uids(folder: Path) -> list[str]:
    return sorted(path.read_text() for path in folder.iterdir())


@pytest.mark.slow
@pytest.mark.parametrize("ask", [("--no-sandbox",), ()], ids=["--no-sandbox", "the sandbox, which cannot start"])
@pytest.mark.parametrize("command", ["grade ch00", "grade batch", "grade regrade"])
def test_no_command_runs_learner_code_as_root(tmp_path, seen, command, ask):
    """With bubblewrap failing on every start (a container without user namespaces), each command either grades with
    learner code as grader-learner (never uid 0) or grades nobody and says why (the one-off `grade` tries bubblewrap
    and reports that its child did not start); the uid learner code ran as is read from what it wrote."""
    broken = FakeBwrap(tmp_path / "bwrap", failing=range(1, 100000))
    submissions = tmp_path / "submissions"
    telling_submission(submissions / "ann", seen)
    if command == "grade ch00":
        done = grade(broken.env, "ch00", "--no-quiz", *ask, "--submission", submissions / "ann", cwd=tmp_path)
    elif command == "grade batch":
        done = grade(broken.env, "batch", submissions, "--out", tmp_path / "out", "--chapters", "ch00", "--no-html",
                     *ask, cwd=tmp_path)
    else:
        env = {**os.environ}
        env.pop("GRADER_SANDBOX", None)
        first = grade(env, "batch", submissions, "--out", tmp_path / "out", "--chapters", "ch00", "--no-html",
                      cwd=tmp_path)
        assert first.returncode == 0, first.stderr[-2000:]
        for path in seen.iterdir():
            path.unlink()
        done = grade(broken.env, "regrade", tmp_path / "out", *ask, cwd=tmp_path)
    said = done.stdout + done.stderr
    assert "0" not in uids(seen), said[-3000:]
    if uids(seen):  # graded as the dropped uid: the isolation line says so
        assert "learner code runs as the unprivileged user grader-learner" in said and "never as root" in said
        return
    assert done.returncode != 0, said[-3000:]
    if ask:  # --no-sandbox as root: the dropped uid or nothing, never uid 0
        assert REFUSED in said, said[-3000:]
    elif command == "grade ch00":  # the one-off grade starts its child behind bubblewrap without a probe: it fails
        assert "could not be graded: the grading process failed to start" in said, said[-3000:]
    else:  # a batch requires bubblewrap; as root --no-sandbox would grade as grader-learner, and says so
        assert done.returncode == 2 and "no learner was graded" in said, said[-3000:]
        if command == "grade batch":
            assert "--no-sandbox grades without bubblewrap, learner code as the unprivileged user grader-learner" in said


def test_the_door_never_chooses_root_for_learner_code(monkeypatch):
    """grader.boundary.choose as root where the answers are installed, bubblewrap absent: "off" and "auto" each give
    the dropped uid or BoundaryUnavailable naming the rule; "required" and "barrier" never a boundary without one."""
    from grader.boundary import BoundaryUnavailable, choose
    from grader.boundary.dropped import DroppedUser

    monkeypatch.setenv("PATH", "/nonexistent")
    for mode in ("off", "auto", "required", "barrier"):
        try:
            boundary = choose(mode)
        except BoundaryUnavailable as exc:
            assert mode in ("required", "barrier") or REFUSED in str(exc), (mode, str(exc))
        else:
            assert isinstance(boundary.sandbox, DroppedUser), mode
