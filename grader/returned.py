"""What one learner call produced, as the parent sees it: decoded plain data, never a live object."""

from __future__ import annotations

import binascii
from dataclasses import dataclass
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # numpy is imported lazily: the runner starts the child before numpy loads here
    import numpy as np

VALUE = "value"
RAISED = "raised"
NOT_IMPLEMENTED = "not-implemented"
MISSING = "missing"
TIMEOUT = "timeout"
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

    @property
    def ok(self) -> bool:
        return self.kind == VALUE

    @property
    def type_name(self) -> str:
        if self.encoded is None:
            return "nothing"
        if self.encoded["t"] in ("tuple", "list"):
            return f'{self.encoded["t"]} of {len(self.encoded["items"])}'
        return self.encoded.get("type") or self.encoded["t"]

    def items(self) -> list[Returned] | None:
        """The elements of a returned tuple or list, each as its own Returned."""
        if self.encoded is None or self.encoded["t"] not in ("tuple", "list"):
            return None
        return [Returned(VALUE, self.function, item) for item in self.encoded["items"]]

    def as_array(self) -> np.ndarray | None:
        """Plain float64 array for an exact ndarray or a real scalar (shape ()); None otherwise."""
        import numpy as np

        enc = self.encoded
        if enc is None:
            return None
        if enc["t"] == "scalar":
            return np.array(enc["data"], dtype=np.float64)
        if enc["t"] == "ndarray":
            shape = tuple(int(n) for n in enc["shape"])
            if "f8" in enc:  # little-endian float64 bytes, base64 (grader.child.encode)
                try:
                    raw = binascii.a2b_base64(enc["f8"])
                except (binascii.Error, TypeError, ValueError):
                    return None
                if len(raw) % 8:
                    return None
                data = np.frombuffer(raw, dtype="<f8").astype(np.float64)
            else:
                data = np.array(enc["data"], dtype=np.float64)
            if data.size != int(np.prod(shape, dtype=np.int64)):
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
            where = f" (line {err['line']})" if err.get("line") else ""
            return f"{name} raised {err.get('exception')}: {err.get('message')}{where}"
        if self.kind == TIMEOUT:
            return f"{name} did not return in time ({self.note}): an endless loop?"
        if self.kind == CRASHED:
            return f"the process running {name} ended abruptly ({self.note})."
        if self.kind == NOT_RUN:
            return f"{name} was not run: {self.note}"
        return ""

    @property
    def traceback(self) -> str:
        return (self.error or {}).get("traceback", "") if self.kind == RAISED else ""


def from_event(function: str, event: dict) -> Returned:
    """Build a Returned from one child result line (already parsed JSON)."""
    kind = event.get("event")
    if kind == "returned" and isinstance(event.get("value"), dict) and "t" in event["value"]:
        return Returned(VALUE, function, encoded=event["value"])
    if kind == "raised" and isinstance(event.get("error"), dict):
        if event["error"].get("not_implemented"):
            return Returned(NOT_IMPLEMENTED, function, error=event["error"])
        return Returned(RAISED, function, error=event["error"])
    if kind == "missing":
        return Returned(MISSING, function)
    return Returned(CRASHED, function, note="the child sent a malformed result")
