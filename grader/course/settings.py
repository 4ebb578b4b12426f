"""What a run of the history graded with (grader.course.history keeps it with each run): the course file, the
overrides and the roster as they were read (their paths and their text), the seed and where it came from, the
chapters, the handout, the outputs asked for, the time budget, the sandbox and the grader's version.

`grade regrade OUT` grades with the last run's settings unless told others, and says what differs (differences):
nothing a regrade records can come from a default that silently differs from what the batch ran with.
"""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING

from grader.course_config import CourseError, from_text

if TYPE_CHECKING:
    from grader.course_config import Course


@dataclass(frozen=True)
class Source:
    """A file a run read: its path as given and the text it held (None: there was no such file)."""

    path: str | None = None
    text: str | None = None

    @classmethod
    def read(cls, path: Path | None) -> Source:
        """The file at `path` as it is now (UTF-8; its bytes replaced where not), or Source() for none."""
        if path is None:
            return cls()
        try:
            return cls(str(path), path.read_bytes().decode("utf-8-sig", "replace"))
        except OSError:
            return cls(str(path), None)

    @property
    def name(self) -> str:
        """The file's name for messages ("none" for no file)."""
        return Path(self.path).name if self.path else "none"


@dataclass(frozen=True)
class RunSettings:
    """What one run graded with (plain data, kept as JSON in the history)."""

    chapters: tuple[str, ...]
    seed: int
    seed_from: str = "the course file"  # "--seed", "the course file", "the public seed"
    course: Source = field(default_factory=Source)
    overrides: Source = field(default_factory=Source)
    roster: Source = field(default_factory=Source)
    handout: str | None = None  # the current handout, as the course file or --handout said
    lms: tuple[str, ...] = ()  # the LMS gradebooks asked for (canvas, moodle)
    html: bool = True
    plots: bool = False
    time_budget: float = 60.0
    sandbox: str = "required"
    grader: str = ""

    def to_json(self) -> str:
        return json.dumps(asdict(self), ensure_ascii=False, sort_keys=True)

    @classmethod
    def from_json(cls, text: str | None) -> RunSettings | None:
        """The settings a run kept (None for a run of a history from before settings were kept)."""
        if not text:
            return None
        data = json.loads(text)
        for name in ("course", "overrides", "roster"):
            data[name] = Source(**(data.get(name) or {}))
        for name in ("chapters", "lms"):
            data[name] = tuple(data.get(name) or ())
        return cls(**{k: v for k, v in data.items() if k in cls.__dataclass_fields__})

    def with_(self, **changes) -> RunSettings:
        return replace(self, **changes)

    def course_file(self) -> Course | None:
        """The course this run read, made again from the text it kept (None where it read no file: the defaults);
        grader.course_config.CourseError where the kept text is not a course file (a hand-edited history)."""
        if self.course.text is None:
            return None
        return from_text(self.course.text, f"{self.course.path} (as run with)")


def differences(before: RunSettings, now: RunSettings) -> list[str]:
    """What `now` does differently from `before`, in words, one item per setting (the grader's version is not among
    them: a regrade is for a new grader)."""
    said = []
    if before.chapters != now.chapters:
        said.append(f"chapters {', '.join(before.chapters)} -> {', '.join(now.chapters)}")
    if before.seed != now.seed:
        said.append(f"seed {before.seed} ({before.seed_from}) -> {now.seed} ({now.seed_from})")
    said += _course_differences(before, now)
    if before.overrides.text != now.overrides.text:
        said.append(f"overrides: {before.overrides.path or 'no file'} as run with -> {now.overrides.path or 'no file'} "
                    f"({_rows_differ(before.overrides.text, now.overrides.text)})")
    if before.handout != now.handout:
        said.append(f"the current handout {before.handout or 'none'} -> {now.handout or 'none'}")
    if before.time_budget != now.time_budget:
        said.append(f"time budget {before.time_budget:g} s -> {now.time_budget:g} s")
    return said


def _course_differences(before: RunSettings, now: RunSettings) -> list[str]:
    if before.course.text == now.course.text:
        return []
    try:
        old, new = before.course_file(), now.course_file()
    except CourseError as exc:
        return [f"course file {before.course.name} -> {now.course.name} (one cannot be read: {exc})"]
    fields = ("id", "seed", "late", "hidden", "exact_derivatives", "quiz_feedback", "quiz_feedback_by",
              "accepts_manifest_time", "current_handout")
    changed = [name for name in fields if getattr(old, name, None) != getattr(new, name, None)]
    what = ", ".join("deadline and late penalty" if name == "late" else name for name in changed) or "comments only"
    return [f"course file {before.course.path or 'defaults'} -> {now.course.path or 'defaults'} ({what})"]


def _rows_differ(before: str | None, now: str | None) -> str:
    """How two overrides files differ, by their rows: "2 rows more, 1 row fewer"."""
    old = [line.strip() for line in (before or "").splitlines()[1:] if line.strip()]
    new = [line.strip() for line in (now or "").splitlines()[1:] if line.strip()]
    more, fewer = [r for r in new if r not in old], [r for r in old if r not in new]
    parts = [f"{len(more)} row{'s' * (len(more) != 1)} more" if more else "",
             f"{len(fewer)} row{'s' * (len(fewer) != 1)} fewer" if fewer else ""]
    return ", ".join(p for p in parts if p) or "the same rows, changed in form"
