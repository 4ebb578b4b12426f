"""Grade chapters: plan every check's calls (grader.core.planning), run them in one child session, judge in this
process; with a memo (grader.core.memo), a chapter whose child answered exactly as in a kept run is not planned or
judged again, and neither the checks nor numpy are imported for it."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import TYPE_CHECKING

from grader.boundary import ChapterRequest, ChapterRun, Session
from grader.chapters import BY_ID
from grader.course_config import PUBLIC_SEED
from grader.model import ChapterResult, CheckResult, Report, Status
from grader.notebook import KERNEL, relocate
from grader.system import trace

if TYPE_CHECKING:
    from grader.boundary.wire import Returned
    from grader.core.memo import Memo
    from grader.core.planning import ChapterPlan

DEFAULT_SEED = PUBLIC_SEED


def _relocate(run: ChapterRun, sources: dict) -> None:
    """An import error names the chapter file's top-level statement that raised and where the error happened, when
    that is elsewhere; errors of modules made from notebook cells say "cell N, line M" (grader.notebook.relocate)."""
    relocate(run.import_error, sources)
    if not sources:
        return
    for returned in run.results:
        if returned is not None:
            relocate(returned.error, sources)


def point_upstream(report: Report, builds_on: dict[str, dict], reached: dict[str, dict]) -> None:
    """Blame once: a failing check of a function whose calls in that check entered the learner's own helper (of this
    chapter or an earlier one graded in the same report) says first that the helper fails its checks. `builds_on`:
    per chapter, each function's helpers (grader.checks.base.ChapterChecks.builds_on); `reached`: per chapter, per
    check, the helpers its calls of its function entered (grader.core.planning.ChapterPlan.reached, as the child
    saw them run). A helper no call was seen to enter (a function that does not use it, a call that timed out) is
    not blamed, however it fails."""
    failing = {c.function for ch in report.chapters for c in ch.checks if c.kind == "code" and c.status == Status.FAIL}
    for chapter in report.chapters:
        uses = builds_on.get(chapter.chapter, {})
        entered = reached.get(chapter.chapter, {})
        for check in chapter.checks:
            if check.status != Status.FAIL or check.kind != "code":
                continue
            seen = entered.get(check.id, ())
            helpers = [h for h in uses.get(check.function, ()) if h in failing and h != check.function and h in seen]
            if helpers:
                check.upstream = helpers
                named = " and ".join(helpers)
                check.message = (f"{check.function} calls your {named}, which "
                                 f"{'fails its' if len(helpers) == 1 else 'fail their'} own checks: fix "
                                 f"{'it' if len(helpers) == 1 else 'them'} first.\n{check.message}")


def _plan(chapter_id: str, seed: int, with_plots: bool, exclude: frozenset[str]) -> ChapterPlan:
    from grader import checks as check_registry
    from grader.core.planning import ChapterPlan, plots_of

    return ChapterPlan(check_registry.load(chapter_id), seed, plots_of(chapter_id) if with_plots else None, exclude)


def _answer(returned: Returned | None) -> list | None:
    """Everything the child answered for one call, as plain data (a memo key's part): its value by the hash of the
    line it came in (the value itself where that is not known), with the helpers the call entered, which decide
    where a failure is blamed (point_upstream)."""
    r = returned
    return None if r is None else [r.kind, r.function, r.line_hash or r.encoded, r.error, r.note, r.reached]


def _answered(run: ChapterRun) -> list:
    """Everything the child answered for one chapter, as plain data (a memo key's part)."""
    return [run.import_error, [_answer(r) for r in run.results]]


def _check_keys(plan_key: str | None, slots: dict[str, list[int]] | None, module_file: str, limits: object,
                run: ChapterRun) -> dict[str, str | None]:
    """The memo key of each check's verdict: what decides it (the plan, the chapter's file, the limits) and what the
    child answered for the check's own calls (`slots`); none where the chapter did not import."""
    from grader.core.memo import key_of

    if not slots or run.import_error is not None or \
            any(not 0 <= i < len(run.results) for numbers in slots.values() for i in numbers):
        return {}
    return {check: key_of(plan_key, check, module_file, repr(limits), [_answer(run.results[i]) for i in numbers])
            for check, numbers in slots.items()}


def _load_checks(chapter_id: str) -> None:
    """Import what planning `chapter_id` needs (numpy, its checks, the planning), before its checks to plan are known."""
    from grader import checks as check_registry
    from grader.core import planning  # noqa: F401

    check_registry.load(chapter_id)


def _judged_in_part(memo: Memo, chapter_id: str, slots: dict[str, list[int]], keys: dict[str, str | None],
                    calls: list, run: ChapterRun, module_file: str, seed: int,
                    exclude: frozenset[str]) -> tuple[ChapterResult, dict] | None:
    """The chapter judged check by check (only the changed functions judged afresh): a check whose own calls answered
    exactly as when its last verdict was kept (`keys`) gets that verdict, and only the others are planned and judged
    (by the warm judge where one answers, grader.core.warm_judge), with the answers to their calls. (the
    ChapterResult, the helpers each check's calls entered); None where the memo does not hold what that needs, or
    the plan's calls are not the kept ones (then the chapter is judged whole)."""
    from grader.core import warm_judge

    if not keys or any(i >= len(calls) for numbers in slots.values() for i in numbers):
        return None
    kept = memo.check_verdicts(chapter_id)
    reused = {c for c in slots if c in kept and keys.get(c) is not None and kept[c][0] == keys[c]}
    fresh_slots = {c: numbers for c, numbers in slots.items() if c not in reused}
    numbers = sorted({i for own in fresh_slots.values() for i in own})
    asked = (chapter_id, seed, exclude | {f"{chapter_id}/{c}" for c in reused}, fresh_slots,
             {i: calls[i].to_json(i) for i in numbers}, {i: run.results[i] for i in numbers}, module_file)
    judged = warm_judge.judge(memo.grader, *asked) if fresh_slots else ([], {})
    if fresh_slots and judged is not None:
        trace(f"{chapter_id} judged by the warm judge")
    elif judged is None:
        from grader.core.planning import judge_checks

        judged = judge_checks(*asked)
    fresh, fresh_entered = ({c.id: c for c in judged[0]}, judged[1]) if judged is not None else ({}, {})
    if set(fresh) != set(fresh_slots):
        return None
    chapter, entered = ChapterResult(chapter_id, BY_ID[chapter_id].title), {}
    for c in slots:
        if c not in reused:
            chapter.checks.append(fresh[c])
            if c in fresh_entered:
                entered[c] = fresh_entered[c]
            continue
        value = kept[c][1]
        try:
            kept_check = ChapterResult.from_dict({"chapter": chapter_id, "checks": [value["check"]]}).checks[0]
            helpers = [str(h) for h in value.get("reached") or []]
        except (KeyError, TypeError, ValueError, IndexError):
            return None
        chapter.checks.append(kept_check)
        if helpers:
            entered[c] = helpers
    trace(f"{chapter_id}: {len(fresh_slots)} of {len(slots)} checks judged afresh")
    return chapter, entered


def _judged_by_check(memo: Memo, plan_key: str | None, request: ChapterRequest, run: ChapterRun, module_file: str,
                     limits: object, seed: int, exclude: frozenset[str]) -> tuple[ChapterResult, dict, dict] | None:
    """The chapter judged without its whole plan: check by check (_judged_in_part), or, for a file that could not be
    imported, by the warm judge. (the ChapterResult, the helpers each check's calls entered, each check's verdict
    key); None where neither can (then the chapter is judged whole)."""
    chapter_id = request.chapter
    if run.import_error is not None:
        from grader.core import warm_judge

        chapter = warm_judge.judge_not_imported(memo.grader, chapter_id, exclude, run.import_error, module_file)
        if chapter is not None:
            trace(f"{chapter_id} judged by the warm judge")
        return None if chapter is None else (chapter, {}, {})
    slots = memo.slots(chapter_id, plan_key) if plan_key else None
    keys = _check_keys(plan_key, slots, module_file, limits, run)
    judged = _judged_in_part(memo, chapter_id, slots, keys, request.calls, run, module_file, seed, exclude) \
        if slots and keys else None
    return None if judged is None else (*judged, keys)


def _keep_check_verdicts(memo: Memo, chapter: ChapterResult, kept: dict, keys: dict[str, str | None],
                         entered: dict) -> None:
    """Keep each check's verdict (`kept`: the chapter's to_kept()) under its key (`keys`), for a later run that
    changes other functions only; never a grader's own failure (it is judged again)."""
    memo.keep_check_verdicts(chapter.chapter, {
        check.id: [keys[check.id], {"check": value, "reached": entered.get(check.id)}]
        for check, value in zip(chapter.checks, kept["checks"])
        if keys.get(check.id) is not None and not _grader_failed(check)})


def _grader_failed(check: CheckResult) -> bool:
    """Whether `check` failed for a reason of the grader's own (its verdict is never kept: judged again next time)."""
    return check.status == Status.ERROR and check.message.startswith(("grader error", "not graded here"))


def _settled(chapter: ChapterResult, run: ChapterRun) -> bool:
    """Whether a verdict may be kept: no failure of the grader's own (it is judged again next time)."""
    if run.import_error is not None and (run.import_error.get("grader") or run.import_error.get("infrastructure")):
        return False
    return not any(_grader_failed(c) for c in chapter.checks)


def judge_chapters(session: Session, chapter_ids: list[str], seed: int = DEFAULT_SEED,
          with_plots: bool = False, submission_label: str | None = None,
          exclude: frozenset[str] = frozenset(), memo: Memo | None = None) -> Report:
    """Grade `chapter_ids` of the session's submission, but the checks in `exclude` ("chNN/check_id");
    learner code runs only in the session's child. With `memo`, kept plans and verdicts (with their plot data)
    are reused where they were made from exactly this, and a judge kept warm may judge what changed (its connection
    let go at the end, whatever happened: a process that grades again asks afresh)."""
    try:
        return _judge_chapters(session, chapter_ids, seed, with_plots, submission_label, exclude, memo)
    finally:
        if "grader.core.warm_judge" in sys.modules:
            sys.modules["grader.core.warm_judge"].release()


def _judge_chapters(session: Session, chapter_ids: list[str], seed: int, with_plots: bool,
                    submission_label: str | None, exclude: frozenset[str], memo: Memo | None) -> Report:
    from grader.core.memo import key_of

    plans: dict[str, ChapterPlan] = {}
    plan_keys: dict[str, str | None] = {}
    requests = []
    kept_calls: set[str] = set()  # the chapters whose calls came from the memo, not from a plan made here
    for cid in chapter_ids:
        plan_keys[cid] = key_of(cid, seed, sorted(e for e in exclude if e.startswith(f"{cid}/")), with_plots)
        calls = memo.calls(cid, plan_keys[cid]) if memo is not None and plan_keys[cid] else None
        helpers = memo.builds_on(cid) if calls is not None else None  # both kept, or planned again
        if calls is not None and helpers is not None:
            kept_calls.add(cid)
        else:
            plans[cid] = _plan(cid, seed, with_plots, exclude)
            calls, helpers = plans[cid].calls, plans[cid].chapter.builds_on
            if memo is not None and plan_keys[cid]:
                memo.keep_calls(cid, plan_keys[cid], calls, helpers, plans[cid].slots())
        requests.append(ChapterRequest(cid, BY_ID[cid].module, calls, helpers))
    # one learner's runs: which files a kept verdict was made from says which chapters will most likely be judged
    files = key_of(session.prepared.files) if memo is not None and memo.one_learner else None
    unseen = [cid for cid in chapter_ids if cid not in plans and files is not None and not memo.seen(cid, files)]
    by_check_ahead = {cid for cid in unseen if not with_plots and memo.slots(cid, plan_keys[cid]) is not None}
    if memo is not None and memo.one_learner:
        from grader.core import warm_judge

        warm_judge.wanted(memo.grader)
    if unseen:  # files no kept verdict was made from: most likely judged afresh, so planned while the child runs
        def plan_meanwhile() -> None:  # or, where the chapter may be judged check by check, its checks imported
            from grader.core import warm_judge

            for cid in unseen:
                try:
                    if cid in by_check_ahead:
                        if not warm_judge.available(memo.grader):  # the warm judge has them imported
                            _load_checks(cid)
                    else:
                        plans[cid] = _plan(cid, seed, with_plots, exclude)
                except Exception:  # noqa: BLE001  planned again below, where what it raises is the report's to meet
                    return

        session.meanwhile.append(plan_meanwhile)
    runs = session.run(requests)
    submission = session.submission
    prepared = session.prepared
    report = Report(submission_label or str(submission.root), seed=seed)
    builds_on: dict[str, dict] = {}
    reached: dict[str, dict] = {}
    for request in requests:
        cid, module = request.chapter, request.module
        graded = prepared.graded.get(module)  # a notebook, or the cells a kernel ran
        module_file = str(Path(graded) if graded and graded.endswith(".ipynb") else graded or
                          Path(submission.package) / f"{module}.py")  # as the system writes it
        run = runs[cid]
        if module in prepared.problems:  # a notebook that could not be read: the child had no module
            run.import_error = {"exception": "NotebookError", "message": prepared.problems[module], "traceback": "",
                                "line": None}
        _relocate(run, prepared.sources)
        key = key_of(plan_keys[cid], module_file, repr(session.limits), _answered(run)) if memo is not None else None
        kept = memo.verdict(cid, key, files) if memo is not None else None
        try:
            chapter = ChapterResult.from_dict(kept["chapter"], kept=True) if kept is not None else None
            uses = {str(f): tuple(map(str, h)) for f, h in dict(kept["builds_on"]).items()} if kept else {}
            entered = {str(c): list(map(str, h)) for c, h in dict(kept.get("reached") or {}).items()} if kept else {}
        except (KeyError, TypeError, ValueError):
            chapter = None
        if chapter is None:
            by_check = memo is not None and memo.one_learner and not with_plots and key is not None
            judged = _judged_by_check(memo, plan_keys[cid], request, run, module_file, session.limits, seed,
                                      exclude) if by_check and cid not in plans else None
            if judged is not None:
                (chapter, entered, keys), uses = judged, dict(request.helpers)
            else:
                plan = plans.get(cid) or _plan(cid, seed, with_plots, exclude)  # at the same seed: the same calls
                if cid in kept_calls and [c.to_json(i) for i, c in enumerate(plan.calls)] != \
                        [c.to_json(i) for i, c in enumerate(request.calls)]:  # never, unless the memo is wrong
                    run = session.run([plan.request()])[cid]
                    _relocate(run, prepared.sources)
                    key = None
                chapter = plan.judge(run, module_file)
                uses, entered = plan.chapter.builds_on, plan.reached(run)
                keys = _check_keys(plan_keys[cid], plan.slots(), module_file, session.limits, run) \
                    if by_check and key is not None else {}
            if memo is not None and _settled(chapter, run):
                value = chapter.to_kept()
                memo.keep_verdict(cid, key, {"chapter": value, "builds_on": uses, "reached": entered}, files)
                if keys:
                    _keep_check_verdicts(memo, chapter, value, keys, entered)
        builds_on[cid], reached[cid] = uses, entered
        chapter.source = Path(module_file).as_posix() if graded != KERNEL else KERNEL
        chapter.unread = module in prepared.problems  # a notebook that could not be read: nothing of it was graded
        chapter.notes.extend(prepared.notes.get(module, []))
        report.chapters.append(chapter)
    point_upstream(report, builds_on, reached)
    report.learner_output = session.output
    broken = [run.import_error.get("message", "") for run in runs.values()
              if run.import_error and run.import_error.get("infrastructure")]
    report.infrastructure = broken[0] if broken else ""
    return report
