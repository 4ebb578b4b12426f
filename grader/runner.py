"""The parent side of the process boundary: start the child, send calls, collect outcomes in time.

One child process serves a whole grading run: it imports numpy once, then each chapter's module
in turn. If a chapter hangs or kills its process, the parent kills the child's whole process group,
records what happened for that call or import, and starts a fresh child for what remains, so one
broken chapter never stops the others.
"""

from __future__ import annotations

import functools
import json
import signal
import time
from dataclasses import dataclass, field
from typing import Callable, Protocol

from grader.spawn import CommandWrapper, start_child
from grader.submission import Prepared, Submission
from grader.wire import (
    CRASHED, DONE, IMPORT, IMPORT_FAILED, IMPORTED, MAX_LINE, MISSING_EVENT, NOT_RUN, RAISED_EVENT, RETURNED, TIMEOUT,
    Call, Returned, clean_error, from_event,
)


class ChildHandle(Protocol):
    """A started child process as the runner drives it (grader.spawn.SpawnedChild and PortableChild,
    grader.forkserver.ForkedChild)."""

    def send(self, request: dict) -> None: ...

    def read(self, timeout: float) -> bytes: ...

    def wait(self, timeout: float) -> None: ...

    @property
    def returncode(self) -> int | None: ...

    def stop(self, output_limit: int) -> str: ...


Launcher = Callable[[Submission], ChildHandle]

_CAPTURE_LIMIT = 64 * 1024


@dataclass
class ChapterRequest:
    chapter: str
    module: str
    calls: list[Call]


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


def _parse(line: bytes) -> dict:
    if len(line) > MAX_LINE:
        return MALFORMED
    try:
        event = json.loads(line)
    except (ValueError, RecursionError):  # RecursionError: a line of 200,000 '['
        return MALFORMED
    return event if isinstance(event, dict) else MALFORMED


class _Child:
    """One running child (grader.spawn.SpawnedChild or grader.forkserver.ForkedChild) and its result pipe."""

    def __init__(self, handle: ChildHandle) -> None:
        self.handle = handle
        self.buffer = b""

    def send(self, request: dict) -> None:
        self.handle.send(request)

    def events(self, deadline: Callable[[], float]):
        """Yield parsed result lines; stop at EOF. Raises TimeoutError when the deadline passes. A line that
        is not one JSON object (malformed, too deeply nested, longer than MAX_LINE) is yielded as MALFORMED:
        the caller stops the child for it."""
        while True:
            if b"\n" in self.buffer:
                *lines, self.buffer = self.buffer.split(b"\n")  # one split per chunk, not one copy per line
                for line in lines:
                    yield _parse(line)
            if len(self.buffer) > MAX_LINE:
                yield MALFORMED
                return
            chunk = self.handle.read(deadline() - time.monotonic())  # TimeoutError when nothing comes in time
            if not chunk:
                return
            self.buffer += chunk

    def stop(self) -> str:
        """Kill the child and everything it started; return what learner code printed (capped)."""
        return self.handle.stop(_CAPTURE_LIMIT)

    def exit_description(self, limits: Limits) -> str:
        from grader.confine import OUT_OF_MEMORY

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


class Session:
    """Runs chapters' calls in child processes; start it early so its startup overlaps ours."""

    def __init__(self, submission: Submission, limits: Limits = Limits(), wrap: CommandWrapper | None = None,
                 started: ChildHandle | None = None, launcher: Launcher | None = None) -> None:
        """Start the child now, or adopt one already started (`started`).

        Children come from `launcher` (e.g. grader.forkserver.ForkServer.start); by default each is a
        fresh interpreter from grader.spawn.start_child, wrapped by `wrap` (e.g. a sandbox)."""
        self.submission = submission
        self.limits = limits
        self.wrap = wrap
        self.launcher: Launcher = launcher or functools.partial(start_child, wrap=wrap)
        self.output = ""
        self._prepared: Prepared | None = None
        self._learner_end: float | None = None  # the learner's whole time budget runs out then (set by run)
        # work of the grader's own (no learner code) done once, in order, while the first child starts and
        # runs the calls: whatever does not need their results (the quiz, the output's modules)
        self.meanwhile: list[Callable[[], None]] = []
        self._child: _Child | None = _Child(started or self.launcher(submission))

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

    def _request(self, pending: list[ChapterRequest], runs: dict[str, ChapterRun]) -> dict:
        chapters = []
        for req in pending:
            calls = [c.to_json(i) for i, c in enumerate(req.calls) if runs[req.chapter].results[i] is None]
            chapters.append({"chapter": req.chapter, "module": req.module, "calls": calls})
        return {"package": self.submission.package, "files": self.prepared.files,
                "chapters": chapters, "limits": self.limits.rlimits()}

    def _run_once(self, pending: list[ChapterRequest], runs: dict[str, ChapterRun]) -> list[ChapterRequest]:
        """Run what is pending in one child; return what still needs a fresh child."""
        if self._child is None:
            self._child = _Child(self.launcher(self.submission))
        child = self._child
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
        by_name = {r.chapter: r for r in pending}
        limits = self.limits
        state = {"deadline": time.monotonic() + limits.startup_seconds, "chapter_end": float("inf"),
                 "chapter": None, "index": None, "stage": "startup"}

        def deadline() -> float:
            return min(state["deadline"], state["chapter_end"], self.learner_end)

        # The child's lines must follow the request exactly: import, imported, then one result per
        # pending call in order, ..., done. Anything else means learner code wrote to the channel
        # (it runs in the same process): the child is stopped and nothing more is read. The call in
        # flight is always the next pending one, so the child need not announce it.
        order = [(r.chapter, [i for i, x in enumerate(runs[r.chapter].results) if x is None]) for r in pending]
        position = {"chapter": 0, "call": 0}
        finished = timed_out = violated = False

        def next_call() -> int | None:
            calls = order[position["chapter"]][1]
            return calls[position["call"]] if position["call"] < len(calls) else None

        def start_next_call(now: float) -> None:
            index = next_call()
            if index is not None:
                state.update(index=index, stage="call", deadline=now + limits.call_seconds)
            else:  # the chapter is done; the child moves on at once
                position.update(chapter=position["chapter"] + 1, call=0)
                state.update(index=None, stage="between", deadline=now + limits.call_seconds)

        try:
            for event in child.events(deadline):
                kind, name, now = event.get("event"), event.get("chapter"), time.monotonic()
                stage = state["stage"]
                if stage in ("startup", "between"):
                    if kind == DONE and position["chapter"] == len(order):
                        finished = True
                        break
                    if kind == IMPORT and position["chapter"] < len(order) and name == order[position["chapter"]][0]:
                        state.update(chapter=name, index=None, stage="import", deadline=now + limits.import_seconds,
                                     chapter_end=now + limits.chapter_seconds)
                        continue
                elif stage == "import" and name == state["chapter"]:
                    if kind == IMPORT_FAILED:
                        runs[name].import_error = clean_error(event.get("error"))
                        position.update(chapter=position["chapter"] + 1, call=0)
                        state.update(stage="between", deadline=now + limits.call_seconds)
                        continue
                    if kind == IMPORTED:
                        start_next_call(now)
                        continue
                elif stage == "call" and kind in (RETURNED, RAISED_EVENT, MISSING_EVENT) and name == state["chapter"] \
                        and event.get("index") == state["index"]:
                    req = by_name[name]
                    runs[name].results[state["index"]] = from_event(req.calls[state["index"]].function, event)
                    position["call"] += 1
                    start_next_call(now)
                    continue
                violated = True
                break
        except TimeoutError:
            timed_out = True
        if not finished and not timed_out and not violated:  # the pipe closed: let the process finish dying
            child.handle.wait(2)
        self.output += child.stop()
        self._child = None
        if sender is not None:
            sender.join(5)  # the child is gone: a write still under way has failed by now
        if finished:
            return []
        exit_text = ("it broke the grading protocol: learner code wrote to the grader's result channel"
                     if violated else child.exit_description(self.limits))
        return self._recover(state, pending, runs, timed_out, exit_text)

    def _recover(self, state: dict, pending: list[ChapterRequest], runs: dict[str, ChapterRun],
                 timed_out: bool, exit_text: str) -> list[ChapterRequest]:
        """Record what broke the child and return the requests a fresh child should still run."""
        name = state["chapter"]
        if name is None:  # the child never got to learner code: nothing more can be done
            for req in pending:
                runs[req.chapter].import_error = {
                    "exception": "GraderError", "message": f"the grading process failed to start ({exit_text})",
                    "traceback": "", "line": None, "grader": True, "infrastructure": True}
            return []
        run = runs[name]
        req = next(r for r in pending if r.chapter == name)
        if time.monotonic() >= self.learner_end:
            return self._budget_spent(pending, runs, state)
        chapter_over = time.monotonic() >= state["chapter_end"]
        if state["stage"] == "import":
            why = (f"importing it took longer than {self.limits.import_seconds:g} s" if timed_out
                   else f"the process ended while importing it ({exit_text})")
            run.import_error = {"exception": "TimeoutError" if timed_out else "ProcessExit",
                                "message": why, "traceback": "", "line": None}
        elif state["stage"] == "call" and state["index"] is not None:
            function = req.calls[state["index"]].function
            if timed_out:
                note = f"stopped after {self.limits.call_seconds:g} s"
                run.results[state["index"]] = Returned(TIMEOUT, function, note=note)
            else:
                run.results[state["index"]] = Returned(CRASHED, function, note=exit_text)
            for i, c in enumerate(req.calls):
                if run.results[i] is None and c.function == function:
                    run.results[i] = Returned(NOT_RUN, function, note=f"an earlier call of {function} did not return")
        if chapter_over or state["stage"] in ("import", "between"):
            for i, c in enumerate(req.calls):
                if run.results[i] is None and run.import_error is None:
                    run.results[i] = Returned(TIMEOUT if timed_out else NOT_RUN, c.function,
                                              note=f"the chapter's {self.limits.chapter_seconds:g} s ran out")
        position = pending.index(req)
        rest = [r for r in pending[position:] if runs[r.chapter].import_error is None
                and any(x is None for x in runs[r.chapter].results)]
        return rest


    def _budget_spent(self, pending: list[ChapterRequest], runs: dict[str, ChapterRun], state: dict) -> list:
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
