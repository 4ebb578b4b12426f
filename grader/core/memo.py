"""Verdicts kept from a learner's last runs of `grade`, reused when their code returned exactly what it returned
then (and the quiz answers are exactly those judged then).

A learner runs `grade ch06` again and again while most of the chapter's functions return what they returned
before. What a check decides is a function of the grader, the seed, the calls it planned and what came back
(values, errors, their tracebacks, timeouts: every byte of the child's answer, as the parent recorded it), so a
chapter whose child answered exactly as before is judged as before without planning or judging again: the
parent then imports neither numpy nor the checks. The child still runs every call every time; only the judging
is kept. Each check's last verdict is kept too, by what the check's own calls answered: a chapter whose answers
differ from every kept run's judges only the checks whose calls answered otherwise (grader.core.grading).

Only `grade` on one submission uses it, and only where learner code cannot write this user's files (the sandbox
or a dropped uid: grader.boundary's `walled`): an entry is the grader's own word, kept where only the grader writes.
Batch, Gradescope and every instructor's command judge afresh. An entry's key covers the grader's files (their
paths, sizes and modification times), the interpreter and numpy, so an edited check, reference or key is a miss.
Anything missing, unreadable or malformed is a miss too: the memo never breaks a grade.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import sys
from pathlib import Path

from grader.boundary.wire import Call, EncodedCalls

ENTRIES = 8  # verdicts kept per chapter (the last runs'), and quiz verdicts, of one learner
PLANS = 4  # plans kept per chapter (with and without the report's plots; a course's hidden checks)
WORKER_ENTRIES = 32  # verdicts a batch worker keeps per chapter (the last used), some 20 KB each
_NAMES = frozenset(f"ch{n:02d}" for n in range(100)) | {"quiz", "version"}  # the memo's files


class PlannedCall(Call):
    """A call as a plan made it, kept encoded: sent again as it was, without planning (or numpy)."""

    def __init__(self, encoded: dict) -> None:
        object.__setattr__(self, "function", str(encoded["function"]))
        object.__setattr__(self, "args", ())
        object.__setattr__(self, "kwargs", ())
        object.__setattr__(self, "encoded", encoded)

    def to_json(self, index: int) -> dict:
        return dict(self.encoded, index=index)


def _stamp_of(folders: list[Path]) -> list:
    """Each file that decides a verdict, by path, size and modification time (not read: a stamp, not a hash)."""
    stamp: list = []

    def visit(folder: str) -> None:
        with contextlib.suppress(OSError):
            for entry in sorted(os.scandir(folder), key=lambda e: e.name):
                if entry.is_dir():
                    if entry.name != "__pycache__":
                        visit(entry.path)
                elif entry.name.endswith((".py", ".yaml", ".json")):
                    with contextlib.suppress(OSError):
                        info = entry.stat()
                        stamp.append((entry.path, info.st_size, info.st_mtime_ns))

    for folder in folders:
        visit(str(folder))
    return stamp


def grader_stamp() -> str:
    """What the grader's verdicts depend on here, as a hash: its files, the references and keys where they are
    installed (the course file with them), a handout's own file, the interpreter and numpy (found, not imported)."""
    import importlib.util

    from grader import course_config, provenance

    folders = provenance.verdict_sources()
    extra = [course_config.HANDOUT_FILE] if course_config.in_handout() else []  # the course file is among the references
    numpy = importlib.util.find_spec("numpy")
    if numpy is not None and numpy.origin:
        extra.append(Path(numpy.origin).with_name("version.py"))
    stamp = _stamp_of(folders)
    for path in extra:
        with contextlib.suppress(OSError):
            info = os.stat(path)
            stamp.append((str(path), info.st_size, info.st_mtime_ns))
    text = json.dumps([sys.executable, sys.version, stamp])
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


def key_of(*parts: object) -> str | None:
    """A hash of plain data (None where it is not plain data: then nothing is kept or reused). Dicts count in
    their order (a child's lines give theirs): the same data in another order is a miss, never a wrong hit."""
    try:
        text = json.dumps(parts, allow_nan=True)
    except (TypeError, ValueError):
        return None
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


class Memo:
    """The kept plans and verdicts of this grader, in `folder` as one JSON file per chapter (quiz.json, version.json):
    one learner's runs (`one_learner`: a chapter whose files are new is planned while the child runs, and the quiz
    is kept too). With `folder` None, kept in this process only: a batch worker's, across the learners it grades
    (every learner whose code answers a chapter exactly as another's gets that verdict without planning or judging
    again; the quiz, with each learner's own numbers, is judged for each)."""

    def __init__(self, folder: Path | None, grader: str) -> None:
        self.folder = folder
        self.grader = grader
        self.one_learner = folder is not None
        self._files: dict[str, dict] = {}
        self._calls: dict[tuple[str, str], tuple[list, EncodedCalls]] = {}  # made once from each kept list

    def _read(self, name: str) -> dict:
        if name not in self._files and self.folder is None:
            self._files[name] = {"grader": self.grader}
        if name not in self._files:
            entry: object = None
            with contextlib.suppress(OSError, ValueError):
                entry = json.loads((self.folder / f"{name}.json").read_text(encoding="utf-8"))
            valid = isinstance(entry, dict) and entry.get("grader") == self.grader
            self._files[name] = entry if valid else {"grader": self.grader}  # type: ignore[assignment]
        return self._files[name]

    def _write(self, name: str, data: dict | None = None) -> None:
        """Write one file atomically (`data`, else the kept index `name`); failing to write is not an error (the
        next run judges again)."""
        if self.folder is None:
            return
        path = self.folder / f"{name}.json"
        temporary = path.with_name(f".{name}.{os.getpid()}.tmp")
        try:
            self.folder.mkdir(parents=True, exist_ok=True)
            temporary.write_text(json.dumps(self._files[name] if data is None else data), encoding="utf-8")
            os.replace(temporary, path)
        except (OSError, TypeError, ValueError):
            with contextlib.suppress(OSError):
                temporary.unlink(missing_ok=True)

    def _value(self, name: str, entry: dict) -> dict | None:
        """A kept verdict's value: in memory, in its entry; in a folder, in a file of its own (`name`.`key`.json,
        read only when it is wanted), made by this grader."""
        if self.folder is None:
            value = entry.get("value")
        else:
            key = entry.get("key")
            if not isinstance(key, str) or not key.isalnum():
                return None
            value = None
            with contextlib.suppress(OSError, ValueError):
                kept = json.loads((self.folder / f"{name}.{key}.json").read_text(encoding="utf-8"))
                value = kept.get("value") if isinstance(kept, dict) and kept.get("grader") == self.grader else None
        return value if isinstance(value, dict) else None

    def calls(self, chapter: str, plan_key: str) -> EncodedCalls | None:
        """The calls a plan of `chapter` made under `plan_key`, with their JSON text, or None. The same list each
        time while what is kept stays: a batch worker encodes them once for all its learners."""
        if chapter not in _NAMES:
            return None
        plans = self._read(chapter).get("plans")
        calls = plans.get(plan_key) if isinstance(plans, dict) else None
        if not isinstance(calls, list):
            return None
        made = self._calls.get((chapter, plan_key))
        if made is not None and made[0] is calls:
            return made[1]
        if not all(isinstance(c, dict) and isinstance(c.get("function"), str) for c in calls):
            return None
        try:
            text = json.dumps([dict(c, index=i) for i, c in enumerate(calls)], allow_nan=False)
        except (TypeError, ValueError):
            return None
        encoded = EncodedCalls([PlannedCall(c) for c in calls], text)
        self._calls[(chapter, plan_key)] = (calls, encoded)
        return encoded

    def keep_calls(self, chapter: str, plan_key: str, calls: list[Call],
                   builds_on: dict[str, tuple[str, ...]] | None = None,
                   slots: dict[str, list[int]] | None = None) -> None:
        """Keep a plan's calls, with the chapter's `builds_on` (its functions' helpers: what the child is asked to
        watch for, grader.boundary.wire), which a run that reuses the calls needs without loading the checks, and
        with `slots`, which of the calls each check made (by their numbers), which judging one check alone needs."""
        if chapter not in _NAMES:
            return
        data = self._read(chapter)
        plans = data.get("plans") if isinstance(data.get("plans"), dict) else {}
        plans = {k: v for k, v in plans.items() if k != plan_key}
        data["plans"] = dict([*list(plans.items())[-(PLANS - 1):], (plan_key, [c.to_json(i) for i, c in enumerate(calls)])])
        kept_slots = data.get("slots") if isinstance(data.get("slots"), dict) else {}
        data["slots"] = {k: v for k, v in kept_slots.items() if k in data["plans"] and k != plan_key}
        if slots is not None:
            data["slots"][plan_key] = slots
        if builds_on is not None:
            data["builds_on"] = {function: list(helpers) for function, helpers in builds_on.items()}
        self._write(chapter)

    def slots(self, chapter: str, plan_key: str) -> dict[str, list[int]] | None:
        """Which of the kept calls (`calls`) each check of the plan made, by check id in the plan's order; or None."""
        kept = self._read(chapter).get("slots") if chapter in _NAMES else None
        slots = kept.get(plan_key) if isinstance(kept, dict) else None
        if not isinstance(slots, dict) or not all(isinstance(c, str) and isinstance(n, list) and
                                                  all(type(i) is int for i in n) for c, n in slots.items()):
            return None
        return slots

    def check_verdicts(self, chapter: str) -> dict[str, list]:
        """Each check's last verdict kept for `chapter` (keep_check_verdicts), by check id: [its key, its value]."""
        if chapter not in _NAMES or self.folder is None:
            return {}
        kept = self._read(f"{chapter}-checks").get("checks")
        return {c: v for c, v in kept.items() if isinstance(v, list) and len(v) == 2 and isinstance(v[1], dict)} \
            if isinstance(kept, dict) else {}

    def keep_check_verdicts(self, chapter: str, verdicts: dict[str, list]) -> None:
        """Keep each check's last verdict (check id -> [its key, its value]): a run whose chapter answers differ from
        every kept run's judges afresh only the checks whose own calls answered otherwise. One learner's memo only."""
        if chapter not in _NAMES or self.folder is None or not verdicts:
            return
        data = self._read(f"{chapter}-checks")
        kept = data.get("checks") if isinstance(data.get("checks"), dict) else {}
        data["checks"] = {**kept, **verdicts}
        self._write(f"{chapter}-checks")

    def builds_on(self, chapter: str) -> dict[str, tuple[str, ...]] | None:
        """The chapter's builds_on kept with its calls (keep_calls), or None (then its calls are planned again)."""
        kept = self._read(chapter).get("builds_on") if chapter in _NAMES else None
        if not isinstance(kept, dict) or not all(isinstance(f, str) and isinstance(h, list) and
                                                 all(isinstance(n, str) for n in h) for f, h in kept.items()):
            return None
        return {function: tuple(helpers) for function, helpers in kept.items()}

    def verdict(self, name: str, key: str | None, files: str | None = None) -> dict | None:
        """The verdict kept under `key` in `name`'s file (a chapter, or "quiz"), or None; found, it is marked as
        made from the learner's files hashed as `files` too (see seen)."""
        if key is None or name not in _NAMES:
            return None
        entries = self._read(name).get("verdicts")
        if not isinstance(entries, list):
            return None
        found = next((e for e in entries if isinstance(e, dict) and e.get("key") == key), None)
        if found is not None and self.folder is None:  # kept in memory: the last used is the last let go
            entries.remove(found)
            entries.append(found)
        value = self._value(name, found) if found is not None else None
        if value is not None and files is not None and found.get("files") != files:
            found["files"] = files  # these files answer alike: the next run with them plans nothing ahead
            self._write(name)
        return value

    def keep_verdict(self, name: str, key: str | None, value: dict, files: str | None = None) -> None:
        """Keep `value` under `key` (the last ENTRIES per file), made from the learner's files hashed as `files`: in
        a folder, the value in a file of its own beside the file of entries, so a run reads only the one it uses."""
        if key is None or name not in _NAMES or (self.folder is not None and not key.isalnum()):
            return
        data = self._read(name)
        entries = [e for e in data.get("verdicts") or [] if isinstance(e, dict) and e.get("key") != key]
        kept = ENTRIES if self.one_learner else WORKER_ENTRIES
        dropped, entries = entries[:-(kept - 1)], entries[-(kept - 1):]
        if self.folder is None:
            data["verdicts"] = [*entries, {"key": key, "value": value, "files": files}]
            return
        self._write(f"{name}.{key}", {"grader": self.grader, "value": value})
        data["verdicts"] = [*({k: v for k, v in e.items() if k != "value"} for e in entries), {"key": key, "files": files}]
        self._write(name)
        for entry in dropped:
            if isinstance(entry.get("key"), str) and entry["key"].isalnum():
                with contextlib.suppress(OSError):
                    (self.folder / f"{name}.{entry['key']}.json").unlink()

    def seen(self, name: str, files: str | None) -> bool:
        """Whether a verdict of `name` was kept from learner files hashed as `files` (then this run's answers are
        most likely the same, and judging is most likely not needed)."""
        entries = self._read(name).get("verdicts") if name in _NAMES else None
        return files is not None and isinstance(entries, list) and any(
            isinstance(e, dict) and e.get("files") == files for e in entries)


    def version(self) -> str:
        """The grader's version (grader.provenance.grader_version), kept while the grader's files are unchanged: on
        the instructor's side it is a hash of them all."""
        data = self._read("version")
        if isinstance(data.get("version"), str):
            return data["version"]
        from grader import provenance

        data["version"] = provenance.grader_version()
        self._write("version")
        return data["version"]


def default(walled: bool) -> Memo | None:
    """The memo in the user's cache folder, where learner code cannot write it (`walled`); else None (and with
    GRADER_CACHE_DIR empty)."""
    if not walled:
        return None
    from grader.system import cache_folder

    folder = cache_folder("results")
    if folder is None:
        return None
    try:
        return Memo(Path(folder), grader_stamp())
    except (OSError, ValueError):
        return None
