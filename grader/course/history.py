"""The course's history: a SQLite gradebook (OUT/gradebook.db) of every run that recorded grades, from which every
class output is rebuilt (grader.course.outputs).

Tables:
- runs: one per `grade batch` (and per `grade regrade --apply`, with its reason): when it started and finished,
  the grader's version, the course's current handout, the course, the seed, the chapters, and everything it ran
  with (grader.course.settings.RunSettings: the course file's and the overrides' text among them).
- results: per run and learner: status, message, the submission's hash (its files only) and the content hash
  (files, grader, seed, what judging depends on), the handout and time in its manifest and where the time came
  from, the score as graded, the score with overrides and penalties, the adjustments, the flags, the scores per
  chapter that the gradebooks export, and the report as judged (its hash in `reports`).
- reports: each report as judged (grader.model.Report.to_kept, compressed), by its hash: a learner graded once
  and unchanged since is kept once, whatever the runs.
- overrides: per run, every row of overrides.csv in force, with what it did.
- changes: per run, each learner whose score moved since the last finished run, by how much, and why.

Every learner's result is written in its own transaction as soon as it is graded (an interrupted run keeps what it
graded; its run stays unfinished, and the next run compares with the last finished one, but reuses what was graded).
"""

from __future__ import annotations

import hashlib
import json
import sqlite3
import zlib
from dataclasses import fields
from datetime import datetime, timezone
from pathlib import Path

from grader.course.settings import RunSettings
from grader.model import LearnerResult, Report, check_texts
from grader.safe_text import json_spliced

FILE_NAME = "gradebook.db"
SCHEMA = """
CREATE TABLE IF NOT EXISTS runs (
    id INTEGER PRIMARY KEY, started TEXT NOT NULL, finished TEXT, grader TEXT NOT NULL, handout TEXT,
    course TEXT, seed INTEGER, chapters TEXT NOT NULL, gradebook_sha TEXT, reason TEXT, settings TEXT);
CREATE TABLE IF NOT EXISTS results (
    run INTEGER NOT NULL REFERENCES runs(id), learner TEXT NOT NULL, status TEXT NOT NULL, message TEXT NOT NULL,
    files_hash TEXT, content_hash TEXT, manifest_handout TEXT, submitted TEXT, grader TEXT, seed INTEGER,
    raw_score REAL, score REAL, max_score REAL, chapters TEXT NOT NULL, adjustments TEXT NOT NULL,
    flags TEXT NOT NULL, time_from TEXT, seconds REAL, manifest TEXT, report TEXT, PRIMARY KEY (run, learner));
CREATE TABLE IF NOT EXISTS reports (sha TEXT PRIMARY KEY, data BLOB NOT NULL);
CREATE TABLE IF NOT EXISTS overrides (
    run INTEGER NOT NULL REFERENCES runs(id), learner TEXT NOT NULL, target TEXT NOT NULL, points REAL, factor REAL,
    reason TEXT NOT NULL, who TEXT NOT NULL, source TEXT NOT NULL, applied TEXT NOT NULL);
CREATE TABLE IF NOT EXISTS changes (
    run INTEGER NOT NULL REFERENCES runs(id), learner TEXT NOT NULL, before REAL, after REAL, delta REAL,
    why TEXT NOT NULL, PRIMARY KEY (run, learner));
"""
# columns a history written by an earlier grader lacks, added when it is opened
_ADDED = {"runs": {"reason": "TEXT", "settings": "TEXT"},
          "results": {"time_from": "TEXT", "seconds": "REAL", "manifest": "TEXT", "report": "TEXT"}}
_JSON = ("chapters", "adjustments", "flags", "manifest")
_COLUMNS = tuple(f.name for f in fields(LearnerResult))


def now() -> str:
    return datetime.now(timezone.utc).isoformat(timespec="seconds")


def kept_report(report: Report, chapters: list[dict] | None = None) -> tuple[str, bytes]:
    """(the hash, the compressed data) the history keeps `report` as judged by: Report.to_kept, without adjustments
    (`chapters`: its chapters' to_dict(), made already)."""
    kept = report.to_kept(chapters)
    texts = check_texts(report.chapters, kept["chapters"], "kept text", _kept_json)
    text = json_spliced(kept, texts, _kept_json, ("chapters", "checks")).encode("utf-8", "surrogatepass")
    return hashlib.sha256(text).hexdigest(), zlib.compress(text, 1)


# JSON text as the history keeps a report (strings as they are, NaN allowed): json.dumps's, its encoder made once
_kept_json = json.JSONEncoder(ensure_ascii=False, allow_nan=True).encode


class History:
    """The SQLite gradebook of one output folder."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self.db = sqlite3.connect(path, timeout=30)
        self.db.row_factory = sqlite3.Row
        # write-ahead log: a commit survives the grader being killed without waiting for the disk each time
        # (only a power cut may lose the last commits)
        self.db.execute("PRAGMA journal_mode=WAL")
        self.db.execute("PRAGMA synchronous=NORMAL")
        with self.db:
            self.db.executescript(SCHEMA)
            for table, columns in _ADDED.items():
                have = {row["name"] for row in self.db.execute(f"PRAGMA table_info({table})")}
                for name, kind in columns.items():
                    if name not in have:
                        self.db.execute(f"ALTER TABLE {table} ADD COLUMN {name} {kind}")

    def close(self) -> None:
        self.db.close()

    def __enter__(self) -> History:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    # ------------------------------------------------------------------------------------ runs

    def start(self, settings: RunSettings, course: str | None = None, reason: str | None = None) -> int:
        """A new run (its id) graded with `settings`; `reason`: why it was made, where it is no batch (`grade regrade
        --apply`)."""
        with self.db:
            cursor = self.db.execute(
                "INSERT INTO runs (started, grader, handout, course, seed, chapters, reason, settings) "
                "VALUES (?, ?, ?, ?, ?, ?, ?, ?)", (now(), settings.grader, settings.handout, course, settings.seed,
                                                    json.dumps(list(settings.chapters)), reason, settings.to_json()))
        return int(cursor.lastrowid)

    def last_finished(self) -> int | None:
        """The last finished run, or None."""
        return self.db.execute("SELECT max(id) FROM runs WHERE finished IS NOT NULL").fetchone()[0]

    def previous(self, run: int) -> int | None:
        """The last finished run before `run`."""
        return self.db.execute("SELECT max(id) FROM runs WHERE id < ? AND finished IS NOT NULL", (run,)).fetchone()[0]

    def run_info(self, run: int) -> dict:
        return dict(self.db.execute("SELECT * FROM runs WHERE id = ?", (run,)).fetchone())

    def settings(self, run: int) -> RunSettings | None:
        """What `run` graded with (None for a run of a history from before settings were kept, or whose record of
        them cannot be read: a database edited by hand)."""
        try:
            return RunSettings.from_json(self.run_info(run).get("settings"))
        except (ValueError, TypeError, AttributeError):
            return None

    def finish(self, run: int, results: list[LearnerResult], overrides: list[tuple], changes: list[tuple],
               gradebook_sha: str | None = None) -> None:
        """Close `run` in one transaction: every learner's final result, the overrides in force (each a tuple
        learner, target, points, factor, reason, who, source, what it did), the changes, and the hash of the
        gradebook.csv exported from it (a later hand edit of that file is noticed)."""
        with self.db:
            for result in results:
                self._write(run, result)
            self.db.execute("DELETE FROM overrides WHERE run = ?", (run,))
            self.db.executemany("INSERT INTO overrides VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?)",
                                [(run, *row) for row in overrides])
            self.db.executemany("INSERT OR REPLACE INTO changes VALUES (?, ?, ?, ?, ?, ?)",
                                [(run, *row) for row in changes])
            self.db.execute("UPDATE runs SET finished = ?, gradebook_sha = ? WHERE id = ?", (now(), gradebook_sha, run))

    # ------------------------------------------------------------------------------------ results

    def record(self, run: int, result: LearnerResult, judged: Report | None = None, kept: tuple | None = None) -> None:
        """Write (or rewrite) one learner's result of `run`, in a transaction of its own, with the report as judged
        (`judged`, or `kept`: its kept_report already made) where there is one."""
        if judged is not None and kept is None:
            kept = kept_report(judged)
        with self.db:
            if kept is not None:
                result.report = kept[0]
                self.db.execute("INSERT OR IGNORE INTO reports VALUES (?, ?)", kept)
            self._write(run, result)

    def _write(self, run: int, result: LearnerResult) -> None:
        values = [getattr(result, name) for name in _COLUMNS]
        values = [json.dumps(v) if name in _JSON else v for name, v in zip(_COLUMNS, values)]
        self.db.execute(f"INSERT OR REPLACE INTO results (run, {', '.join(_COLUMNS)}) VALUES "
                        f"(?, {', '.join('?' * len(_COLUMNS))})", (run, *values))

    def results(self, run: int) -> dict[str, LearnerResult]:
        """Every learner's result of `run`, in the order they were recorded."""
        rows = self.db.execute("SELECT * FROM results WHERE run = ? ORDER BY rowid", (run,)).fetchall()
        return {row["learner"]: _result(row) for row in rows}

    def result(self, run: int, learner: str) -> LearnerResult | None:
        """`learner`'s result of `run` (None: none recorded)."""
        row = self.db.execute("SELECT * FROM results WHERE run = ? AND learner = ?", (run, learner)).fetchone()
        return None if row is None else _result(row)

    def judged(self, sha: str | None) -> Report | None:
        """The report as judged that the history keeps by `sha` (None for none)."""
        if not sha:
            return None
        row = self.db.execute("SELECT data FROM reports WHERE sha = ?", (sha,)).fetchone()
        if row is None:
            return None
        return Report.from_kept(json.loads(zlib.decompress(row["data"]).decode("utf-8", "surrogatepass")))

    def report(self, result: LearnerResult) -> Report | None:
        """`result`'s report as every output shows it: as judged, with its adjustments (None: not graded)."""
        report = self.judged(result.report) if result.status == "graded" else None
        if report is not None:
            report.attach(result.adjustments)
        return report

    def before(self) -> tuple[dict[str, LearnerResult], dict[str, LearnerResult]]:
        """Of every learner any run recorded (an interrupted one too): (their latest result with a report, which a new
        run need not grade again where the content hash is the same; their latest result of all, which their files
        show)."""
        kept, latest = {}, {}
        for row in self.db.execute("SELECT * FROM results ORDER BY run"):
            result = latest[row["learner"]] = _result(row)
            if result.status == "graded" and result.report and result.content_hash:
                kept[row["learner"]] = result
        return kept, latest


def _result(row: sqlite3.Row) -> LearnerResult:
    data = {name: row[name] for name in _COLUMNS}
    for name in _JSON:
        data[name] = json.loads(data[name]) if data[name] is not None else ({} if name == "chapters" else None if
                                                                             name == "manifest" else [])
    data["seconds"] = data["seconds"] or 0.0
    return LearnerResult(**data)


def why_moved(before: LearnerResult, after: LearnerResult, before_run: dict, run: dict) -> str:
    """Why a learner's score moved between two runs: a regrade (its reason), a resubmission, the grader or
    handout, the seed or chapters, the overrides, the late penalty; each that differs, in words."""
    reasons = [f"regrade ({run['reason']})"] if run.get("reason") else []
    if before.files_hash != after.files_hash:
        reasons.append("resubmission (other files)")
    if (before.grader or before_run["grader"]) != (after.grader or run["grader"]):
        reasons.append(f"grader {before.grader or before_run['grader']} -> {after.grader or run['grader']}")
    if before.manifest_handout != after.manifest_handout:
        reasons.append(f"packed with handout {before.manifest_handout or 'none'} -> {after.manifest_handout or 'none'}")
    if before_run["handout"] != run["handout"]:
        reasons.append(f"the course's handout {before_run['handout'] or 'none'} -> {run['handout'] or 'none'}")
    if before.seed != after.seed:
        reasons.append(f"seed {before.seed} -> {after.seed}")
    if before_run["chapters"] != run["chapters"]:
        reasons.append("other chapters graded")
    overrides = [[a for a in result.adjustments if a["kind"] == "override"] for result in (before, after)]
    if overrides[0] != overrides[1]:
        gone = [a for a in overrides[0] if a not in overrides[1]]
        new = [a for a in overrides[1] if a not in overrides[0]]
        said = [f"override {a['points']:+g} on {a['target']} ({a['reason']})" for a in new]
        said += [f"override removed: {a['points']:+g} on {a['target']} ({a['reason']})" for a in gone]
        reasons.append("; ".join(said) or "overrides changed")
    late = [[a for a in result.adjustments if a["kind"] == "late"] for result in (before, after)]
    if late[0] != late[1]:
        reasons.append("late penalty: " + ("; ".join(a["reason"] for a in late[1]) if late[1] else "none now"))
    if before.status != after.status:
        reasons.append(f"{before.status} -> {after.status}" + (f" ({after.message})" if after.message else ""))
    return "; ".join(reasons) or "graded again with the same files, grader and seed (a timeout or the machine's load?)"


def changes(history: History, run: int, results: dict[str, LearnerResult]) -> list[tuple]:
    """(learner, before, after, delta, why) of each learner whose score moved since the last finished run
    (a learner first graded, or no longer graded, moved too)."""
    previous = history.previous(run)
    if previous is None:
        return [(r.learner, None, r.score, r.score, "first graded") for r in results.values() if r.score is not None]
    before_run, this_run = history.run_info(previous), history.run_info(run)
    before = history.results(previous)
    moved = []
    for learner, result in results.items():
        old = before.get(learner)
        if old is None:
            if result.score is not None:
                moved.append((learner, None, result.score, result.score, "first graded"))
            continue
        if old.score == result.score:
            continue
        delta = None if old.score is None or result.score is None else round(result.score - old.score, 6)
        moved.append((learner, old.score, result.score, delta, why_moved(old, result, before_run, this_run)))
    for learner, old in before.items():
        if learner not in results and old.score is not None:
            moved.append((learner, old.score, None, None, "not in this run's submissions"))
    return sorted(moved)
