"""Batch grading of a folder of submissions: discover, stage, grade in parallel, write every output.

Each submission (a folder or a .zip, holding exercises/ or the chapter files directly) is copied
or safely extracted into OUT/.staging/<learner>/exercises/ and graded by a worker process, in a
child forked by that worker's sandboxed fork server (grader.forkserver), and its outputs are written
atomically into OUT/<learner>/. A learner whose staged
files hash the same as last time is not graded again. The gradebook, JUnit file and class summary
are rebuilt from the per-learner reports at the end, so an interrupted run loses nothing graded.
"""

from __future__ import annotations

import csv
import functools
import hashlib
import io
import json
import os
import re
import sys
import time
import zipfile
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass
from pathlib import Path

from grader.chapters import CHAPTERS

CHAPTER_FILE = re.compile(r"^ch0[0-9]_[a-z_]+\.py$")
ANSWER_FILE = re.compile(r"^(ch0[0-9]|learner)\.yaml$")
MAX_FILE_BYTES = 1 << 20
MAX_TOTAL_BYTES = 16 << 20
MAX_FILES = 200
SAFE_ID = re.compile(r"[^A-Za-z0-9_.@-]+")


class StagingError(ValueError):
    """A submission that cannot be staged (the message says why)."""


@dataclass
class Entry:
    learner: str
    source: Path


def discover(folder: Path, roster: Path | None = None) -> list[Entry]:
    """Learner folders and .zip files in `folder`; ids from their names or the roster CSV
    (columns `submission` and `learner`)."""
    names = {}
    if roster is not None:
        with open(roster, newline="", encoding="utf-8") as handle:
            for row in csv.DictReader(handle):
                names[row["submission"].strip()] = row["learner"].strip()
    entries = []
    for path in sorted(folder.iterdir()):
        if path.name.startswith("."):
            continue
        if path.is_symlink() or path.is_dir() or (path.is_file() and path.suffix.lower() == ".zip"):
            stem = path.stem if path.is_file() else path.name
            learner = SAFE_ID.sub("_", names.get(path.name) or names.get(stem) or stem)
            taken = {e.learner for e in entries}
            unique, n = learner, 2
            while unique in taken:  # e.g. both alice/ and alice.zip: neither overwrites the other
                unique, n = f"{learner}-{n}", n + 1
            entries.append(Entry(unique, path))
    return entries


def _wanted(relative: str) -> str | None:
    """Where a file of the submission goes in the staged package, or None to leave it out."""
    parts = relative.replace("\\", "/").split("/")
    name = parts[-1]
    if CHAPTER_FILE.match(name):
        return name
    if ANSWER_FILE.match(name) and len(parts) >= 2 and parts[-2] == "answers":
        return f"answers/{name}"
    return None


def stage(entry: Entry, staging: Path) -> Path:
    """Copy the submission's chapter and answer files into staging/<learner>/exercises/ (a file
    already staged with the same bytes is left as it is; files no longer submitted are removed)."""
    root = staging / entry.learner
    package = root / "exercises"
    files: dict[str, bytes] = {"__init__.py": b""}
    total = 0
    if entry.source.is_symlink():
        raise StagingError("is a symbolic link; a submission is a real folder or .zip file (links are never "
                           "followed: one could point at the references)")
    if entry.source.is_dir():
        for folder, subfolders, names in os.walk(entry.source):  # never into a symlinked folder
            subfolders.sort()
            for name in sorted(names):
                path = Path(folder) / name
                if path.is_symlink() or not path.is_file():
                    continue
                target = _wanted(str(path.relative_to(entry.source)))
                if target is None:
                    continue
                size = path.stat().st_size
                if size > MAX_FILE_BYTES:
                    raise StagingError(f"{path.name} is {size} bytes; at most {MAX_FILE_BYTES} are read")
                files[target] = path.read_bytes()
                total += size
    else:
        try:
            archive = zipfile.ZipFile(entry.source)
        except zipfile.BadZipFile:
            raise StagingError(f"{entry.source.name} is not a valid zip file") from None
        with archive:
            infos = archive.infolist()
            if len(infos) > 10 * MAX_FILES:
                raise StagingError(f"{entry.source.name} holds {len(infos)} entries")
            for info in infos:
                name = info.filename
                if name.startswith("/") or ".." in name.split("/") or (info.external_attr >> 16) & 0o170000 == 0o120000:
                    continue  # absolute paths, parent references and symlinks are never extracted
                target = _wanted(name)
                if target is None or info.is_dir():
                    continue
                if info.file_size > MAX_FILE_BYTES:
                    raise StagingError(f"{name} is {info.file_size} bytes unpacked; at most {MAX_FILE_BYTES}")
                with archive.open(info) as handle:
                    data = handle.read(MAX_FILE_BYTES + 1)
                if len(data) > MAX_FILE_BYTES:
                    raise StagingError(f"{name} unpacks to more than {MAX_FILE_BYTES} bytes")
                files[target] = data
                total += len(data)
    if total > MAX_TOTAL_BYTES or len(files) > MAX_FILES:
        raise StagingError("the submission is too large")
    if not any(CHAPTER_FILE.match(name) for name in files):
        raise StagingError("no chapter files (chNN_*.py) found, neither in exercises/ nor at the top")
    (package / "answers").mkdir(parents=True, exist_ok=True)
    for path in package.rglob("*"):
        if path.is_file() and path.relative_to(package).as_posix() not in files:
            path.unlink()
    for target, data in files.items():
        path = package / target
        try:
            if path.read_bytes() == data:
                continue
        except OSError:
            pass
        path.write_bytes(data)
    return root


def content_hash(root: Path, chapters: list[str], seed: int) -> str:
    digest = hashlib.sha256(f"{chapters}|{seed}|{_grader_version()}".encode())
    for path in sorted((root / "exercises").rglob("*")):
        if path.is_file():
            digest.update(str(path.relative_to(root)).encode() + b"\0" + path.read_bytes() + b"\0")
    return digest.hexdigest()


@functools.lru_cache(maxsize=1)
def _grader_version() -> str:
    """Changes when the grader's own checks change, so a re-run re-grades after an update."""
    digest = hashlib.sha256()
    base = Path(__file__).resolve().parent
    for path in sorted(base.rglob("*.py")):
        digest.update(path.read_bytes())
    return digest.hexdigest()[:16]


def write_atomically(path: Path, text: str) -> None:
    temporary = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    temporary.write_text(text, encoding="utf-8")
    os.replace(temporary, path)


# ------------------------------------------------------------------------------------ grading

_worker_state: dict = {}


def _grade_one(entry: Entry, out: str, chapters: list[str], seed: int, html: bool, plots: bool,
               limits: dict) -> tuple[str, str, str]:
    """Stage and grade one submission (in a worker process); returns (learner, status, message).

    A submission whose staged files hash as at its last grading is not graded again."""
    from grader.forkserver import ForkServer
    from grader.pipeline import Request, build_report
    from grader.render import lms
    from grader.runner import Limits, Session
    from grader.submission import Submission
    from grader.sandbox import Sandbox
    from grader.spawn import start_child

    started = time.monotonic()
    learner = entry.learner
    staging = Path(out) / ".staging"
    try:
        root = stage(entry, staging)
    except StagingError as exc:
        return learner, "unreadable", f"{entry.source.name}: {exc}"
    digest = content_hash(root, chapters, seed)
    folder = Path(out) / learner
    if _previous_hash(folder) == digest:
        return learner, "unchanged", "already graded, files unchanged"
    folder.mkdir(parents=True, exist_ok=True)
    if "launcher" not in _worker_state:
        sandbox = Sandbox()
        if os.environ.get("GRADER_FORK_SERVER") == "off":  # a fresh interpreter per learner (slower)
            _worker_state["launcher"] = functools.partial(start_child, wrap=sandbox)
        else:  # one fork server per worker; it sees no learner's files, they come with each request
            _worker_state["launcher"] = ForkServer(sandbox).start
    submission = Submission(root, "exercises")
    session = Session(submission, Limits(**limits), launcher=_worker_state["launcher"])
    report = build_report(session, Request(tuple(chapters), seed, learner=learner, plots=plots, label=learner))
    data = report.to_dict()
    data["batch"] = {"hash": digest, "seconds": round(time.monotonic() - started, 3),
                     "learner_output": report.learner_output[:4000]}
    write_atomically(folder / "results.json", lms.gradescope(report))
    if html:
        from grader.render import html as html_renderer

        write_atomically(folder / "report.html", html_renderer.render(report))
    write_atomically(folder / "report.json", json.dumps(data, allow_nan=False) + "\n")  # last: marks done
    problems = sum(bool(c.problems) for c in report.chapters)
    return learner, "graded", f"{report.score:g}/{report.max_score:g}" + (f", {problems} chapter(s) with problems" if problems else "")


def _previous_hash(folder: Path) -> str | None:
    try:
        return json.loads((folder / "report.json").read_text())["batch"]["hash"]
    except (OSError, ValueError, KeyError, TypeError):
        return None


def run_batch(submissions: Path, out: Path, *, chapters: list[str] | None = None, roster: Path | None = None,
              jobs: int | None = None, seed: int, html: bool = True, plots: bool = False,
              limits: dict | None = None, progress=None) -> dict:
    """Grade every submission in `submissions` into `out`; returns counts for the end summary."""
    chapters = chapters or [c.id for c in CHAPTERS]
    out.mkdir(parents=True, exist_ok=True)
    entries = discover(submissions, roster)
    statuses: dict[str, str] = {}
    messages: dict[str, str] = {}
    jobs = jobs or os.cpu_count() or 1
    started = time.monotonic()
    done = 0
    limits = limits or {}
    with ProcessPoolExecutor(max_workers=jobs) as pool:
        futures = {pool.submit(_grade_one, entry, str(out), chapters, seed, html, plots, limits): entry.learner
                   for entry in entries}
        for future in as_completed(futures):
            learner = futures[future]
            try:
                _, statuses[learner], messages[learner] = future.result()
            except Exception as exc:  # one broken submission never stops the batch
                statuses[learner], messages[learner] = "error", f"{type(exc).__name__}: {exc}"
            done += 1
            if progress:
                progress(done, len(entries), time.monotonic() - started)
    write_summaries(out, [e.learner for e in entries], chapters, statuses, messages)
    counts: dict[str, int] = {}
    for status in statuses.values():
        counts[status] = counts.get(status, 0) + 1
    graded_now = sum(status == "graded" for status in statuses.values())
    return {"counts": counts, "seconds": time.monotonic() - started, "graded_now": graded_now,
            "messages": messages, "statuses": statuses}


def write_summaries(out: Path, learners: list[str], chapters: list[str], statuses: dict, messages: dict) -> None:
    """gradebook.csv, junit.xml and summary.html from the per-learner reports on disk."""
    from grader.model import Report
    from grader.render import lms

    reports = []
    buffer = io.StringIO()
    writer = csv.writer(buffer)
    writer.writerow(lms.gradebook_header(chapters))
    for learner in learners:
        report = None
        try:
            report = Report.from_dict(json.loads((out / learner / "report.json").read_text()))
            reports.append((learner, report))
        except (OSError, ValueError, KeyError):
            pass
        status = statuses.get(learner, "graded")
        status = "graded" if status == "unchanged" and report else status
        writer.writerow(lms.gradebook_row(learner, report, chapters, status))
    write_atomically(out / "gradebook.csv", buffer.getvalue())
    write_atomically(out / "junit.xml", lms.junit(reports))
    from grader.render import summary
    from grader.sandbox import Sandbox

    unreadable = {k: v for k, v in messages.items() if statuses.get(k) in ("error", "unreadable")}
    write_atomically(out / "summary.html", summary.render(reports, unreadable, Sandbox().describe()))


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
