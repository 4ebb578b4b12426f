"""A value too large to send back is told as such, never as a call that did not return: a value that holds more
numbers than are read back says how many it holds and the limit (grader.boundary.wire.encode_value), and one whose
line was still coming when the call's time ran out says it returned (grader.boundary.session, UNREAD); the parent
reads a long line in time linear in its length."""

from __future__ import annotations

import json

import numpy as np
import pytest

from grader.boundary.session import ChapterRequest, Limits, Session
from grader.boundary.wire import T_TOO_LARGE, UNREAD, Call, encode_value
from tests.support import build_submission, grade_checks, replace_function


def test_a_value_holding_more_numbers_than_are_read_back_says_how_many_and_the_limit():
    five = tuple(np.zeros(1_000_000) for _ in range(5))
    assert encode_value(five) == {"t": T_TOO_LARGE, "type": "tuple holding 5,000,000 numbers (at most 1,000,000 are "
                                                            "read back)"}
    assert encode_value(np.zeros(1_000_001))["t"] == T_TOO_LARGE
    assert encode_value(np.zeros(1_000_000))["t"] != T_TOO_LARGE  # the limit itself is read back
    assert encode_value([np.zeros(10)] * 3)["t"] == "list"


def test_a_function_returning_millions_of_numbers_is_told_their_count_not_a_timeout(tmp_path):
    huge = replace_function("ch06_measurement", "H_jacobian", "def H_jacobian(x, y):\n"
                            "    return tuple(np.arange(1_000_000, dtype=float) for _ in range(5))\n")
    checks = grade_checks(build_submission(tmp_path / "sub", {"ch06_measurement": huge}), "ch06")
    message = checks["H_worked_example"].message
    assert "holding 5,000,000 numbers (at most 1,000,000 are read back)" in message, message
    assert "did not return in time" not in message


class _Sending:
    """A child that imports its chapter and has begun to send its first call's value when its time runs out."""

    def __init__(self) -> None:
        self.lines: list[bytes] = []

    def send(self, request: str) -> None:
        chapter = json.loads(request)["chapters"][0]["chapter"]
        self.lines = [json.dumps({"event": "import", "chapter": chapter}).encode() + b"\n",
                      json.dumps({"event": "imported", "chapter": chapter, "compiling": []}).encode() + b"\n",
                      b'{"event": "returned", "chapter": "' + chapter.encode() + b'", "index": 0, "value": {"t": '
                      + b'"ndarray", "f8": "' + b"A" * (3 << 20)]  # 3 MiB of a value, and no more in time

    def read(self, timeout: float) -> bytes:
        if not self.lines:
            raise TimeoutError
        return self.lines.pop(0)

    def wait(self, timeout: float) -> None:
        pass

    returncode = None

    def stop(self, output_limit: int) -> str:
        return ""


def test_a_call_whose_value_was_still_coming_when_its_time_ran_out_returned(tmp_path):
    session = Session(_submission(tmp_path), _Sending, Limits(call_seconds=1))
    run = session.run([ChapterRequest("ch06", "ch06_measurement", [Call("H_jacobian", (3, 4)),
                                                                      Call("H_jacobian", (1, 2))])])["ch06"]
    first, second = run.results
    assert first.kind == UNREAD, first
    assert first.problem().startswith("H_jacobian returned, but its value could not be read back: only 3.0 MiB")
    assert "did not return" not in first.problem() and "could not be read back" in second.problem()


def _submission(tmp_path):
    from grader.submission import Submission

    return Submission(build_submission(tmp_path / "sub"), "exercises")


@pytest.mark.parametrize("chunk", [1, 7, 4096, 1 << 20])
def test_lines_are_read_back_whole_whatever_the_chunks(chunk):
    """The parent's reading of the result pipe gives each line whole however the bytes come: across chunks, several
    lines in one chunk, a long line in many."""
    from grader.boundary.session import _Child

    lines = [{"event": "import", "chapter": "ch06"}, {"event": "returned", "index": 0, "text": "x" * 100_000},
             {"event": "done"}]
    data = b"".join(json.dumps(line).encode() + b"\n" for line in lines)

    class Pipe:
        position = 0

        def read(self, timeout: float) -> bytes:
            part = data[self.position:self.position + chunk]
            self.position += len(part)
            return part

    assert list(_Child(Pipe()).events(lambda: float("inf"))) == [(line, json.dumps(line).encode()) for line in lines]
