"""The course this grader serves: its seeds, hidden checks and quiz feedback.

Two places hold it. On the instructor's side, `solutions/course.yaml` (never in a release; its
`seed` is the course seed that `grade batch` grades at). In a learner's handout, the file
`grader/data/handout.json` that `grade release` wrote: the public seed the handout's check data was
recorded at, and how many checks (and points) are hidden from it. Reading the handout file is cheap
(JSON); the YAML config is read only where it is needed (batch, release).
"""

from __future__ import annotations

import functools
import json
from dataclasses import dataclass
from pathlib import Path

PUBLIC_SEED = 20261122  # the seed of `grade chNN`, at home and in the project; a handout's data is recorded at it
QUIZ_FEEDBACK = ("recorded", "immediate")
DATA_DIR = Path(__file__).resolve().parent / "data"
HANDOUT_FILE = DATA_DIR / "handout.json"
CONFIG_NAME = "course.yaml"


class CourseError(ValueError):
    """A course configuration that cannot be used; the message names the file (and line)."""


@dataclass(frozen=True)
class Course:
    id: str = "jacobians-linearization"
    public_seed: int = PUBLIC_SEED
    seed: int | None = None  # the course seed (instructor side only; None in a handout)
    quiz_feedback: str = "recorded"  # "recorded": keys stay with the instructor; "immediate": practice keys ship
    hidden: frozenset[str] = frozenset()  # "ch06/H_rows_orthogonal": checks run only when submissions are graded
    handout: dict | None = None  # in a handout: its version and the hidden checks' counts per chapter
    source: str = ""  # where this came from, for messages

    @property
    def in_handout(self) -> bool:
        return self.handout is not None

    @property
    def grading_seed(self) -> int:
        """The seed submissions are graded at: the course seed, else the public one."""
        return self.public_seed if self.seed is None else self.seed

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
def current(config: str | None = None) -> Course:
    """The handout's course in a handout; else the instructor's `config` file, else
    solutions/course.yaml where the references are installed, else the defaults."""
    if config is None and in_handout():
        return _from_handout(HANDOUT_FILE)
    path = Path(config) if config is not None else _project_config()
    if path is None:
        return Course(source="defaults")
    return _from_yaml(path)


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
                      quiz_feedback=str(data.get("quiz_feedback", "recorded")), handout=data, source=str(path))
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise CourseError(f"{path}: the handout's course data cannot be read ({exc}); reinstall the handout") from None


_FIELDS = {"course", "seed", "quiz_feedback", "hidden"}


def _from_yaml(path: Path) -> Course:
    import yaml

    try:
        data = yaml.safe_load(path.read_text(encoding="utf-8")) or {}
    except OSError as exc:
        raise CourseError(f"{path}: cannot be read ({exc.strerror})") from None
    except yaml.MarkedYAMLError as exc:
        line = exc.problem_mark.line + 1 if exc.problem_mark else "?"
        raise CourseError(f"{path}, line {line}: not valid YAML ({exc.problem})") from None
    except (yaml.YAMLError, UnicodeDecodeError) as exc:
        raise CourseError(f"{path}: not valid YAML ({exc})") from None
    if not isinstance(data, dict):
        raise CourseError(f"{path}: expected settings `name: value`, one per line")
    unknown = set(map(str, data)) - _FIELDS
    if unknown:
        raise CourseError(f"{path}: unknown setting(s) {', '.join(sorted(unknown))}; the settings are "
                          f"{', '.join(sorted(_FIELDS))}")
    feedback = str(data.get("quiz_feedback", "recorded"))
    if feedback not in QUIZ_FEEDBACK:
        raise CourseError(f"{path}: quiz_feedback is {feedback!r}; one of {', '.join(QUIZ_FEEDBACK)}")
    hidden = data.get("hidden") or []
    if not isinstance(hidden, list) or not all(isinstance(h, str) and h.count("/") == 1 for h in hidden):
        raise CourseError(f"{path}: hidden is a list of chapter/check ids, e.g. [ch06/H_rows_orthogonal]")
    try:
        seed = None if data.get("seed") is None else int(data["seed"])
    except (TypeError, ValueError):
        raise CourseError(f"{path}: seed is a whole number") from None
    if seed == PUBLIC_SEED:
        raise CourseError(f"{path}: the course seed equals the public seed {PUBLIC_SEED}; hard-coded public values "
                          "would pass")
    return Course(id=str(data.get("course", Course.id)), seed=seed,
                  quiz_feedback=feedback, hidden=frozenset(hidden), source=str(path))

