"""The one door: how learner code starts here is decided in `choose`, and nowhere else.

From what the system offers (grader.system: process groups, whether a process holding numpy may fork;
bubblewrap on the PATH) and what the caller asks (a sandbox required, wanted where it starts, or off; a
resident process kept between sessions), `choose` picks
- the launcher: a resident fork server (grader.boundary.forkserver; where forking is safe and the caller keeps
  the Boundary between sessions; a lean one, and one that also holds sympy for learners whose files name it), a
  fresh interpreter per session with process groups and passed descriptors (grader.boundary.spawn, POSIX), or
  the portable one (Windows: request over stdin, a job object);
- the barrier: bubblewrap (grader.boundary.sandbox) where it is installed and starts; where it does not and the
  grader is root, a dropped uid (grader.boundary.dropped: learner code as an unprivileged user that cannot read
  the references, keys or course file), proved by a probe; else none, and the isolation line says which, and why.
  Learner code never runs as root where the answers are installed: there, whatever was asked, it runs behind
  bubblewrap or as the dropped uid (with --no-sandbox: that user, without trying bubblewrap), or not at all.
Environment overrides, for tests and benchmarks: GRADER_SANDBOX=off (no sandbox), GRADER_FORK_SERVER=off (a
fresh interpreter per session even where a fork server would serve), GRADER_LAUNCHER=fork-server|spawn|portable
(force one launcher).
"""

from __future__ import annotations

import enum
import functools
import os
import shutil

from grader.boundary.session import ChildHandle, Limits, Session
from grader.boundary.spawn import start_child
from grader.system import fork_is_safe, process_groups


class SandboxMode(str, enum.Enum):
    """What a face asks of the barrier between learner code and the answers: the one vocabulary of every face and
    every option (`grade --no-sandbox`, `grade batch`, `grade classroom --sandbox`, `grade gradescope --sandbox`)."""

    AUTO = "auto"  # bubblewrap where it starts, else none (the isolation line says so): a learner's own machine
    BARRIER = "barrier"  # bubblewrap, else, as root, a dropped uid that cannot read the answers, else nothing
    REQUIRED = "required"  # bubblewrap, else nothing
    OFF = "off"  # none, as the person grading asked


SANDBOX_MODES = tuple(mode.value for mode in SandboxMode)


class Launch(enum.Enum):
    """How a session's child starts."""

    FORK_SERVER = "fork server"  # forked from a resident sandboxed interpreter that has numpy loaded
    SPAWN = "spawn"  # a fresh interpreter in a process group of its own, descriptors passed
    PORTABLE = "portable"  # a fresh interpreter, request on stdin, results on stdout (Windows)


class BoundaryUnavailable(RuntimeError):
    """Learner code cannot be run here as asked (the sandbox is required and does not start, or no child
    interpreter starts at all): the message says why. An infrastructure failure, never a grade."""


class Boundary:
    """The chosen way learner code runs here: `open_session` for each submission; `close` when done (it stops a
    resident fork server). Made by `choose`."""

    def __init__(self, launch: Launch, sandbox, turned_off: str = "", probe_failure: str = "") -> None:
        self.launch = launch
        self.sandbox = sandbox  # a grader.boundary.sandbox.Sandbox, or None
        self.turned_off = turned_off  # how the sandbox was turned off ("" when it was not)
        self.probe_failure = probe_failure  # why bubblewrap, installed, did not start here ("" when it did)
        self._servers: dict = {}  # the resident fork servers, by what they preload (grader.boundary.forkserver)

    def command_prefix(self) -> list[str] | None:
        """What a child's command line is wrapped in (bubblewrap and its allow-list), None when it is not."""
        prefix = getattr(self.sandbox, "command_prefix", None)
        return None if prefix is None else prefix()

    @property
    def sandboxed(self) -> bool:
        return self.sandbox is not None

    @property
    def why_not(self) -> str:
        """Why learner code runs without the sandbox, in a few words ("" when it has it)."""
        if self.sandbox is not None:
            return ""
        if self.turned_off:
            return f"turned off {self.turned_off}"
        return self.probe_failure or "bubblewrap is not installed"

    @property
    def isolation(self) -> str:
        """The isolation line: what holds for learner code here."""
        if self.sandbox is not None:
            return self.sandbox.describe()
        from grader.course_config import in_handout

        readable = ("this handout holds no answers" if in_handout()
                    else "answers included, wherever the references and keys are installed")
        if self.turned_off:
            return (f"isolation: no sandbox (turned off {self.turned_off}): learner code runs as you, with resource "
                    f"limits only, and can read every file you can ({readable})")
        why = (f"bubblewrap cannot start here: {self.probe_failure}" if self.probe_failure
               else _no_bubblewrap(self.launch is Launch.PORTABLE))
        return f"isolation: no sandbox ({why}); it runs as you and can read every file you can ({readable})"

    def start_child(self, preload: tuple[str, ...] = ()) -> ChildHandle:
        """A fresh child for one session (a grader.boundary.session Launcher); a forked one comes from the fork
        server that holds `preload` too."""
        if self.launch is Launch.FORK_SERVER:
            return self._fork_server(preload).start()
        return start_child(self.sandbox, portable=self.launch is Launch.PORTABLE)

    def _fork_server(self, preload: tuple[str, ...] = ()):
        if preload not in self._servers:
            from grader.boundary.forkserver import ForkServer

            self._servers[preload] = ForkServer(self.sandbox, preload)
        return self._servers[preload]

    def warm_up(self) -> None:
        """Start the resident (lean) fork server now, before the first session asks (nothing for the other
        launchers)."""
        if self.launch is Launch.FORK_SERVER and self._fork_server().process is None:
            self._fork_server().launch()

    def open_session(self, submission, limits: Limits = Limits(), started: ChildHandle | None = None) -> Session:
        """A session for `submission`: its first child starts now (or `started`, one this boundary started); a
        forked one from the server that preloads what its files name (grader.boundary.forkserver.preloads_for)."""
        launcher, prepared = self.start_child, None
        if self.launch is Launch.FORK_SERVER and started is None:
            from grader.boundary.forkserver import preloads_for

            try:
                prepared = submission.prepare()
            except Exception:  # noqa: BLE001  the session prepares it again, and meets this where it always did
                prepared = None
            else:
                launcher = functools.partial(self.start_child, preloads_for(prepared.files))
        return Session(submission, launcher, limits, started=started, isolation=self.isolation,
                       walled=self.sandboxed, prepared=prepared)

    def close(self) -> None:
        servers, self._servers = self._servers, {}
        for server in servers.values():
            server.close()


def bubblewrap_possible() -> bool:
    """Whether this system could run bubblewrap at all (Linux's namespaces): what a refusal tells to fix."""
    return process_groups() and os.path.isdir("/proc/self/ns")


def how_to_get_a_barrier() -> str:
    """What to do where no barrier stands, in the words of what this system offers."""
    if bubblewrap_possible():
        return ("fix the sandbox (bubblewrap: `apt-get install bubblewrap`, then `bwrap --version` must work, with "
                "unprivileged user namespaces allowed)")
    return ("this system has no bubblewrap (it exists on Linux only): grade a course on Linux with bubblewrap, or "
            "grade only code you trust without it")


def without_a_sandbox() -> str:
    """What --no-sandbox does here, for a refusal that names it."""
    if root_with_answers():
        return ("--no-sandbox grades without bubblewrap, learner code as the unprivileged user grader-learner (never "
                "as root) where that user can read none of the answers (the references, keys and course file "
                "readable by root only)")
    return "--no-sandbox grades without it (learner code then runs as you and can read every file you can)"


def _no_bubblewrap(portable: bool) -> str:
    if portable:
        return ("this system has no bubblewrap; learner code runs in a child process whose whole process tree is "
                "killed on a timeout (a job object, with its memory capped, where Windows offers one)")
    if os.path.isdir("/proc/self/ns"):  # Linux namespaces exist here: bubblewrap would run
        return "bubblewrap not found; apt-get install bubblewrap: learner code runs with resource limits only"
    return ("this system has no bubblewrap; learner code runs in a child process with resource limits, its process "
            "group killed on a timeout")


def choose(sandbox: str = "auto", resident: bool = False, probe: bool = False,
           turned_off: str = "with --no-sandbox", secrets: tuple[str, ...] = (), remember: bool = False) -> Boundary:
    """How learner code runs here. `sandbox`: "required" (BoundaryUnavailable where bubblewrap cannot run
    learner code), "barrier" (bubblewrap, else, as root, learner code as an unprivileged user that cannot read
    `secrets`; BoundaryUnavailable where neither holds), "auto" (bubblewrap where it starts, else none, and
    the isolation line says why) or "off"; `resident`: the caller keeps the Boundary for many sessions (a fork
    server where forking is safe); `probe`: start one interpreter the way sessions will before saying yes
    (BoundaryUnavailable if none starts at all; for "barrier" it must also fail to read every path of
    `secrets`); `turned_off`: how "off" was asked, for the isolation line; `remember`: the one-off `grade` keeps the
    sandbox's command line for the next command's launcher, and uses the one kept (grader.boundary.kept). As root
    where the answers are installed (root_with_answers), whatever `sandbox` says, learner code runs behind
    bubblewrap or as the dropped uid, proved to read none of the answers ("off": that user without trying
    bubblewrap; "required": bubblewrap only), or BoundaryUnavailable."""
    if sandbox not in SANDBOX_MODES:
        raise ValueError(f"sandbox must be one of {SANDBOX_MODES}, not {sandbox!r}")
    sandbox = SandboxMode(sandbox).value
    forced = os.environ.get("GRADER_LAUNCHER", "")
    portable = forced == "portable" or not process_groups()
    if portable:
        launch = Launch.PORTABLE
    elif forced == "fork-server" or (resident and forced != "spawn" and os.environ.get("GRADER_FORK_SERVER") != "off"
                                      and fork_is_safe()):
        launch = Launch.FORK_SERVER
    else:
        launch = Launch.SPAWN
    if os.environ.get("GRADER_SANDBOX") == "off" and sandbox != "off":
        sandbox, turned_off = "off", "by GRADER_SANDBOX=off"
    bwrap = None if portable or sandbox == "off" else shutil.which("bwrap")
    if bwrap is None:
        chosen = Boundary(launch, None, turned_off=turned_off if sandbox == "off" else "")
    else:
        from grader.boundary.sandbox import Sandbox

        chosen = Boundary(launch, Sandbox(bwrap, shutil.which("setpriv"),
                                          remember=sandbox if remember and not resident and not probe else None))
    if probe or sandbox == "barrier":  # a barrier is proved, by every process that relies on it
        from grader.boundary.sandbox import probe as try_one

        reason = try_one(chosen.sandbox, secrets=secrets if sandbox != "off" else ())  # off: no barrier, as asked
        if reason is not None and chosen.sandbox is not None and sandbox in ("auto", "barrier"):
            chosen = Boundary(launch, None, probe_failure=" ".join(reason.split())[:300])
        elif reason is not None:
            raise BoundaryUnavailable(reason)
    as_root = root_with_answers()
    if chosen.sandbox is None and (sandbox == "barrier" or as_root):
        chosen = _dropped_user(launch, chosen, (*secrets, *answer_places()))
    if chosen.sandbox is None and as_root:
        raise BoundaryUnavailable(f"{chosen.why_not}. Learner code never runs as root where the answers are "
                                  "installed: install bubblewrap, or create the user grader-learner (`useradd --system "
                                  "--no-create-home --shell /usr/sbin/nologin grader-learner`) with the references, "
                                  "keys and course file readable by root only, or grade as an unprivileged user")
    if sandbox in ("required", "barrier") and chosen.sandbox is None:
        raise BoundaryUnavailable(chosen.why_not)
    return chosen


def root_with_answers() -> bool:
    """Whether learner code started here would start as root with the answers installed (not a learner's
    handout): then it runs behind bubblewrap or as the dropped uid, whatever was asked, or not at all."""
    if not hasattr(os, "geteuid") or os.geteuid() != 0:
        return False
    from grader.course_config import in_handout

    return not in_handout()


def answer_places() -> list[str]:
    """Where this grader's answers are, wherever it is installed: the references (the solutions package) and the
    quizzes' keys (inside the grader in its wheel, beside it in the project). The probe of a dropped uid proves that
    user reads none of them."""
    import importlib.util
    from pathlib import Path

    places = []
    try:
        spec = importlib.util.find_spec("solutions")
    except (ImportError, ValueError):
        spec = None
    if spec is not None and spec.submodule_search_locations:
        places += list(spec.submodule_search_locations)
    grader_dir = Path(__file__).resolve().parents[1]
    for quizzes in (grader_dir / "quizzes", grader_dir.parent / "quizzes"):
        if (quizzes / "keys").is_dir():
            places.append(str(quizzes / "keys"))
            break
    return places


def _dropped_user(launch: Launch, without: Boundary, secrets: tuple[str, ...]) -> Boundary:
    """Learner code as an unprivileged user, where this process is root and the probe shows that user starts an
    interpreter and reads none of `secrets`; else `without`, its reason extended."""
    from grader.boundary import dropped
    from grader.boundary.sandbox import probe as try_one

    setpriv = dropped.possible()
    if setpriv is None:
        return Boundary(launch, None, probe_failure=f"{without.why_not}; and {dropped.why_impossible()}")
    user = dropped.DroppedUser(setpriv)
    user.before_run()  # a process left by an earlier run could kill the probe
    try:
        reason = try_one(user, secrets=secrets)
    finally:
        user.after_run()
    if reason is not None:
        return Boundary(launch, None, probe_failure=f"{without.why_not}; and as the unprivileged user {user.name}: "
                                                    f"{' '.join(reason.split())[:300]}")
    # never a resident fork server as that user: every process of it is killed after each run (DroppedUser.after_run)
    return Boundary(Launch.SPAWN if launch is Launch.FORK_SERVER else launch, user)


def first_child(sandbox: str) -> tuple:
    """The one-off `grade`'s child, started as `choose` decides now for mode `sandbox` (and keeps for the next
    command: grader.boundary.kept): (the command prefix it was started behind or None, the child)."""
    door = choose(sandbox, remember=True)
    return door.command_prefix(), door.start_child()


def open_session(submission, limits: Limits = Limits(), sandbox: str = "auto") -> Session:
    """A one-off session for `submission` (e.g. `grade ch06`): a fresh child, sandboxed as `sandbox` asks."""
    return choose(sandbox).open_session(submission, limits)
