"""The parent side of the process boundary: send a child the calls, collect outcomes in time.

One child process serves a whole grading run: it imports numpy once, then each chapter's module
in turn. If a chapter hangs or kills its process, the parent kills the child's whole process group,
records what happened for that call or import, and starts a fresh child for what remains, so one
broken chapter never stops the others.
"""

from __future__ import annotations

import enum
import json
import signal
import time
from dataclasses import dataclass, field
from typing import Callable, Protocol

from grader.boundary.wire import (
    COMPILING,
    CRASHED,
    DONE,
    IMPORT,
    IMPORT_FAILED,
    IMPORTED,
    MAX_LINE,
    MISSING_EVENT,
    NOT_RUN,
    RAISED_EVENT,
    RETURNED,
    TIMEOUT,
    UNREAD,
    Call,
    EncodedCalls,
    Returned,
    clean_error,
    from_event,
)
from grader.submission import Prepared, Submission
from grader.system import trace


class ChildHandle(Protocol):
    """A started child process as a Session drives it (grader.boundary.spawn.SpawnedChild and PortableChild,
    grader.boundary.forkserver.ForkedChild)."""

    def send(self, request: str) -> None: ...

    def read(self, timeout: float) -> bytes: ...

    def wait(self, timeout: float) -> None: ...

    @property
    def returncode(self) -> int | None: ...

    def stop(self, output_limit: int) -> str: ...


Launcher = Callable[[], ChildHandle]  # starts a fresh child (grader.boundary.door.Boundary)

_CAPTURE_LIMIT = 64 * 1024


@dataclass
class ChapterRequest:
    chapter: str
    module: str
    calls: list[Call]
    # function -> the learner's own functions it is usually written with (grader.checks.base.ChapterChecks.builds_on):
    # the child says, for each call of such a function, which of them it entered (Returned.reached)
    helpers: dict[str, tuple[str, ...]] = field(default_factory=dict)


@dataclass
class ChapterRun:
    """What came back for one chapter: an import failure, or one Returned per call."""

    chapter: str
    import_error: dict | None = None
    results: list[Returned | None] = field(default_factory=list)


@dataclass(frozen=True)
class Limits:
    """Time and resource limits for learner code."""

    startup_seconds: float = 60.0
    import_seconds: float = 15.0  # jax or torch alone take seconds to import on a busy laptop
    call_seconds: float = 5.0
    chapter_seconds: float = 20.0
    learner_seconds: float = 60.0  # everything of one learner together (all chapters' code; the quiz gets what is left)
    data_bytes: int | None = 1 << 30  # memory one learner process writes (RLIMIT_DATA): address space reserved is free
    cpu_seconds: int | None = 60
    file_size: int | None = 16 << 20
    open_files: int | None = 256
    processes: int | None = 64  # in a sandbox: the learner's processes and threads (own user namespace)
    memory_bytes: int | None = 1 << 30  # in a sandbox: all the learner's processes together (resident)
    tmp_bytes: int = 64 << 20  # in a sandbox: the learner's own /tmp

    def rlimits(self) -> dict:
        return {"data_bytes": self.data_bytes, "cpu_seconds": self.cpu_seconds,
                "file_size": self.file_size, "open_files": self.open_files, "core": 0,
                "processes": self.processes, "memory_bytes": self.memory_bytes, "tmp_bytes": self.tmp_bytes}


MALFORMED = {"event": None}  # a result line that is not one JSON object (see _Child.events)
_RESULTS = frozenset((RETURNED, RAISED_EVENT, MISSING_EVENT))  # the lines that answer a call


_DECODER = json.JSONDecoder()


def _parse(line: bytes) -> dict:
    """One result line as the JSON object it is, else MALFORMED. A line as the child writes them (one object, no
    space around it) is decoded straight (json.loads would first guess its encoding and skip spaces); any other is
    read by json.loads, the same as ever."""
    if len(line) > MAX_LINE:
        return MALFORMED
    try:
        if line[:1] == b"{" and line[-1:] == b"}":
            text = line.decode("utf-8")
            event, end = _DECODER.raw_decode(text)
            if end != len(text):
                return MALFORMED  # an object, then more after it
        else:
            event = json.loads(line)
    except (ValueError, RecursionError):  # RecursionError: a line of 200,000 '['; UnicodeDecodeError is a ValueError
        return MALFORMED
    return event if isinstance(event, dict) else MALFORMED


class _Child:
    """One running child (a ChildHandle) and its result pipe."""

    def __init__(self, handle: ChildHandle) -> None:
        self.handle = handle
        self.buffer = bytearray()  # what came after the last whole line: grows in place, however long the line

    def send(self, request: str) -> None:
        self.handle.send(request)

    @property
    def partial(self) -> int:
        """How many bytes of a line not yet whole have come (a large value still on its way)."""
        return len(self.buffer)

    def events(self, deadline: Callable[[], float]):
        """Yield each result line, parsed, with its bytes; stop at EOF. Raises TimeoutError when the deadline passes. A
        line that is not one JSON object (malformed, too deeply nested, longer than MAX_LINE) is yielded as MALFORMED:
        the caller stops the child for it. Each byte is looked at once for a line's end, and kept once."""
        while True:
            chunk = self.handle.read(deadline() - time.monotonic())  # TimeoutError when nothing comes in time
            if not chunk:
                return
            end = chunk.rfind(b"\n")
            if end < 0:
                self.buffer += chunk
            else:
                *lines, rest = (bytes(self.buffer) + chunk[:end + 1] if self.buffer else chunk[:end + 1]).split(b"\n")
                self.buffer = bytearray(chunk[end + 1:])
                for line in lines:
                    yield _parse(line), line
            if len(self.buffer) > MAX_LINE:
                yield MALFORMED, b""
                return

    def stop(self) -> str:
        """Kill the child and everything it started; return what learner code printed (capped)."""
        return self.handle.stop(_CAPTURE_LIMIT)

    def exit_description(self, limits: Limits) -> str:
        from grader.boundary.confine import OUT_OF_MEMORY

        code = self.handle.returncode
        if code is None:
            return "it was still running"
        if code >= 0xC0000000:  # Windows: an NTSTATUS error code
            what = {0xC0000005: "a crash in native code (access violation)", 0xC00000FD: "a stack overflow",
                    0xC0000409: "an abort in native code (fail fast)", 0xC0000017: "it ran out of memory",
                    0xC000001D: "an illegal instruction in native code"}.get(code, "a crash in native code")
            return f"{what}, status {code:#010x}"
        if code < 0 or code > 128:  # killed by a signal (as the sandbox's init passes it on: 128 + signal)
            number = -code if code < 0 else code - 128
            try:
                name = signal.Signals(number).name
            except ValueError:
                return f"exit status {code}"
            what = {"SIGSEGV": "a crash in native code (segmentation fault)", "SIGABRT": "an abort in native code",
                    "SIGBUS": "a crash in native code (bus error)", "SIGFPE": "a floating-point trap in native code",
                    "SIGKILL": "killed", "SIGILL": "an illegal instruction in native code"}.get(name, "killed")
            return f"{what}, signal {name}"
        if code == OUT_OF_MEMORY and limits.memory_bytes:
            return (f"it ran out of memory: all its processes together may use at most "
                    f"{limits.memory_bytes >> 20} MiB")
        return f"exit status {code}"


class Stage(enum.Enum):
    """Where the child is in a request, as its lines have told so far."""

    STARTUP = "startup"  # no chapter begun yet (the interpreter, numpy, the learner's files)
    IMPORT = "import"  # importing a chapter's module
    CALL = "call"  # a call of a learner function in flight
    BETWEEN = "between"  # a chapter done, the next not begun


class Ending(enum.Enum):
    """How a child's run ended."""

    FINISHED = "finished"  # every call answered, DONE read
    TIMED_OUT = "timed out"  # a deadline passed
    VIOLATED = "violated"  # a line the request did not ask for: learner code wrote to the channel
    PIPE_CLOSED = "pipe closed"  # the child died


@dataclass
class Progress:
    """The protocol as a state machine: the child's lines must follow the request exactly (import, imported,
    then one result per pending call in order, ..., done). The call in flight is always the next pending
    one, so the child need not announce it. `take` records each line into the runs and says how the run
    ended, if it did; the deadlines say by when the next line is due."""

    order: list[tuple[ChapterRequest, list[int]]]  # per pending chapter, the indices of its calls still to run
    limits: Limits
    deadline: float
    stage: Stage = Stage.STARTUP
    chapter_at: int = 0  # position in `order` of the chapter being imported or called
    call_at: int = 0  # position in that chapter's calls
    chapter: str | None = None  # the chapter being imported or called (None before the first)
    index: int | None = None  # the call in flight
    function: str = ""  # the function of the call in flight
    watched: tuple[str, ...] = ()  # its helpers, which the child says the call entered or not (ChapterRequest.helpers)
    chapter_end: float = float("inf")
    compiling: tuple[str, ...] = ()  # what the chapter's module loaded that compiles on a first call (jax, torch)
    called: set[str] = field(default_factory=set)  # the chapter's functions called so far
    first_call: bool = False  # the call in flight is its function's first, with a compiling library loaded
    call_started: float = 0.0
    slowest: dict[str, float] = field(default_factory=dict)  # the longest a returned call of each function took

    @classmethod
    def of(cls, pending: list[ChapterRequest], runs: dict[str, ChapterRun], limits: Limits) -> Progress:
        order = [(r, [i for i, x in enumerate(runs[r.chapter].results) if x is None]) for r in pending]
        return cls(order, limits, deadline=time.monotonic() + limits.startup_seconds)

    def _next_call(self, now: float) -> None:
        request, calls = self.order[self.chapter_at]
        if self.call_at < len(calls):
            self.stage, self.index, self.call_started = Stage.CALL, calls[self.call_at], now
            self.function = function = request.calls[self.index].function
            self.watched = request.helpers.get(function, ()) if request.helpers else ()
            if self.compiling:
                self.first_call = function not in self.called
                self.called.add(function)
            self.deadline = now + self.call_budget
        else:  # the chapter is done; the child moves on at once
            self._next_chapter(now)

    @property
    def call_budget(self) -> float:
        """The call in flight's time: a call's, or for a first call that may compile (jax, torch) an import's."""
        return max(self.limits.call_seconds, self.limits.import_seconds) if self.first_call \
            else self.limits.call_seconds

    def timeout_note(self, function: str) -> str:
        """Why the call in flight was stopped, and what that says: a limit alone is no proof of an endless loop."""
        budget = f"stopped after {self.call_budget:g} s"
        if self.first_call:
            return (f"{budget}, the time of a first call of a {' or '.join(self.compiling)} function, which includes "
                    "compiling it; if it is only slow, compile once outside the function, or grade when the machine "
                    "is less busy")
        slowest = self.slowest.get(function)
        if slowest is not None and slowest < self.limits.call_seconds / 10:
            return (f"{budget}, while its other calls returned within {slowest:.2g} s: for these arguments it most "
                    "likely never ends (a loop whose condition never changes?)")
        return f"{budget}: it may never end for these arguments (a loop whose condition never changes), or be too slow"

    def _next_chapter(self, now: float) -> None:
        self.chapter_at, self.call_at, self.compiling, self.first_call = self.chapter_at + 1, 0, (), False
        self.called = set()
        self.stage, self.index, self.deadline = Stage.BETWEEN, None, now + self.limits.call_seconds

    def take(self, event: dict, now: float, runs: dict[str, ChapterRun], line: bytes = b"") -> Ending | None:
        """Record one line of the child's (`event`, read from `line`); FINISHED after DONE, VIOLATED for a line out of
        order, else None."""
        kind, name = event.get("event"), event.get("chapter")
        if self.stage is Stage.CALL:  # most lines: the result of the call in flight
            if kind in _RESULTS and name == self.chapter and event.get("index") == self.index:
                function = self.function
                runs[name].results[self.index] = from_event(function, event, self.watched, line)
                if now - self.call_started > self.slowest.get(function, 0.0):
                    self.slowest[function] = now - self.call_started
                self.call_at += 1
                self._next_call(now)
                return None
            return Ending.VIOLATED
        if self.stage in (Stage.STARTUP, Stage.BETWEEN):
            if kind == DONE and self.chapter_at == len(self.order):
                return Ending.FINISHED
            if kind == IMPORT and self.chapter_at < len(self.order) and name == self.order[self.chapter_at][0].chapter:
                self.stage, self.chapter, self.index = Stage.IMPORT, name, None
                self.deadline, self.chapter_end = now + self.limits.import_seconds, now + self.limits.chapter_seconds
                return None
        elif self.stage is Stage.IMPORT and name == self.chapter:
            if kind == IMPORT_FAILED:
                runs[name].import_error = clean_error(event.get("error"))
                self._next_chapter(now)
                return None
            if kind == IMPORTED:
                said = event.get("compiling")
                self.compiling = tuple(sorted(COMPILING & set(said))) if isinstance(said, list) and all(
                    isinstance(name, str) for name in said) else ()
                self._next_call(now)
                return None
        return Ending.VIOLATED


class Session:
    """Runs chapters' calls in child processes; start it early so its startup overlaps ours."""

    def __init__(self, submission: Submission, launcher: Launcher, limits: Limits = Limits(),
                 started: ChildHandle | None = None, isolation: str = "", walled: bool = False,
                 prepared: Prepared | None = None) -> None:
        """Start the first child now (or adopt `started`, one the launcher already started); fresh children come
        from `launcher`. Made by grader.boundary.door.Boundary.open_session, which chose the launcher and says
        what isolates learner code (`isolation`, the line `-v` and the batch print) and whether learner code is
        walled off from this user's files (`walled`: bubblewrap or a dropped uid); `prepared`: the submission's
        files, where the caller has read them already."""
        self.submission = submission
        self.limits = limits
        self.launcher = launcher
        self.isolation = isolation
        self.walled = walled
        self.output = ""
        self._prepared = prepared
        self._learner_end: float | None = None  # the learner's whole time budget runs out then (set by run)
        # work of the grader's own (no learner code) done once, in order, while the first child starts and
        # runs the calls: whatever does not need their results (the quiz, the output's modules)
        self.meanwhile: list[Callable[[], None]] = []
        self._child: _Child | None = _Child(started or launcher())

    @property
    def prepared(self) -> Prepared:
        """The submission's files as the child gets them, and how to speak of them (read once per session:
        every fresh child gets the same files)."""
        if self._prepared is None:
            self._prepared = self.submission.prepare()
        return self._prepared

    def close(self) -> None:
        if self._child is not None:
            self.output += self._child.stop()
            self._child = None

    @property
    def learner_end(self) -> float:
        """When this learner's whole time budget (Limits.learner_seconds) runs out (time.monotonic());
        it starts with the first run."""
        return float("inf") if self._learner_end is None else self._learner_end

    def run(self, requests: list[ChapterRequest]) -> dict[str, ChapterRun]:
        runs = {r.chapter: ChapterRun(r.chapter, results=[None] * len(r.calls)) for r in requests}
        pending = list(requests)
        if self._learner_end is None:
            self._learner_end = time.monotonic() + self.limits.learner_seconds
        try:
            while pending:
                before = _unresolved(runs)
                pending = self._run_once(pending, runs)
                if pending and _unresolved(runs) == before:  # no progress: do not loop forever
                    break
        finally:
            self.close()
        for run in runs.values():
            for i, result in enumerate(run.results):
                if result is None and run.import_error is None:
                    function = next(r for r in requests if r.chapter == run.chapter).calls[i].function
                    run.results[i] = Returned(NOT_RUN, function, note="no result came back from the process")
        return runs

    def _request(self, pending: list[ChapterRequest], runs: dict[str, ChapterRun]) -> str:
        """The request for what is still pending, as JSON text (a chapter's calls sent whole from their kept
        text, grader.boundary.wire.EncodedCalls)."""
        chapters = []
        for req in pending:
            results = runs[req.chapter].results
            if isinstance(req.calls, EncodedCalls) and all(result is None for result in results):
                calls = req.calls.text
            else:
                calls = json.dumps([c.to_json(i) for i, c in enumerate(req.calls) if results[i] is None])
            helpers = f', "helpers": {json.dumps(req.helpers)}' if req.helpers else ""
            chapters.append(f'{{"chapter": {json.dumps(req.chapter)}, "module": {json.dumps(req.module)}, '
                            f'"calls": {calls}{helpers}}}')
        head = json.dumps({"package": self.submission.package, "files": self.prepared.files,
                           "limits": self.limits.rlimits()})
        return f'{head[:-1]}, "chapters": [{", ".join(chapters)}]}}'

    def _run_once(self, pending: list[ChapterRequest], runs: dict[str, ChapterRun]) -> list[ChapterRequest]:
        """Run what is pending in one child; return what still needs a fresh child."""
        child = self._child or _Child(self.launcher())
        self._child = child
        request = self._request(pending, runs)
        work, self.meanwhile = self.meanwhile, []
        sender = None
        if not work:
            child.send(request)
        else:  # a thread writes the request (a child still starting reads it only when ready) while we work
            import threading

            sender = threading.Thread(target=child.send, args=(request,), daemon=True)
            sender.start()
            for job in work:  # the child runs on the other core meanwhile; its lines wait in the pipe
                job()
        progress = Progress.of(pending, runs, self.limits)
        ending = Ending.PIPE_CLOSED
        trace("the grader's own work done; waiting for the child's lines")
        try:
            for event, line in child.events(lambda: min(progress.deadline, progress.chapter_end, self.learner_end)):
                if progress.stage is Stage.STARTUP:
                    trace("the child's first line")
                ending = progress.take(event, time.monotonic(), runs, line)
                if ending is not None:
                    break
            else:
                ending = Ending.PIPE_CLOSED
        except TimeoutError:
            ending = Ending.TIMED_OUT
        if ending is Ending.PIPE_CLOSED:  # let the process finish dying
            child.handle.wait(2)
        trace("the child's last line")
        self.output += child.stop()
        self._child = None
        if sender is not None:
            sender.join(5)  # the child is gone: a write still under way has failed by now
        if ending is Ending.FINISHED:
            return []
        exit_text = ("it broke the grading protocol: learner code wrote to the grader's result channel"
                     if ending is Ending.VIOLATED else child.exit_description(self.limits))
        return self._recover(progress, pending, runs, ending is Ending.TIMED_OUT, exit_text, child.partial)

    def _recover(self, progress: Progress, pending: list[ChapterRequest], runs: dict[str, ChapterRun],
                 timed_out: bool, exit_text: str, partial: int = 0) -> list[ChapterRequest]:
        """Record what broke the child (`partial`: the bytes of a result that had begun to come) and return the
        requests a fresh child should still run."""
        name = progress.chapter
        if name is None:  # the child never got to learner code: nothing more can be done
            for req in pending:
                runs[req.chapter].import_error = {
                    "exception": "GraderError", "message": f"the grading process failed to start ({exit_text})",
                    "traceback": "", "line": None, "grader": True, "infrastructure": True}
            return []
        run = runs[name]
        req = next(r for r in pending if r.chapter == name)
        if time.monotonic() >= self.learner_end:
            return self._budget_spent(pending, runs)
        chapter_over = time.monotonic() >= progress.chapter_end
        if progress.stage is Stage.IMPORT:
            why = (f"importing it took longer than {self.limits.import_seconds:g} s" if timed_out
                   else f"the process ended while importing it ({exit_text})")
            run.import_error = {"exception": "TimeoutError" if timed_out else "ProcessExit",
                                "message": why, "traceback": "", "line": None}
        elif progress.stage is Stage.CALL and progress.index is not None:
            function = req.calls[progress.index].function
            if timed_out and partial:  # the call had returned: its value was still on its way
                run.results[progress.index] = Returned(UNREAD, function, note=(
                    f"only {partial / 2**20:.1f} MiB of its value had come when its {progress.call_budget:g} s ran "
                    "out; a value that large (arrays of millions of numbers) takes too long to send"))
            elif timed_out:
                note = (f"stopped when the chapter's {self.limits.chapter_seconds:g} s ran out" if chapter_over
                        else progress.timeout_note(function))
                run.results[progress.index] = Returned(TIMEOUT, function, note=note)
            else:
                run.results[progress.index] = Returned(CRASHED, function, note=exit_text)
            why = (f"the value of an earlier call of {function} could not be read back" if timed_out and partial
                   else f"an earlier call of {function} did not return")
            for i, c in enumerate(req.calls):
                if run.results[i] is None and c.function == function:
                    run.results[i] = Returned(NOT_RUN, function, note=why)
        if chapter_over or progress.stage in (Stage.IMPORT, Stage.BETWEEN):
            for i, c in enumerate(req.calls):
                if run.results[i] is None and run.import_error is None:
                    run.results[i] = Returned(TIMEOUT if timed_out else NOT_RUN, c.function,
                                              note=f"the chapter's {self.limits.chapter_seconds:g} s ran out")
        position = pending.index(req)
        return [r for r in pending[position:] if runs[r.chapter].import_error is None
                and any(x is None for x in runs[r.chapter].results)]

    def _budget_spent(self, pending: list[ChapterRequest], runs: dict[str, ChapterRun]) -> list:
        """The learner's whole time is spent: every call not yet answered, in every chapter, timed out."""
        note = f"this learner's {self.limits.learner_seconds:g} s for all chapters ran out"
        for req in pending:
            run = runs[req.chapter]
            if run.import_error is not None:
                continue
            for i, c in enumerate(req.calls):
                if run.results[i] is None:
                    run.results[i] = Returned(TIMEOUT, c.function, note=note)
        return []


def _unresolved(runs: dict[str, ChapterRun]) -> int:
    return sum(r.import_error is None and x is None for r in runs.values() for x in r.results)
