"""Plan every check of a chapter (its calls, chosen at the seed) and judge what came back, in this process:
the checks, the references' expected values, numpy. grader.core.grading runs the plans' calls in one child."""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path
from typing import Generator

from grader.boundary import ChapterRequest, ChapterRun
from grader.boundary.wire import NOT_IMPLEMENTED, Call, Returned
from grader.checks.base import ChapterChecks, Check, Context, Skip
from grader.judging import diagnose, expected
from grader.judging.compare import Verdict
from grader.model import ChapterResult, CheckResult, Status


@dataclass
class _Pending:
    """A started check generator waiting for the values of the calls it yielded."""

    name: str
    generator: Generator | None
    wanted: object  # the yielded structure of Calls
    slots: list[int]  # indices into the chapter's call list, in flattening order
    setup_error: str = ""  # a grader bug while planning (its trace)
    unavailable: str = ""  # the expected values cannot be had here (e.g. a handout asked for another seed)
    ctx: Context | None = None
    own: dict[int, Call] | None = None  # the calls of the check's own function, by their number in the check


def _trace() -> str:
    """The current exception's last frames (for a grader bug: where in the grader it broke)."""
    import traceback

    return traceback.format_exc(limit=-3)


def _flatten(structure: object, out: list[Call]) -> None:
    if isinstance(structure, Call):
        out.append(structure)
    elif isinstance(structure, (list, tuple)):
        for item in structure:
            _flatten(item, out)
    elif isinstance(structure, dict):
        for item in structure.values():
            _flatten(item, out)
    else:
        raise TypeError(f"a check yielded {type(structure).__name__}, not calls")


def _rebuild(structure: object, values: list[Returned]) -> object:
    """The yielded structure with every Call replaced by its Returned (consumes `values`)."""
    if isinstance(structure, Call):
        return values.pop(0)
    if isinstance(structure, list):
        return [_rebuild(s, values) for s in structure]
    if isinstance(structure, tuple):
        return tuple(_rebuild(s, values) for s in structure)
    return {k: _rebuild(s, values) for k, s in structure.items()}


def _start(name: str, body, ctx: Context, calls: list[Call], function: str = "") -> _Pending:
    """Plan one check: run it up to its yield (it asks the reference for its expected values now, and its
    calls of its own `function` are told to the backend, which may compute their generated slips)."""
    generator = body(ctx)
    try:
        with expected.planning(ctx.chapter, ctx.check_id, ctx.seed):
            wanted = next(generator)
        flat: list[Call] = []
        _flatten(wanted, flat)
        own = {i: c for i, c in enumerate(flat) if c.function == function} if function else {}
        if own:
            expected.planned(ctx.chapter, ctx.check_id, ctx.seed, list(own.items()))
    except expected.ReferenceUnavailable as exc:
        return _Pending(name, None, None, [], unavailable=str(exc))
    except Exception:
        return _Pending(name, None, None, [], setup_error=_trace())
    start = len(calls)
    calls.extend(flat)
    return _Pending(name, generator, wanted, list(range(start, start + len(flat))), ctx=ctx, own=own)


def _slips_lookup(pending: _Pending, values: list[Returned]):
    """For grader.judging.diagnose while the check judges: the generated mistakes at the call that returned a value, of
    the keys asked for (each asked of the backend once, the first time a comparison needs it)."""
    numbers = {id(v): i for i, v in enumerate(values) if i in (pending.own or {})}
    found: dict[int, dict[str, diagnose.Mistake | None]] = {}  # per call: key -> its mistake (None: says nothing)
    complete: set[int] = set()

    def lookup(returned: object, keys: set[str] | None = None) -> list[diagnose.Mistake]:
        index = numbers.get(id(returned))
        if index is None or pending.ctx is None:
            return []
        known = found.setdefault(index, {})
        missing = None if keys is None else {k for k in keys if k not in known}
        if index not in complete and (missing is None or missing):
            ctx = pending.ctx
            for s in expected.slips(ctx.chapter, ctx.check_id, ctx.seed, index, pending.own[index], missing):
                known[s["key"]] = diagnose.Mistake(s["name"], s["help"], s["value"], "generated", s["key"])
            for key in missing or ():
                known.setdefault(key, None)
            if missing is None:
                complete.add(index)
        return [m for k, m in known.items() if m is not None and (keys is None or k in keys)]
    return lookup


def _finish(pending: _Pending, run: ChapterRun) -> object:
    """Send the returned values into the check; its return value (Verdict or dict) or an exception."""
    values = [run.results[i] for i in pending.slots]
    with diagnose.judging(_slips_lookup(pending, values)):
        try:
            pending.generator.send(_rebuild(pending.wanted, values))
        except StopIteration as stop:
            if isinstance(stop.value, Verdict):
                stop.value.explain()  # a lone comparison's mistake, named while the slips can still be asked
            return stop.value
    raise RuntimeError(f"check {pending.name} yielded twice; a check may yield only once")


class ChapterPlan:
    """Every check of one chapter started, with the calls they need collected into one request."""

    def __init__(self, chapter: ChapterChecks, seed: int, plots: list | None = None,
                 exclude: frozenset[str] = frozenset()) -> None:
        self.chapter = chapter
        self.calls: list[Call] = []
        info = chapter.info
        self.checks = [c for c in chapter.checks if f"{info.id}/{c.id}" not in exclude]
        self.pending = [(check, _start(check.id, check.body, Context(seed, info.id, check.id), self.calls,
                                       check.function)) for check in self.checks]
        self.plot_pending = [(name, _start(name, body, Context(seed, info.id, f"plot/{name}"), self.calls))
                             for name, body in (plots or [])]

    def request(self) -> ChapterRequest:
        return ChapterRequest(self.chapter.info.id, self.chapter.info.module, self.calls, self.chapter.builds_on)

    def slots(self) -> dict[str, list[int]]:
        """Which of the plan's calls each check made (by their numbers in `calls`), by check id in report order."""
        return {check.id: list(pending.slots) for check, pending in self.pending}

    def reached(self, run: ChapterRun) -> dict[str, list[str]]:
        """Per check of a function with helpers (ChapterChecks.builds_on), the helpers that the calls of its own
        function made by the check entered (Returned.reached; a call the child said nothing of counts for none):
        the evidence grader.core.grading.point_upstream blames a helper on. Checks that reached none are left out."""
        found: dict[str, list[str]] = {}
        for check, pending in self.pending:
            helpers = self.chapter.builds_on.get(check.function)
            if not helpers or run.import_error is not None:
                continue
            entered = {name for i in pending.slots if (r := run.results[i]) is not None
                       and r.function == check.function and r.reached for name in r.reached}
            if entered:
                found[check.id] = [h for h in helpers if h in entered]
        return found

    def judge(self, run: ChapterRun, module_file: str) -> ChapterResult:
        info = self.chapter.info
        result = ChapterResult(info.id, info.title)
        if run.import_error is not None:
            return _not_imported(result, self.checks, run.import_error, module_file)
        for check, pending in self.pending:
            result.checks.append(_judge_one(check, pending, run))
        for name, pending in self.plot_pending:
            if pending.generator is None:
                continue
            try:
                data = _finish(pending, run)
            except Exception:  # a plot never breaks grading
                continue
            if isinstance(data, dict):
                result.plots[name] = data
        return result


def _not_imported(result: ChapterResult, checks: list[Check], import_error: dict, module_file: str) -> ChapterResult:
    """`result` for a chapter file that could not be imported (or read): its message, every check not graded."""
    result.problems.append(import_problem(import_error, module_file))
    failed = "read" if import_error.get("exception") == "NotebookError" else "imported"  # a notebook or not
    short = f"not graded: {module_file} could not be {failed} (see the chapter's message)"
    result.checks = [_result(check, Status.ERROR, 0.0, short) for check in checks]
    return result


def judge_not_imported(chapter_id: str, exclude: frozenset[str], import_error: dict, module_file: str) -> ChapterResult:
    """The chapter whose file could not be imported, as its plan judges it (ChapterPlan.judge), without planning."""
    from grader import checks as check_registry

    chapter = check_registry.load(chapter_id)
    info = chapter.info
    checks = [c for c in chapter.checks if f"{info.id}/{c.id}" not in exclude]
    return _not_imported(ChapterResult(info.id, info.title), checks, import_error, module_file)


def judge_checks(chapter_id: str, seed: int, exclude: frozenset[str], slots: dict[str, list[int]],
                 calls: dict[int, dict], results: dict[int, Returned | None],
                 module_file: str) -> tuple[list[CheckResult], dict] | None:
    """Plan and judge only the checks of `slots` (check id -> the numbers of its calls in the chapter's kept plan, in
    report order; `exclude`: every other check), with the kept calls (`calls`: number -> Call.to_json) and what the
    child answered to them (`results`, by the same numbers): (their CheckResults, the helpers each check's calls
    entered); None where the plan made now is not the kept one (the chapter is then judged whole)."""
    from grader import checks as check_registry

    plan = ChapterPlan(check_registry.load(chapter_id), seed, None, exclude)
    if [check.id for check, _ in plan.pending] != list(slots):
        return None
    answered: list[Returned | None] = [None] * len(plan.calls)
    for check, pending in plan.pending:
        own = slots[check.id]
        if len(own) != len(pending.slots):
            return None
        for mine, kept_number in zip(pending.slots, own):
            if kept_number not in calls or plan.calls[mine].to_json(kept_number) != calls[kept_number]:
                return None  # never, unless the memo is wrong
            answered[mine] = results.get(kept_number)
    part = ChapterRun(chapter_id, None, answered)
    return plan.judge(part, module_file).checks, plan.reached(part)


def _result(check: Check, status: Status, points: float, message: str, verdict: Verdict | None = None) -> CheckResult:
    return CheckResult(
        id=check.id, function=check.function, description=check.description, status=status,
        points=points, max_points=check.points, message=message,
        expected=None if verdict is None else verdict.expected,
        got=None if verdict is None else verdict.got,
        details={} if verdict is None else verdict.details,
        mistake="" if verdict is None or verdict.mistake is None else verdict.mistake.name,
        help="" if verdict is None or verdict.passed else verdict.help,
    )


def _judge_one(check: Check, pending: _Pending, run: ChapterRun) -> CheckResult:
    if pending.generator is None:
        return _result(check, Status.ERROR, 0.0, f"not graded here: {pending.unavailable}" if pending.unavailable
                       else f"grader error while preparing this check:\n{pending.setup_error}")
    try:
        verdict = _finish(pending, run)
    except Skip as skip:
        return _result(check, Status.SKIP, check.points if skip.costs_nothing else 0.0, str(skip))
    except Exception:
        return _result(check, Status.ERROR, 0.0,
                       f"grader error while judging this check:\n{_trace()}")
    if not isinstance(verdict, Verdict):
        return _result(check, Status.ERROR, 0.0, f"grader error: check returned {type(verdict).__name__}")
    status = Status.PASS if verdict.passed else Status.FAIL
    result = _result(check, status, check.points if verdict.passed else 0.0, verdict.message, verdict)
    mine = [run.results[i] for i in pending.slots if run.results[i] is not None and run.results[i].function == check.function]
    if not verdict.passed and mine and all(r.kind == NOT_IMPLEMENTED for r in mine):
        result.details["not_implemented"] = True  # the renderer folds such checks into one line per function
    return result



IMPORT_FORMS = ("an earlier chapter's file is imported in one of three forms, all graded alike: "
                "`from .ch03_jacobian import polar_to_cartesian` (relative), "
                "`from exercises.ch03_jacobian import polar_to_cartesian` or "
                "`from ch03_jacobian import polar_to_cartesian` (which also works when the file runs as a script); "
                "the module is the chapter's file name without .py or .ipynb (`grade list` names them), and the file "
                "must be in the same folder")


def import_hint(error: dict) -> str:
    """The accepted import forms, for an ImportError that an import of an earlier chapter may have caused."""
    if error.get("exception") not in ("ModuleNotFoundError", "ImportError"):
        return ""
    message = error.get("message", "")
    if re.search(r"relative import|No module named '(exercises|ch\d|solutions\.ch)|cannot import name", message) or \
            re.search(r"'ch\d\d?_?\w*'", message):
        return f"\nHow to import: {IMPORT_FORMS}."
    return ""


def import_problem(error: dict, module_file: str) -> str:
    """The learner-facing message for a chapter file that could not be imported."""
    if error.get("grader"):
        return f"{module_file} could not be graded: {error.get('message')}"
    exception = error.get("exception", "")
    if exception == "NotebookError":
        return error.get("message", "")
    line = f", line {error['line']}" if error.get("line") else ""
    if error.get("file") and Path(error["file"]) != Path(module_file):  # in an earlier chapter's file it imports
        module_file = f"{Path(error['file'])} (imported by {module_file})"
    if error.get("where"):  # a notebook: "exercises/ch06_measurement.ipynb, cell 4, line 2"
        module_file, line = error["where"], ""
    inside = ""
    if error.get("statement"):  # the top-level statement that raised (a notebook: its cell), the error elsewhere
        module_file, line, inside = error["statement"], "", f" (in {error.get('inside')})"
    if exception == "SyntaxError" or exception == "IndentationError":
        head = f"{module_file}{line}: {exception}: {error.get('message')}"
    elif exception == "ModuleNotFoundError" and "No module named" in error.get("message", "") and not error.get("traceback", "").count("File"):
        return f"{module_file} was not found ({error.get('message')})"
    elif exception in ("TimeoutError", "ProcessExit"):
        head = f"{module_file} could not be imported: {error.get('message')}"
    elif exception == "SystemExit":
        head = f"{module_file}{line} called sys.exit(){inside} while being imported; remove it (or put it under if __name__ == '__main__':)"
    else:
        head = f"{module_file}{line} raised {exception} while being imported{inside}: {error.get('message')}"
    trace = error.get("traceback", "")
    return head + (f"\n{trace}" if trace and exception not in ("TimeoutError", "ProcessExit") else "") + \
        import_hint(error)



def plots_of(chapter_id: str) -> list:
    """The plot-data gatherers of a chapter (grader/checks/plots.py), for the HTML report."""
    from grader.checks.plots import PLOTS

    return PLOTS.get(chapter_id, [])
