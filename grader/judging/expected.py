"""Expected values: every value a check compares against is asked of the reference here.

A check module holds no formula of an answer. It asks `REF = reference("ch06")` for what it needs,
`REF.H_jacobian(x, y)`, and it asks while it plans, before it yields its learner calls, so what it
asks depends only on the seed and never on what a learner returned. Three backends answer:

- live (the instructor's side): `solutions/oracle/chNN.py`, else the chapter's reference solution;
- recording (`grade release`): live, and every question and answer is kept, in order, per check;
- replay (a learner's handout): the answers recorded at the public seed, read from
  grader/data/expected/chNN.json. The handout holds no reference code, only these values.

Values come back in one normal form whatever the backend (floats, float64 arrays, tuples, lists,
strings), so a check judges the same in the project and in a handout.

The mistakes generated from the reference (grader.judging.mutants) travel the same way: the values every
single slip of the reference gives at each call a check makes of its own function. Live computes them
when a failing comparison first asks (once per call, kept in the memo), a recording computes them all
while each check plans and writes them beside the expected values (grader/data/expected/chNN.mutants.json:
names, sentences and numbers, never a mutated source), and a handout's replay reads them from there.
"""

from __future__ import annotations

import contextlib
import contextvars
import functools
import importlib
import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Iterator

from grader.boundary.wire import Call
from grader.chapters import BY_ID

DATA_DIR = Path(__file__).resolve().parents[1] / "data" / "expected"
ARG_RTOL, ARG_ATOL = 1e-9, 1e-12  # recorded arguments match despite last-bit differences of libm


class ReferenceUnavailable(LookupError):
    """The reference cannot answer here (not installed, or not recorded for this question)."""


@functools.lru_cache(maxsize=None)
def reference_function(chapter: str, name: str) -> Callable:
    """The instructor-side reference `name` of `chapter`: solutions.oracle.<chapter>, then the
    chapter's reference solution. ReferenceUnavailable where the references are not installed."""
    for module_name in (f"solutions.oracle.{chapter}", f"solutions.{BY_ID[chapter].module}"):
        try:
            module = importlib.import_module(module_name)
        except ModuleNotFoundError as exc:
            if exc.name is not None and module_name.startswith(exc.name):
                continue  # that module does not exist (here)
            raise
        function = getattr(module, name, None)
        if callable(function):
            return function
    raise ReferenceUnavailable(f"the reference {chapter}.{name} is not installed here")


# ------------------------------------------------------------------------------ plain data

def encode(value: object) -> object:
    """A reference argument or answer as JSON data (exact: floats keep every bit)."""
    if value is None or isinstance(value, (bool, str)):
        return value
    if isinstance(value, int):
        return value
    if isinstance(value, float):
        return value if math.isfinite(value) else {"$f": repr(value)}
    if isinstance(value, tuple):
        return {"$t": [encode(v) for v in value]}
    if isinstance(value, list):
        return [encode(v) for v in value]
    if isinstance(value, dict):
        return {"$d": {str(k): encode(v) for k, v in value.items()}}
    if hasattr(value, "shape") and hasattr(value, "dtype"):  # numpy array or scalar
        import numpy as np

        array = np.asarray(value)
        if array.dtype.kind in "US":
            return str(array)
        if array.ndim == 0:
            return float(array) if array.dtype.kind == "f" else encode(array.item())
        return {"$a": [encode(float(v)) for v in array.astype(float).ravel()], "shape": list(array.shape)}
    raise TypeError(f"a reference value of type {type(value).__name__} cannot be recorded")


def decode(data: object) -> object:
    """The normal form of an encoded value: float64 arrays, floats, tuples, lists, strings."""
    if isinstance(data, list):
        return [decode(v) for v in data]
    if isinstance(data, dict):
        if "$f" in data:
            return float(data["$f"])
        if "$t" in data:
            return tuple(decode(v) for v in data["$t"])
        if "$d" in data:
            return {k: decode(v) for k, v in data["$d"].items()}
        if "$a" in data:
            import numpy as np

            return np.array([decode(v) for v in data["$a"]], dtype=float).reshape(data["shape"])
    return data


def normal(value: object) -> object:
    """What decode(encode(value)) gives, without the detour through lists (the live backend's hot path)."""
    if value is None or isinstance(value, (bool, str, int, float)):
        return value
    if isinstance(value, tuple):
        return tuple(normal(v) for v in value)
    if isinstance(value, list):
        return [normal(v) for v in value]
    if isinstance(value, dict):
        return {str(k): normal(v) for k, v in value.items()}
    if hasattr(value, "shape") and hasattr(value, "dtype"):
        import numpy as np

        array = np.asarray(value)
        if array.dtype.kind in "US":
            return str(array)
        if array.ndim == 0:
            return float(array) if array.dtype.kind == "f" else normal(array.item())
        return array.astype(float)  # a copy: a check may change it without touching the reference's
    return decode(encode(value))  # anything else: the same error or form as a recording


def _fresh(value: object) -> object:
    """A copy of a normal-form value that a check may change freely (arrays copied, numbers shared)."""
    if isinstance(value, (tuple, list)):
        return type(value)(_fresh(v) for v in value)
    if isinstance(value, dict):
        return {k: _fresh(v) for k, v in value.items()}
    return value.copy() if hasattr(value, "copy") and hasattr(value, "shape") else value


def _same_argument(a: object, b: object) -> bool:
    """Encoded arguments equal up to the last bits of a float."""
    if isinstance(a, float) and isinstance(b, (float, int)) and not isinstance(b, bool):
        return abs(a - b) <= ARG_ATOL + ARG_RTOL * abs(b)
    if isinstance(a, list) and isinstance(b, list):
        return len(a) == len(b) and all(_same_argument(x, y) for x, y in zip(a, b))
    if isinstance(a, dict) and isinstance(b, dict):
        return a.keys() == b.keys() and all(_same_argument(a[k], b[k]) for k in a)
    return a == b


# ------------------------------------------------------------------------------ backends

class Live:
    """Ask the installed references. With `memo`, each answer is kept by where it was asked (seed, check,
    order): planning depends only on the seed, so the next learner of a batch or the next run of a watch
    asks the same questions, and gets a copy of the same answers without computing them again."""

    def __init__(self, memo: bool = False) -> None:
        self.memo: dict | None = {} if memo else None

    def answer(self, asked: _Planning, chapter: str, name: str, args: tuple, kwargs: dict) -> object:
        if self.memo is None:
            return normal(reference_function(chapter, name)(*args, **kwargs))
        key = (asked.seed, asked.chapter, asked.check, asked.next_index(), chapter, name)
        if key not in self.memo:
            if len(self.memo) > 200_000:  # another seed's answers, long unused
                self.memo.clear()
            self.memo[key] = normal(reference_function(chapter, name)(*args, **kwargs))
        return _fresh(self.memo[key])

    def slips(self, chapter: str, check: str, seed: int, index: int, asked: Call,
              keys: set[str] | None = None) -> list[dict]:
        """The generated slips of `asked` (the check's call number `index`), of `keys` only if given:
        [{key, name, help, value}] for every one whose value there differs from the reference's."""
        if self.memo is None:
            return slips_at(chapter, asked, keys)
        key = ("slips", seed, chapter, check, index)
        kept = self.memo.setdefault(key, {"complete": False, "slips": {}})  # key -> record (None: says nothing)
        if not kept["complete"]:
            missing = None if keys is None else {k for k in keys if k not in kept["slips"]}
            if missing is None or missing:
                for record in slips_at(chapter, asked, missing):
                    kept["slips"][record["key"]] = record
                for k in missing or ():
                    kept["slips"].setdefault(k, None)
                kept["complete"] = missing is None
        return [r for k, r in kept["slips"].items() if r is not None and (keys is None or k in keys)]

    def planned(self, chapter: str, check: str, seed: int, calls: list[tuple[int, Call]]) -> None:
        """A check has planned these calls of its own function (a recording computes their slips now)."""


@dataclass
class Recording(Live):
    """Ask the installed references and keep every question and answer: {chapter: {check: [...]}}."""

    seed: int
    data: dict = field(default_factory=dict)
    slip_data: dict = field(default_factory=dict)  # {chapter: {"mistakes": {key: [name, help]}, "checks": ...}}
    memo = None

    def answer(self, asked: _Planning, chapter: str, name: str, args: tuple, kwargs: dict) -> object:
        value = super().answer(asked, chapter, name, args, kwargs)
        self.data.setdefault(asked.chapter, {}).setdefault(asked.check, []).append(
            {"name": f"{chapter}.{name}", "args": encode(list(args)), "kwargs": encode(dict(kwargs)),
             "value": encode(value)})
        return value

    def planned(self, chapter: str, check: str, seed: int, calls: list[tuple[int, Call]]) -> None:
        """Compute and keep the generated slips of every call a check makes of its own function."""
        kept = self.slip_data.setdefault(chapter, {"mistakes": {}, "checks": {}})
        for index, asked in calls:
            found = slips_at(chapter, asked)
            for slip in found:
                kept["mistakes"][slip["key"]] = [slip["name"], slip["help"]]
            if found:
                kept["checks"].setdefault(check, {})[str(index)] = {s["key"]: _encode_slip(s["value"]) for s in found}

    def write(self, folder: Path) -> list[Path]:
        """One JSON file per chapter (a handout loads only the chapters it grades), and one of its generated slips
        (loaded only when a check fails)."""
        folder.mkdir(parents=True, exist_ok=True)
        written = []
        for chapter, checks in sorted(self.data.items()):
            path = folder / f"{chapter}.json"
            path.write_text(json.dumps({"seed": self.seed, "checks": checks}, separators=(",", ":")), encoding="utf-8")
            written.append(path)
        for chapter, slips in sorted(self.slip_data.items()):
            path = folder / f"{chapter}.mutants.json"
            path.write_text(json.dumps({"seed": self.seed, **slips}, separators=(",", ":")), encoding="utf-8")
            written.append(path)
        return written


class Replay:
    """Answer from the values recorded at release time, in the order they were asked."""

    def __init__(self, folder: Path = DATA_DIR) -> None:
        self.folder = folder

    @functools.lru_cache(maxsize=None)
    def _chapter(self, chapter: str) -> dict:
        path = self.folder / f"{chapter}.json"
        try:
            return json.loads(path.read_text(encoding="utf-8"))
        except (OSError, ValueError) as exc:
            raise ReferenceUnavailable(f"the check data {path.name} of this handout cannot be read ({exc}); "
                                       "reinstall the handout") from None

    def answer(self, asked: _Planning, chapter: str, name: str, args: tuple, kwargs: dict) -> object:
        recorded = self._chapter(asked.chapter)
        if asked.seed != recorded.get("seed"):
            raise ReferenceUnavailable(f"this handout's checks are recorded at seed {recorded.get('seed')}, "
                                       f"not {asked.seed}")
        check = asked.check
        entries = recorded.get("checks", {}).get(check, [])
        index = asked.next_index()
        if index >= len(entries):
            raise ReferenceUnavailable(f"no recorded value for {asked.chapter} {check} #{index + 1}: the handout's "
                                       "check data does not match its checks; reinstall the handout")
        entry = entries[index]
        if entry["name"] != f"{chapter}.{name}" or not _same_argument(encode(list(args)), entry["args"]) or \
                not _same_argument(encode(dict(kwargs)), entry["kwargs"]):
            raise ReferenceUnavailable(f"the recorded value for {asked.chapter} {check} #{index + 1} was asked of "
                                       f"{entry['name']} with other arguments: the handout's check data does not "
                                       "match its checks; reinstall the handout")
        return decode(entry["value"])

    @functools.lru_cache(maxsize=None)
    def _slips(self, chapter: str) -> dict:
        path = self.folder / f"{chapter}.mutants.json"
        try:
            return json.loads(path.read_text(encoding="utf-8"))
        except (OSError, ValueError):
            return {}  # a handout without them names only the checks' own mistakes

    def slips(self, chapter: str, check: str, seed: int, index: int, asked: Call,
              keys: set[str] | None = None) -> list[dict]:
        recorded = self._slips(chapter)
        if recorded.get("seed") != seed:
            return []
        names = recorded.get("mistakes", {})
        values = recorded.get("checks", {}).get(check, {}).get(str(index), {})
        return [{"key": key, "name": names[key][0], "help": names[key][1], "value": _decode_slip(value)}
                for key, value in values.items() if key in names and (keys is None or key in keys)]

    def planned(self, chapter: str, check: str, seed: int, calls: list[tuple[int, Call]]) -> None:
        """Nothing to do: the slips were recorded with the handout."""


# ------------------------------------------------------------------------------ asking

@dataclass
class _Planning:
    """Which check is planning now, at which seed, and how many questions it has asked."""

    chapter: str
    check: str
    seed: int
    asked: int = 0

    def next_index(self) -> int:
        self.asked += 1
        return self.asked - 1


_PLANNING: contextvars.ContextVar[_Planning | None] = contextvars.ContextVar("planning", default=None)
_BACKEND: contextvars.ContextVar[object | None] = contextvars.ContextVar("backend", default=None)


def default_backend() -> Live | Replay:
    """The handout's replay in a handout, else the live references (the instructor's side)."""
    from grader.course_config import in_handout

    return Replay() if in_handout() else Live(memo=True)


@contextlib.contextmanager
def using(backend: object) -> Iterator[None]:
    """Answer the checks planned inside this block from `backend`."""
    token = _BACKEND.set(backend)
    try:
        yield
    finally:
        _BACKEND.reset(token)


@contextlib.contextmanager
def planning(chapter: str, check: str, seed: int) -> Iterator[None]:
    """The block in which check `check` of `chapter` plans (and may ask the reference)."""
    token = _PLANNING.set(_Planning(chapter, check, seed))
    try:
        yield
    finally:
        _PLANNING.reset(token)


class Reference:
    """A chapter's references as the checks ask them: `REF.H_jacobian(3, 4)` while planning."""

    def __init__(self, chapter: str) -> None:
        self._chapter = chapter

    def __getattr__(self, name: str) -> Callable:
        if name.startswith("_"):
            raise AttributeError(name)
        return functools.partial(_ask, self._chapter, name)


def reference(chapter: str) -> Reference:
    return Reference(chapter)


def _ask(chapter: str, name: str, *args: object, **kwargs: object) -> object:
    asked = _PLANNING.get()
    if asked is None:
        raise RuntimeError(f"the reference {chapter}.{name} was asked outside a check's planning: a check asks for "
                           "its expected values before it yields its calls")
    backend = _BACKEND.get() or _default()
    return backend.answer(asked, chapter, name, args, kwargs)


@functools.lru_cache(maxsize=1)
def _default() -> Live | Replay:
    return default_backend()


# ------------------------------------------------------------------------------ generated slips

def slips_at(chapter: str, asked: Call, keys: set[str] | None = None) -> list[dict]:
    """Every slip grader.judging.mutants makes of the reference of `asked.function` (of `keys` only, if given), evaluated
    at the call's own arguments (decoded as the learner's function gets them): [{key, name, help, value}] where
    the value differs from the reference's ([] where the references are not installed)."""
    from grader.judging import mutants

    try:
        _, found = mutants.at_call(chapter, asked.function, mutants.arguments_of(asked), keys)
    except mutants.Unavailable:
        return []
    from grader.judging.diagnose import SKETCHED, Sketch

    out = []
    for mutant, value in found:
        try:
            value = normal(value)
        except TypeError:
            continue  # a value no recording could keep (an object): it names nothing
        if hasattr(value, "shape") and value.size > SKETCHED:
            value = Sketch.of(value)  # thousands of samples: known by a sketch, here as in a handout
        out.append({"key": mutant.key, "name": mutant.name, "help": mutant.help, "value": value})
    return out


def _encode_slip(value: object) -> object:
    from grader.judging.diagnose import Sketch

    return encode(["$sketch", list(value.shape), list(value.values)] if isinstance(value, Sketch) else value)


def _decode_slip(data: object) -> object:
    from grader.judging.diagnose import Sketch

    value = decode(data)
    if isinstance(value, list) and len(value) == 3 and value[0] == "$sketch":
        return Sketch(tuple(value[1]), tuple(value[2]))
    return value


def planned(chapter: str, check: str, seed: int, calls: list[tuple[int, Call]]) -> None:
    """Tell the backend the calls a check made of its own function while it planned (a recording computes their
    generated slips now)."""
    (_BACKEND.get() or _default()).planned(chapter, check, seed, calls)


def slips(chapter: str, check: str, seed: int, index: int, asked: Call, keys: set[str] | None = None) -> list[dict]:
    """The generated slips at a check's call number `index`, of `keys` only if given (asked of the backend: live,
    recorded or replayed)."""
    return (_BACKEND.get() or _default()).slips(chapter, check, seed, index, asked, keys)
