"""The process boundary's one home: what crosses between the grading process and the child.

Parent -> child, one JSON request: the learner's files (path -> base64), then per chapter the module
to import, the calls to make and, optionally, `helpers`: {function: [helper, ...]}, the learner's own functions
each function is usually written with (grader.checks.base.ChapterChecks.builds_on). A call's arguments are plain
JSON, or tagged forms: `Fn` (a catalogue callable by name), `Rng` (a numpy Generator from a seed), `Array` (a numpy
array of a dtype), tuples and non-finite floats.

Child -> parent, one JSON line per event, in the order the request asks: IMPORT, then IMPORTED
or IMPORT_FAILED, then one of RETURNED / RAISED / MISSING per call in order, ..., DONE. A returned
value travels as type-tagged plain data (`encode_value`); the parent rebuilds only numbers from it
(`Returned.as_array`), never an object. Nothing is ever pickled. The RETURNED or RAISED line of a call of a
function with helpers also says which of them the call entered (`reached`: the names of those whose code ran
during the call, at any depth, of whichever of the learner's files or import forms; grader.core.grading blames
only a helper a check's calls reached).

Light on purpose: the child and `grade`'s launcher import this before numpy (numpy loads lazily).
"""

from __future__ import annotations

import binascii
import functools
import math
from dataclasses import dataclass, field

# ------------------------------------------------------------------------------ events (child -> parent)

IMPORT, IMPORTED, IMPORT_FAILED = "import", "imported", "import-failed"
RETURNED, RAISED_EVENT, MISSING_EVENT = "returned", "raised", "missing"
DONE = "done"
MAX_LINE = 64 << 20  # a longer result line is a protocol violation
# Libraries whose functions may compile on their first call (jax.jit, torch.compile): IMPORTED lists those the
# learner's module loaded, and the first call of each function then gets the import's time instead of a call's.
COMPILING = frozenset({"jax", "torch"})

# value tags of encode_value
T_NDARRAY, T_SCALAR, T_NONE, T_STR = "ndarray", "scalar", "none", "str"
T_TUPLE, T_LIST, T_OTHER, T_TOO_LARGE, T_NDARRAY_OTHER = "tuple", "list", "other", "too-large", "ndarray-other"

_MAX_ELEMENTS = 1_000_000
_MAX_AS_TEXT = 16
_MAX_DEPTH = 3
_MAX_ITEMS = 64


# ------------------------------------------------------------------------------ arguments (parent -> child)

@dataclass(frozen=True)
class Fn:
    """A callable from grader.catalogue, passed to a learner function by name."""

    name: str


@dataclass(frozen=True)
class Rng:
    """A fresh numpy Generator, np.random.default_rng(seed), built in the child."""

    seed: int


@dataclass(frozen=True)
class Array:
    """A numpy array argument of a given dtype (plain lists and tuples pass as they are)."""

    values: object
    dtype: str = "float64"


def _plain(values: object) -> object:
    return values.tolist() if hasattr(values, "tolist") else values


def encode_argument(arg: object) -> object:
    """An argument the parent chose, as JSON data for the child."""
    if isinstance(arg, Fn):
        return {"$fn": arg.name}
    if isinstance(arg, Rng):
        return {"$rng": int(arg.seed)}
    if isinstance(arg, Array):
        return {"$array": _plain(arg.values), "dtype": arg.dtype}
    if isinstance(arg, tuple):
        return {"$tuple": [encode_argument(a) for a in arg]}
    if isinstance(arg, list):
        return [encode_argument(a) for a in arg]
    if isinstance(arg, float):
        return arg if arg == arg and abs(arg) != float("inf") else {"$float": repr(arg)}
    if isinstance(arg, (int, str, bool)) or arg is None:
        return arg
    if hasattr(arg, "tolist"):  # a numpy scalar or array from the check: pass as a plain float array
        return {"$array": _plain(arg), "dtype": "float64"}
    raise TypeError(f"cannot pass {type(arg).__name__} to the child")


def decode_argument(arg: object, callables) -> object:
    """The child's side: JSON argument -> Python value (arrays, catalogue callables, Generators)."""
    import numpy as np

    if isinstance(arg, dict):
        if "$fn" in arg:
            return callables[arg["$fn"]]
        if "$array" in arg:
            return np.array(arg["$array"], dtype=arg.get("dtype", "float64"))
        if "$rng" in arg:
            return np.random.default_rng(arg["$rng"])
        if "$tuple" in arg:
            return tuple(decode_argument(a, callables) for a in arg["$tuple"])
        if "$float" in arg:
            return float(arg["$float"])
        raise ValueError(f"unknown argument form {sorted(arg)}")
    if isinstance(arg, list):
        return [decode_argument(a, callables) for a in arg]
    return arg


def show_argument(arg: object) -> str:
    """How an argument reads in a learner-facing label: 0.5, (3, 4), sqrt, np.array([1, 2])."""
    from grader.numbers import fmt, fmt_array

    if isinstance(arg, Fn):
        return arg.name
    if isinstance(arg, Rng):
        return f"np.random.default_rng({arg.seed})"
    if isinstance(arg, Array):
        import numpy as np

        values = np.asarray(arg.values, dtype=float)
        return f"np.array({fmt_array(values)})" if values.ndim else fmt(values)
    if isinstance(arg, bool) or arg is None or isinstance(arg, str):
        return repr(arg)
    if isinstance(arg, (int, float)):
        return fmt(arg) if isinstance(arg, float) else str(arg)
    if isinstance(arg, tuple):
        return "(" + ", ".join(show_argument(a) for a in arg) + ("," if len(arg) == 1 else "") + ")"
    if isinstance(arg, list):
        return "[" + ", ".join(show_argument(a) for a in arg) + "]"
    if hasattr(arg, "tolist"):
        import numpy as np

        return fmt_array(np.asarray(arg, dtype=float))
    return repr(arg)


class EncodedCalls(list):
    """A chapter's calls with the JSON text of them all, as a request sends them (grader.boundary.session): a batch
    worker's kept calls (grader.core.memo) go to every learner's child alike, encoded once."""

    def __init__(self, calls: list, text: str) -> None:
        super().__init__(calls)
        self.text = text


def placed(request: str, root: str, confine: bool) -> bytes:
    """An encoded request (a JSON object's text: grader.boundary.session) as one child reads it, with where that
    child writes the learner's files and whether it confines itself (grader.boundary.confine)."""
    import json

    rest = request.strip()[1:]
    comma = "" if rest.lstrip().startswith("}") else ", "
    return f'{{"root": {json.dumps(root)}, "confine": {json.dumps(bool(confine))}{comma}{rest}'.encode()


@dataclass(frozen=True)
class Call:
    """One call of a learner function on arguments the grader chose."""

    function: str
    args: tuple = ()
    kwargs: tuple = ()

    def to_json(self, index: int) -> dict:
        return {
            "index": index,
            "function": self.function,
            "args": [encode_argument(a) for a in self.args],
            "kwargs": {k: encode_argument(v) for k, v in self.kwargs},
        }

    @property
    def label(self) -> str:
        """The call as the learner would write it: `H_jacobian(3, 4)`, `propagate_covariance(P, F, Q=Q)`."""
        shown = [show_argument(a) for a in self.args] + [f"{k}={show_argument(v)}" for k, v in self.kwargs]
        return f"{self.function}({', '.join(shown)})"


def call(function: str, *args: object, **kwargs: object) -> Call:
    """Describe a call of the learner's `function(*args, **kwargs)`."""
    return Call(function, tuple(args), tuple(sorted(kwargs.items())))


# ------------------------------------------------------------------------------ values (child -> parent)

def _type_name(value: object) -> str:
    kind = type(value)
    module = getattr(kind, "__module__", "") or ""
    name = getattr(kind, "__qualname__", kind.__name__)
    return name if module in ("builtins", "") else f"{module}.{name}"


ARRAY_LIBRARIES = frozenset({"jax", "jaxlib", "torch"})  # their arrays count as numpy arrays (the contract)


def from_array_library(value: object):
    """A jax array or a torch tensor (on the CPU, also one that requires grad) as a numpy array, or None
    when `value` is not one (or cannot be converted: then the message says how to return an array)."""
    import numpy as np

    module = (getattr(type(value), "__module__", "") or "").split(".")[0]
    if module not in ARRAY_LIBRARIES:
        return None
    try:
        if module == "torch" and hasattr(value, "detach"):
            value = value.detach().cpu()
        converted = np.asarray(value)
    except Exception:  # noqa: BLE001 - an array the library cannot hand over (a GPU tensor, ...)
        return None
    return converted if type(converted) is np.ndarray else None


def encode_value(value: object, depth: int = 0) -> dict:
    """The child's side: a learner's return value as plain JSON data. Nothing of it is called but an
    array library's own conversion to numpy (a jax array, a torch tensor: the contract counts them). A value that
    holds more than _MAX_ELEMENTS numbers in all is not sent: its result says how many it holds, and the limit."""
    import numpy as np

    if depth == 0:
        count = _numbers_in(value)
        if count > _MAX_ELEMENTS:
            return {"t": T_TOO_LARGE, "type": f"{_type_name(value)} holding {count:,} numbers (at most "
                                              f"{_MAX_ELEMENTS:,} are read back)"}
    kind = type(value)
    if kind is not np.ndarray and kind not in _real_scalar_types():
        converted = from_array_library(value)
        if converted is not None:
            if converted.ndim == 0 and converted.dtype.kind in "fiu":
                return {"t": T_SCALAR, "type": _type_name(value), "dtype": _dtype_name(converted.dtype),
                        "data": float(converted)}
            value, kind = converted, np.ndarray
        elif (getattr(kind, "__module__", "") or "").split(".")[0] in ARRAY_LIBRARIES:
            return {"t": T_OTHER, "type": f"{_type_name(value)} (convert it with np.asarray(...); a torch tensor "
                                          "with .detach().cpu().numpy())"}
    if kind is np.ndarray:
        if value.dtype.kind not in "fiu":
            return {"t": T_NDARRAY_OTHER, "type": f"ndarray of dtype {value.dtype}"}
        if value.size > _MAX_ELEMENTS:  # one an array library converted, which _numbers_in could not count
            return {"t": T_TOO_LARGE, "type": f"ndarray holding {value.size:,} numbers (at most {_MAX_ELEMENTS:,} "
                                              "are read back)"}
        encoded = {"t": T_NDARRAY, "dtype": _dtype_name(value.dtype), "shape": list(value.shape)}
        if value.size <= _MAX_AS_TEXT:  # small arrays stay readable in the protocol
            encoded["data"] = np.asarray(value, dtype=np.float64).ravel().tolist()
        else:  # large ones travel as little-endian float64 bytes: exact and fast both ways
            raw = np.ascontiguousarray(value, dtype="<f8").tobytes()
            encoded["f8"] = binascii.b2a_base64(raw, newline=False).decode("ascii")
        return encoded
    if kind in _real_scalar_types():
        try:
            return {"t": T_SCALAR, "type": _type_name(value), "data": float(value)}
        except OverflowError:
            return {"t": T_SCALAR, "type": _type_name(value), "data": float("inf")}
    if kind in (tuple, list):
        if depth >= _MAX_DEPTH or len(value) > _MAX_ITEMS:
            return {"t": T_OTHER, "type": f"{kind.__name__} of {len(value)} items"}
        return {"t": kind.__name__, "items": [encode_value(item, depth + 1) for item in value]}
    if value is None:
        return {"t": T_NONE, "type": "None"}
    if kind is str:
        return {"t": T_STR, "type": "str", "text": value[:80]}
    name = _type_name(value)
    if isinstance(value, np.ndarray):
        name = f"{name} (an ndarray subclass)"
    return {"t": T_OTHER, "type": name}


def _numbers_in(value: object, depth: int = 0) -> int:
    """How many numbers `value` would send back: an array's (or an array library's) elements, a tuple's or list's
    items' (as deep and as many as encode_value reads them); 0 for anything else. Reads sizes only, never data."""
    import numpy as np

    if isinstance(value, np.ndarray):
        return int(value.size)
    if type(value) in (tuple, list):
        if depth >= _MAX_DEPTH or len(value) > _MAX_ITEMS:
            return 0
        return sum(_numbers_in(item, depth + 1) for item in value)
    size = getattr(value, "size", None) if (getattr(type(value), "__module__", "") or "").split(".")[0] \
        in ARRAY_LIBRARIES else None
    return size if type(size) is int else 0


@functools.lru_cache(maxsize=64)
def _dtype_name(dtype) -> str:
    """str(dtype), which numpy builds afresh each time (4 us, once per returned array)."""
    return str(dtype)


_SCALARS: frozenset | None = None


def _real_scalar_types() -> frozenset:
    """Exact types whose value is a real number (subclasses are rejected by `type(x) in`)."""
    global _SCALARS
    if _SCALARS is None:
        import numpy as np

        _SCALARS = frozenset({float, int, np.float16, np.float32, np.float64, np.longdouble, np.int8, np.int16,
                              np.int32, np.int64, np.uint8, np.uint16, np.uint32, np.uint64})
    return _SCALARS


# ------------------------------------------------------------------------------ outcomes, as the parent sees them

VALUE = "value"
RAISED = "raised"
NOT_IMPLEMENTED = "not-implemented"
MISSING = "missing"
TIMEOUT = "timeout"
UNREAD = "unread"  # it returned, but its value did not come back in time
CRASHED = "crashed"
NOT_RUN = "not-run"


@dataclass(frozen=True)
class Returned:
    """The outcome of one call: a value (as the child encoded it) or why there is none."""

    kind: str
    function: str
    encoded: dict | None = None
    error: dict | None = None
    note: str = ""
    # the function's helpers (ChapterRequest.helpers) the call entered; None: not known (no helpers asked about, no
    # line from the child that says, a timeout or a crash)
    reached: tuple[str, ...] | None = None
    # a value's line from the child, hashed (SHA-256): what a memo key holds of the value (grader.core.grading), the
    # same line always read as the same value; None where it is not known
    line_hash: str | None = field(default=None, compare=False)

    @property
    def ok(self) -> bool:
        return self.kind == VALUE

    def to_plain(self) -> list:
        """This outcome as plain data (a JSON line's), which from_plain makes again."""
        return [self.kind, self.function, self.encoded, self.error, self.note,
                None if self.reached is None else list(self.reached), self.line_hash]

    @classmethod
    def from_plain(cls, data: list) -> Returned:
        """The Returned whose to_plain() `data` is (ValueError where it is not one)."""
        if not isinstance(data, list) or len(data) != 7:
            raise ValueError("not a Returned's plain data")
        kind, function, encoded, error, note, reached, line_hash = data
        return cls(str(kind), str(function), encoded if isinstance(encoded, dict) else None,
                   error if isinstance(error, dict) else None, str(note),
                   None if reached is None else tuple(map(str, reached)), None if line_hash is None else str(line_hash))

    @property
    def type_name(self) -> str:
        if self.encoded is None:
            return "nothing"
        if self.encoded["t"] in (T_TUPLE, T_LIST):
            return f'{self.encoded["t"]} of {len(self.encoded["items"])}'
        return self.encoded.get("type") or self.encoded["t"]

    @property
    def text(self) -> str | None:
        """The returned string (first 80 characters), or None when the value is not a str."""
        text = self.encoded.get("text") if self.ok and self.encoded.get("t") == T_STR else None
        return text if isinstance(text, str) else None

    def items(self) -> list[Returned] | None:
        """The elements of a returned tuple or list, each as its own Returned."""
        if self.encoded is None or self.encoded["t"] not in (T_TUPLE, T_LIST):
            return None
        return [Returned(VALUE, self.function, item) for item in self.encoded["items"]]

    def as_array(self):
        """Plain float64 array for an exact ndarray or a real scalar (shape ()); None otherwise. Decoded
        once; each caller gets its own copy."""
        array = self._decoded_array
        return None if array is None else array.copy()

    @functools.cached_property
    def _decoded_array(self):
        import numpy as np

        enc = self.encoded
        if enc is None:
            return None
        if enc["t"] == T_SCALAR:
            return np.array(enc["data"], dtype=np.float64)
        if enc["t"] == T_NDARRAY:
            shape = tuple(int(n) for n in enc["shape"])
            if "f8" in enc:  # little-endian float64 bytes, base64 (encode_value)
                try:
                    raw = binascii.a2b_base64(enc["f8"])
                except (binascii.Error, TypeError, ValueError):
                    return None
                if len(raw) % 8:
                    return None
                data = np.frombuffer(raw, dtype="<f8").astype(np.float64)
            else:
                data = np.array(enc["data"], dtype=np.float64)
            if data.size != math.prod(shape):
                return None
            return data.reshape(shape)
        return None

    def problem(self) -> str:
        """One learner-facing sentence for a call that gave no value."""
        name = self.function
        if self.kind == NOT_IMPLEMENTED:
            return f"{name} is not implemented yet (it raises NotImplementedError)."
        if self.kind == MISSING:
            return f"{name} is not defined in your file (check the spelling against the stub)."
        if self.kind == RAISED:
            err = self.error or {}
            where = f" ({err['where']})" if err.get("where") else f" (line {err['line']})" if err.get("line") else ""
            return f"{name} raised {err.get('exception')}: {err.get('message')}{where}"
        if self.kind == TIMEOUT:
            return f"{name} did not return in time: {self.note}."
        if self.kind == UNREAD:
            return f"{name} returned, but its value could not be read back: {self.note}."
        if self.kind == CRASHED:
            return f"the process running {name} ended abruptly ({self.note})."
        if self.kind == NOT_RUN:
            return f"{name} was not run: {self.note}"
        return ""

    @property
    def traceback(self) -> str:
        return (self.error or {}).get("traceback", "") if self.kind == RAISED else ""


def clean_error(value: object) -> dict:
    """An error description from the child with every field of the type the grader reads (learner code
    can forge result lines, so nothing in one is trusted to have the right types)."""
    value = value if isinstance(value, dict) else {}

    def text(key: str, limit: int = 20_000) -> str:
        item = value.get(key)
        return item[:limit] if isinstance(item, str) else ""

    line = value.get("line")
    bases = value.get("bases")
    return {"exception": text("exception", 200), "message": text("message", 2000), "traceback": text("traceback"),
            "line": line if isinstance(line, int) and not isinstance(line, bool) else None,
            "file": text("file", 500) or None,  # the submission's file the innermost line is in
            "not_implemented": value.get("not_implemented") is True,
            "bases": [b for b in bases if isinstance(b, str)][:8] if isinstance(bases, list) else []}


_NUMBER_TYPES = frozenset((int, float))  # what JSON numbers decode to (true and false are bools)


def _is_number(value: object) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def valid_value(encoded: object, depth: int = 0) -> bool:
    """Whether an encoded value has the shape encode_value gives it (a forged one may not)."""
    if not isinstance(encoded, dict) or not isinstance(encoded.get("t"), str) or depth > _MAX_DEPTH:
        return False
    kind = encoded["t"]
    if kind in (T_TUPLE, T_LIST):
        items = encoded.get("items")
        return isinstance(items, list) and len(items) <= _MAX_ITEMS and all(valid_value(i, depth + 1) for i in items)
    if kind == T_SCALAR:
        return _is_number(encoded.get("data"))
    if kind == T_NDARRAY:
        shape = encoded.get("shape")
        if not (isinstance(shape, list) and len(shape) <= 8 and all(isinstance(n, int) and 0 <= n for n in shape)):
            return False
        data = encoded.get("data")
        # every element a number, looked at in C (a result line's values are JSON: a bool is no number)
        return isinstance(encoded.get("f8"), str) if data is None else (
            isinstance(data, list) and _NUMBER_TYPES.issuperset(map(type, data)))
    return kind in (T_NONE, T_STR, T_OTHER, T_TOO_LARGE, T_NDARRAY_OTHER)


def _reached(event: dict, watched: tuple[str, ...]) -> tuple[str, ...] | None:
    """Which of `watched` (the helpers the parent asked about) a result line says its call entered, in
    `watched`'s order; None where nothing was asked or the line says nothing readable (a forged line names no more
    than was asked)."""
    said = event.get("reached")
    if not watched or not isinstance(said, list) or not all(isinstance(name, str) for name in said):
        return None
    return tuple(name for name in watched if name in said)


def from_event(function: str, event: dict, watched: tuple[str, ...] = (), line: bytes = b"") -> Returned:
    """Build a Returned from one child result line (already parsed JSON: `event`; `line`, its bytes as read, where
    they are at hand); `watched`: the function's helpers the request asked about (ChapterRequest.helpers)."""
    kind = event.get("event")
    if kind == RETURNED and valid_value(event.get("value")):
        import hashlib

        return Returned(VALUE, function, encoded=event["value"], reached=_reached(event, watched),
                        line_hash=hashlib.sha256(line).hexdigest() if line else None)
    if kind == RAISED_EVENT and isinstance(event.get("error"), dict):
        error = clean_error(event["error"])
        return Returned(NOT_IMPLEMENTED if error["not_implemented"] else RAISED, function, error=error,
                        reached=_reached(event, watched))
    if kind == MISSING_EVENT:
        return Returned(MISSING, function)
    return Returned(CRASHED, function, note="the child sent a malformed result")
