"""What a run's grades are shown in: each learner's files (report.json, results.json, report.html in OUT/<folder>/)
and the class outputs, rebuilt by one function (rebuild) from the history after every run that records anything
(a batch, `grade regrade --apply`): gradebook.csv, changes.csv, the Canvas and Moodle gradebooks, junit.xml,
summary.html and summary.json. So no class file is older than the history, and every one shows the grade the
history holds.

A learner's files are a function of their report (as judged, with its adjustments) and what their staging found
(LearnerFacts): learner_files. What a learner reads never holds a seed other than the public one.
"""

from __future__ import annotations

import hashlib
import marshal
import os
import tempfile
import time
import zlib
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import TYPE_CHECKING

from grader.course import history as histories
from grader.course import statistics
from grader.course.staging import STAGING, folder_name
from grader.course_config import PUBLIC_SEED, CourseError
from grader.files import write_atomically, write_atomically_from
from grader.model import LearnerResult, Report, check_texts
from grader.quiz import class_questions
from grader.render import lms, plural, summary
from grader.safe_text import ascii_as_escaped, json_spliced, json_text, unicode_json

if TYPE_CHECKING:
    from grader.course.history import History
    from grader.course.settings import RunSettings
    from grader.course.staging import Skipped
    from grader.course.workers import Grading, Staged

HELD_REPORTS = 32  # reports graded before their turn in the class outputs kept meanwhile; others are read again
LEARNER_OUTPUT = 4000  # characters of what a learner's code printed that the history and their report.json keep
LMS_FILES = {"canvas": "gradebook-canvas.csv", "moodle": "gradebook-moodle.csv"}


# ------------------------------------------------------------------------------------ a learner's files

@dataclass(frozen=True)
class LearnerFacts:
    """What a learner's report.json keeps beside the report: what staging found (warnings, the submission time and
    where it came from, the archive's manifest, the files' hash, the content hash), the seconds grading took and
    what the learner's code printed; `extra`: what the batch adds (a cluster worker's isolation line)."""

    learner: str
    warnings: tuple[str, ...] = ()
    seconds: float = 0.0
    files_hash: str | None = None
    submitted: str | None = None
    time_from: str | None = None
    manifest: dict | None = None
    digest: str | None = None
    learner_output: str = ""
    extra: Mapping = field(default_factory=dict)

    @classmethod
    def of(cls, staged: Staged, report: Report | None = None, extra: Mapping = ()) -> LearnerFacts:
        """The facts of a learner just staged, and graded into `report` (None: not graded)."""
        return cls(staged.learner, tuple(staged.warnings) + tuple(report.flags if report else ()),
                   round(staged.seconds, 3), staged.files_hash, staged.submitted or None, staged.time_from,
                   staged.manifest, staged.digest, report.learner_output[:LEARNER_OUTPUT] if report else "",
                   dict(extra))

    @classmethod
    def of_result(cls, result: LearnerResult, report: Report | None = None, extra: Mapping = ()) -> LearnerFacts:
        """The facts of a learner as the history records them."""
        return cls(result.learner, tuple(result.flags), round(result.seconds or 0.0, 3), result.files_hash,
                   result.submitted, result.time_from, result.manifest, result.content_hash,
                   report.learner_output[:LEARNER_OUTPUT] if report is not None else "", dict(extra))

    def result(self, report: Report | None, status: str = "graded", message: str = "") -> LearnerResult:
        """The history's line for this learner graded with `report` (adjusted; None: not graded, `status` says why
        and `message` how)."""
        manifest = self.manifest or {}
        return LearnerResult.of(self.learner, report, status, message, flags=list(self.warnings),
                                files_hash=self.files_hash, content_hash=self.digest if report else None,
                                manifest_handout=manifest.get("handout"), submitted=self.submitted,
                                time_from=self.time_from, seconds=self.seconds, manifest=self.manifest)


def report_json(report: Report, facts: LearnerFacts, chapters: list[dict] | None = None) -> str:
    """A learner's report.json: the report (grader/schemas/batch-report.schema.json) and what the batch keeps; a
    seed other than the public one is not in it (null: the learner reads this file). `chapters`: its chapters'
    to_dict(), made already."""
    data = report.to_dict(chapters)
    if report.seed != PUBLIC_SEED:
        data["seed"] = None
        data["provenance"]["seed"] = None
    data["batch"] = {"seconds": facts.seconds, "learner_output": facts.learner_output,
                     "warnings": list(facts.warnings), "files_hash": facts.files_hash, "submitted": facts.submitted,
                     "time_from": facts.time_from, "manifest": facts.manifest}
    if not report.infrastructure and facts.digest:
        data["batch"]["hash"] = facts.digest
    data["batch"].update(facts.extra)
    texts = check_texts(report.chapters, data["chapters"], "report.json text", unicode_json)
    text = json_spliced(data, texts, unicode_json, ("chapters", "checks"))
    return (text if ascii_as_escaped(text) else json_text(data)) + "\n"  # json_text's text, its check dicts made once


def learner_files(report: Report, facts: LearnerFacts, grading: Grading,
                  chapters: list[dict] | None = None) -> dict[str, str | None]:
    """The texts of a graded learner's files, in the order they are written: results.json (Gradescope's format),
    report.html (where the run writes it) and report.json, last: it marks the learner done (`chapters`: the
    report's chapters' to_dict(), made already)."""
    files: dict[str, str | None] = {
        "results.json": lms.gradescope(report, hidden=grading.hidden, execution_time=facts.seconds,
                                       heading=[f"Graded as {facts.learner}."], notes=list(facts.warnings))}
    if grading.html:
        from grader.render import html

        # a worker draws its learner's figures itself: the other workers keep the other cores busy
        files["report.html"] = html.render(report, draw_here=True, learner_sees=True)
    files["report.json"] = report_json(report, facts, chapters)
    return files


def not_graded_files(report: Report, staged: Staged, extra: Mapping = ()) -> dict[str, str | None]:
    """A learner who could not be graded for a reason outside their code: results.json and report.html removed, so
    that nothing looks like a grade; report.json says why (and keeps no hash: the next run grades it again)."""
    facts = LearnerFacts.of(staged, report, extra)
    return {"results.json": None, "report.html": None, "report.json": report_json(report, facts)}


def graded_message(report: Report) -> str:
    """The one line a batch prints of a graded learner: the score, and the chapters with problems."""
    problems = sum(bool(c.problems) for c in report.chapters)
    return f"{report.score:g}/{report.max_score:g}" + (f", {plural(problems, 'chapter')} with problems"
                                                       if problems else "")


def write_learner_files(out: Path, learner: str, files: Mapping[str, str | None]) -> None:
    """Write (or remove) a learner's files in OUT/<folder>/, each atomically, report.json last: a reader never sees
    half a file. The coordinator alone writes into OUT."""
    if not files:
        return
    folder = out / folder_name(learner)
    folder.mkdir(parents=True, exist_ok=True)
    for name, text in files.items():
        if text is None:
            (folder / name).unlink(missing_ok=True)
        else:
            write_atomically(folder / name, text)


def shown_alike(before: LearnerResult | None, after: LearnerResult) -> bool:
    """Whether a learner's files show the same for `after` as they showed for `before` (the same report as judged,
    adjustments, warnings and submission time): then they are not written again."""
    if before is None:
        return False
    keys = ("status", "report", "adjustments", "flags", "submitted", "time_from", "manifest", "files_hash")
    return all(getattr(before, key) == getattr(after, key) for key in keys)


# ------------------------------------------------------------------------------------ the class outputs

class PackedResults(Mapping):
    """LearnerResult by learner, in the order added, each kept packed (marshal, the values' types kept: 5 is not
    5.0; compressed where that pays: about 1 kB for a graded learner) and unpacked when read: a class's results in a
    fraction of the memory of the objects, and none of it scattered among the reports read meanwhile."""

    def __init__(self) -> None:
        self._packed: dict[str, bytes | object] = {}
        self._fields = tuple(f.name for f in fields(LearnerResult))

    def add(self, result: LearnerResult) -> None:
        try:
            data = marshal.dumps(tuple(getattr(result, name) for name in self._fields))
        except ValueError:  # a value marshal does not know: kept as it is
            self._packed[result.learner] = result
            return
        self._packed[result.learner] = b"z" + zlib.compress(data, 1) if len(data) > 512 else b"m" + data

    def __getitem__(self, learner: str) -> LearnerResult:
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
    """What the class outputs need of every learner of a run, taken in learner by learner in the run's order (the
    order of `learners`) as each is recorded: the report is counted into the summary (grader.render.summary.Tally)
    and its <testsuite> written into a scratch file for junit.xml (grader.render.lms.JUnit), then let go; what
    stays per learner is small (its LearnerResult, packed; its flags). A learner recorded before its turn waits with
    its report, at most HELD_REPORTS of them; the report of any other is read from the history when its turn comes.
    So the memory of a batch does not grow with its reports."""

    def __init__(self, out: Path, history: History, run: int, learners: list[str], chapters: list[str]) -> None:
        self.out, self.history, self.run = out, history, run
        self.learners = class_order(learners, history.settings(run))  # every class output's rows in this order
        self.position = 0  # learners[:position] are taken in
        self.waiting: dict[str, tuple | None] = {}  # recorded before their turn: (result, report), None to read again
        self.held: set[str] = set()  # those waiting with their report
        self.results = PackedResults()  # LearnerResult by learner, in order
        self.flagged: dict[str, list[str]] = {}
        self.not_graded: dict[str, str] = {}
        self.graded: list[str] = []
        self.untimed: list[str] = []  # graded without a trusted submission time
        catalogue = class_questions(list(chapters))
        self.tally = summary.Tally(catalogue)  # the summary reads no bank or key
        self.items = statistics.collector(list(chapters), catalogue)  # each item's points per learner
        # no name in OUT: gone even when the batch is killed; closed by close()
        self.scratch = tempfile.TemporaryFile("w+", encoding="utf-8", newline="", dir=out)  # noqa: SIM115
        self.junit = lms.JUnit(self.scratch)

    def arrived(self, result: LearnerResult, report: Report | None) -> None:
        """A learner just recorded, with its report (adjusted; None: not graded)."""
        learner = result.learner
        state: tuple | None = (result, report)
        if report is not None and learner != self.learners[self.position]:
            if len(self.held) < HELD_REPORTS:
                self.held.add(learner)
            else:
                state = None
        self.waiting[learner] = state
        while self.position < len(self.learners) and self.learners[self.position] in self.waiting:
            self._take(self.learners[self.position])

    def finish(self) -> None:
        """Take in every learner not taken in yet (their results and reports read from the history)."""
        while self.position < len(self.learners):
            self._take(self.learners[self.position])

    def close(self) -> None:
        self.scratch.close()
        self.tally.close()

    def _take(self, learner: str) -> None:
        state = self.waiting.pop(learner, None)
        self.held.discard(learner)
        self.position += 1
        if state is None:  # not held: its result and report as the history recorded them
            result = self.history.result(self.run, learner)
            if result is None:
                return  # none recorded in this run
            state = (result, None)
        result, report = state
        if report is None and result.status == "graded":
            report = self.history.report(result)
        self.results.add(result)
        if report is None:
            self.not_graded[learner] = result.message
            return
        if result.flags:
            self.flagged[learner] = list(result.flags)
        extra = {"seconds": result.seconds or 0.0, "output": report.learner_output, "manifest": result.manifest,
                 "submitted": result.submitted}
        self.graded.append(learner)
        if result.time_from != "roster":  # no time, or only the learner's own (their manifest's)
            self.untimed.append(learner)
        self.tally.add(learner, report, extra)
        self.items.add(learner, report)
        self.junit.add(learner, report, extra)


def class_order(learners: list[str], settings: RunSettings | None) -> list[str]:
    """The order of every class output's rows: the roster's (by the first row naming each learner) where the run had
    one, then those it names not, by id; without a roster, by id. Never the order of the submissions' folders."""
    from grader.csvtable import TableError, read_table

    rank: dict[str, int] = {}
    roster = settings.roster if settings is not None else None
    if roster is not None and roster.text is not None:
        try:
            rows = read_table(Path(roster.path or "roster"), ("submission", "learner"), roster.text)
        except TableError:
            rows = []
        for _, row in rows:
            if row["submission"]:
                rank.setdefault(row["learner"], len(rank))
    return sorted(learners, key=lambda learner: (0, rank[learner], "") if learner in rank else (1, 0, learner))


@dataclass
class Rebuilt:
    """What a rebuild found for the instructor: the learners flagged, the changes since the last finished run (and
    whether there was one), the similar pairs, and its own notes (a gradebook edited by hand, learners without a
    trusted time, what similarity could not rank)."""

    flagged: dict[str, list[str]]
    changes: list[tuple]
    first_run: bool
    similar: list
    notes: list[str]


def rebuild(out: Path, history: History, run: int, settings: RunSettings, collected: ClassOutputs | None = None, *,
            overrides: list[tuple] = (), notes: list[str] = (), skipped: list[Skipped] = (), isolation: str = "",
            roster: dict | None = None, similarity: bool = False) -> Rebuilt:
    """Close `run` in the history and write every class output from it: gradebook.csv, changes.csv and the LMS
    gradebooks (those the run asks for, and any OUT holds already) as exports of its results; junit.xml,
    summary.html and summary.json (with the item statistics, grader.course.statistics) from its reports.
    `collected` has taken in the learners recorded so far (their reports in memory); the others' are read from the
    history. `overrides`: each row in force and what it did (learner, target, points, factor, reason, who, source,
    said). A gradebook.csv changed by hand since the last run is kept as gradebook.edited-<time>.csv (it is an
    export: changes belong in overrides.csv) and said so."""
    chapters = list(settings.chapters)
    own = collected is None
    if own:
        collected = ClassOutputs(out, history, run, list(history.results(run)), chapters)
    try:
        collected.finish()
        results, graded = collected.results.values(), collected.graded  # read one by one
        position = {learner: i for i, learner in enumerate(collected.learners)}  # changes.csv in the class's order too
        moved = sorted(histories.changes(history, run, collected.results),
                       key=lambda change: (position.get(change[0], len(position)), change[0]))
        first_run = history.previous(run) is None
        found = _keep_hand_edits(out, history, run)
        deadline = has_deadline(settings)
        if deadline and collected.untimed:
            found.append(_untimed_line(collected.untimed, len(graded), settings.roster.path))
        digest = hashlib.sha256()

        def gradebook(handle) -> None:
            for line in lms.gradebook_lines(results, chapters):
                digest.update(line.encode())
                handle.write(line)

        written = write_atomically_from(out / "gradebook.csv", gradebook, replace=False)
        history.finish(run, list(results), list(overrides), moved, digest.hexdigest())
        os.replace(written, out / "gradebook.csv")
        write_atomically(out / "changes.csv", lms.changes_csv(moved))
        for layout in lms_layouts(out, settings):
            write = lms.canvas_gradebook if layout == "canvas" else lms.moodle_gradebook
            write_atomically(out / LMS_FILES[layout], write(list(results), chapters))
        write_atomically_from(out / "junit.xml", collected.junit.write)  # the suites copied from the scratch file
        similar = []
        if similarity:
            from grader.course import similarity as similarities

            try:
                similar, left_out = similarities.rank(out / STAGING, graded)
            except Exception as exc:  # noqa: BLE001  a ranking for a person to look at never costs the class outputs
                similar, left_out = [], [f"--similarity could not rank this class ({type(exc).__name__}: {exc})"]
            found += left_out
        view = summary.Summary(collected.tally, collected.not_graded, isolation,
                               [(s.name, s.reason) for s in skipped], collected.flagged, moved, list(notes) + found,
                               similar=similar, untimed=list(collected.untimed) if deadline else [],
                               statistics=statistics.compute(collected.items), first_run=first_run,
                               roster=roster or {})
        write_atomically_from(out / "summary.html", lambda handle: handle.writelines(summary.html_parts(view)))
        write_atomically_from(out / "summary.json", lambda handle: summary.write_json(view, handle))
    finally:
        if own:
            collected.close()
    return Rebuilt(collected.flagged, moved, first_run, similar, found)


def _untimed_line(untimed: list[str], graded: int, roster: str | None) -> str:
    """One line for every learner graded without a trusted submission time, and why (each learner's own reason, a
    roster time that is not a time or a manifest's time not trusted, is flagged on that learner)."""
    why = ("no roster was given, and a late penalty trusts only a roster's `submitted` column (or, with "
           "manifest_time: accept, the learner's own archive manifest)" if roster is None else
           "no usable `submitted` in the roster for them (a time only from their own archive's manifest counts only "
           "with manifest_time: accept)")
    names = ", ".join(untimed[:20]) + (" ..." if len(untimed) > 20 else "")
    return f"no trusted submission time for {len(untimed)} of {graded} graded: {why}: {names}"


def lms_layouts(out: Path, settings: RunSettings) -> list[str]:
    """The LMS gradebooks a rebuild writes: those the run asks for, and those OUT holds from an earlier run (an
    export left as it was would show old grades)."""
    return [layout for layout, name in LMS_FILES.items() if layout in settings.lms or (out / name).is_file()]


def has_deadline(settings: RunSettings) -> bool:
    """Whether the run's course file sets a deadline with a late penalty (so a time is needed)."""
    try:
        course = settings.course_file()
    except CourseError:
        return False
    return bool(course and course.late)


def _keep_hand_edits(out: Path, history: History, run: int) -> list[str]:
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


def override_rows(rows: list, outcomes: Mapping[tuple[str, str], str], graded: set[str]) -> list[tuple]:
    """Each override row in force with what it did (as the history keeps it): its outcome for its learner where
    they were graded, else why not."""
    return [(o.learner, o.target, o.points, o.factor, o.reason, o.who, o.source,
             outcomes.get((o.learner, o.source), "not applied (the learner is not graded)" if o.learner not in graded
                          else "not applied")) for o in rows]
