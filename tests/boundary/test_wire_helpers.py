"""What crosses the boundary about a function's helpers: the request names them per function, the child says for
each call of such a function which of them it entered (at any depth, through any import form, also when the call
raised), and the parent believes no more than it asked about."""

from __future__ import annotations

from grader.boundary import ChapterRequest
from grader.boundary.wire import (
    RAISED,
    RAISED_EVENT,
    RETURNED,
    VALUE,
    Call,
    encode_value,
    from_event,
)
from tests.support import build_submission, open_session, replace_function

LAB = '''
import numpy as np

import ch06_measurement as plain


def through_two(x, y):
    return _inner(x, y)


def _inner(x, y):
    return plain.H_jacobian(x, y)


def both(x, y):
    plain.range_bearing(x, y)
    return through_two(x, y)


def never(x, y):
    return np.eye(2)


def raises_after(x, y):
    plain.range_bearing(x, y)
    raise RuntimeError("after the helper")


def unwatched(x, y):
    return plain.H_jacobian(x, y)


def H_jacobian(x, y):  # a function of this file named like the helper is the learner's too
    return np.eye(2)


def own_name(x, y):
    return H_jacobian(x, y)
'''


def test_the_child_says_which_helpers_each_watched_call_entered(tmp_path):
    root = build_submission(tmp_path, {"ch08_lab": LAB})
    helpers = {"through_two": ("H_jacobian", "range_bearing"), "never": ("H_jacobian",),
               "raises_after": ("range_bearing", "H_jacobian"), "own_name": ("H_jacobian",),
               "both": ("H_jacobian", "range_bearing")}
    names = ("through_two", "both", "both", "never", "raises_after", "unwatched", "own_name")
    session = open_session(root)
    run = session.run([ChapterRequest("ch08", "ch08_lab", [Call(name, (3.0, 4.0)) for name in names], helpers)])["ch08"]
    through_two, both, both_again, never, raises_after, unwatched, own_name = run.results
    assert through_two.kind == VALUE and through_two.reached == ("H_jacobian",)
    assert both.reached == both_again.reached == ("H_jacobian", "range_bearing")  # each call watched afresh
    assert never.kind == VALUE and never.reached == ()
    assert raises_after.kind == RAISED and raises_after.reached == ("range_bearing",)
    assert unwatched.kind == VALUE and unwatched.reached is None  # nothing asked: nothing known
    assert own_name.reached == ("H_jacobian",)


def test_a_request_without_helpers_is_answered_as_before(tmp_path):
    root = build_submission(tmp_path, {"ch06_measurement": replace_function("ch06_measurement", "H_jacobian", """
def H_jacobian(x, y):
    return range_bearing(x, y)
""")})
    run = open_session(root).run([ChapterRequest("ch06", "ch06_measurement", [Call("H_jacobian", (3, 4))])])["ch06"]
    assert run.results[0].kind == VALUE and run.results[0].reached is None


def test_the_parent_believes_no_more_than_it_asked_about():
    value = encode_value(1.0)
    forged = {"event": RETURNED, "value": value, "reached": ["H_jacobian", "anything", 3]}
    assert from_event("f", forged, ("H_jacobian",)).reached is None  # not a list of names: says nothing
    forged["reached"] = ["anything", "H_jacobian"]
    assert from_event("f", forged, ("range_bearing", "H_jacobian")).reached == ("H_jacobian",)
    assert from_event("f", forged).reached is None  # asked about nothing
    assert from_event("f", {"event": RETURNED, "value": value}, ("H_jacobian",)).reached is None
    raised = {"event": RAISED_EVENT, "error": {"exception": "E"}, "reached": "H_jacobian"}
    assert from_event("f", raised, ("H_jacobian",)).reached is None
