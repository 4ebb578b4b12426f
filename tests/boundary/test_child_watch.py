"""The child's watch of a call's helpers (grader.boundary.child._Watch), in this process on functions of a file the
test writes: each mechanism (sys.monitoring from Python 3.12, a profile function before, or where the tool id is
taken) sees the same helpers entered, at any depth and through a raise, and leaves nothing of itself behind."""

from __future__ import annotations

import importlib.util
import os
import sys

import pytest

from grader.boundary.child import _Watch

SOURCE = '''
def helper(x):
    return x + 1


def other_helper(x):
    return helper(x) * 2


def deep(x):
    return [other_helper(i) for i in range(3)][-1]


def loops(x):
    total = 0
    for i in range(200):
        total += len(str(i))
    return total


def raises(x):
    helper(x)
    raise ValueError("after the helper")
'''
MECHANISMS = ["monitoring", "profile"] if hasattr(sys, "monitoring") else ["profile"]


@pytest.fixture
def learner(tmp_path):
    path = tmp_path / "learner" / "module.py"
    path.parent.mkdir()
    path.write_text(SOURCE, encoding="utf-8")
    spec = importlib.util.spec_from_file_location("watched_learner_module", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module, os.path.join(str(path.parent), "")


@pytest.fixture(params=MECHANISMS)
def watch(request, learner):
    watch = _Watch(learner[1], frozenset({"helper", "other_helper"}))
    if request.param == "profile":
        watch.close()
        watch.monitoring = None
    else:
        assert watch.monitoring is not None
    yield watch
    watch.close()
    if watch.monitoring is not None:
        sys.monitoring.free_tool_id(_Watch.TOOL)


def _reached(watch, function, names) -> tuple[list, object]:
    reached: set[str] = set()
    try:
        value = watch.call(function, [1], {}, frozenset(names), reached)
    except ValueError as exc:
        value = exc
    return sorted(reached), value


def test_each_mechanism_sees_the_helpers_entered_at_any_depth_and_through_a_raise(watch, learner):
    module = learner[0]
    profile_before = sys.getprofile()
    assert _reached(watch, module.deep, {"helper", "other_helper"}) == (["helper", "other_helper"], 6)
    assert _reached(watch, module.deep, {"helper"})[0] == ["helper"]
    assert _reached(watch, module.loops, {"helper", "other_helper"})[0] == []
    reached, raised = _reached(watch, module.raises, {"helper", "other_helper"})
    assert reached == ["helper"] and isinstance(raised, ValueError)
    assert _reached(watch, module.deep, {"other_helper"})[0] == ["other_helper"]  # watched afresh each call
    reached: set[str] = set()
    watch.call(module.loops, [1], {}, frozenset({"helper"}), reached)
    module.deep(1)  # between watched calls: nothing is noted
    assert reached == set() and sys.getprofile() is profile_before


def test_a_function_of_that_name_elsewhere_is_no_helper(watch, tmp_path):
    path = tmp_path / "learner_sibling" / "other.py"  # beside the submission's folder, not in it
    path.parent.mkdir()
    path.write_text("def helper(x):\n    return x\n\n\ndef calls(x):\n    return helper(x)\n", encoding="utf-8")
    spec = importlib.util.spec_from_file_location("watched_other_module", path)
    outside = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(outside)
    assert _reached(watch, outside.calls, {"helper"})[0] == []
