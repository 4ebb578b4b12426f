"""The course's history: a SQLite gradebook (OUT/gradebook.db) of every `grade batch` run.

Tables:
- runs: one per `grade batch` (and per `grade regrade --apply`, with its reason): when it started and
  finished, the grader's version, the course's current handout, the course, the seed and the chapters.
- results: per run and learner: status, message, the submission's hash (its files only) and the
  content hash (files, grader, seed), the handout and time in its manifest, the score as graded, the
  score with overrides and penalties, the adjustments, the flags, and the scores per chapter that
  the gradebooks export.
- overrides: per run, every row of overrides.csv in force, with what it changed.
- changes: per run, each learner whose score moved since the last finished run, by how much, and why.

Every learner's result is written in its own transaction as soon as it is graded (an interrupted run
keeps what it graded; its run stays unfinished, and the next run compares with the last finished one).
gradebook.csv, changes.csv and the LMS gradebooks are exports of the run's results.
"""

from __future__ import annotations

import json
import sqlite3
from dataclasses import dataclass, field
from datetime import datetime, timezone
from pathlib import Path

from grader.model import LearnerResult

FILE_NAME = "gradebook.db"
SCHEMA = """
CREATE TABLE IF NOT EXISTS runs (
    id INTEGER PRIMARY KEY, started TEXT NOT NULL, finished TEXT, grader TEXT NOT NULL, handout TEXT,
    course TEXT, seed INTEGER, chapters TEXT NOT NULL, gradebook_sha TEXT, reason TEXT);
CREATE TABLE IF NOT EXISTS results (
    run INTEGER NOT NULL REFERENCES runs(id), learner TEXT NOT NULL, status TEXT NOT NULL, message TEXT NOT NULL,
    files_hash TEXT, content_hash TEXT, manifest_handout TEXT, submitted TEXT, grader TEXT, seed INTEGER,
    raw_score REAL, score REAL, max_score REAL, chapters TEXT NOT NULL, adjustments TEXT NOT NULL,
    flags TEXT NOT NULL, PRIMARY KEY (run, learner));
CREATE TABLE IF NOT EXISTS overrides (
    run INTEGER NOT NULL REFERENCES runs(id), learner TEXT NOT NULL, target TEXT NOT NULL, points REAL, factor REAL,
    reason TEXT NOT NULL, who TEXT NOT NULL, source TEXT NOT NULL, applied TEXT NOT NULL);
CREATE TABLE IF NOT EXISTS changes (
    run INTEGER NOT NULL REFERENCES runs(id), learner TEXT NOT NULL, before REAL, after REAL, delta REAL,
    why TEXT NOT NULL, PRIMARY KEY (run, learner));
"""


def now() -> str:
    return datetime.now(timezone.utc).isoformat(timespec="seconds")


class History:
    """The SQLite gradebook of one output folder."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self.db = sqlite3.connect(path, timeout=30)
        self.db.row_factory = sqlite3.Row
        # write-ahead log: a commit survives the grader being killed without waiting for the disk each time
        # (only a power cut may lose the last commits; report.json has them too)
        self.db.execute("PRAGMA journal_mode=WAL")
        self.db.execute("PRAGMA synchronous=NORMAL")
        with self.db:
            self.db.executescript(SCHEMA)
            if "reason" not in {row["name"] for row in self.db.execute("PRAGMA table_info(runs)")}:
                self.db.execute("ALTER TABLE runs ADD COLUMN reason TEXT")  # a history from before regrades

    def close(self) -> None:
        self.db.close()

    def start(self, grader: str, handout: str | None, course: str | None, seed: int, chapters: list[str],
              reason: str | None = None) -> int:
        """A new run (its id); `reason`: why it was made, where it is no batch (`grade regrade --apply`)."""
        with self.db:
            cursor = self.db.execute("INSERT INTO runs (started, grader, handout, course, seed, chapters, reason) "
                                     "VALUES (?, ?, ?, ?, ?, ?, ?)", (now(), grader, handout, course, seed,
                                                                      json.dumps(chapters), reason))
        return int(cursor.lastrowid)

    def record(self, run: int, result: LearnerResult) -> None:
        """Write (or rewrite) one learner's result of `run`, in a transaction of its own."""
        with self.db:
            self.record_in_transaction(run, result)

    def results(self, run: int) -> dict[str, LearnerResult]:
        rows = self.db.execute("SELECT * FROM results WHERE run = ?", (run,)).fetchall()
        out = {}
        for row in rows:
            data = dict(row)
            data.pop("run")
            for key in ("chapters", "adjustments", "flags"):
                data[key] = json.loads(data[key])
            out[row["learner"]] = LearnerResult(**data)
        return out

    def last_finished(self) -> int | None:
        """The last finished run, or None."""
        return self.db.execute("SELECT max(id) FROM runs WHERE finished IS NOT NULL").fetchone()[0]

    def previous(self, run: int) -> int | None:
        """The last finished run before `run`."""
        row = self.db.execute("SELECT max(id) FROM runs WHERE id < ? AND finished IS NOT NULL", (run,)).fetchone()
        return row[0]

    def run_info(self, run: int) -> dict:
        return dict(self.db.execute("SELECT * FROM runs WHERE id = ?", (run,)).fetchone())

    def finish(self, run: int, results: list[LearnerResult], overrides: list[tuple], changes: list[tuple],
               gradebook_sha: str | None = None) -> None:
        """Close `run` in one transaction: every learner's final result, the overrides in force (each a tuple
        learner, target, points, factor, reason, who, source, what it changed), the changes, and the hash of
        the gradebook.csv exported from it (a later hand edit of that file is noticed)."""
        with self.db:
            for result in results:
                self.record_in_transaction(run, result)
            self.db.executemany("INSERT INTO overrides VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?)",
                                [(run, *row) for row in overrides])
            self.db.executemany("INSERT OR REPLACE INTO changes VALUES (?, ?, ?, ?, ?, ?)",
                                [(run, *row) for row in changes])
            self.db.execute("UPDATE runs SET finished = ?, gradebook_sha = ? WHERE id = ?", (now(), gradebook_sha, run))

    def record_in_transaction(self, run: int, result: LearnerResult) -> None:
        self.db.execute(
            "INSERT OR REPLACE INTO results (run, learner, status, message, files_hash, content_hash, "
            "manifest_handout, submitted, grader, seed, raw_score, score, max_score, chapters, adjustments, flags) "
            "VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)",
            (run, result.learner, result.status, result.message, result.files_hash, result.content_hash,
             result.manifest_handout, result.submitted, result.grader, result.seed, result.raw_score,
             result.score, result.max_score, json.dumps(result.chapters), json.dumps(result.adjustments),
             json.dumps(result.flags)))


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
        reasons.append("late penalty: " + (late[1][0]["reason"] if late[1] else "none now"))
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
