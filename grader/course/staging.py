"""Finding and staging submissions: each learner's folder or .zip in a submissions folder, with its learner
id (its name, or a roster's), copied or safely extracted into a staging folder of chapter and answer files
only; the record of those files a batch keeps per learner (keep, kept_files); and where a learner's outputs go
(folder_name). Used by grade batch, grade submit's check of its own archive, the Gradescope autograder and
--similarity.

Only chNN_*.py, chNN_*.ipynb (without outputs), answers/*.yaml and a grade submit manifest are staged; zip
entries with absolute paths, '..' or symlinks are never extracted, links inside a folder are never followed,
and sizes are capped.
"""

from __future__ import annotations

import hashlib
import os
import re
import zipfile
from dataclasses import dataclass
from pathlib import Path

from grader.ids import id_problem
from grader.safe_text import unicode_clean

MANIFEST = "submission-manifest.json"  # what grade submit writes into an archive (grader.course.submit)
CHAPTER_FILE = re.compile(r"^ch0[0-9]_[a-z_]+\.(py|ipynb)$")  # a chapter may be kept as a notebook
ANSWER_FILE = re.compile(r"^(ch0[0-9]|learner)\.yaml$")
MAX_FILE_BYTES = 1 << 20
MAX_NOTEBOOK_BYTES = 16 << 20  # a notebook with its outputs (plots); staged without them (grader.notebook)
MAX_TOTAL_BYTES = 16 << 20
MAX_FILES = 200
STAGING = ".staging"
RECORDS = ".records"  # in STAGING: each learner's files as graded, one zip each (record_path)
MAX_SUGGESTIONS = 250_000  # pairs of unmatched rows and submissions compared for a did-you-mean
CLASS_OUTPUTS = ("gradebook.csv", "junit.xml", "summary.html", "gradebook-canvas.csv", "gradebook-moodle.csv",
                 "changes.csv", "summary.json", "gradebook.db", "gradebook.db-wal", "gradebook.db-shm", "overrides.csv")
_PLAIN = frozenset("ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789_.@+-")
_MAX_FOLDER = 160

class StagingError(ValueError):
    """A submission that cannot be staged (the message says why)."""


class RosterError(ValueError):
    """A roster that cannot be read (the message names the file and line)."""


@dataclass
class Entry:
    learner: str
    source: Path
    origin: str = ""  # where the id comes from, for messages: "its name" or "roster.csv, line 3"
    submitted: str = ""  # when it was submitted, from the roster's `submitted` column (for late penalties)


@dataclass
class Skipped:
    """Something in the submissions folder that is not graded, and why."""

    name: str
    reason: str
    submission: bool = False  # a learner's folder or zip, skipped because its id is unusable


def folder_name(learner: str) -> str:
    """The learner's folder in OUT (and OUT/.staging): the id itself where it has only letters, digits
    and _ . @ + -, else each other character percent-encoded as UTF-8 (zoë -> zo%C3%AB); a leading '.'
    and the names of the class outputs get their dots encoded (%2E), a leading '-' too (%2D), and a long
    id is shortened with a hash. Different ids never share a folder; no id names a class output or a
    hidden folder."""
    encoded = "".join(ch if ch in _PLAIN else "".join(f"%{b:02X}" for b in ch.encode("utf-8", "surrogatepass"))
                      for ch in learner)
    if encoded.casefold() in CLASS_OUTPUTS or encoded.casefold() == STAGING or encoded.startswith("."):
        encoded = encoded.replace(".", "%2E")
    if encoded.startswith("-"):  # not an option to the shell tools that will handle the folder
        encoded = "%2D" + encoded[1:]
    if len(encoded) > _MAX_FOLDER:  # '~' never appears otherwise
        digest = hashlib.sha256(learner.encode("utf-8", "surrogatepass")).hexdigest()[:20]
        encoded = f"{encoded[:_MAX_FOLDER - 21]}~{digest}"
    return encoded


def read_roster(roster: Path) -> dict[str, tuple[str, int, str]]:
    """The roster CSV as {submission: (learner id, line, submitted)}: columns `submission` and `learner` (and
    optionally `submitted`, the time of submission as the LMS gives it, ISO 8601) in any order and case,
    separated by ',' or ';' (or a tab), UTF-8 with or without a byte-order mark (grader.csvtable)."""
    from grader.csvtable import TableError, read_table

    try:
        rows = read_table(roster, ("submission", "learner"))
    except TableError as exc:
        raise RosterError(str(exc)) from None
    return {row["submission"]: (row["learner"], line, row.get("submitted", "")) for line, row in rows
            if row["submission"]}


@dataclass
class Unmatched:
    """Where a roster and the submissions folder disagree: a row naming no submission (its line, the submission it
    names, its learner), or a submission no row names (graded under its own name); with the closest name on the
    other side, where one is close."""

    kind: str  # "row" (a row naming no submission) or "submission" (a submission no row names)
    name: str  # the submission as the row names it, or the submission's name
    learner: str = ""  # the row's learner, or the id the submission is graded as
    line: int = 0  # the row's line
    close: str = ""  # the closest name on the other side: did you mean it?

    def describe(self, roster: str) -> str:
        mean = f"; did you mean {self.close!r}?" if self.close else ""
        if self.kind == "row":
            return (f"{roster}, line {self.line}: {self.name!r} (learner {self.learner!r}) names no submission in the "
                    f"submissions folder, so {self.learner!r} has no grade{mean}")
        return f"{self.name!r}: no row of {roster} names it; graded as {self.learner!r}{mean}"

    def to_dict(self) -> dict:
        return {"kind": self.kind, "name": self.name, "learner": self.learner, "line": self.line or None,
                "did_you_mean": self.close or None}


@dataclass
class Survey:
    """A submissions folder read with its roster: the submissions to grade with their learner ids, what is skipped
    and why, and where the roster and the folder disagree (nothing is left out silently)."""

    entries: list[Entry]
    skipped: list[Skipped]
    unmatched: list[Unmatched]


def survey(folder: Path, roster: Path | None = None) -> Survey:
    """The submissions in `folder` (learner folders and .zip files) with their learner ids, what is skipped with the
    reason (other files, hidden (dot-named) entries the roster does not name, ids that cannot be ids: id_problem),
    and the roster's rows that name no submission and the submissions no row names. An id comes from the roster
    (--roster), else from the name; two submissions with one id become id and id-2."""
    import difflib

    names = read_roster(roster) if roster is not None else {}
    entries: list[Entry] = []
    skipped: list[Skipped] = []
    taken: set[str] = set()
    suffix: dict[str, int] = {}  # id -> the n of id-n to try next: a name once taken stays taken
    named_rows: set[str] = set()  # the roster's submissions found in the folder
    unnamed: list[tuple[str, str]] = []  # (a submission no row names, the id it is graded as)
    with os.scandir(folder) as listing:  # the types come with the listing: no stat per entry
        items = sorted(listing, key=lambda item: os.path.normcase(item.name))  # the order of sorted Paths
    for item in items:
        path = folder / item.name
        shown = unicode_clean(item.name)
        if not (item.is_symlink() or item.is_dir(follow_symlinks=False)
                or (item.is_file(follow_symlinks=False) and path.suffix.lower() == ".zip")):
            skipped.append(Skipped(shown, "not a folder or a .zip file"))
            continue
        stem = path.stem if item.is_file() else path.name  # a link: what it points at
        key = path.name if path.name in names else stem if stem in names else None
        named = names.get(key) if key is not None else None
        if named is None and path.name.startswith("."):
            skipped.append(Skipped(shown, "a hidden (dot-named) entry, as tools leave behind (.git, .DS_Store, "
                                          "._name); to grade it, rename it or name it in a roster (--roster)"))
            continue
        if named is not None:
            named_rows.add(key)
            learner, line, _ = named
            problem = id_problem(learner)
            why = f"{roster}, line {line}: the learner id {learner!r} {problem}"
            origin = f"the roster {roster.name}, line {line}"
        else:
            learner = unicode_clean(stem)  # bytes that are not UTF-8 become U+FFFD
            problem = id_problem(learner)
            why = f"its name, the learner id, {problem}; rename it or give its id in a roster (--roster)"
            origin = f"the name of {shown}"
        if problem is not None:
            skipped.append(Skipped(shown, why, submission=True))
            continue
        unique, n = learner, suffix.get(learner, 2)
        while unique in taken:  # e.g. both alice/ and alice.zip: neither overwrites the other
            unique, n = f"{learner}-{n}", n + 1
        suffix[learner] = n  # the next submission with this id starts here, not at id-2 again
        taken.add(unique)
        if roster is not None and named is None:
            unnamed.append((shown if item.is_dir(follow_symlinks=False) else unicode_clean(stem), unique))
        entries.append(Entry(unique, path, origin if unique == learner else f"{origin}, made unique",
                             named[2] if named is not None else ""))
    rows = {name: value for name, value in names.items() if name not in named_rows}
    suggest = len(rows) * len(unnamed) <= MAX_SUGGESTIONS  # each pair compared once at most

    def closest(name: str, among: list[str]) -> str:
        return next(iter(difflib.get_close_matches(name, among, n=1)), "") if suggest else ""

    unmatched = [Unmatched("row", name, learner, line, closest(name, [u for u, _ in unnamed]))
                 for name, (learner, line, _) in sorted(rows.items(), key=lambda item: item[1][1])]
    unmatched += [Unmatched("submission", name, learner, 0, closest(name, list(rows))) for name, learner in unnamed]
    return Survey(entries, skipped, unmatched)


def discover(folder: Path, roster: Path | None = None) -> list[Entry]:
    """Learner folders and .zip files in `folder` with their ids (survey, without what is skipped)."""
    return survey(folder, roster).entries


def _wanted(relative: str) -> str | None:
    """Where a file of the submission goes in the staged package, or None to leave it out."""
    parts = relative.replace("\\", "/").split("/")
    name = parts[-1]
    if CHAPTER_FILE.match(name):
        return name
    if ANSWER_FILE.match(name) and len(parts) >= 2 and parts[-2] == "answers":
        return f"answers/{name}"
    if name == MANIFEST:  # written by grade submit (grader.course.submit): checked, never graded
        return name
    return None


def _limit(target: str) -> int:
    return MAX_NOTEBOOK_BYTES if target.endswith(".ipynb") else MAX_FILE_BYTES


def _staged(target: str, data: bytes) -> bytes:
    """What is staged of a file: a notebook without its outputs (grading reads its code cells only)."""
    if not target.endswith(".ipynb"):
        return data
    from grader.notebook import without_outputs

    return without_outputs(data)


def stage(entry: Entry, staging: Path) -> Path:
    """Copy the submission's chapter and answer files into staging/<folder>/exercises/ (a file
    already staged with the same bytes is left as it is; files no longer submitted are removed)."""
    return stage_files(entry, staging)[0]


def staged_files(package: Path) -> dict[str, bytes]:
    """Every file of a staged package, by its posix path in it, with its bytes: what stage_files returns, read back
    (staging makes no link: one placed there since is not followed)."""
    return {path.relative_to(package).as_posix(): path.read_bytes() for path in package.rglob("*")
            if path.is_file() and not path.is_symlink()}


def submitted_files(entry: Entry) -> dict[str, bytes]:
    """The files of a submission that are staged, each read once, by their path in exercises/ (posix), with their
    bytes (StagingError where it cannot be staged)."""
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
                if size > _limit(target):
                    raise StagingError(f"{path.name} is {size} bytes; at most {_limit(target)} are read")
                files[target] = _staged(target, path.read_bytes())
                total += len(files[target])
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
                if info.file_size > _limit(target):
                    raise StagingError(f"{name} is {info.file_size} bytes unpacked; at most {_limit(target)}")
                with archive.open(info) as handle:
                    data = handle.read(_limit(target) + 1)
                if len(data) > _limit(target):
                    raise StagingError(f"{name} unpacks to more than {_limit(target)} bytes")
                files[target] = _staged(target, data)
                total += len(files[target])
    if total > MAX_TOTAL_BYTES or len(files) > MAX_FILES:
        raise StagingError("the submission is too large")
    if not any(CHAPTER_FILE.match(name) for name in files):
        raise StagingError("no chapter files (chNN_*.py or chNN_*.ipynb) found, neither in exercises/ nor at the top")
    return files


def stage_files(entry: Entry, staging: Path) -> tuple[Path, dict[str, bytes]]:
    """stage(), and every file staged by its path in exercises/ (posix) with its bytes, exactly what is on disk
    there now: what the hashes of the staged files are made from without reading them again."""
    root = staging / folder_name(entry.learner)
    files = submitted_files(entry)
    put(files, root / "exercises")
    return root, files


def put(files: dict[str, bytes], package: Path, held: dict[str, bytes] | None = None) -> None:
    """Make `package` hold exactly `files` (posix path in it -> bytes): a file already there with the same bytes is
    left as it is (no new file where a folder is reused), one not in `files` is removed. `held`: what the package
    holds, where its only writer keeps it (nothing is read back then); made to hold `files` too."""
    (package / "answers").mkdir(parents=True, exist_ok=True)
    if held is None:
        held = staged_files(package)
    for name in [name for name in held if name not in files]:
        (package / name).unlink(missing_ok=True)
        del held[name]
    for target, data in files.items():
        if held.get(target) != data:
            held.pop(target, None)  # a write that fails midway leaves a file that is no longer known
            path = package / target
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_bytes(data)
            held[target] = data


# ------------------------------------------------------------------------------------ the record a batch keeps

_RECORD_TIME = (1980, 1, 1, 0, 0, 0)  # every entry's: the same files make the same record, byte for byte


def record_path(staging: Path, learner: str) -> Path:
    """Where a batch keeps the files it graded of `learner`: one uncompressed zip, staging/.records/<folder>.zip (one
    file per learner, however many it submitted; no learner's folder is named .records: folder_name)."""
    return staging / RECORDS / f"{folder_name(learner)}.zip"


def keep(staging: Path, learner: str, files: dict[str, bytes]) -> Path:
    """Keep `files` (posix path in exercises/ -> bytes) as `learner`'s record (record_path), written through a
    temporary file and replaced at once; the folder an older grader staged the learner into is removed: the record
    alone says what was graded."""
    import io
    import shutil

    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w", zipfile.ZIP_STORED) as archive:
        for name in sorted(files):
            archive.writestr(zipfile.ZipInfo(f"exercises/{name}", _RECORD_TIME), files[name])
    data = buffer.getvalue()
    path = record_path(staging, learner)
    try:
        same = path.read_bytes() == data  # graded again with the same files: nothing to write
    except OSError:
        same = False
    if not same:
        path.parent.mkdir(parents=True, exist_ok=True)
        temporary = path.with_name(f".{path.name}.{os.getpid()}.tmp")
        temporary.write_bytes(data)
        os.replace(temporary, path)
    older = staging / folder_name(learner)
    if older.is_dir() and not older.is_symlink():
        shutil.rmtree(older, ignore_errors=True)
    return path


def kept_place(staging: Path, learner: str) -> Path | None:
    """Where the files a batch graded of `learner` are kept: its record (record_path), or the package folder an
    older grader staged it into (staging/<folder>/exercises); None where neither is there."""
    path = record_path(staging, learner)
    if path.is_file():
        return path
    package = staging / folder_name(learner) / "exercises"
    return package if package.is_dir() and not package.is_symlink() else None


def read_kept(place: Path) -> dict[str, bytes] | None:
    """The files kept at `place` (kept_place: a record, or an older grader's staged package), by their posix path in
    exercises/, with their bytes; None where they cannot be read."""
    if place.is_dir():
        return staged_files(place)
    try:
        with zipfile.ZipFile(place) as archive:
            return {name: archive.read(info) for info in archive.infolist()
                    if (name := info.filename.removeprefix("exercises/")) != info.filename
                    and (name == "__init__.py" or _wanted(name) == name)}  # only what staging writes
    except (OSError, zipfile.BadZipFile):
        return None


def kept_files(staging: Path, learner: str) -> dict[str, bytes] | None:
    """The files a batch graded of `learner` (kept_place, read_kept), or None."""
    place = kept_place(staging, learner)
    return None if place is None else read_kept(place)
