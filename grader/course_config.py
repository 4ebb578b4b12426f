"""The course this grader serves: its seeds, hidden checks, quiz feedback and whether derivatives must be exact.

Two places hold it. On the instructor's side, `solutions/course.yaml` (never in a release; its
`seed` is the course seed that `grade batch` grades at). In a learner's handout, the file
`grader/data/handout.json` that `grade release` wrote: the public seed the handout's check data was
recorded at, and how many checks (and points) are hidden from it. Reading the handout file is cheap
(JSON); the YAML config is read only where it is needed (batch, release).
"""

from __future__ import annotations

import functools
import json
import math
import os
from dataclasses import dataclass, field
from datetime import datetime
from pathlib import Path

PUBLIC_SEED = 20261122  # the seed of `grade chNN`, at home and in the project; a handout's data is recorded at it
QUIZ_FEEDBACK = ("recorded", "immediate")
DATA_DIR = Path(__file__).resolve().parent / "data"
HANDOUT_FILE = DATA_DIR / "handout.json"
CONFIG_NAME = "course.yaml"


class CourseError(ValueError):
    """A course configuration that cannot be used; the message names the file (and line)."""


@dataclass(frozen=True)
class Late:
    """The deadline and the late penalty: `per_day` of the score (a fraction) per day or part of a day late,
    at most `cap`, after `grace_minutes`."""

    deadline: datetime
    per_day: float
    cap: float = 1.0
    grace_minutes: float = 0.0

    def fraction(self, submitted: datetime) -> tuple[float, float]:
        """(the share of the score taken, days late rounded up) for a submission made at `submitted`."""
        late = (submitted - self.deadline).total_seconds() - 60 * self.grace_minutes
        if late <= 0:
            return 0.0, 0
        days = math.ceil(late / 86400)
        return min(self.cap, self.per_day * days), days


@dataclass(frozen=True)
class Course:
    id: str = "jacobians-linearization"
    public_seed: int = PUBLIC_SEED
    seed: int | None = None  # the course seed (instructor side only; None in a handout)
    quiz_feedback: str = "recorded"  # "recorded": keys stay with the instructor; "immediate": practice keys ship
    hidden: frozenset[str] = frozenset()  # "ch06/H_rows_orthogonal": checks run only when submissions are graded
    exact_derivatives: bool = True  # False: the exact-derivative checks are not part of this course
    handout: dict | None = None  # in a handout: its version and the hidden checks' counts per chapter
    source: str = ""  # where this came from, for messages
    quiz_feedback_by: dict | None = None  # chapter -> "recorded" or "immediate" where it differs from quiz_feedback
    current_handout: str | None = None  # instructor side: the id (version) of the handout learners should have
    late: Late | None = None  # the deadline and the late penalty, where the course has them
    # whether a submission time in the learner's own archive manifest may decide a late penalty where the roster
    # gives none (`manifest_time: accept`; by default it may not: the learner's machine wrote it)
    accepts_manifest_time: bool = False
    scheduler: str | None = None  # instructor side: the Dask scheduler grade batch grades on (grader.course.cluster)
    scheduler_certs: str | None = None  # the folder of the cluster's certificates (grader.course.credentials)
    lines: dict | None = field(default=None, compare=False, hash=False)  # setting -> the line of its file it is on

    def where(self, setting: str) -> str:
        """Where `setting` is written: "course.yaml, line 7" (the file alone where the line is not known)."""
        line = (self.lines or {}).get(setting)
        return f"{self.source}, line {line}" if line else self.source

    @property
    def in_handout(self) -> bool:
        return self.handout is not None

    @property
    def grading_seed(self) -> int:
        """The seed submissions are graded at: the course seed, else the public one."""
        return self.public_seed if self.seed is None else self.seed

    def feedback(self, chapter: str) -> str:
        """How `chapter`'s quiz is given: "recorded" (graded on submission, counted) or "immediate" (keys of
        the fixed questions in the handout: practice, never counted)."""
        return (self.quiz_feedback_by or {}).get(chapter, self.quiz_feedback)

    def practice(self, chapter: str) -> bool:
        """Whether `chapter`'s quiz is practice: immediate feedback, so not counted anywhere."""
        return self.feedback(chapter) == "immediate"

    def is_hidden(self, chapter: str, check_id: str) -> bool:
        return f"{chapter}/{check_id}" in self.hidden

    def hidden_in(self, chapter: str) -> tuple[int, float]:
        """(checks, points) of `chapter` hidden from this handout; (0, 0) outside a handout."""
        if self.handout is None:
            return 0, 0.0
        entry = self.handout.get("hidden", {}).get(chapter, {})
        return int(entry.get("checks", 0)), float(entry.get("points", 0.0))


def in_handout() -> bool:
    """Whether this grader is a learner's handout (no references; check data recorded at release)."""
    return HANDOUT_FILE.is_file()


@functools.lru_cache(maxsize=None)
def current(config: str | None = None, kept_parse: bool = False) -> Course:
    """The handout's course in a handout; else the instructor's `config` file, else
    solutions/course.yaml where the references are installed, else the defaults. `kept_parse`: a YAML file's parse
    may be the one kept in the user's cache folder (_parsed; for the commands that grade one submission only)."""
    if config is None and in_handout():
        return _from_handout(HANDOUT_FILE)
    path = Path(config) if config is not None else _project_config()
    if path is None:
        return Course(source="defaults")
    return _from_yaml(path, kept_parse)


def here() -> Course:
    """The course the commands that grade one submission report for (`grade chNN`, `grade quiz`, `grade list`,
    `grade submit`): a handout's own; on the instructor's side the course file beside the references (its id,
    its quiz feedback and exact derivatives), or the defaults where there is none or it cannot be read."""
    try:
        return current(kept_parse=True)
    except CourseError:
        return Course(source="defaults")


def _project_config() -> Path | None:
    import importlib.util

    try:
        spec = importlib.util.find_spec("solutions")
    except (ImportError, ValueError):
        return None
    if spec is None or not spec.submodule_search_locations:
        return None
    path = Path(list(spec.submodule_search_locations)[0]) / CONFIG_NAME
    return path if path.is_file() else None


def _from_handout(path: Path) -> Course:
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
        return Course(id=str(data["course"]), public_seed=int(data["public_seed"]),
                      quiz_feedback=str(data.get("quiz_feedback", "recorded")),
                      quiz_feedback_by=dict(data.get("quiz_feedback_by") or {}),
                      exact_derivatives=bool(data.get("exact_derivatives", True)), handout=data, source=str(path))
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise CourseError(f"{path}: the handout's course data cannot be read ({exc}); reinstall the handout") from None


_FIELDS = {"course", "seed", "quiz_feedback", "hidden", "exact_derivatives", "handout", "deadline", "late_penalty",
           "manifest_time", "scheduler"}


def _key_lines(text: str) -> dict[str, int]:
    """The line (1-based) of each top-level setting in the YAML text, for messages."""
    import yaml

    try:
        node = yaml.compose(text)
    except yaml.YAMLError:
        return {}
    if not isinstance(node, yaml.MappingNode):
        return {}
    return {str(key.value): key.start_mark.line + 1 for key, _ in node.value}


def _from_yaml(path: Path, kept_parse: bool = False) -> Course:
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise CourseError(f"{path}: cannot be read ({exc.strerror})") from None
    except UnicodeDecodeError as exc:
        raise CourseError(f"{path}: not UTF-8 text ({exc})") from None
    return from_text(text, str(path), kept_parse)


def _parsed(text: str, path: str, kept_parse: bool = False) -> tuple[object, dict[str, int]]:
    """The YAML `text`'s data and the line of each top-level setting. With `kept_parse` (a command that grades one
    submission), a parse that JSON holds exactly is kept in the user's cache folder by the hash of the text and of
    this module's file, so that such a command reads an unchanged course without importing yaml; the instructor's
    commands (batch, regrade, Gradescope's) always parse the file, trusting no cache."""
    import hashlib

    from grader.system import cache_folder

    folder = cache_folder("course") if kept_parse else None
    kept = None
    if folder is not None:
        try:
            parser = os.stat(__file__)
            key = json.dumps([text, parser.st_size, parser.st_mtime_ns])
            kept = os.path.join(folder, hashlib.sha256(key.encode("utf-8", "surrogatepass")).hexdigest() + ".json")
        except OSError:
            kept = None
    if kept is not None:
        try:
            with open(kept, encoding="utf-8") as handle:
                data, lines = json.load(handle)
            if isinstance(lines, dict):
                return data, lines
        except (OSError, ValueError, TypeError):
            pass
    import yaml

    try:
        data = yaml.safe_load(text) or {}
    except yaml.MarkedYAMLError as exc:
        line = exc.problem_mark.line + 1 if exc.problem_mark else "?"
        raise CourseError(f"{path}, line {line}: not valid YAML ({exc.problem})") from None
    except (yaml.YAMLError, UnicodeDecodeError) as exc:
        raise CourseError(f"{path}: not valid YAML ({exc})") from None
    lines = _key_lines(text) if isinstance(data, dict) else {}
    if kept is not None and isinstance(data, dict):
        try:
            held = json.dumps([data, lines], allow_nan=False)
            if json.loads(held) == [data, lines]:  # no date, tuple or number JSON would change
                os.makedirs(folder, exist_ok=True)
                temporary = f"{kept}.{os.getpid()}.tmp"
                with open(temporary, "w", encoding="utf-8") as handle:
                    handle.write(held)
                os.replace(temporary, kept)
        except (OSError, TypeError, ValueError):
            pass
    return data, lines


def from_text(text: str, path: str, kept_parse: bool = False) -> Course:
    """The course file whose text is `text`, read from `path` (which messages name); `kept_parse`: see _parsed.
    CourseError for what cannot be a course file."""
    data, lines = _parsed(text, path, kept_parse)
    if not isinstance(data, dict):
        raise CourseError(f"{path}: expected settings `name: value`, one per line")

    def where(key: str) -> str:
        return f"{path}, line {lines[key]}" if key in lines else str(path)

    unknown = sorted(set(map(str, data)) - _FIELDS)
    if unknown:
        raise CourseError(f"{where(unknown[0])}: unknown setting(s) {', '.join(unknown)}; the settings are "
                          f"{', '.join(sorted(_FIELDS))}")
    feedback, feedback_by = _quiz_feedback(data.get("quiz_feedback", "recorded"), where("quiz_feedback"))
    hidden = data.get("hidden") or []
    if not isinstance(hidden, list) or not all(isinstance(h, str) and h.count("/") == 1 for h in hidden):
        raise CourseError(f"{where('hidden')}: hidden is a list of chapter/check ids, e.g. [ch06/H_rows_orthogonal]")
    exact = data.get("exact_derivatives", True)
    if not isinstance(exact, bool):
        raise CourseError(f"{where('exact_derivatives')}: exact_derivatives is true or false (whether derivatives "
                          f"must be exact to rounding, not only to a finite difference's digits), not {exact!r}")
    try:
        seed = None if data.get("seed") is None else int(data["seed"])
    except (TypeError, ValueError):
        raise CourseError(f"{where('seed')}: seed is a whole number") from None
    if seed == PUBLIC_SEED:
        raise CourseError(f"{where('seed')}: the course seed equals the public seed {PUBLIC_SEED}; hard-coded public "
                          "values would pass")
    manifest_time = data.get("manifest_time", "ignore")
    if manifest_time not in ("accept", "ignore"):
        raise CourseError(f"{where('manifest_time')}: manifest_time is accept or ignore (whether the time in a learner's "
                          f"own archive manifest may decide a late penalty where the roster gives none), not "
                          f"{manifest_time!r}")
    handout = data.get("handout")
    if handout is not None and (not isinstance(handout, str) or not handout.strip()):
        raise CourseError(f"{where('handout')}: handout is the id of the current handout, as `grade release` prints "
                          "it (e.g. 0.1.0+handout.3f2a9c1b0d4e)")
    scheduler, scheduler_certs = _scheduler(data.get("scheduler"), path, where)
    return Course(id=str(data.get("course", Course.id)), seed=seed, quiz_feedback=feedback, hidden=frozenset(hidden),
                  exact_derivatives=exact, source=str(path), quiz_feedback_by=feedback_by, lines=lines,
                  accepts_manifest_time=manifest_time == "accept",
                  current_handout=handout.strip() if handout else None,
                  late=_late(data, where), scheduler=scheduler, scheduler_certs=scheduler_certs)


def _scheduler(value: object, path: Path, where) -> tuple[str | None, str | None]:
    """scheduler: the address of the Dask scheduler grade batch grades on, or a mapping `{address: ..., certs: DIR}`
    naming the folder of the cluster's certificates too (relative to the course file's folder)."""
    if value is None:
        return None, None
    address, certs = (value.get("address"), value.get("certs")) if isinstance(value, dict) else (value, None)
    unknown = sorted(set(value) - {"address", "certs"}) if isinstance(value, dict) else []
    if unknown or not isinstance(address, str) or not address.strip() or (
            certs is not None and (not isinstance(certs, str) or not certs.strip())):
        raise CourseError(f"{where('scheduler')}: scheduler is the address of the Dask scheduler grade batch grades on, "
                          "e.g. tls://scheduler.example.org:8786, or {address: tls://..., certs: DIR} with the folder of "
                          f"the cluster's certificates (grade cluster certs DIR), not {value!r}")
    if certs is not None:
        certs = str(Path(path).parent / Path(certs.strip()).expanduser())
    return address.strip(), certs


def _quiz_feedback(value: object, where: str) -> tuple[str, dict]:
    """quiz_feedback: one mode for every quiz, or a mapping `{default: recorded, ch00: immediate}`."""
    modes = value if isinstance(value, dict) else {"default": value}
    from grader.chapters import BY_ID

    for chapter, mode in modes.items():
        if str(mode) not in QUIZ_FEEDBACK:
            raise CourseError(f"{where}: quiz_feedback{'' if chapter == 'default' else ' of ' + str(chapter)} is "
                              f"{mode!r}; one of {', '.join(QUIZ_FEEDBACK)}")
        if chapter != "default" and str(chapter) not in BY_ID:
            raise CourseError(f"{where}: quiz_feedback names {chapter!r}, not a chapter (ch00 ... ch09, or default)")
    default = str(modes.get("default", "recorded"))
    return default, {str(c): str(m) for c, m in modes.items() if c != "default" and str(m) != default}


def _late(data: dict, where) -> Late | None:
    """deadline (with its time zone) and late_penalty `{per_day: 0.1, max: 0.5, grace_minutes: 15}`."""
    if data.get("deadline") is None:
        if data.get("late_penalty") is not None:
            raise CourseError(f"{where('late_penalty')}: a late penalty needs a deadline (deadline: "
                              "2026-05-01T23:59:00+02:00)")
        return None
    deadline = data["deadline"]
    if isinstance(deadline, str):
        try:
            deadline = datetime.fromisoformat(deadline.strip())
        except ValueError:
            raise CourseError(f"{where('deadline')}: deadline is a date and time with its time zone, e.g. "
                              "2026-05-01T23:59:00+02:00") from None
    if not isinstance(deadline, datetime) or deadline.tzinfo is None:
        raise CourseError(f"{where('deadline')}: deadline needs its time zone, e.g. 2026-05-01T23:59:00+02:00 "
                          "(submission times are compared across zones)")
    penalty = data.get("late_penalty") or {}
    if not isinstance(penalty, dict) or set(map(str, penalty)) - {"per_day", "max", "grace_minutes"}:
        raise CourseError(f"{where('late_penalty')}: late_penalty is {{per_day: 0.1, max: 0.5, grace_minutes: 0}} "
                          "(shares of the score)")
    try:
        late = Late(deadline, float(penalty.get("per_day", 0.0)), float(penalty.get("max", 1.0)),
                    float(penalty.get("grace_minutes", 0.0)))
    except (TypeError, ValueError):
        raise CourseError(f"{where('late_penalty')}: per_day, max and grace_minutes are numbers") from None
    if not (0 <= late.per_day <= 1 and 0 <= late.cap <= 1 and late.grace_minutes >= 0):
        raise CourseError(f"{where('late_penalty')}: per_day and max are shares of the score between 0 and 1")
    return late
