"""Shared fixtures: the repository root on sys.path, and submissions built from real files."""

from __future__ import annotations

import importlib.util
import os
import re
import sys
import textwrap
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
if str(REPO) not in sys.path:
    sys.path.insert(0, str(REPO))

# The HTML report's figure cache (grader.render.figure_cache) is off in tests: a figure kept by one test
# would be reused by the next, and tests never touch the tester's own cache. Its tests turn it on.
os.environ["GRADER_CACHE_DIR"] = ""

HAVE_JAX = importlib.util.find_spec("jax") is not None  # found, not imported: importing it takes a second
# the autograd route's tests need jax (CI installs it with the test extras)
needs_jax = pytest.mark.skipif(not HAVE_JAX and not os.environ.get("CI"),
                               reason="jax is not installed here (CI installs it with the test extras)")

# the contract's "Beyond the worked examples": per chapter, the maps the lesson does not work out
BEYOND_THE_WORKED_EXAMPLES = {
    "ch02": ("planner_cost", "planner_cost_gradient"),
    "ch03": ("spherical_to_cartesian", "spherical_to_cartesian_jacobian", "volume_scale"),
    "ch04": ("lidar_to_world", "lidar_to_world_jacobian", "lidar_pose_jacobian"),
    "ch06": ("range_bearing_elevation", "H3_jacobian"),
    "ch07": ("bicycle_model", "bicycle_control_jacobian", "control_noise_covariance"),
}


def build_submission(root: Path, replacements: dict[str, str] | None = None) -> Path:
    """A submission at root/exercises: the reference solutions, with whole modules replaced.

    `replacements` maps a module name ('ch06_measurement') to the full source of that file.
    Imports of `solutions.` become `exercises.`, as a learner's files would have them.
    """
    package = root / "exercises"
    package.mkdir(parents=True, exist_ok=True)
    for source in sorted((REPO / "solutions").glob("*.py")):
        text = re.sub(r"\bsolutions\.", "exercises.", source.read_text())
        (package / source.name).write_text(text)
    for module, text in (replacements or {}).items():
        (package / f"{module}.py").write_text(textwrap.dedent(text))
    return root


def replace_function(module: str, function: str, new_source: str) -> str:
    """The reference module's source with one top-level function replaced by `new_source`."""
    return replace_functions(module, {function: new_source})


def replace_functions(module: str, replacements: dict[str, str]) -> str:
    """The reference module's source with top-level functions replaced: {function: its new source}."""
    text = re.sub(r"\bsolutions\.", "exercises.", (REPO / "solutions" / f"{module}.py").read_text()) + "\n#end\n"
    for function, new_source in replacements.items():
        pattern = re.compile(rf"^def {function}\(.*?(?=^\S)", re.S | re.M)
        if not pattern.search(text):
            raise KeyError(f"{function} not found in {module}")
        replacement = textwrap.dedent(new_source).strip() + "\n\n\n"
        text = pattern.sub(lambda _, replacement=replacement: replacement, text, count=1)
    return text


def run_on_terminal(command: list[str], cwd: Path, env: dict | None = None, timeout: float = 120,
                    reply: tuple[bytes, bytes] | None = None) -> tuple[int, str]:
    """Run `command` with stdout and stderr on a pseudo-terminal; (exit status, everything it wrote). With
    `reply` (prompt, answer) its standard input is the terminal too, and the answer is typed once the prompt
    shows."""
    import os
    import pty
    import subprocess

    master, slave = pty.openpty()
    proc = subprocess.Popen(command, cwd=cwd, env=env, stdout=slave, stderr=slave, stdin=slave if reply else None)
    os.close(slave)
    chunks = []
    while True:
        try:
            chunk = os.read(master, 65536)
        except OSError:  # the terminal closed: the process has ended
            break
        if not chunk:
            break
        chunks.append(chunk)
        if reply and reply[0] in b"".join(chunks):
            os.write(master, reply[1])
            reply = None
    proc.wait(timeout=timeout)
    os.close(master)
    return proc.returncode, b"".join(chunks).decode(errors="replace")


def processes_with(marker: str) -> list[str]:
    """"pid: command line" of each running process whose command line holds `marker` (a learner's strays)."""
    found = []
    for pid in os.listdir("/proc"):
        if pid.isdigit():
            try:
                command = Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace")
            except OSError:
                continue
            if marker in command:
                found.append(f"{pid}: {command}")
    return found


def code_points(chapter_id: str) -> str:
    """A chapter's code points as the gradebook and the text report write them ("27")."""
    from grader import checks

    return f"{checks.load(chapter_id).max_score:g}"


def checks_by_id(chapter) -> dict:
    """A ChapterResult's checks by id."""
    return {c.id: c for c in chapter.checks}


@pytest.fixture(scope="session")
def repo_root() -> Path:
    return REPO


@pytest.fixture
def submission_factory(tmp_path):
    """Build a submission under tmp_path from {module: source}; returns its root."""
    counter = iter(range(1000))

    def make(replacements: dict[str, str] | None = None) -> Path:
        return build_submission(tmp_path / f"sub{next(counter)}", replacements)

    return make
