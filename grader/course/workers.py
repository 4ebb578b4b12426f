"""What a batch's worker does with one learner: stage the submission, decide whether it is due, grade it through
the one transaction (grader.core.transaction.grade_submission) behind the worker's resident door, and render the
learner's files; and the pool of such workers on this machine (LocalPool; grader.course.cluster.ClusterPool runs
the same on a Dask cluster).

A worker returns plain data (Outcome): the learner's status, the report as judged (kept as the history keeps it),
its adjustments, what each override did and the texts of its files. Only the coordinator (grader.course.batch)
writes the learners' files into OUT and records the history; a worker writes only the record of the files it stages
(OUT/.staging/.records, grader.course.staging.keep).
"""

from __future__ import annotations

import gc
import hashlib
import json
import os
import time
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

from grader import provenance
from grader.boundary import BoundaryUnavailable, Limits, SandboxMode
from grader.core.memo import Memo
from grader.core.pipeline import Request
from grader.core.policy import Override, Policy, parse_time
from grader.core.transaction import Door, grade_submission
from grader.course import outputs, submit
from grader.course.history import kept_report
from grader.course.staging import (
    STAGING,
    Entry,
    StagingError,
    keep,
    kept_place,
    put,
    read_kept,
    submitted_files,
)
from grader.quiz import learner_id
from grader.submission import Submission

if TYPE_CHECKING:
    from grader.course_config import Course
    from grader.model import Report

RETRY_PAUSE = 1.0  # seconds before a learner whose child could not start is tried again


class InfrastructureError(RuntimeError):
    """Grading cannot work here (the sandbox does not start): no learner is graded."""


@dataclass(frozen=True)
class Grading:
    """What every learner of a run is graded with, the same wherever it is graded (plain data: it travels with each
    task to a cluster's workers). `hidden` (the course's hidden check ids) are shown in results.json only after
    grades are published; `course` leaves out the checks it switches off and gives the late penalty and the
    current handout; `render`: the worker renders the learner's files (a regrade renders only those that move)."""

    chapters: tuple[str, ...]
    seed: int
    html: bool = True
    plots: bool = False
    limits: Mapping = field(default_factory=dict)
    sandbox: str = SandboxMode.REQUIRED.value
    hidden: frozenset[str] = frozenset()
    course: Course | None = None
    render: bool = True

    def judging(self, learner: str) -> str:
        """What a learner's report as judged depends on beside their files: a report graded with the same is not
        graded again."""
        course = self.course
        return json.dumps([list(self.chapters), self.seed, provenance.code_digest()[:16], self.plots,
                           sorted(dict(self.limits).items()), learner, course.id if course else None,
                           course.exact_derivatives if course else True,
                           [course.practice(c) for c in self.chapters] if course else []], default=str)


@dataclass
class Staged:
    """A learner staged and due for grading (plain data): the folder its files were put in to be read here (`root`:
    a process's own, reused for the next learner; for a learner staged again from what the batch kept, staged_again,
    that place: a worker puts the files into its own folder and grades them there, _grade_one), its content hash,
    what was found while staging (warnings, the submission time and where it came from, its manifest), its
    overrides, the seconds staging took, and where the batch keeps its files (`kept`:
    grader.course.staging.kept_place)."""

    learner: str
    root: str
    digest: str
    warnings: list[str]
    submitted: str
    time_from: str | None
    manifest: dict | None
    other_ids: tuple[str, ...]
    files_hash: str
    overrides: tuple[Override, ...] = ()
    seconds: float = 0.0
    learner_from: str = ""  # where its id came from (the roster and line, the submission's name), for the report
    kept: str = ""

    def files(self) -> dict[str, bytes]:
        """The staged files (relative path -> bytes), as the batch keeps them: what a worker grades (put into a
        folder of its own), wherever it is."""
        files = read_kept(Path(self.kept)) if self.kept else None
        if files is None:
            raise StagingError(f"the files kept of {self.learner} ({self.kept}) cannot be read")
        return dict(sorted(files.items()))

    def policy(self, course: Course | None) -> Policy:
        """What this learner's grade is adjusted by: their overrides, and the late penalty at their trusted time."""
        return Policy(tuple(self.overrides), course.late if course else None, parse_time(self.submitted))


@dataclass
class Outcome:
    """One learner's outcome as plain data. status: "graded" (now: `kept` is the report as judged, as the history
    keeps it, grader.course.history.kept_report, and `report` that report adjusted), "unchanged" (its files, grader
    and settings as when the history last kept its report: not graded again), "unreadable" or "error"; the message;
    `staged` (what staging found);
    the adjustments made and what each override did (its source, whether applied, in words); the texts of its
    files in OUT/<folder>/ in the order they are written (None: remove that file), report.json last;
    `infrastructure`: why it could not be graded for a reason outside the learner's code ("" when it was)."""

    learner: str
    status: str
    message: str
    staged: Staged | None = None
    kept: tuple[str, bytes] | None = None
    report: Report | None = None  # graded now, adjusted: a grader process's own object, never learner code's
    adjustments: list[dict] = field(default_factory=list)
    outcomes: list[tuple[str, bool, str]] = field(default_factory=list)
    files: dict[str, str | None] = field(default_factory=dict)
    infrastructure: str = ""
    extra: dict = field(default_factory=dict)  # what the batch keeps beside (a cluster worker's isolation line)


# ------------------------------------------------------------------------------------ staging

def content_hash(learner: str, grading: Grading, files: Mapping[str, bytes]) -> str:
    """What a learner's report as judged depends on: the staged files (posix path in exercises/ -> bytes: what
    staging wrote) and Grading.judging. In the order of their paths' parts, as sorted Paths are."""
    digest = hashlib.sha256(grading.judging(learner).encode("utf-8", "surrogatepass"))
    for name in sorted(files, key=lambda n: n.split("/")):
        digest.update(f"exercises/{name}".encode("utf-8", "surrogatepass") + b"\0" + files[name] + b"\0")
    return digest.hexdigest()


def scratch(files: dict[str, bytes]) -> Path:
    """This process's folder for the files of the learner it stages or grades, put there (the same folder for each,
    one at a time: a file put there again with the same name is rewritten, not made anew; only this process writes
    it, so what it holds is known without reading it back), in memory where the system has room for it
    (grader.system.memory_temp_dir), removed as the process ends. A folder removed meanwhile by anyone else (a
    temporary-file cleaner, the end of a login session, which empties /dev/shm) is made anew, nothing of it trusted."""
    pid, folder, _ = _worker_state.get("scratch", (None, None, None))
    if pid != os.getpid() or not _scratch_intact():  # (a worker forked from a process that had one makes its own)
        import shutil
        import tempfile
        from multiprocessing.util import Finalize

        from grader.system import memory_temp_dir

        folder = Path(tempfile.mkdtemp(prefix="grade-staged-", dir=memory_temp_dir()))
        Finalize(None, shutil.rmtree, args=(folder, True), exitpriority=10)  # a pool's worker runs no atexit
        found = folder.stat()
        _worker_state["scratch"] = (os.getpid(), folder, (found.st_dev, found.st_ino))
        _worker_state["scratch_files"] = {}
    put(files, folder / "exercises", _worker_state["scratch_files"])
    return folder


def _scratch_intact() -> bool:
    """Whether this process's scratch folder is still the one it made (not removed, nor removed and made again)."""
    pid, folder, made = _worker_state.get("scratch", (None, None, None))
    if pid != os.getpid():
        return False
    try:
        found = folder.stat()
    except OSError:
        return False
    return (found.st_dev, found.st_ino) == made


SCRATCH_GONE = ("its files were removed from the grader's scratch folder while it was graded (by a temporary-file "
                "cleaner, or the end of the login session that started the batch); the next run grades it again")


def drop_scratch() -> None:
    """Remove this process's scratch folder now (a command that leaves by os._exit runs no exit handler)."""
    pid, folder, _ = _worker_state.pop("scratch", (None, None, None))
    if pid == os.getpid():
        import shutil

        shutil.rmtree(folder, ignore_errors=True)


def stage_one(entry: Entry, out: Path, grading: Grading, overrides: tuple = (), previous: str | None = None,
              force: bool = False) -> Staged | Outcome:
    """Stage one submission: its files kept in OUT/.staging (grader.course.staging.keep: one record each) and put
    into this process's scratch folder to be read; the Staged learner, due for grading, or its Outcome without grading
    (unreadable; unchanged: its content hash is `previous`, that of the report the history keeps, unless `force`).
    The manifest of an archive made by `grade submit` is checked (grader.course.submit.check) and what it says is
    flagged."""
    started = time.monotonic()
    learner = entry.learner
    try:
        files = submitted_files(entry)  # each file read once: the hashes are made from these
    except StagingError as exc:
        return Outcome(learner, "unreadable", f"{entry.source.name}: {exc}")
    kept = keep(out / STAGING, learner, files)
    root = scratch(files)
    course = grading.course
    course_id, handout = (course.id, course.current_handout) if course else (None, None)
    manifest, manifest_flags = submit.check(root / "exercises", learner, course_id, handout)
    submitted, timing = submission_time(entry, manifest, course, root / "exercises")
    staged = Staged(learner, str(root), content_hash(learner, grading, files),
                    learner_yaml_warnings(root, learner, entry.origin) + manifest_flags + timing, submitted,
                    _time_source(entry, submitted), _manifest_summary(manifest),
                    (str(manifest.get("learner")),) if manifest else (), submit.files_hash(root / "exercises", files),
                    tuple(overrides), time.monotonic() - started, entry.origin, str(kept))
    if staged.digest == previous and not force:
        return Outcome(learner, "unchanged", "already graded, files unchanged", staged)
    return staged


def learner_yaml_warnings(root: Path, learner: str, origin: str = "") -> list[str]:
    """A staged submission's own answers/learner.yaml naming someone other than the id it is graded as (its folder
    or zip name, or the roster): the quiz numbers and option letters are the graded id's, so answers worked out for
    the other id's do not match. One sentence saying so, or nothing."""
    who, source = learner_id(root / "exercises" / "answers", None)
    if not source.endswith("learner.yaml") or who == learner:
        return []
    where = f" (from {origin})" if origin else ""
    return [(f"learner.yaml names {who!r}, but this submission is graded as {learner!r}{where}: it gets the quiz "
             f"numbers and option letters of {learner!r}, so answers worked out with those of {who!r} do not match; "
             "correct the roster or the file and grade again")]


def submission_time(entry: Entry, manifest: dict | None, course: Course | None,
                    package: Path | None = None) -> tuple[str, list[str]]:
    """(the submission time that decides a late penalty, ISO 8601 or "", and what to flag about it). Trusted: the
    roster's `submitted` column (the LMS's time). The time in the archive's manifest is written on the learner's own
    machine: it is used only where the course accepts it (`manifest_time: accept`), never silently, and never where
    the archive (staged in `package`) was edited after packing. An unparsable time is no time, and said. A learner
    with no time at all is not flagged: the run says once how many are untimed and why (grader.course.outputs)."""
    flags = []
    if entry.submitted:
        if parse_time(entry.submitted) is not None:
            return entry.submitted, flags
        flags.append(f"the roster's submission time {entry.submitted!r} ({entry.origin}) is not a time (ISO 8601, "
                     "e.g. 2026-05-01T23:59:00+02:00)")
    packed = submit.packed_time(manifest)
    if not course or not course.late:
        return "", flags
    if not packed:
        return "", flags
    edited = bool(package is not None and submit.edits(package, manifest))
    if course.accepts_manifest_time and parse_time(packed) is not None and not edited:
        return packed, flags + [f"submission time {packed} from the learner's own archive manifest (the course accepts "
                                "it: manifest_time: accept); the roster gives none"]
    said = (f"its archive's manifest says {packed!r}, but the archive was edited after packing, so that time is not "
            "trusted" if edited else
            f"its archive's manifest says {packed!r}, written on the learner's own machine and not accepted "
            "(manifest_time: accept in the course file would)")
    return "", flags + [f"no trusted submission time: {said}; no late penalty applied"]


def _time_source(entry: Entry, submitted: str) -> str | None:
    """Where the submission time that was used came from: "roster", "manifest", or None (none used)."""
    if not submitted:
        return None
    return "roster" if submitted == entry.submitted else "manifest"


def _manifest_summary(manifest: dict | None) -> dict | None:
    """What the history keeps of a grade submit manifest: who packed it, with which handout and grader, when, and
    the score the packed archive had at home."""
    if manifest is None:
        return None

    def text(value: object) -> str | None:
        return None if value is None else str(value)[:200]

    local = manifest.get("local") if isinstance(manifest.get("local"), dict) else {}
    return {**{key: text(manifest.get(key)) for key in ("learner", "course", "handout", "handout_released", "grader",
                                                        "packed")},
            "local": {key: local[key] for key in ("seed", "score", "max_score", "pending_score")
                      if isinstance(local.get(key), (int, float)) and not isinstance(local.get(key), bool)}}


# ------------------------------------------------------------------------------------ grading

_worker_state: dict = {}


# The collector's thresholds in a batch's processes: a young pass after 20,000 new objects, not 700 (a learner makes
# tens of thousands, nearly all freed by their reference counts; the passes cost a worker about 3 ms a learner, 1 with
# these), and the older generations walked every 10 passes as before. What a learner leaves in a cycle is freed in
# the pass after it: memory does not grow with the class (benchmarks/batch.py --rss).
BATCH_COLLECTION = (20_000, 10, 10)


@contextmanager
def collecting_as_a_batch() -> Iterator[None]:
    """This process's collector at BATCH_COLLECTION meanwhile (a batch's coordinator), as it was after."""
    before = gc.get_threshold()
    gc.set_threshold(*BATCH_COLLECTION)
    try:
        yield
    finally:
        gc.set_threshold(*before)


def _settle_heap() -> None:
    """After a worker's first graded learner, what it imported and cached lives as long as the worker: frozen
    (gc.freeze), the garbage collector's full passes no longer walk it (they took about half its time)."""
    if not _worker_state.get("settled"):
        _worker_state["settled"] = True
        gc.collect()
        gc.freeze()


def _worker_collects_as_a_batch() -> None:
    """A local pool's worker, a process of the batch's own, collects as the batch does (BATCH_COLLECTION) for the rest
    of its life; a cluster's worker (a process shared with others) is left as it is."""
    if not _worker_state.get("collecting"):
        _worker_state["collecting"] = True
        gc.set_threshold(*BATCH_COLLECTION)


def door(sandbox: str, secrets: tuple[str, ...] = ()):
    """This worker's door for `sandbox` (grader.core.transaction.Door, resident: its fork server started on first
    use), kept for every learner it grades with the same mode (a cluster's worker outlives a batch: one asking
    another mode gets a door of its own). `secrets`: what learner code must not read beside the answers (a barrier
    that is not bubblewrap proves it first)."""
    if _worker_state.get("sandbox") != (sandbox, secrets):
        drop_door()
    if "door" not in _worker_state:
        _worker_state["door"] = Door(sandbox, resident=True, pause=RETRY_PAUSE, secrets=secrets)
        _worker_state["sandbox"] = (sandbox, secrets)
    return _worker_state["door"]


def worker_isolation(sandbox: str, secrets: tuple[str, ...] = ()) -> str:
    """The isolation line of this worker's door for `sandbox` (InfrastructureError where it cannot start)."""
    try:
        return door(sandbox, secrets).isolation
    except BoundaryUnavailable as exc:
        drop_door()
        raise InfrastructureError(str(exc)) from None


def drop_door() -> None:
    """Stop this worker's fork server: the next learner gets a new one."""
    chosen = _worker_state.pop("door", None)
    _worker_state.pop("sandbox", None)
    if chosen is not None:
        chosen.close()


def _worker_memo():
    """This worker's verdicts, kept across the learners it grades (grader.core.memo.Memo without a folder): a chapter
    answered exactly as another learner's is judged once."""
    if "memo" not in _worker_state:
        _worker_state["memo"] = Memo(None, "this worker")
    return _worker_state["memo"]


def probe(sandbox: str, secrets: tuple[str, ...] = ()) -> str:
    """The isolation line here, after one child interpreter started the way the workers will start theirs
    (InfrastructureError with the reason when it does not), so that no learner is graded on a broken sandbox."""
    try:
        return Door(sandbox, probe=True, secrets=secrets).isolation
    except BoundaryUnavailable as exc:
        raise InfrastructureError(str(exc)) from None


def grade_staged(staged: Staged, grading: Grading, root: Path | None = None, extra: Mapping = (),
                 secrets: tuple[str, ...] = ()) -> Outcome:
    """Grade a staged learner (in a worker process: here, or on a cluster's worker with its files copied to `root`)
    through the one transaction, its overrides and late penalty applied, and (Grading.render) render its files.
    `secrets`: what learner code must not read beside the answers (a cluster worker's credentials).
    One whose child could not start, twice, is `error`: no report is kept (the next run grades it again), and its
    results.json and report.html are removed, so that nothing looks like a grade."""
    started = time.monotonic()
    learner, course = staged.learner, grading.course
    request = Request(tuple(grading.chapters), grading.seed, learner=learner, plots=grading.plots, label=learner,
                      other_ids=staged.other_ids, learner_from=staged.learner_from or "the batch")
    if course is not None and Path(course.source).is_file():
        secrets = (*secrets, course.source)
    graded = grade_submission(Submission(root or Path(staged.root), "exercises"), request,
                              door(grading.sandbox, secrets),
                              staged.policy(course), limits=Limits(**dict(grading.limits)), course=course,
                              memo=_worker_memo())
    report = graded.report
    staged.seconds += time.monotonic() - started
    if report.infrastructure:
        return _not_graded(staged, report, f"not graded, twice, for a reason outside the learner's code: "
                                           f"{report.infrastructure}; the next run grades it again", extra)
    report.learner_output = report.learner_output[:outputs.LEARNER_OUTPUT]
    chapters = [chapter.to_dict() for chapter in report.chapters]  # made once: the kept report's and report.json's
    kept = kept_report(report, chapters)
    outcome = Outcome(learner, "graded", outputs.graded_message(report), staged, kept, report,
                      [a.to_dict() for a in report.all_adjustments()],
                      [(o.override.source, o.applied, o.said) for o in graded.outcomes], extra=dict(extra))
    if grading.render:
        outcome.files = outputs.learner_files(report, outputs.LearnerFacts.of(staged, report, extra), grading, chapters)
    _settle_heap()
    return outcome


def _grade_one(entry: Entry | Staged, out: str, grading: Grading, overrides: tuple, previous: str | None,
               force: bool) -> Outcome:
    """Stage (an Entry; a Staged learner is staged already) and grade one submission in a worker process of the
    local pool."""
    _worker_collects_as_a_batch()
    if isinstance(entry, Staged):  # staged by the coordinator (grade regrade): its kept files put here
        staged, outcome = entry, grade_staged(entry, grading, root=scratch(entry.files()))
    else:
        staged = stage_one(entry, Path(out), grading, overrides, previous, force)
        if isinstance(staged, Outcome):
            return staged
        outcome = grade_staged(staged, grading)
    if outcome.report is not None and not _scratch_intact():  # what was read of it may be missing: not a grade
        outcome.report.infrastructure = SCRATCH_GONE
        return _not_graded(staged, outcome.report, f"not graded: {SCRATCH_GONE}", outcome.extra)
    return outcome


def _not_graded(staged: Staged, report: Report, message: str, extra: Mapping) -> Outcome:
    """A learner not graded for a reason outside their code (report.infrastructure says which): an error the next run
    grades again, its results.json and report.html removed, so that nothing looks like a grade."""
    return Outcome(staged.learner, "error", message, staged, files=outputs.not_graded_files(report, staged, extra),
                   infrastructure=report.infrastructure, extra=dict(extra))


class LocalPool:
    """The embedded default pool: `jobs` worker processes on this machine (default: one per core), each staging
    and grading its learners behind its own resident door (a sandboxed fork server). A pool is what a batch grades
    through: `isolation` proves learner code can run before anyone is graded, and `grade` yields each learner's
    Outcome as it completes (grader.course.cluster.ClusterPool is the other, on Dask)."""

    def __init__(self, jobs: int | None = None) -> None:
        if jobs is not None and jobs < 1:
            raise ValueError(f"jobs must be at least 1, not {jobs}")
        self.jobs = jobs or os.cpu_count() or 1

    def isolation(self, sandbox: str) -> str:
        """The isolation line here, after one child interpreter started the way the workers will start theirs
        (InfrastructureError with the reason when it does not)."""
        return probe(sandbox)

    def grade(self, tasks: list[Entry | Staged], out: Path, grading: Grading, overrides: Mapping[str, tuple],
              previous: Mapping[str, str] = {}, force: bool = False) -> Iterator[Outcome]:  # noqa: B006
        """Each learner's Outcome, in the order they complete (`previous`: the content hash of each learner's report
        the history keeps; `force`: grade every one again); one whose worker failed is `error`, saying why."""
        with ProcessPoolExecutor(max_workers=max(1, min(self.jobs, len(tasks) or 1))) as pool:
            futures = {pool.submit(_grade_one, task, str(out), grading, tuple(overrides.get(task.learner, ())),
                                   previous.get(task.learner), force): task.learner for task in tasks}
            for future in as_completed(futures):
                learner = futures.pop(future)  # its outcome is let go once taken: memory does not grow with the class
                try:
                    yield future.result()
                except Exception as exc:  # one broken submission never stops the batch
                    yield Outcome(learner, "error", f"{type(exc).__name__}: {exc}")


def staged_again(out: Path, learner: str, result, grading: Grading, overrides: tuple) -> Staged | None:
    """A learner of an earlier run as it was staged (OUT/.staging keeps exactly the files it graded), to be graded
    again (grade regrade) with `grading`, with its submission time as the history keeps it and what its staging finds
    to flag; None where the stored files are gone. Its `root` is where they are kept: a worker puts them into its
    own folder to grade them (_grade_one)."""
    import tempfile

    place = kept_place(out / STAGING, learner)
    files = read_kept(place) if place is not None else None
    if files is None:
        return None
    course = grading.course
    course_id, handout = (course.id, course.current_handout) if course else (None, None)
    try:
        with tempfile.TemporaryDirectory(prefix="grade-staged-") as folder:
            root = Path(folder)
            put(files, root / "exercises")
            manifest, manifest_flags = submit.check(root / "exercises", learner, course_id, handout)
            roster_time = result.submitted if result.time_from == "roster" else ""
            submitted, timing = submission_time(Entry(learner, root, "the history", roster_time or ""), manifest,
                                                course, root / "exercises")
            warnings = learner_yaml_warnings(root, learner) + manifest_flags + timing
    except OSError:  # its files cannot be put where they are read (a full disk): not graded again, said as gone
        return None
    return Staged(learner, str(place), content_hash(learner, grading, files), warnings, submitted,
                  result.time_from if submitted else None, _manifest_summary(manifest),
                  (str(manifest.get("learner")),) if manifest else (), submit.files_hash(root / "exercises", files),
                  tuple(overrides), result.seconds or 0.0, "the history in gradebook.db", str(place))
