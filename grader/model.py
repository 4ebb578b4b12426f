"""The result model every renderer reads: check -> chapter -> report, plain dataclasses."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from enum import Enum

SCHEMA_VERSION = "1.3"


class Status(str, Enum):
    PASS = "pass"
    FAIL = "fail"
    ERROR = "error"  # the chapter could not be graded, or the grader itself broke
    SKIP = "skip"  # not run because something it depends on failed; still counts in max_points
    RECORDED = "recorded"  # a quiz answer read and well-formed, graded on submission: not in max_points

    @property
    def counted(self) -> bool:
        """Judged here: part of score and max_score (a recorded answer is pending instead)."""
        return self is not Status.RECORDED


_RECORDED = Status.RECORDED  # the one status not counted (Status.counted), compared without a call in the sums


class _RoundedPoints:
    """A dataclass field of points, rounded once, as it is set (rounded_points): every sum and every output is of
    these. A descriptor, so that setting the other fields costs no call of Python's."""

    def __set_name__(self, owner: type, name: str) -> None:
        self.key = f"_{name}_rounded"

    def __get__(self, instance: object, owner: type | None = None) -> float:
        if instance is None:  # the field has no default (dataclasses: descriptor-typed fields)
            raise AttributeError(self.key)
        return instance.__dict__[self.key]

    def __set__(self, instance: object, value: float) -> None:
        instance.__dict__[self.key] = rounded_points(value)


NOT_ANSWERED = "not answered yet"  # a blank quiz question's message (grader.quiz)


@dataclass
class CheckResult:
    """The verdict on one check: a code check or a quiz question."""

    id: str
    function: str
    description: str
    status: Status
    points: float = _RoundedPoints()  # type: ignore[assignment]
    max_points: float = _RoundedPoints()  # type: ignore[assignment]
    message: str = ""
    expected: object = None
    got: object = None
    kind: str = "code"  # "code" or "quiz"
    details: dict = field(default_factory=dict)  # renderer hints, e.g. the wrong matrix entries
    mistake: str = ""  # the name of the known mistake a wrong answer matches (grader.judging.diagnose), "" if none
    help: str = ""  # what to change (the named mistake's sentence), kept apart from the message, which says what is wrong
    practice: bool = False  # a quiz question of a practice quiz (immediate feedback): judged, never counted
    upstream: list[str] = field(default_factory=list)  # failing helpers this failure may come from (point_upstream)
    # a judged quiz answer in the quiz's own terms, for the class summary: {"options": [canonical options
    # chosen]} (the letters are each learner's own) or {"form": the answer's form, its numbers by name}
    answer: dict = field(default_factory=dict)

    @property
    def unanswered(self) -> bool:
        """A quiz question the learner left blank: no answer to judge (0 points), which the class statistics count
        apart from a wrong one."""
        return self.kind == "quiz" and self.status == Status.FAIL and self.message == NOT_ANSWERED

    def __getstate__(self) -> dict:
        """Its fields (pickled, copied): never the kept verdict it was made from (made_once), which stays here."""
        state = self.__dict__
        return {k: v for k, v in state.items() if k != _MADE_FROM} if _MADE_FROM in state else state

    def to_dict(self, chapter: str = "") -> dict:
        """The check as report.json and the history have it: the same dict, not to be changed, for a check made
        unchanged from a kept verdict (made_once)."""
        return made_once(self, ("dict", chapter), self._to_dict, chapter)

    def _to_dict(self, chapter: str) -> dict:
        return {
            "id": self.id,
            "stable_id": f"{chapter}/{self.id}" if chapter else self.id,
            "function": self.function,
            "description": self.description,
            "status": self.status.value,
            "points": rounded_points(self.points),
            "max_points": rounded_points(self.max_points),
            "message": self.message,
            "expected": jsonable(self.expected),
            "got": jsonable(self.got),
            "kind": self.kind,
            "mistake": self.mistake or None,
            **({"help": self.help} if self.help else {}),
            "practice": self.practice,
            "upstream": list(self.upstream),
            **({"answer": self.answer} if self.answer else {}),
        }


def not_written(checks: list[CheckResult]) -> dict[str, list[CheckResult]]:
    """Among `checks`, the functions every check of which failed only because the function is not written yet
    (it raises NotImplementedError), with their checks: shown as one line each."""
    by_function: dict[str, list[CheckResult]] = {}
    for check in checks:
        by_function.setdefault(check.function, []).append(check)
    return {f: cs for f, cs in by_function.items() if all(c.details.get("not_implemented") for c in cs)}


@dataclass
class Adjustment:
    """A change of points made after grading: an instructor's override (overrides.csv) or a late penalty.
    `target` is what it changes: a check ("ch06/H_worked_example"), a chapter ("ch06") or "total"; `points`
    is the change it made (negative for a penalty), already kept within 0 and the check's maximum."""

    target: str
    points: float = _RoundedPoints()  # type: ignore[assignment]  # rounded once, as CheckResult's
    reason: str
    kind: str = "override"  # "override" or "late"
    who: str = ""
    source: str = ""  # where it was read, e.g. "overrides.csv, line 3"
    check_kind: str = ""  # for a check: "code" or "quiz" (its chapter's column it changes)

    @property
    def chapter(self) -> str | None:
        return self.target.split("/", 1)[0] if self.target.startswith("ch") else None

    @property
    def on_check(self) -> bool:
        return "/" in self.target

    def to_dict(self) -> dict:
        return {"target": self.target, "points": rounded_points(self.points), "reason": self.reason, "kind": self.kind,
                "who": self.who, "source": self.source}

    @classmethod
    def said(cls, kept: dict) -> str:
        """An adjustment as report.json and the history keep it (to_dict), in words with its kind: "override +2 on
        ch06 (regrade request; by bo, overrides.csv, line 3)"; a record that is none (a history edited by hand) as
        its values."""
        try:
            made = cls(**kept)
        except TypeError:
            return " ".join(str(v) for v in kept.values())
        return f"{made.kind} {made.describe()}"

    def describe(self) -> str:
        """One line: '+2 on ch06/H_worked_example (regrade request; by bo, overrides.csv, line 3)'."""
        by = ", ".join(p for p in (f"by {self.who}" if self.who else "", self.source) if p)
        return f"{self.points:+g} on {self.target} ({self.reason}{'; ' + by if by else ''})"


@dataclass
class ChapterResult:
    chapter: str
    title: str
    checks: list[CheckResult] = field(default_factory=list)
    problems: list[str] = field(default_factory=list)  # chapter-level messages (import failures ...)
    plots: dict = field(default_factory=dict)  # learner outputs kept for the report's plots

    hidden_checks: int = 0  # checks of this chapter not run here (graded on submission)
    hidden_points: float = 0.0
    source: str = ""  # the file graded ("exercises/ch06_measurement.ipynb"), or the code a notebook's kernel ran
    unread: bool = False  # `source` could not be read (a notebook that is not one): nothing in it was graded
    notes: list[str] = field(default_factory=list)  # what the learner should know that is no problem of the code
    adjustments: list[Adjustment] = field(default_factory=list)  # overrides of its checks and of the chapter

    def score_of(self, kind: str | None = None) -> float:
        """Points of the checks judged here (of one kind), with the overrides of those checks."""
        checks = sum(c.points for c in self.checks if kind in (None, c.kind) and c.status is not _RECORDED)
        overridden = sum(a.points for a in self.adjustments if a.on_check and kind in (None, a.check_kind))
        return rounded_points(checks + overridden)

    @property
    def raw_score(self) -> float:
        """Points of the checks as graded, before any override."""
        return rounded_points(sum(c.points for c in self.checks if c.status is not _RECORDED))

    def max_score_of(self, kind: str | None = None) -> float:
        return rounded_points(sum(c.max_points for c in self.checks if kind in (None, c.kind) and c.status is not _RECORDED))

    def recorded_score_of(self, kind: str | None = None) -> float:
        """The points of answers recorded here and graded on submission."""
        return rounded_points(sum(c.max_points for c in self.checks if kind in (None, c.kind) and c.status is _RECORDED))

    @property
    def pending_score(self) -> float:
        """Points not judged here: recorded quiz answers and hidden checks."""
        return rounded_points(self.recorded_score_of() + self.hidden_points)

    @property
    def score(self) -> float:
        """The chapter's points: its checks', with every override of them or of the chapter."""
        return rounded_points(self.score_of() + sum(a.points for a in self.adjustments if not a.on_check))

    @property
    def max_score(self) -> float:
        return self.max_score_of()

    def to_dict(self) -> dict:
        return {
            "chapter": self.chapter,
            "title": self.title,
            "score": self.score,
            "max_score": self.max_score,
            "code_score": self.score_of("code"),
            "code_max_score": self.max_score_of("code"),
            "quiz_score": self.score_of("quiz"),
            "quiz_max_score": self.max_score_of("quiz"),
            "pending_score": self.pending_score,
            "hidden_checks": self.hidden_checks,
            "hidden_points": rounded_points(self.hidden_points),
            "problems": list(self.problems),
            "source": self.source or None,
            "notes": list(self.notes),
            "checks": [c.to_dict(self.chapter) for c in self.checks],
        }

    @classmethod
    def from_dict(cls, ch: dict, kept: bool = False) -> ChapterResult:
        """The chapter a to_dict() or to_kept() made; each check's `details` and the plot data where the dict has
        them (to_kept's, not to_dict's). `kept`: `ch` is a verdict a memo keeps, and goes on keeping as it is, for
        other learners too: what the renderers make of each check is made once while it stays as made (made_once)."""
        checks = [CheckResult(id=c["id"], function=c["function"], description=c["description"],
                              status=Status(c["status"]), points=c["points"], max_points=c["max_points"],
                              message=c.get("message", ""), expected=c.get("expected"), got=c.get("got"),
                              kind=c.get("kind", "code"), mistake=c.get("mistake") or "", help=c.get("help") or "",
                              practice=bool(c.get("practice")), upstream=list(c.get("upstream") or []),
                              answer=dict(c.get("answer") or {}), details=dict(c.get("details") or {}))
                  for c in ch.get("checks", [])]
        if kept:
            for check, c in zip(checks, ch.get("checks", [])):
                _made_from(check, c)
        return cls(ch["chapter"], ch.get("title", ""), checks, list(ch.get("problems", [])),
                   plots=dict(ch.get("plots") or {}), hidden_checks=int(ch.get("hidden_checks", 0)),
                   hidden_points=float(ch.get("hidden_points", 0.0)), source=ch.get("source") or "",
                   unread=ch.get("unread") is True, notes=list(ch.get("notes") or []))

    def to_kept(self, made: dict | None = None) -> dict:
        """to_dict() (`made`: that dict, made already, which is left as it is) with each check's details, the plot
        data and whether `source` could not be read: what from_dict() makes this chapter again from
        (grader.core.memo, the history)."""
        data = self.to_dict() if made is None else dict(made)
        if self.unread:
            data["unread"] = True
        if any(check.details for check in self.checks):
            data["checks"] = [made_once(check, ("kept", self.chapter), _with_details, check, kept) if check.details
                              else kept for check, kept in zip(self.checks, data["checks"])]
        if self.plots:
            data["plots"] = plain(self.plots)
        return data


@dataclass
class Report:
    submission: str
    chapters: list[ChapterResult] = field(default_factory=list)
    seed: int | None = None
    learner: str | None = None  # whose quiz variants were graded, and where the id came from
    learner_output: str = ""  # what learner code printed while graded (capped)
    infrastructure: str = ""  # why grading failed for a reason outside the learner's code (then it is no grade)
    # provenance: what made this report (grader.provenance), rendered by every renderer
    grader: str = ""  # the grader's version
    handout: str | None = None  # the handout's id (its version): the one grading here, or the course's current one
    course: str | None = None  # the course id
    learner_id: str | None = None  # the plain learner id whose quiz numbers were graded
    learner_unset: bool = False  # no id was given: the quiz was graded with the default id's numbers
    adjustments: list[Adjustment] = field(default_factory=list)  # overrides of the total and late penalties
    flags: list[str] = field(default_factory=list)  # for the instructor's eyes (grade batch keeps them in report.json)

    @property
    def score(self) -> float:
        """Every check's points, with every override and penalty (grade batch applies them)."""
        return rounded_points(sum(c.score for c in self.chapters) + sum(a.points for a in self.adjustments))

    @property
    def raw_score(self) -> float:
        """The points of the checks as graded, before any override or penalty."""
        return rounded_points(sum(c.raw_score for c in self.chapters))

    def all_adjustments(self) -> list[Adjustment]:
        return [a for ch in self.chapters for a in ch.adjustments] + list(self.adjustments)

    def provenance(self) -> dict:
        """What made this report: grader version, handout id, course, seed and learner id."""
        return {"grader": self.grader or None, "handout": self.handout, "course": self.course, "seed": self.seed,
                "learner": self.learner_id}

    @property
    def max_score(self) -> float:
        return rounded_points(sum(c.max_score for c in self.chapters))

    @property
    def pending_score(self) -> float:
        """Points that are graded on submission, not here (hidden checks, recorded quiz answers)."""
        return rounded_points(sum(c.pending_score for c in self.chapters))

    @property
    def all_passed(self) -> bool:
        """Every check judged here passed (says nothing about pending points)."""
        return all(c.status in (Status.PASS, Status.RECORDED) for ch in self.chapters for c in ch.checks) and not any(
            ch.problems for ch in self.chapters)

    @classmethod
    def from_dict(cls, data: dict) -> Report:
        """The report a to_dict() made (for resumed batches); details and plots are not kept."""
        chapters = [ChapterResult.from_dict(ch) for ch in data.get("chapters", [])]
        made = data.get("provenance") or {}
        report = cls(data.get("submission", ""), chapters, seed=data.get("seed"), learner=data.get("learner"),
                     infrastructure=data.get("infrastructure") or "", grader=made.get("grader") or "",
                     handout=made.get("handout"), course=made.get("course"), learner_id=made.get("learner"))
        report.attach(data.get("adjustments") or [])
        return report

    def attach(self, adjustments: list[dict]) -> None:
        """Put adjustments (Adjustment.to_dict()s, as report.json and the history keep them) where they belong: on
        their chapter (a check's or a chapter's), else on the total."""
        by_id = {c.chapter: c for c in self.chapters}
        for item in adjustments:
            adjustment = Adjustment(**item)
            chapter = by_id.get(adjustment.chapter or "")
            if chapter is None:
                self.adjustments.append(adjustment)
                continue
            if adjustment.on_check:
                check_id = adjustment.target.split("/", 1)[1]
                adjustment.check_kind = next((c.kind for c in chapter.checks if c.id == check_id), "code")
            chapter.adjustments.append(adjustment)

    def to_kept(self, chapters: list[dict] | None = None) -> dict:
        """The report as judged, to be made again by from_kept (grader.core.memo, the history): to_dict() without
        the adjustments, with each check's details, the plot data, what learner code printed and the flags;
        `chapters`: its chapters' to_dict(), made already (left as they are)."""
        made = chapters or [None] * len(self.chapters)
        return dict(self.to_dict(chapters=[c.to_kept(m) for c, m in zip(self.chapters, made)]), adjustments=[],
                    learner_output=self.learner_output, flags=list(self.flags), learner_unset=self.learner_unset)

    @classmethod
    def from_kept(cls, data: dict) -> Report:
        """The report a to_kept() made."""
        report = cls.from_dict(data)
        report.learner_output = str(data.get("learner_output") or "")
        report.flags = [str(f) for f in data.get("flags") or []]
        report.learner_unset = bool(data.get("learner_unset"))
        return report

    def to_dict(self, chapters: list[dict] | None = None) -> dict:
        """The report as plain data (grader/schemas/report.schema.json); `chapters`: its chapters' data, made already."""
        return {
            "version": SCHEMA_VERSION,
            "submission": self.submission,
            "seed": self.seed,
            "learner": self.learner,
            "provenance": self.provenance(),
            "score": self.score,
            "max_score": self.max_score,
            "pending_score": self.pending_score,
            "raw_score": self.raw_score,
            "adjustments": [a.to_dict() for a in self.all_adjustments()],
            "infrastructure": self.infrastructure or None,
            "chapters": [c.to_dict() for c in self.chapters] if chapters is None else chapters,
        }


@dataclass
class LearnerResult:
    """One learner's line in a run of the history (grader.course.history): what the gradebooks export, and what
    changes.csv compares."""

    learner: str
    status: str  # graded, unreadable, error
    message: str = ""
    files_hash: str | None = None
    content_hash: str | None = None
    manifest_handout: str | None = None
    submitted: str | None = None
    grader: str | None = None
    seed: int | None = None
    raw_score: float | None = None
    score: float | None = None
    max_score: float | None = None
    chapters: dict = field(default_factory=dict)  # chNN -> {"code", "quiz", "score", "max"}
    adjustments: list = field(default_factory=list)  # Adjustment.to_dict()s
    flags: list = field(default_factory=list)  # what an instructor should look at
    time_from: str | None = None  # where `submitted` came from: "roster" or "manifest" (None: no time used)
    seconds: float = 0.0  # how long staging and grading took
    manifest: dict | None = None  # what the archive's `grade submit` manifest said (grader.course.batch)
    report: str | None = None  # the report as judged, by its hash in the history's reports

    @classmethod
    def of(cls, learner: str, report, status: str = "graded", message: str = "", **extra) -> LearnerResult:
        """The result of `report` (None: not graded) as the gradebooks show it."""
        if report is None:
            return cls(learner, status, message, **extra)
        chapters = {c.chapter: {"code": c.score_of("code"), "quiz": c.score_of("quiz"), "score": c.score,
                                "max": c.max_score} for c in report.chapters}
        return cls(learner, status, message, grader=report.grader, seed=report.seed, raw_score=report.raw_score,
                   score=report.score, max_score=report.max_score, chapters=chapters,
                   adjustments=[a.to_dict() for a in report.all_adjustments()], **extra)


def _with_details(check: CheckResult, made: dict) -> dict:
    """A check's to_dict() `made` with its details: as to_kept keeps it."""
    return dict(made, details=jsonable(check.details))


# ------------------------------------------------------------------------ checks made again from a kept verdict
# A batch's worker makes most learners' code checks again from the verdicts its memo keeps (grader.core.grading):
# the same dict, learner after learner. What a renderer makes of such a check (its dict, its HTML block, ...) is
# made once per kept dict and renderer, and given again while the check is as it was made from it.

_MADE_FROM = "_made_from"  # a check's own attribute, not a field: (the kept dict, its values as made, what is made)
_MADE_ONCE: dict[int, tuple[dict, tuple, dict]] = {}  # id(kept dict) -> (it, a check's values as made, {what: made})
MADE_ONCE_LIMIT = 1024  # kept dicts remembered (a few KB made of each); past it, forgotten all at once


def _made_from(check: CheckResult, kept: dict) -> None:
    """Note that `check` was made just now by ChapterResult.from_dict from `kept`, a verdict's dict that is kept, with
    what the renderers made of the checks made from it before (the same values: a kept dict changed since starts
    afresh)."""
    values = tuple(check.__dict__.values())
    entry = _MADE_ONCE.get(id(kept))
    if entry is None or entry[0] is not kept or entry[1] != values:
        if len(_MADE_ONCE) >= MADE_ONCE_LIMIT:
            _MADE_ONCE.clear()
        entry = _MADE_ONCE[id(kept)] = (kept, values, {})
    check.__dict__[_MADE_FROM] = (kept, values, entry[2])


def _entry(check: CheckResult) -> dict | None:
    """What the renderers made of the kept verdict `check` was made from (a dict, by what), where every field of the
    check is still as made from it; else None."""
    state = check.__dict__
    mark = state.get(_MADE_FROM)
    if mark is None:
        return None
    kept, values, made = mark
    if tuple(state.values())[:-1] != values or next(reversed(state)) != _MADE_FROM:
        return None  # a field set again since (point_upstream's message), or another attribute added
    # the lists and dicts it was given as copies: changed in place?
    if check.upstream != (kept.get("upstream") or []) or check.details != (kept.get("details") or {}) or \
            check.answer != (kept.get("answer") or {}):
        return None
    return made


def made_once(check: CheckResult, what: tuple, make, *args):
    """`make(*args)`, a renderer's `what` of `check` (which it alone decides): made once for a check made unchanged
    from a kept verdict (ChapterResult.from_dict(..., kept=True)), and the same object given again for every check
    made unchanged from that verdict with the same values; made each time for any other check. What is given again
    is not to be changed."""
    made = _entry(check)
    if made is None:
        return make(*args)
    found = made.get(what, _NOTHING)
    if found is _NOTHING:
        found = made[what] = make(*args)
    return found


_NOTHING = object()


def made_text(check: CheckResult, what: tuple, dumps, value: object) -> str | None:
    """`dumps(value)`, the text of a renderer's data `value` of `check` (`what` names which, and how it is written),
    made once per kept verdict for a check made unchanged from one; None for any other check (its data is written
    with the rest, as ever)."""
    entry = _entry(check)
    if entry is None:
        return None
    text = entry.get(what)
    if text is None:
        text = entry[what] = dumps(value)
    return text


def check_texts(chapters: list[ChapterResult], made: list[dict], what: str, dumps) -> dict[int, str]:
    """made_text of each check's dict among `made` (the chapters' to_dict() or to_kept() data, in their order; `what`
    names which, and how `dumps` writes them), by the dict's id (for grader.safe_text.json_spliced)."""
    texts = {}
    for chapter, data in zip(chapters, made):
        key = (what, chapter.chapter)
        for check, value in zip(chapter.checks, data.get("checks") or ()):
            text = made_text(check, key, dumps, value)
            if text is not None:
                texts[id(value)] = text
    return texts


POINTS_DECIMALS = 4  # points are rounded once, here, to this many decimals; every output prints that value


def rounded_points(value: float) -> float:
    """Points as every output has them: rounded once, to POINTS_DECIMALS decimals (an int when whole)."""
    rounded = round(float(value), POINTS_DECIMALS)
    return int(rounded) if rounded == int(rounded) else rounded


def points_text(value: float | None) -> str:
    """Points as a gradebook cell writes them: the rounded value, every decimal it has ("" for none)."""
    return "" if value is None else f"{rounded_points(value):.{POINTS_DECIMALS + 8}g}"


def plain(value: object) -> object:
    """Plain data of plot data: numpy arrays and scalars as lists and numbers, tuples as lists; a non-finite float
    stays a float (JSON's NaN and Infinity, which Python's json reads back)."""
    if hasattr(value, "tolist"):
        return value.tolist()
    if isinstance(value, dict):
        return {str(k): plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [plain(v) for v in value]
    return value


def jsonable(value: object) -> object:
    """Plain JSON data: arrays to nested lists, non-finite floats to the strings 'nan', 'inf'."""
    if value is None or isinstance(value, (bool, str, int)):
        return value
    if isinstance(value, float):
        if math.isnan(value):
            return "nan"
        if math.isinf(value):
            return "inf" if value > 0 else "-inf"
        return value
    if hasattr(value, "tolist"):
        return jsonable(value.tolist())
    if isinstance(value, dict):
        return {str(k): jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [jsonable(v) for v in value]
    return str(value)
