"""`grade submit`: the learner's archive, checked before it is packed, and its manifest.

The archive is exactly what `grade batch`, the Gradescope autograder and the GitHub Classroom workflow
read: `exercises/` with the chapter files and `exercises/answers/` (the files grade batch stages,
selected by the same rules, grader.course.staging.stage), plus `exercises/submission-manifest.json`:

    {"format": 1, "course": ..., "handout": ..., "handout_released": ..., "grader": ...,
     "learner": "ann", "packed": "2026-05-01T21:14:03+00:00",
     "files": {"ch06_measurement.py": "<sha256>", "answers/ch06.yaml": "<sha256>", ...},
     "local": {"seed": 20261122, "score": 22, "max_score": 22, "pending_score": 5,
               "chapters": {"ch06": [22, 22]}}}

The local score is that of the packed archive, graded again in a fresh process (`python -m grader
all --submission <the archive staged as grade batch stages it>`), not of the folder it was made from.

`check` is grade batch's side: it reads a staged submission's manifest and says what an instructor
should look at: an archive packed with another handout than the course's current one, files edited
after packing (changed, added or removed), packed as another learner or for another course.
"""

from __future__ import annotations

import hashlib
import json
import re
import subprocess
import sys
import tempfile
import zipfile
from collections.abc import Mapping
from datetime import datetime, timezone
from pathlib import Path

from grader.course.staging import MANIFEST, staged_files

FORMAT = 1


class SubmitError(RuntimeError):
    """The archive cannot be made (the message says why and what to do)."""


def staged_hashes(package: Path, files: Mapping[str, bytes] | None = None) -> dict[str, str]:
    """SHA-256 of every file of a staged package (relative path -> hex), but the manifest and the
    __init__.py grade batch adds; from `files` (posix path in the package -> bytes: what staging wrote) where
    given, else read from disk. In the order of their paths' parts, as sorted Paths are."""
    if files is None:
        files = staged_files(package)
    return {name: hashlib.sha256(files[name]).hexdigest() for name in sorted(files, key=lambda n: n.split("/"))
            if name.rsplit("/", 1)[-1] != MANIFEST and name != "__init__.py"}


def files_hash(package: Path, files: Mapping[str, bytes] | None = None) -> str:
    """One hash of the submitted files (not the manifest): a resubmission is a change of it (`files` as for
    staged_hashes)."""
    digest = hashlib.sha256()
    for name, sha in staged_hashes(package, files).items():
        digest.update(f"{name}\0{sha}\0".encode())
    return digest.hexdigest()


def read_manifest(package: Path) -> tuple[dict | None, str]:
    """(the manifest, "") or (None, why it cannot be read); (None, "") when there is none."""
    path = package / MANIFEST
    if not path.is_file():
        return None, ""
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError, UnicodeDecodeError) as exc:
        return None, f"{MANIFEST} cannot be read ({type(exc).__name__})"
    if not isinstance(data, dict) or not isinstance(data.get("files"), dict):
        return None, f"{MANIFEST} is not a manifest grade submit wrote"
    return data, ""


def check(package: Path, graded_as: str, course_id: str | None,
          current_handout: str | None) -> tuple[dict | None, list[str]]:
    """What a staged submission's manifest says and what in it an instructor should look at: (the manifest
    or None, flags)."""
    manifest, problem = read_manifest(package)
    if manifest is None:
        return None, [problem] if problem else []
    flags = []
    packed_handout = manifest.get("handout")
    if current_handout and packed_handout != current_handout:
        released = f", released {manifest['handout_released']}" if manifest.get("handout_released") else ""
        flags.append(f"packed with an older or other handout ({packed_handout or 'none: the project, not a handout'}"
                     f"{released}); the course's current handout is {current_handout}: its local score came from "
                     "other checks")
    said = edits(package, manifest)
    if said:
        flags.append(f"edited after packing ({manifest.get('packed', 'at an unknown time')}): {'; '.join(said)}")
    if manifest.get("learner") != graded_as:
        flags.append(f"packed as learner {manifest.get('learner')!r}, graded as {graded_as!r}: its quiz answers were "
                     f"checked with {manifest.get('learner')!r}'s numbers")
    if course_id and manifest.get("course") and manifest["course"] != course_id:
        flags.append(f"packed for the course {manifest['course']!r}, not {course_id!r}")
    return manifest, flags


def edits(package: Path, manifest: dict) -> list[str]:
    """What changed in a staged package since its manifest was written, in words ("ch06_measurement.py changed",
    "answers/ch06.yaml added"): nothing where every file hashes as the manifest says."""
    now = staged_hashes(package)
    packed = {str(k): str(v) for k, v in manifest["files"].items()}
    changed = sorted(n for n in now if n in packed and now[n] != packed[n])
    added = sorted(set(now) - set(packed))
    removed = sorted(set(packed) - set(now))
    return [f"{', '.join(names)} {what}" for names, what in ((changed, "changed"), (added, "added"),
                                                               (removed, "removed")) if names]


def packed_time(manifest: dict | None) -> str | None:
    return str(manifest["packed"]) if manifest and manifest.get("packed") else None


# ------------------------------------------------------------------------------------ the learner's side

def pack(folder: Path, learner: str, out: Path, chapters: tuple[str, ...] = ("all",), timeout: float = 600) -> dict:
    """Build the archive of the chapter and answer files in `folder` (the learner's exercises/) for
    `learner` at `out`: staged as grade batch stages it, graded again from the archive in a fresh process,
    the manifest written into it last. Returns the manifest. SubmitError when nothing can be packed or the
    archive cannot be graded here."""
    from grader import course_config as courses
    from grader import provenance
    from grader.course.staging import Entry, StagingError, stage

    with tempfile.TemporaryDirectory(prefix="grade-submit-") as temporary:
        work = Path(temporary)
        try:
            package = stage(Entry(learner, folder), work / "staged") / "exercises"
        except StagingError as exc:
            raise SubmitError(f"{folder}: {exc}") from None
        files = staged_hashes(package)
        partial = work / "archive.zip"
        _write_zip(partial, package, files, None)
        try:
            regraded = stage(Entry(learner, partial), work / "regraded")  # as grade batch reads it
        except StagingError as exc:
            raise SubmitError(f"the archive cannot be read back: {exc}") from None
        local = _grade_fresh(regraded, learner, chapters, timeout)
        the_course = courses.here()
        manifest = {"format": FORMAT, "course": the_course.id if the_course else None,
                    "handout": provenance.handout_id(the_course) if the_course and the_course.in_handout else None,
                    "handout_released": (the_course.handout or {}).get("released") if the_course else None,
                    "grader": provenance.grader_version(), "learner": learner,
                    "packed": datetime.now(timezone.utc).isoformat(timespec="seconds"), "files": files,
                    "local": local}
        out.parent.mkdir(parents=True, exist_ok=True)
        final = out.with_name(f".{out.name}.partial")
        _write_zip(final, package, files, manifest)
        final.replace(out)
    return manifest


def _write_zip(path: Path, package: Path, files: dict[str, str], manifest: dict | None) -> None:
    with zipfile.ZipFile(path, "w", compression=zipfile.ZIP_DEFLATED) as archive:
        for name in files:
            archive.write(package / name, f"exercises/{name}")
        if manifest is not None:
            archive.writestr(f"exercises/{MANIFEST}", json.dumps(manifest, indent=1, ensure_ascii=False) + "\n")


def _grade_fresh(root: Path, learner: str, chapters: tuple[str, ...], timeout: float) -> dict:
    """The archive's score, from `grade ... --format json` in a new interpreter (nothing of this process's
    state: what a grader at submission reads is the archive alone)."""
    command = [sys.executable, "-m", "grader", *chapters, "--submission", str(root), "--format", "json",
               "--learner", learner]
    try:
        done = subprocess.run(command, capture_output=True, text=True, encoding="utf-8", errors="replace",
                              timeout=timeout)
        data = json.loads(done.stdout)
    except (OSError, subprocess.TimeoutExpired, ValueError) as exc:
        raise SubmitError(f"the packed archive could not be graded here ({type(exc).__name__}); nothing was "
                          f"written. {getattr(exc, 'stderr', '') or ''}".strip()) from None
    if data.get("infrastructure"):
        raise SubmitError(f"the packed archive could not be graded here: {data['infrastructure']}")
    return {"seed": data["seed"], "score": data["score"], "max_score": data["max_score"],
            "pending_score": data["pending_score"],
            "hidden_checks": sum(c["hidden_checks"] for c in data["chapters"]),
            "hidden_points": sum(c["hidden_points"] for c in data["chapters"]),
            "chapters": {c["chapter"]: [c["score"], c["max_score"]] for c in data["chapters"]},
            "all_passed": done.returncode == 0}


def write_learner_yaml(answers: Path, learner: str) -> None:
    """Set `learner: <id>` in learner.yaml, keeping its comments (what `learner:` held, a block list's lines
    included, is replaced)."""
    path = answers / "learner.yaml"
    text = path.read_text(encoding="utf-8") if path.is_file() else ""
    line = f"learner: {learner}"
    held = r"(?m)^learner:.*$(?:\n(?:[ \t]+[^ \t\n#]|-).*$)*"
    if re.search(held, text):
        text = re.sub(held, lambda _: line, text, count=1)
    else:
        text = text + ("" if text.endswith("\n") or not text else "\n") + line + "\n"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text, encoding="utf-8")
