"""Grade chapters: plan every check's calls (grader.core.planning), run them in one child session, judge in this
process; with a memo (grader.core.memo), a chapter whose child answered exactly as in a kept run is not planned or
judged again, and neither the checks nor numpy are imported for it."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from grader.boundary import ChapterRequest, ChapterRun, Session
from grader.chapters import BY_ID
from grader.course_config import PUBLIC_SEED
from grader.model import ChapterResult, Report, Status
from grader.notebook import KERNEL, relocate

if TYPE_CHECKING:
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


def _answered(run: ChapterRun) -> list:
    """Everything the child answered for one chapter, as plain data (a memo key's part): with the helpers each call
    entered, which decide where a failure is blamed (point_upstream)."""
    return [run.import_error, [None if r is None else [r.kind, r.function, r.encoded, r.error, r.note, r.reached]
                               for r in run.results]]


def _settled(chapter: ChapterResult, run: ChapterRun) -> bool:
    """Whether a verdict may be kept: no failure of the grader's own (it is judged again next time)."""
    if run.import_error is not None and (run.import_error.get("grader") or run.import_error.get("infrastructure")):
        return False
    return not any(c.status == Status.ERROR and c.message.startswith(("grader error", "not graded here"))
                   for c in chapter.checks)


def judge_chapters(session: Session, chapter_ids: list[str], seed: int = DEFAULT_SEED,
          with_plots: bool = False, submission_label: str | None = None,
          exclude: frozenset[str] = frozenset(), memo: Memo | None = None) -> Report:
    """Grade `chapter_ids` of the session's submission, but the checks in `exclude` ("chNN/check_id");
    learner code runs only in the session's child. With `memo`, kept plans and verdicts (with their plot data)
    are reused where they were made from exactly this."""
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
                memo.keep_calls(cid, plan_keys[cid], calls, helpers)
        requests.append(ChapterRequest(cid, BY_ID[cid].module, calls, helpers))
    # one learner's runs: which files a kept verdict was made from says which chapters will most likely be judged
    files = key_of(session.prepared.files) if memo is not None and memo.one_learner else None
    unseen = [cid for cid in chapter_ids if cid not in plans and files is not None and not memo.seen(cid, files)]
    if unseen:  # files no kept verdict was made from: most likely judged afresh, so planned while the child runs
        def plan_meanwhile() -> None:
            for cid in unseen:
                try:
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
            chapter = ChapterResult.from_dict(kept["chapter"]) if kept is not None else None
            uses = {str(f): tuple(map(str, h)) for f, h in dict(kept["builds_on"]).items()} if kept else {}
            entered = {str(c): list(map(str, h)) for c, h in dict(kept.get("reached") or {}).items()} if kept else {}
        except (KeyError, TypeError, ValueError):
            chapter = None
        if chapter is None:
            plan = plans.get(cid) or _plan(cid, seed, with_plots, exclude)  # at the same seed: the same calls
            if cid in kept_calls and [c.to_json(i) for i, c in enumerate(plan.calls)] != \
                    [c.to_json(i) for i, c in enumerate(request.calls)]:  # never, unless the memo is wrong
                run = session.run([plan.request()])[cid]
                _relocate(run, prepared.sources)
                key = None
            chapter = plan.judge(run, module_file)
            uses, entered = plan.chapter.builds_on, plan.reached(run)
            if memo is not None and _settled(chapter, run):
                memo.keep_verdict(cid, key, {"chapter": chapter.to_kept(), "builds_on": uses, "reached": entered},
                                  files)
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
