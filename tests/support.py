"""What the tests share, as a plain module (test modules never import each other): submissions built from the
references, grading a submission's code and a learner's quiz answers, the real `grade` command in a fresh
interpreter, and the hostile learners, fake bubblewrap and watcher several test files use. Fixtures built on
these are in conftest.py."""

from __future__ import annotations

import gc
import importlib.util
import json
import os
import queue
import re
import shutil
import subprocess
import sys
import textwrap
import threading
import time
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
if str(REPO) not in sys.path:
    sys.path.insert(0, str(REPO))

HAVE_JAX = importlib.util.find_spec("jax") is not None  # found, not imported: importing it takes a second
# the autograd route's tests need jax (CI installs it with the test extras)
needs_jax = pytest.mark.skipif(not HAVE_JAX and not os.environ.get("CI"),
                               reason="jax is not installed here (CI installs it with the test extras)")

# bubblewrap, unless the tests run with the sandbox turned off (GRADER_SANDBOX=off)
BWRAP = None if os.environ.get("GRADER_SANDBOX") == "off" else shutil.which("bwrap")
REAL_BWRAP = BWRAP  # the real one, behind a FakeBwrap

# the contract's "Beyond the worked examples": per chapter, the maps the lesson does not work out
BEYOND_THE_WORKED_EXAMPLES = {
    "ch02": ("planner_cost", "planner_cost_gradient"),
    "ch03": ("spherical_to_cartesian", "spherical_to_cartesian_jacobian", "volume_scale"),
    "ch04": ("lidar_to_world", "lidar_to_world_jacobian", "lidar_pose_jacobian"),
    "ch06": ("range_bearing_elevation", "H3_jacobian"),
    "ch07": ("bicycle_model", "bicycle_control_jacobian", "control_noise_covariance"),
}


# ------------------------------------------------------------------------------------------- submissions

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


def chapter_submission(root: Path, learner: str, module: str = "ch00_range_sensor", text: str | None = None) -> Path:
    """A learner's submission of one chapter (`module`: the reference's, or `text`) with that chapter's reference
    answers and learner.yaml naming `learner`: a class of these grades in a fraction of a second per learner."""
    shutil.rmtree(root, ignore_errors=True)
    package = root / "exercises"
    (package / "answers").mkdir(parents=True)
    source = re.sub(r"\bsolutions\.", "exercises.", (REPO / "solutions" / f"{module}.py").read_text())
    (package / f"{module}.py").write_text(text if text is not None else source, encoding="utf-8")
    chapter = module[:4]
    shutil.copy(REPO / "solutions" / "answers" / f"{chapter}.yaml", package / "answers" / f"{chapter}.yaml")
    (package / "answers" / "learner.yaml").write_text(f"learner: {learner}\n", encoding="utf-8")
    return root


HOSTILE_H = '''

def H_jacobian(x, y):
    print("\\x1b[2J\\x1b[H\\x1b]0;pwned\\x07\\x1b[32mall checks pass\\r")
    Fake = type("\\x1b[2J\\x1b[1;32mPASS\\x1b[0m", (Exception,), {})
    raise Fake("\\x1b[1;32m\\u2713 [2/2] all good\\x1b[0m\\r\\udcff \\x00 \\u202e\\x9b2J")
'''


def hostile_module() -> str:
    """The reference ch06 with H_jacobian replaced by one that raises and prints hostile text."""
    text = re.sub(r"\bsolutions\.", "exercises.", (REPO / "solutions" / "ch06_measurement.py").read_text())
    return text + HOSTILE_H


def first_of_each(values, group) -> list:
    """`values` as pytest params: the first of each group (`group(value)`) in the fast lane, the others marked slow
    (a family of cases alike: the fast lane runs one per chapter, `python -m pytest` all of them)."""
    seen, params = set(), []
    for value in values:
        key = group(value)
        params.append(pytest.param(value, marks=() if key not in seen else pytest.mark.slow))
        seen.add(key)
    return params


def slow_but_the_first(cases) -> list:
    """`cases` as pytest params (a tuple is one case of several arguments): the first in the fast lane, the others
    marked slow."""
    return [pytest.param(*(case if isinstance(case, tuple) else (case,)), marks=() if i == 0 else pytest.mark.slow)
            for i, case in enumerate(cases)]


def code_points(chapter_id: str) -> str:
    """A chapter's code points as the gradebook and the text report write them ("27")."""
    from grader import checks

    return f"{checks.load(chapter_id).max_score:g}"


def checks_by_id(chapter) -> dict:
    """A ChapterResult's checks by id."""
    return {c.id: c for c in chapter.checks}


# ------------------------------------------------------------------------------- grading, in this process

def unbarred():
    """A boundary for the suite's own code (the references and the submissions the tests write), in this process:
    a fresh child without a barrier, as grader.boundary.choose("off") gives a user who is not root. (As root, where
    the answers are installed, choose never starts learner code without one: tests/boundary/test_door_as_root.py.)"""
    from grader.boundary.door import Boundary, Launch
    from grader.system import process_groups

    return Boundary(Launch.SPAWN if process_groups() else Launch.PORTABLE, None, turned_off="by the test suite")


def not_root(command: list, real: bool = False) -> list:
    """`command` as someone who is not root, where the suite runs as root: the effective uid and gid 65534, which the
    grader reads as not root, while the process may still read and write every file the test made (its real uid
    stays 0, for access(); the ambient capabilities CAP_DAC_OVERRIDE and CAP_DAC_READ_SEARCH, for open()). The
    grader then decides as it does for an instructor or learner who is not root (as root it never runs learner
    code without a barrier: tests/boundary/test_door_as_root.py). `real`: the real uid and gid 65534 too, for a
    command run by a shell (which sets an effective uid that differs from the real one back to it); then access()
    finds only what others may reach. Unchanged where the suite is not root."""
    if not hasattr(os, "geteuid") or os.geteuid() != 0:
        return list(command)
    setpriv = shutil.which("setpriv")
    assert setpriv, "the suite as root needs setpriv (util-linux; .ci/run installs it)"
    caps = "+dac_override,+dac_read_search"
    ids = ["--reuid=65534", "--regid=65534", "--clear-groups"] if real else ["--euid=65534", "--egid=65534",
                                                                              "--keep-groups"]
    return [setpriv, *ids, f"--inh-caps={caps}", f"--ambient-caps={caps}", *map(str, command)]


def open_session(root: Path, package: str = "exercises", limits=None, boundary=None):
    """A session for the submission at root/package: its child from `boundary` (grader.boundary.choose's), by
    default a fresh child without a barrier (unbarred: learner code sees the test's files)."""
    from grader.boundary import Limits
    from grader.submission import Submission

    return (boundary or unbarred()).open_session(Submission(Path(root), package), limits or Limits())


def grade_code(root: Path, chapters, package: str = "exercises", *, seed: int | None = None, limits=None,
               boundary=None, with_plots: bool = False):
    """The Report of `chapters` of the submission at root/package, graded by grader.core.grading.grade in a child
    (see open_session); `seed`: the public seed unless given."""
    from grader.core.grading import DEFAULT_SEED, judge_chapters

    session = open_session(root, package, limits, boundary)
    return judge_chapters(session, list(chapters), seed=DEFAULT_SEED if seed is None else seed, with_plots=with_plots)


def grade_checks(root: Path, chapter: str, **options) -> dict:
    """One chapter of the submission at root/exercises graded (grade_code's options): its checks by id."""
    return checks_by_id(grade_code(root, [chapter], **options).chapters[0])


# ------------------------------------------------------------------------------------------------- quizzes

def write_answers(folder: Path, chapter: str, text: str | bytes) -> Path:
    """`text` (str, written as UTF-8, or bytes as they are) as folder/<chapter>.yaml; returns the folder."""
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / f"{chapter}.yaml"
    path.write_bytes(text) if isinstance(text, bytes) else path.write_text(text, encoding="utf-8")
    return folder


def grade_answers(folder: Path, chapter: str, text: str | bytes, learner: str = "alice", **options):
    """A learner's answer file for `chapter` holding `text`, in `folder`, judged by grader.quiz.grade_quiz
    (`options`: quiz_dir, deadline, only) as it shows it to them (exercises/answers/<chapter>.yaml):
    ({question id: CheckResult}, chapter-level problems)."""
    from grader.quiz import grade_quiz

    results, problems = grade_quiz(chapter, write_answers(folder, chapter, text), learner, "exercises/answers",
                                   **options)
    return {r.function: r for r in results}, problems


class Quiz:
    """The `quiz` fixture: grade answer files written under `folder` (tmp_path/exercises/answers, so a submission
    rooted at tmp_path has them too)."""

    def __init__(self, folder: Path) -> None:
        self.folder = folder

    def write(self, chapter: str, text: str | bytes) -> Path:
        return write_answers(self.folder, chapter, text)

    def __call__(self, chapter: str, text: str | bytes, learner: str = "alice", **options):
        """({question id: CheckResult}, problems) of an answer file holding `text`."""
        return grade_answers(self.folder, chapter, text, learner, **options)

    def one(self, chapter: str, question: str, answer: str, learner: str = "alice", **options):
        """The CheckResult of one answer (`question: answer`, as written), in a file that has no problem."""
        results, problems = self(chapter, f"{question}: {answer}\n", learner, **options)
        assert not problems, problems
        return results[question]


def question_of(chapter: str, qid: str):
    from grader.quiz import bank

    return next(q for q in bank.questions(chapter) if q.id == qid)


def right_value(chapter: str, question, learner: str = "alice"):
    """The key's value of `question` (a bank.Question) for `learner`'s numbers."""
    from grader.quiz import bank

    key = bank.keys(chapter)[question.id]
    return key.value_for(chapter, question.values_for(learner, chapter))


def shown(chapter: str, qid: str, canonical: str, learner: str = "alice") -> str:
    """What `learner` writes for the bank's options `canonical` ("a" or "a, c"): their own letters."""
    letter_of = {c: s for s, c in question_of(chapter, qid).lettering(learner, chapter).items()}
    return ", ".join(letter_of[c.strip()] for c in canonical.split(","))


def _right_letters() -> tuple[str, str]:
    from grader.quiz import bank

    keys = bank.keys("ch06")
    return (shown("ch06", "bearing_near_dish", keys["bearing_near_dish"].answer),
            shown("ch06", "H_facts", ", ".join(keys["H_facts"].answer)))


RIGHT_CHOICE, RIGHT_FACTS = _right_letters()  # alice's letters for ch06's right options


class CpuTime:
    """The CPU time this process spends in a `with` block (time.process_time: user and system time of all its
    threads): the work done here, which other processes on a busy machine do not lengthen as they do the
    wall-clock time. `seconds` once the block has ended."""

    def __enter__(self) -> CpuTime:
        self.seconds = None
        self._collecting = gc.isenabled()
        gc.disable()  # the block's own work, not a collection of what earlier tests left
        self._start = time.process_time()
        return self

    def __exit__(self, *exc_info) -> None:
        self.seconds = time.process_time() - self._start
        if self._collecting:
            gc.enable()


def watch_simplifiers(monkeypatch) -> list:
    """Every grader.quiz.symbolic.Simplifier that starts a sympy worker from now on (for the rest of the test), as a
    list that fills: each records whether its worker started (`started`) and, once it has ended, whether it was
    stopped without an answer (`stopped`: killed at its time limit or the learner's deadline; `out_of_time`
    says which)."""
    from grader.quiz import symbolic

    made = []
    start = symbolic.Simplifier._start

    def recorded(simplifier) -> bool:
        made.append(simplifier)
        simplifier.started = start(simplifier)
        return simplifier.started

    monkeypatch.setattr(symbolic.Simplifier, "_start", recorded)
    return made


def sympy_workers() -> list[int]:
    """Live processes of grader.quiz.symbolic.Simplifier started by this process."""
    found = []
    for entry in os.listdir("/proc"):
        try:
            with open(f"/proc/{entry}/cmdline", "rb") as handle:
                if b"grader-sympy" not in handle.read():
                    continue
            with open(f"/proc/{entry}/stat", "rb") as handle:
                state, parent = handle.read().rsplit(b")", 1)[1].split()[:2]
        except (OSError, ValueError):
            continue
        if state != b"Z" and int(parent) == os.getpid():
            found.append(int(entry))
    return found


# ----------------------------------------------------------------------------- the real command, for real

# `python -m grader` with the quiz banks and keys read from argv[1] (as a handout reads its own)
_WITH_QUIZ_DIR = ("import runpy, sys; from pathlib import Path; import grader.quiz.bank as bank; "
                  "bank.QUIZ_DIR = Path(sys.argv.pop(1)); "
                  "runpy.run_module('grader', run_name='__main__', alter_sys=True)")


def run_grade(*args, cwd: Path = REPO, env: dict | None = None, timeout: float = 600, quiz_dir: Path | None = None,
              flags=(), raw: bool = False, **options) -> subprocess.CompletedProcess:
    """The real `grade ARGS` in a fresh interpreter (`python [FLAGS] -m grader ARGS`), its output as text (as bytes
    with `raw`); with `quiz_dir`, its quiz code reads the banks and keys there. `options` go to subprocess.run;
    `timeout` only stops a hang. Without a sandbox (--no-sandbox, GRADER_SANDBOX=off) it runs as someone who is
    not root (not_root), the user such a run is for."""
    command = ["-m", "grader"] if quiz_dir is None else ["-c", _WITH_QUIZ_DIR, str(quiz_dir)]
    text = {} if raw else {"text": True, "encoding": "utf-8"}
    line = [sys.executable, *flags, *command, *map(str, args)]
    unsandboxed = "--no-sandbox" in map(str, args) or (os.environ if env is None else env).get("GRADER_SANDBOX") == "off"
    return subprocess.run(not_root(line) if unsandboxed else line, cwd=cwd, env=env,
                          timeout=timeout, check=False, capture_output=True, stdin=subprocess.DEVNULL, **text, **options)


def grade_json(*args, html: Path | None = None, **options) -> dict:
    """`grade ARGS --format json [--html HTML]` (run_grade's options), which must grade (exit 0 or 1): the
    report."""
    done = run_grade(*args, "--format", "json", *(("--html", html) if html else ()), **options)
    assert done.returncode in (0, 1), done.stderr[-3000:]
    if html:
        assert Path(html).exists(), done.stderr[-3000:]
    return json.loads(done.stdout)


def run_on_terminal(command: list[str], cwd: Path, env: dict | None = None, timeout: float = 120,
                    reply: tuple[bytes, bytes] | None = None) -> tuple[int, str]:
    """Run `command` with stdout and stderr on a pseudo-terminal; (exit status, everything it wrote). With
    `reply` (prompt, answer) its standard input is the terminal too, and the answer is typed once the prompt
    shows."""
    import pty

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


# ------------------------------------------------------------------------------------------ fake bubblewrap

FAKE = """#!/bin/sh
n=$(( $(cat {counter} 2>/dev/null || echo 0) + 1 ))
echo "$n" > {counter}
if grep -qx "$n" {failing}; then echo "bwrap: creating new namespace failed (fake failure $n)" >&2; exit 1; fi
exec {real} "$@"
"""


class FakeBwrap:
    """A bwrap that fails on the calls (1, 2, ...) in `failing` and runs the real one otherwise."""

    def __init__(self, folder: Path, failing) -> None:
        assert REAL_BWRAP, "CI must have bubblewrap (.ci/run installs it)"
        self.bin = folder / "bin"
        self.bin.mkdir(parents=True)
        self.counter, failing_file = folder / "calls", folder / "failing"
        failing_file.write_text("".join(f"{n}\n" for n in failing))
        script = folder / "bin" / "bwrap"
        script.write_text(FAKE.format(counter=self.counter, failing=failing_file, real=REAL_BWRAP))
        script.chmod(0o755)
        self.env = dict(os.environ, PATH=f"{folder / 'bin'}{os.pathsep}{os.environ.get('PATH', '')}")
        self.env.pop("GRADER_SANDBOX", None)

    @property
    def calls(self) -> int:
        return int(self.counter.read_text()) if self.counter.exists() else 0


# ------------------------------------------------------------------------------------------- Gradescope

SYSTEM_PATH = "/usr/bin:/bin:/usr/sbin:/sbin"  # Gradescope's image: the system's python3, as setup.sh finds it


def unzip_with_modes(archive: Path, target: Path) -> None:
    """Extract as `unzip` does: with each member's permission bits."""
    import zipfile

    with zipfile.ZipFile(archive) as opened:
        for info in opened.infolist():
            path = Path(opened.extract(info, target))
            mode = (info.external_attr >> 16) & 0o777
            if mode:
                path.chmod(mode)


class GradescopeLayout:
    """Gradescope's layout under a temporary base, as Gradescope builds it: the zip `grade gradescope` made
    for `course` unzipped into ROOT/source, setup.sh run there once as root with the system's python3, and
    run_autograder copied to ROOT. `grade` puts a submission and its metadata where Gradescope puts them and
    runs ROOT/run_autograder once. The base is world-readable, as /autograder is, so that learner code run as
    an unprivileged user reaches the interpreter."""

    def __init__(self, course: str, *options: str) -> None:
        if shutil.which("python3", path=SYSTEM_PATH) is None or shutil.which("setpriv", path=SYSTEM_PATH) is None:
            why = "no system python3 or setpriv, as Gradescope's image has (.ci/run installs them)"
            if os.environ.get("CI"):
                pytest.fail(why)
            pytest.skip(why)
        import tempfile

        self.base = Path(tempfile.mkdtemp(prefix="gradescope-"))
        self.base.chmod(0o755)
        (self.base / "course.yaml").write_text(course, encoding="utf-8")
        self.archive = self.base / "autograder.zip"
        built = run_grade("gradescope", self.archive, "--course", self.base / "course.yaml", *options)
        assert built.returncode == 0, built.stderr
        self.root = self.base / "autograder"
        unzip_with_modes(self.archive, self.root / "source")
        self.setup = subprocess.run(["bash", str(self.root / "source" / "setup.sh")], cwd=self.root / "source",
                                    capture_output=True, text=True, timeout=900,
                                    env={"PATH": SYSTEM_PATH, "HOME": str(self.base)})
        assert self.setup.returncode == 0, self.setup.stdout[-3000:] + self.setup.stderr[-3000:]
        shutil.copy2(self.root / "source" / "run_autograder", self.root / "run_autograder")

    def grade(self, submission, metadata: dict | None, path: str = SYSTEM_PATH,
              timeout: float = 600) -> tuple[dict, subprocess.CompletedProcess]:
        """(results.json, the run) for `submission`: a dict of file names and texts, or a function that fills
        the submission folder; no metadata file where `metadata` is None; PATH as given."""
        for name in ("submission", "results"):
            shutil.rmtree(self.root / name, ignore_errors=True)
        (self.root / "submission").mkdir()
        (self.root / "submission_metadata.json").unlink(missing_ok=True)
        if callable(submission):
            submission(self.root / "submission")
        else:
            for name, text in submission.items():
                (self.root / "submission" / name).write_text(text, encoding="utf-8")
        if metadata is not None:
            (self.root / "submission_metadata.json").write_text(json.dumps(metadata), encoding="utf-8")
        run = subprocess.run([str(self.root / "run_autograder")], cwd=self.root, capture_output=True, text=True,
                             timeout=timeout, env={"PATH": path})
        results = json.loads((self.root / "results" / "results.json").read_bytes().decode("utf-8"))
        return results, run

    def close(self) -> None:
        shutil.rmtree(self.base, ignore_errors=True)


# ------------------------------------------------------------------------------------------- grade --watch

RIGHT_H = "    return np.array([[x / r, y / r], [-y / r2, x / r2]])"
WRONG_H = "    return np.array([[x / r, y / r], [y / r2, x / r2]])"


class Watching:
    """`grade ch06 --watch` (or `command`) running, its output lines read as they come."""

    def __init__(self, root: Path, command: list[str] | None = None, env: dict | None = None) -> None:
        command = command or [sys.executable, "-m", "grader", "ch06", "--watch", "--no-quiz", "--submission", str(root)]
        self.process = subprocess.Popen(command, cwd=REPO, env=env, stdout=subprocess.PIPE,
                                        stderr=subprocess.STDOUT, text=True, encoding="utf-8")
        self.lines: queue.Queue = queue.Queue()
        self.reader = threading.Thread(target=self._read, daemon=True)
        self.reader.start()

    def _read(self) -> None:
        for line in self.process.stdout:
            self.lines.put(line.rstrip("\n"))

    def until(self, pattern: str, timeout: float = 30.0) -> list[str]:
        """Every line up to and including the first that matches `pattern`."""
        seen, end = [], time.monotonic() + timeout
        while time.monotonic() < end:
            try:
                line = self.lines.get(timeout=0.1)
            except queue.Empty:
                continue
            seen.append(line)
            if re.search(pattern, line):
                return seen
        raise AssertionError(f"no line matching {pattern!r} in {timeout} s; saw:\n" + "\n".join(seen[-30:]))

    def stop(self) -> None:
        self.process.terminate()
        self.process.wait(timeout=10)
        self.reader.join(timeout=10)
        self.process.stdout.close()


def save(path: Path, text: str) -> None:
    """Save a learner's file as their editor does."""
    path.write_text(text, encoding="utf-8")
