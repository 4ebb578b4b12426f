"""Batch grading of a folder of submissions: discover, stage, grade in parallel, write every output.

Each submission (a folder or a .zip, holding exercises/ or the chapter files directly) is copied
or safely extracted into OUT/.staging/<folder>/exercises/ (grader.course.staging) and graded by a worker process (of
this machine's pool, LocalPool, or of a Dask cluster, grader.course.cluster), in a child forked by that worker's
sandboxed fork server (grader.boundary.forkserver); the worker returns the texts of the learner's files
(grade_staged) and this process alone writes them, atomically, into OUT/<folder>/ (write_graded), where
<folder> is the learner's id kept as given where it is plain
and percent-encoded otherwise (folder_name): no id can name a class output, a hidden folder or a
path outside OUT. A learner whose staged files hash the same as last time is not graded again. The
gradebook, JUnit file and class summary are rebuilt from the per-learner reports at the end, so an
interrupted run loses nothing graded.

An infrastructure failure (the sandbox or the child process could not start, for no reason of the
learner's) is never a grade: the batch does not start when a probe of the sandbox fails, and a
learner whose report says so is tried once more, then listed as `error` with empty score cells and
graded again by the next run.
"""

from __future__ import annotations

import gc
import hashlib
import json
import marshal
import os
import sys
import tempfile
import time
import zlib
from collections.abc import Iterator, Mapping
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import TYPE_CHECKING

from grader.chapters import CHAPTERS
from grader.course.staging import (  # noqa: F401  (RosterError, StagingError: what run_batch raises and reports)
    STAGING,
    Entry,
    RosterError,
    Skipped,
    StagingError,
    folder_name,
    stage,
    survey,
)
from grader.render import plural
from grader.safe_text import json_text

if TYPE_CHECKING:
    from grader.course_config import Course

RETRY_PAUSE = 1.0  # seconds before a learner whose child could not start is tried again
HELD_REPORTS = 32  # reports graded before their turn in the class outputs kept meanwhile; others are read again


class InfrastructureError(RuntimeError):
    """Grading cannot work here (the sandbox does not start): no learner is graded."""


class NoSubmissions(ValueError):
    """The submissions folder holds nothing to grade (the message says what it holds instead)."""


def content_hash(root: Path, chapters: list[str], seed: int, settings: str = "") -> str:
    """What a learner's outputs depend on: the staged files, the chapters, the seed, the grader, and
    `settings` (the learner's overrides, the late penalty, the course's current handout)."""
    digest = hashlib.sha256(f"{chapters}|{seed}|{_grader_version()}|{settings}".encode())
    for path in sorted((root / "exercises").rglob("*")):
        if path.is_file():
            digest.update(str(path.relative_to(root)).encode() + b"\0" + path.read_bytes() + b"\0")
    return digest.hexdigest()


def _grader_version() -> str:
    """Changes when the grader's checks, references or keys change, so a re-run re-grades after an update."""
    from grader import provenance

    return provenance.code_digest()[:16]


def write_atomically(path: Path, text: str) -> None:
    """Write `text` to `path` through a temporary file beside it, so a reader never sees half a file."""
    write_atomically_from(path, lambda handle: handle.write(text))


def write_atomically_from(path: Path, write, replace: bool = True) -> Path:
    """As write_atomically, `write` writing the text into the file it is given (piece by piece: a large class's
    outputs are never whole in memory); with replace=False the written file is left beside `path` (returned)
    for the caller to os.replace."""
    temporary = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    with temporary.open("w", encoding="utf-8") as handle:
        write(handle)
    if replace:
        os.replace(temporary, path)
    return temporary


# ------------------------------------------------------------------------------------ grading

_worker_state: dict = {}


def _settle_heap() -> None:
    """After a worker's first graded learner, what it imported and cached lives as long as the worker: frozen
    (gc.freeze), the garbage collector's full passes no longer walk it (they took about half its time)."""
    if not _worker_state.get("settled"):
        _worker_state["settled"] = True
        gc.collect()
        gc.freeze()


def choose_boundary(sandbox: str = "required", probe: bool = False, secrets: tuple[str, ...] = ()):
    """How learner code runs here (grader.boundary.choose, `sandbox` one of its modes: "required", bubblewrap,
    for a batch; "off" with --no-sandbox); a resident fork server per worker where the system allows. With
    `probe`, one child interpreter is started first the way the workers will start theirs: InfrastructureError
    with the reason when it does not start, so that no learner is graded on a broken sandbox."""
    from grader import boundary

    try:
        return boundary.choose(sandbox, resident=True, probe=probe, secrets=secrets)
    except boundary.BoundaryUnavailable as exc:
        raise InfrastructureError(str(exc)) from None


def _boundary(sandbox: str, secrets: tuple[str, ...] = ()):
    """This worker's boundary (its fork server started on first use), kept for every learner it grades with the
    same `sandbox` (a cluster's worker outlives a batch: one asking another mode gets a boundary of its own)."""
    if _worker_state.get("sandbox") != sandbox:
        _drop_boundary()
    if "boundary" not in _worker_state:
        _worker_state["boundary"] = choose_boundary(sandbox, secrets=secrets)
        _worker_state["sandbox"] = sandbox
    return _worker_state["boundary"]


def worker_isolation(sandbox: str) -> str:
    """The isolation line of this worker's boundary for `sandbox` (InfrastructureError where it cannot start)."""
    return _boundary(sandbox).isolation


def _drop_boundary() -> None:
    """Stop this worker's fork server: the next learner gets a new one."""
    chosen = _worker_state.pop("boundary", None)
    if chosen is not None:
        chosen.close()


def _grade_report(root: Path, learner: str, chapters: list[str], seed: int, plots: bool, limits: dict,
                  sandbox: str, course: Course | None = None, other_ids: tuple[str, ...] = (),
                  secrets: tuple[str, ...] = ()):
    """One learner's report, as `course` has it (grader.core.pipeline.build_report), its learner code behind the
    boundary `sandbox` asks (choose_boundary); tried a second time, with a new fork server, when the first attempt
    failed for a reason outside the learner's code (Report.infrastructure, or no process could be started at
    all: an OSError, raised again if the second attempt meets it too)."""
    from grader.boundary import Limits
    from grader.core.pipeline import Request, build_report
    from grader.submission import Submission

    for attempt in (1, 2):
        try:
            session = _boundary(sandbox, secrets).open_session(Submission(root, "exercises"), Limits(**limits))
        except OSError:
            if attempt == 2:
                raise
        else:
            report = build_report(session, Request(tuple(chapters), seed, learner=learner, plots=plots,
                                                   label=learner, other_ids=other_ids), course, _worker_memo())
            if not report.infrastructure:
                break
        _drop_boundary()
        if attempt == 1:
            time.sleep(RETRY_PAUSE)
    return report


def _worker_memo():
    """This worker's verdicts, kept across the learners it grades (grader.core.memo.Memo without a folder): a chapter
    answered exactly as another learner's is judged once."""
    if "memo" not in _worker_state:
        from grader.core.memo import Memo

        _worker_state["memo"] = Memo(None, "this worker")
    return _worker_state["memo"]


def learner_yaml_warnings(root: Path, learner: str, origin: str = "") -> list[str]:
    """A staged submission's own answers/learner.yaml naming someone other than the id it is graded as
    (its folder or zip name, or the roster): the quiz numbers and option letters are the graded id's, so
    answers worked out for the other id's do not match. One sentence saying so, or nothing."""
    from grader.quiz import learner_id

    who, source = learner_id(root / "exercises" / "answers", None)
    if not source.endswith("learner.yaml") or who == learner:
        return []
    where = f" (from {origin})" if origin else ""
    return [(f"learner.yaml names {who!r}, but this submission is graded as {learner!r}{where}: it gets the quiz "
             f"numbers and option letters of {learner!r}, so answers worked out with those of {who!r} do not match; "
             "correct the roster or the file and grade again")]


@dataclass(frozen=True)
class Grading:
    """What every learner of a batch is graded with, the same wherever it is graded (plain data: it travels with
    each task to a cluster's workers). `hidden` (the course's hidden check ids) are shown in results.json only
    after grades are published; `course` leaves out the checks it switches off and gives the late penalty and
    the current handout."""

    chapters: tuple[str, ...]
    seed: int
    html: bool = True
    plots: bool = False
    limits: Mapping = field(default_factory=dict)
    sandboxed: bool = True
    hidden: frozenset[str] = frozenset()
    course: Course | None = None

    @property
    def sandbox(self) -> str:
        """The boundary's sandbox mode (grader.boundary.choose) these learners are graded behind."""
        return "required" if self.sandboxed else "off"


@dataclass
class Staged:
    """A learner staged and due for grading (plain data): where its files are staged, its content hash, what was
    found while staging (warnings, the submission time and where it came from, its manifest), its overrides,
    and the seconds staging took."""

    learner: str
    root: str
    digest: str
    warnings: list[str]
    submitted: str
    time_from: str | None
    manifest: dict | None
    other_ids: tuple[str, ...]
    files_hash: str
    overrides: tuple = ()
    seconds: float = 0.0

    def files(self) -> dict[str, bytes]:
        """The staged files (relative path -> bytes): what travels to a worker that does not share this disk."""
        package = Path(self.root) / "exercises"
        return {path.relative_to(package).as_posix(): path.read_bytes()
                for path in sorted(package.rglob("*")) if path.is_file()}


@dataclass
class Graded:
    """One learner's outcome as plain data: status (graded, unchanged, unreadable, error), the message, and the
    texts of its files in OUT/<folder>/ in the order they are written (None: remove that file), report.json
    last; `infrastructure` says why it could not be graded for a reason outside the learner's code ("" when it
    was). Written into OUT by the coordinator alone (write_graded)."""

    learner: str
    status: str
    message: str
    files: dict[str, str | None] = field(default_factory=dict)
    infrastructure: str = ""


def stage_one(entry: Entry, out: Path, grading: Grading, overrides: tuple = ()) -> Staged | Graded:
    """Stage one submission into OUT/.staging and decide whether it is due: a Staged learner to grade, or its
    Graded outcome without grading (unreadable; unchanged: its staged files hash as at its last grading, with
    the same overrides, late penalty and current handout). The manifest of an archive made by `grade submit` is
    checked (grader.course.submit.check) and what it says is flagged."""
    from grader.course import submit

    started = time.monotonic()
    learner = entry.learner
    try:
        root = stage(entry, out / STAGING)
    except StagingError as exc:
        return Graded(learner, "unreadable", f"{entry.source.name}: {exc}")
    course = grading.course
    course_id, handout = (course.id, course.current_handout) if course else (None, None)
    manifest, manifest_flags = submit.check(root / "exercises", learner, course_id, handout)
    submitted, timing = submission_time(entry, manifest, course)
    late = course.late if course else None
    settings = json.dumps([[o.key() for o in overrides], repr(late), submitted, handout, course_id], default=str)
    digest = content_hash(root, list(grading.chapters), grading.seed, settings)
    if _previous_hash(out / folder_name(learner)) == digest:
        return Graded(learner, "unchanged", "already graded, files unchanged")
    return Staged(learner, str(root), digest, learner_yaml_warnings(root, learner, entry.origin) + manifest_flags
                  + timing, submitted, _time_source(entry, submitted), _manifest_summary(manifest),
                  (str(manifest.get("learner")),) if manifest else (), submit.files_hash(root / "exercises"),
                  tuple(overrides), time.monotonic() - started)


def grade_staged(staged: Staged, grading: Grading, root: Path | None = None, batch_extra: Mapping = ()) -> Graded:
    """Grade a staged learner (in a worker process: here, or on a cluster's worker with its files copied to `root`)
    into the texts of its files: report.json (the report's data and what the batch keeps, `batch_extra` added),
    results.json and report.html. `overrides` and the course's late penalty are applied before anything is
    rendered. One whose child could not start, twice, is `error`: its report.json keeps why (and no hash, so the
    next run grades it again), and its results.json and report.html are removed, so that nothing looks like a
    grade."""
    from grader.course import overrides as adjusting
    from grader.render import lms

    started = time.monotonic()
    learner, course = staged.learner, grading.course
    report = _grade_report(root or Path(staged.root), learner, list(grading.chapters), grading.seed, grading.plots,
                           dict(grading.limits), grading.sandbox, course, other_ids=staged.other_ids)
    warnings = list(staged.warnings) + report.flags
    warnings += adjusting.apply(report, list(staged.overrides), course.late if course else None,
                                adjusting.parse_time(staged.submitted))
    seconds = staged.seconds + time.monotonic() - started
    data = report.to_dict()
    data["batch"] = {"seconds": round(seconds, 3), "learner_output": report.learner_output[:4000],
                     "warnings": warnings, "files_hash": staged.files_hash, "submitted": staged.submitted or None,
                     "time_from": staged.time_from, "manifest": staged.manifest}
    if report.infrastructure:
        data["batch"].update(batch_extra)
        return Graded(learner, "error", (f"not graded, twice, for a reason outside the learner's code: "
                                         f"{report.infrastructure}; the next run grades it again"),
                      {"results.json": None, "report.html": None,
                       "report.json": json_text(data) + "\n"},
                      infrastructure=report.infrastructure)
    data["batch"]["hash"] = staged.digest
    data["batch"].update(batch_extra)
    files: dict[str, str | None] = {
        "results.json": lms.gradescope(report, hidden=grading.hidden, execution_time=seconds,
                                       heading=[f"Graded as {learner}."], notes=warnings)}
    if grading.html:
        from grader.render import html as html_renderer

        # this worker draws its learner's figures itself: the other workers keep the other cores busy
        files["report.html"] = html_renderer.render(report, draw_here=True)
    files["report.json"] = json_text(data) + "\n"  # last: marks done
    _settle_heap()
    problems = sum(bool(c.problems) for c in report.chapters)
    with_problems = f", {plural(problems, 'chapter')} with problems" if problems else ""
    return Graded(learner, "graded", f"{report.score:g}/{report.max_score:g}{with_problems}", files)


def _grade_one(entry: Entry, out: str, grading: Grading, overrides: tuple = ()) -> Graded:
    """Stage and grade one submission in a worker process of the local pool (stage_one, then grade_staged)."""
    staged = stage_one(entry, Path(out), grading, overrides)
    return staged if isinstance(staged, Graded) else grade_staged(staged, grading)


def write_graded(out: Path, graded: Graded) -> None:
    """Write (or remove) a graded learner's files in OUT/<folder>/, each atomically, report.json last: a reader
    never sees half a file, and a report.json with its hash marks the learner done. The coordinator alone
    writes into OUT."""
    if not graded.files:
        return
    folder = out / folder_name(graded.learner)
    folder.mkdir(parents=True, exist_ok=True)
    for name, text in graded.files.items():
        if text is None:
            (folder / name).unlink(missing_ok=True)
        else:
            write_atomically(folder / name, text)


def submission_time(entry: Entry, manifest: dict | None, course: Course | None) -> tuple[str, list[str]]:
    """(the submission time that decides a late penalty, ISO 8601 or "", and what to flag about it). Trusted:
    the roster's `submitted` column (the LMS's time). The time in the archive's manifest is written on the
    learner's own machine: it is used only where the course accepts it (`manifest_time: accept`), and never
    silently. An unparsable time is no time, and said."""
    from grader.course import overrides as adjusting
    from grader.course import submit

    flags = []
    if entry.submitted:
        if adjusting.parse_time(entry.submitted) is not None:
            return entry.submitted, flags
        flags.append(f"the roster's submission time {entry.submitted!r} ({entry.origin}) is not a time (ISO 8601, "
                     "e.g. 2026-05-01T23:59:00+02:00)")
    packed = submit.packed_time(manifest)
    if not course or not course.late:
        return "", flags
    if packed and course.accepts_manifest_time and adjusting.parse_time(packed) is not None:
        return packed, flags + [f"submission time {packed} from the learner's own archive manifest (the course accepts "
                                "it: manifest_time: accept); the roster gives none"]
    said = (f"its archive's manifest says {packed!r}, written on the learner's own machine and not accepted "
            "(manifest_time: accept in the course file would)" if packed else "no time at all")
    return "", flags + [f"no trusted submission time (no `submitted` in the roster): {said}; no late penalty applied"]


def _time_source(entry: Entry, submitted: str) -> str | None:
    """Where the submission time that was used came from: "roster", "manifest", or None (none used)."""
    if not submitted:
        return None
    return "roster" if submitted == entry.submitted else "manifest"


def _manifest_summary(manifest: dict | None) -> dict | None:
    """What report.json keeps of a grade submit manifest: who packed it, with which handout and grader,
    when, and the score the packed archive had at home."""
    if manifest is None:
        return None

    def text(value: object) -> str | None:
        return None if value is None else str(value)[:200]

    local = manifest.get("local") if isinstance(manifest.get("local"), dict) else {}
    return {**{key: text(manifest.get(key)) for key in ("learner", "course", "handout", "handout_released", "grader",
                                                        "packed")},
            "local": {key: local[key] for key in ("seed", "score", "max_score", "pending_score")
                      if isinstance(local.get(key), (int, float)) and not isinstance(local.get(key), bool)}}


def _load(folder: Path) -> dict | None:
    try:
        data = json.loads((folder / "report.json").read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    return data if isinstance(data, dict) else None


def _report(data: dict | None):
    """The grader.model.Report in a report.json's data, or None."""
    from grader.model import Report

    try:
        return None if data is None else Report.from_dict(data)
    except (TypeError, ValueError, KeyError, AttributeError):
        return None


def _previous_hash(folder: Path) -> str | None:
    """The content hash of the learner's last grading; None if there is none to keep (no report, or
    one that records an infrastructure failure: that is never kept)."""
    data = _load(folder)
    if data is None or data.get("infrastructure"):
        return None
    batch = data.get("batch")
    return batch.get("hash") if isinstance(batch, dict) else None


class LocalPool:
    """The embedded default pool: `jobs` worker processes on this machine (default: one per core), each staging
    and grading its learners behind its own resident boundary (a sandboxed fork server). A pool is what
    run_batch grades through: `isolation` proves learner code can run before anyone is graded, and `grade`
    yields each learner's Graded outcome as it completes (grader.course.cluster.ClusterPool is the other, on Dask)."""

    def __init__(self, jobs: int | None = None) -> None:
        if jobs is not None and jobs < 1:
            raise ValueError(f"jobs must be at least 1, not {jobs}")
        self.jobs = jobs or os.cpu_count() or 1

    def isolation(self, sandboxed: bool) -> str:
        """The isolation line here, after one child interpreter started the way the workers will start theirs
        (InfrastructureError with the reason when it does not)."""
        return choose_boundary("required" if sandboxed else "off", probe=True).isolation

    def grade(self, entries: list[Entry], out: Path, grading: Grading,
              overrides: Mapping[str, tuple]) -> Iterator[Graded]:
        """Each learner's outcome, in the order they complete; one whose worker failed is `error`, saying why."""
        with ProcessPoolExecutor(max_workers=self.jobs) as pool:
            futures = {pool.submit(_grade_one, entry, str(out), grading, tuple(overrides.get(entry.learner, ()))):
                       entry.learner for entry in entries}
            for future in as_completed(futures):
                try:
                    yield future.result()
                except Exception as exc:  # one broken submission never stops the batch
                    yield Graded(futures[future], "error", f"{type(exc).__name__}: {exc}")


def run_batch(submissions: Path, out: Path, *, chapters: list[str] | None = None, roster: Path | None = None,
              jobs: int | None = None, seed: int, html: bool = True, plots: bool = False,
              limits: dict | None = None, progress=None, sandboxed: bool = True,
              hidden: frozenset[str] = frozenset(), lms_layouts: tuple[str, ...] = (),
              course: Course | None = None, overrides: Path | None = None, similarity: bool = False,
              announce=None, pool=None) -> dict:
    """Grade every submission in `submissions` into `out`; returns counts, statuses and messages per
    learner, what was skipped, what was flagged, the isolation line, the changes since the last run and
    the problems of overrides.csv, for the end summary.
    NoSubmissions (and nothing written) when the folder holds nothing to grade; InfrastructureError when a
    child interpreter does not start here; RosterError for a roster or overrides file that cannot be read.
    `sandboxed=False` grades without bubblewrap (--no-sandbox); `hidden` are the course's hidden check ids
    (results.json shows them after grades are published); `lms_layouts` ("canvas", "moodle") adds those
    gradebooks; `course` (grader.course_config.Course) leaves out the checks it switches off and gives the late
    penalty and the current handout; `overrides` is the overrides file (default OUT/overrides.csv);
    `similarity` ranks pairs of learners by the similarity of their code (grader.course.similarity); `announce` is
    given the isolation line once the boundary is chosen, before anyone is graded; `pool` grades the learners
    (default: LocalPool(jobs), processes on this machine; grader.course.cluster.ClusterPool grades on a Dask cluster),
    and whatever it grades on, this process alone writes into `out`.
    Every learner's result goes into OUT/gradebook.db (grader.course.history) as soon as it is graded, once (a result
    that arrives twice is recorded once)."""
    from grader import provenance
    from grader.course import history as histories

    chapters = chapters or [c.id for c in CHAPTERS]
    if jobs is not None and jobs < 1:
        raise ValueError(f"jobs must be at least 1, not {jobs}")
    entries, skipped = survey(submissions, roster)
    if not entries:
        what = "; ".join(f"{s.name}: {s.reason}" for s in skipped[:5])
        raise NoSubmissions(f"{submissions} holds no submission to grade (a folder or .zip file per learner)"
                            + (f"; it holds only what is skipped: {what}" if what else ": it is empty"))
    rows, override_problems = read_overrides(overrides or out / "overrides.csv", [e.learner for e in entries],
                                             chapters)
    pool = pool or LocalPool(jobs)
    isolation = pool.isolation(sandboxed)
    if announce is not None:
        announce(isolation)
    # the class summary's figures, drawn at the end for a class large enough to have them: matplotlib's import
    # (about 0.4 s) runs meanwhile in a drawing process, forked now where that is safe (no thread yet: not beside a
    # cluster's client), at a low priority; numpy, which this process imports for the statistics, is shared with it
    from grader.course import statistics
    from grader.render import drawer

    if len(entries) >= statistics.RELIABLE_LEARNERS:
        drawer.start()
    out.mkdir(parents=True, exist_ok=True)
    statuses: dict[str, str] = {}
    messages: dict[str, str] = {}
    started = time.monotonic()
    done = 0
    limits = limits or {}
    history = histories.History(out / histories.FILE_NAME)
    collected = ClassOutputs(out, [e.learner for e in entries], statuses, messages, chapters)
    run = history.start(provenance.grader_version(), course.current_handout if course else None,
                        course.id if course else None, seed, chapters)
    by_learner: dict[str, list] = {}  # each learner's overrides, in the file's order
    for row in rows:
        by_learner.setdefault(row.learner, []).append(row)
    try:
        grading = Grading(tuple(chapters), seed, html, plots, limits, sandboxed, frozenset(hidden), course)
        for graded in pool.grade(entries, out, grading, by_learner):
            learner = graded.learner
            if learner in statuses:  # arrived twice (a task run again elsewhere): recorded once
                continue
            statuses[learner], messages[learner] = graded.status, graded.message
            try:
                write_graded(out, graded)
            except OSError as exc:
                statuses[learner], messages[learner] = "error", f"its files could not be written: {exc}"
            state = _learner_state(out, learner, statuses[learner], messages[learner])
            history.record(run, state[0])
            collected.arrived(learner, state)
            done += 1
            if progress:
                progress(done, len(entries), time.monotonic() - started)
        summary = rebuild(out, history, run, chapters, collected, skipped, isolation, lms_layouts, rows,
                          override_problems, similarity=similarity, deadline=bool(course and course.late))
    finally:
        collected.close()
        history.close()
    counts: dict[str, int] = {}
    for status in statuses.values():
        counts[status] = counts.get(status, 0) + 1
    graded_now = sum(status == "graded" for status in statuses.values())
    return {"counts": counts, "seconds": time.monotonic() - started, "graded_now": graded_now,
            "messages": messages, "statuses": statuses, "skipped": skipped, "flagged": summary["flagged"],
            "isolation": isolation, "changes": summary["changes"], "override_problems": override_problems,
            "similar": summary["similar"], "notes": summary["notes"]}


def read_overrides(path: Path, learners: list[str], chapters: list[str]) -> tuple[list, list[str]]:
    """The rows of overrides.csv that can apply in this batch, and a message (file and line) for each that
    cannot: an unknown learner, check or chapter. RosterError for a file that cannot be read at all."""
    from grader import checks as check_registry
    from grader.course import overrides as adjusting

    try:
        rows, problems = adjusting.read(path)
    except adjusting.TableError as exc:
        raise RosterError(str(exc)) from None
    known = set(learners)
    usable = []
    for row in rows:
        chapter = row.target.split("/", 1)[0]
        if row.learner not in known:
            problems.append(f"{row.source}: no learner {row.learner!r} in this batch; row not applied")
        elif row.level in ("check", "chapter") and chapter not in chapters:
            problems.append(f"{row.source}: {chapter} is not graded in this batch (--chapters); row not applied")
        elif row.level == "check" and row.target.split("/", 1)[1] not in {c.id for c in
                                                                          check_registry.load(chapter).checks}:
            problems.append(f"{row.source}: {row.target} is not a check of {chapter} (`grade list --checks` shows "
                            "the ids; a quiz question is quiz_<its id>); row not applied")
        elif row.points is not None and abs(row.points) > _most_points(row, chapters):
            problems.append(f"{row.source}: {row.points:g} points is more than {row.target} can move "
                            f"(at most {_most_points(row, chapters):g}); row not applied")
        else:
            usable.append(row)
    return usable, problems


def _most_points(row, chapters: list[str]) -> float:
    """The most points an override of `row.target` can add or take: its check's, its chapter's code (the quiz's
    questions are not known here: an override of a chapter may also move its quiz, so its quiz's too, at most the
    whole course), or the whole batch's."""
    from grader import checks as check_registry
    from grader.quiz import bank

    def quiz(chapter: str) -> float:
        try:
            return sum(q.points for q in bank.questions(chapter))
        except (OSError, ValueError):
            return 0.0

    if row.level == "check":
        chapter, check_id = row.target.split("/", 1)
        if check_id.startswith("quiz_"):
            return next((q.points for q in bank.questions(chapter) if f"quiz_{q.id}" == check_id), 0.0)
        return next(c.points for c in check_registry.load(chapter).checks if c.id == check_id)
    if row.level == "chapter":
        return check_registry.load(row.target).max_score + quiz(row.target)
    return sum(check_registry.load(c).max_score + quiz(c) for c in chapters)


def _learner_state(out: Path, learner: str, status: str, message: str):
    """(its grader.course.history.Result, its report or None, its report.json's batch data) of one learner, from
    its report.json: a learner not graded (unreadable, an error, a report recording an infrastructure
    failure) has no scores and says why; a graded one's flags are what its report.json says to look at."""
    from grader.model import LearnerResult

    data = _load(out / folder_name(learner))
    batch = data.get("batch") if data is not None and isinstance(data.get("batch"), dict) else {}
    if data is not None and data.get("infrastructure"):
        reason = message if status == "error" else f"not graded: {data['infrastructure']}"
        return LearnerResult(learner, "error", reason), None, batch
    if status in ("error", "unreadable"):
        return LearnerResult(learner, status, message), None, batch
    report = _report(data)  # graded now, or unchanged since it was
    if report is None:
        return LearnerResult(learner, "error", "no readable report.json"), None, batch
    manifest = batch.get("manifest") if isinstance(batch.get("manifest"), dict) else {}
    return LearnerResult.of(learner, report, flags=[str(w) for w in batch.get("warnings") or []],
                     files_hash=batch.get("files_hash"), content_hash=batch.get("hash"),
                     manifest_handout=manifest.get("handout"), submitted=batch.get("submitted")), report, batch


class PackedResults(Mapping):
    """grader.course.history.Result by learner, in the order added, each kept packed (marshal, the values' types kept:
    5 is not 5.0; compressed where that pays: about 1 kB for a graded learner) and unpacked when read: a class's
    results in a fraction of the memory of the objects, and none of it scattered among the reports read meanwhile."""

    def __init__(self) -> None:
        from grader.model import LearnerResult

        self._packed: dict[str, bytes | object] = {}
        self._fields = tuple(f.name for f in fields(LearnerResult))

    def add(self, result) -> None:
        try:
            data = marshal.dumps(tuple(getattr(result, name) for name in self._fields))
        except ValueError:  # a value marshal does not know: kept as it is
            self._packed[result.learner] = result
            return
        self._packed[result.learner] = b"z" + zlib.compress(data, 1) if len(data) > 512 else b"m" + data

    def __getitem__(self, learner: str):
        from grader.model import LearnerResult

        packed = self._packed[learner]
        if not isinstance(packed, bytes):
            return packed
        return LearnerResult(*marshal.loads(zlib.decompress(packed[1:]) if packed[:1] == b"z" else packed[1:]))

    def __contains__(self, learner: object) -> bool:
        return learner in self._packed

    def __iter__(self) -> Iterator[str]:
        return iter(self._packed)

    def __len__(self) -> int:
        return len(self._packed)


class ClassOutputs:
    """What the class outputs need of every learner, taken in learner by learner in the batch's order (the
    order of `learners`) as each is graded: the report is counted into the summary (grader.render.summary.Tally)
    and its <testsuite> written into a scratch file for junit.xml (grader.render.lms.JUnit), then let go; what
    stays per learner is small (its history LearnerResult, packed: PackedResults; its flags; whether it has a
    submission time). A learner graded before its turn waits with its report, at most HELD_REPORTS of them; the
    report of any other is read again from report.json when its turn comes. So the memory of a batch does not
    grow with its reports."""

    def __init__(self, out: Path, learners: list[str], statuses: dict, messages: dict,
                 chapters: list[str] = ()) -> None:
        from grader.course import statistics
        from grader.quiz import class_questions
        from grader.render import lms, summary

        self.out, self.learners, self.statuses, self.messages = out, learners, statuses, messages
        self.position = 0  # learners[:position] are taken in
        self.waiting: dict[str, tuple | None] = {}  # graded before their turn: the state, None to read again
        self.held: set[str] = set()  # those waiting with their report
        self.results = PackedResults()  # grader.course.history.Result by learner, in order
        self.flagged: dict[str, list[str]] = {}
        self.not_graded: dict[str, str] = {}
        self.graded: list[str] = []
        self.untimed: list[str] = []  # graded without a submission time
        catalogue = class_questions(list(chapters))
        self.tally = summary.Tally(catalogue)  # the summary reads no bank or key
        self.items = statistics.collector(list(chapters), catalogue)  # each item's points per learner
        # no name in OUT: gone even when the batch is killed; closed by close()
        self.scratch = tempfile.TemporaryFile("w+", encoding="utf-8", newline="", dir=out)  # noqa: SIM115
        self.junit = lms.JUnit(self.scratch)

    def arrived(self, learner: str, state: tuple) -> None:
        """A learner just graded, with its _learner_state."""
        if state[1] is not None and learner != self.learners[self.position]:
            if len(self.held) < HELD_REPORTS:
                self.held.add(learner)
            else:
                state = None
        self.waiting[learner] = state
        while self.position < len(self.learners) and self.learners[self.position] in self.waiting:
            self._take(self.learners[self.position])

    def finish(self) -> None:
        """Take in every learner not taken in yet (the report.json of those that did not arrive is read)."""
        while self.position < len(self.learners):
            self._take(self.learners[self.position])

    def close(self) -> None:
        self.scratch.close()
        self.tally.close()

    def _take(self, learner: str) -> None:
        state = self.waiting.pop(learner, None)
        self.held.discard(learner)
        self.position += 1
        result, report, batch = state or _learner_state(self.out, learner, self.statuses.get(learner, "graded"),
                                                        self.messages.get(learner, ""))
        self.results.add(result)
        if report is None:
            self.not_graded[learner] = result.message
            return
        if result.flags:
            self.flagged[learner] = result.flags
        extra = {"seconds": batch.get("seconds") or 0.0, "output": batch.get("learner_output", ""),
                 "manifest": batch.get("manifest"), "submitted": batch.get("submitted")}
        self.graded.append(learner)
        if batch.get("time_from") != "roster":  # no time, or only the learner's own (their manifest's)
            self.untimed.append(learner)
        self.tally.add(learner, report, extra)
        self.items.add(learner, report)
        self.junit.add(learner, report, extra)


def rebuild(out: Path, history, run: int, chapters: list[str], collected: ClassOutputs, skipped: list[Skipped] = (),
            isolation: str = "", lms_layouts: tuple[str, ...] = (), overrides=(), override_problems: list[str] = (),
            similarity: bool = False, deadline: bool = False) -> dict:
    """Close the run in the history and write every class output from it: gradebook.csv, changes.csv (and
    gradebook-canvas.csv, gradebook-moodle.csv as asked) as exports of the history; junit.xml, summary.html
    and summary.json (with the item statistics, grader.course.statistics) from the per-learner reports. A gradebook.csv
    changed by hand since the last run is kept as gradebook.edited-<time>.csv (it is an export: changes belong
    in overrides.csv) and said so. `collected` (ClassOutputs) has taken in the learners graded so far; the
    others' report.json are read here. Returns what was flagged per learner, the changes, the similar pairs and notes for the instructor."""
    from grader.course import history as histories
    from grader.course import statistics
    from grader.render import lms, summary

    collected.finish()
    results, flagged, graded = collected.results.values(), collected.flagged, collected.graded  # read one by one
    applied = {(r.learner, a["source"]): a for r in results for a in r.adjustments if a["kind"] == "override"}
    override_rows = [(o.learner, o.target, o.points, o.factor, o.reason, o.who, o.source,
                      f"{applied[(o.learner, o.source)]['points']:+g}" if (o.learner, o.source) in applied
                      else "not applied (the learner is not graded)") for o in overrides]
    moved = histories.changes(history, run, collected.results)
    notes = _keep_hand_edits(out, history, run)
    untimed = collected.untimed
    if deadline and untimed:
        notes.append(f"no trusted submission time for {len(untimed)} of {len(graded)} graded (no `submitted` in the "
                     "roster for them; a time only from their own archive's manifest counts only with "
                     f"manifest_time: accept): {', '.join(untimed[:20])}" + (" ..." if len(untimed) > 20 else ""))
    digest = hashlib.sha256()

    def gradebook(handle) -> None:
        for line in lms.gradebook_lines(results, chapters):
            digest.update(line.encode())
            handle.write(line)

    written = write_atomically_from(out / "gradebook.csv", gradebook, replace=False)
    history.finish(run, results, override_rows, moved, digest.hexdigest())
    os.replace(written, out / "gradebook.csv")
    write_atomically(out / "changes.csv", lms.changes_csv(moved))
    if "canvas" in lms_layouts:
        write_atomically(out / "gradebook-canvas.csv", lms.canvas_gradebook(results, chapters))
    if "moodle" in lms_layouts:
        write_atomically(out / "gradebook-moodle.csv", lms.moodle_gradebook(results, chapters))
    write_atomically_from(out / "junit.xml", collected.junit.write)  # the suites copied from the scratch file
    similar = []
    if similarity:
        from grader.course import similarity as similarities

        try:
            similar, left_out = similarities.rank(out / STAGING, graded)
        except Exception as exc:  # noqa: BLE001  a ranking for a person to look at never costs the class outputs
            similar, left_out = [], [f"--similarity could not rank this class ({type(exc).__name__}: {exc})"]
        notes += left_out
    view = summary.Summary(collected.tally, collected.not_graded, isolation,
                           [(s.name, s.reason) for s in skipped], flagged, moved, list(override_problems) + notes,
                           similar=similar, untimed=list(untimed) if deadline else [],
                           statistics=statistics.compute(collected.items))
    write_atomically_from(out / "summary.html", lambda handle: handle.writelines(summary.html_parts(view)))
    write_atomically_from(out / "summary.json", lambda handle: summary.write_json(view, handle))
    return {"flagged": flagged, "changes": moved, "similar": similar, "notes": notes}


def _keep_hand_edits(out: Path, history, run: int) -> list[str]:
    """gradebook.csv as the last run exported it, or else kept under another name before it is replaced."""
    path = out / "gradebook.csv"
    previous = history.previous(run)
    exported = history.run_info(previous).get("gradebook_sha") if previous else None
    if not exported or not path.is_file() or hashlib.sha256(path.read_bytes()).hexdigest() == exported:
        return []
    kept = out / f"gradebook.edited-{time.strftime('%Y%m%d-%H%M%S')}.csv"
    path.replace(kept)
    return [f"gradebook.csv was changed by hand since the last run; it is an export of gradebook.db and is written "
            f"anew each run: your copy is kept as {kept.name}. Put score changes in overrides.csv (learner, target, "
            "points or factor, reason, who): they are applied on every run and kept in the history."]


def progress_bar(stream=sys.stderr):
    """A one-line progress bar with ETA on a terminal; nothing otherwise."""
    if not stream.isatty():
        return None

    def show(done: int, total: int, elapsed: float) -> None:
        rate = done / elapsed if elapsed > 0 else 0
        eta = (total - done) / rate if rate > 0 else 0
        width = 30
        filled = int(width * done / max(total, 1))
        stream.write(f"\r[{'#' * filled}{'.' * (width - filled)}] {done}/{total}  {rate:.1f}/s  ETA {eta:4.0f} s")
        if done == total:
            stream.write("\n")
        stream.flush()

    return show
