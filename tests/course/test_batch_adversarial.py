"""Hostile submissions in one real batch: no false pass, a clear message, a bounded time, the other
learners graded normally, and no process left behind. Uses real bubblewrap where installed."""

from __future__ import annotations

import csv
import json
import os
import time
from pathlib import Path

import pytest

from grader.course.batch import run_batch
from grader.system import GRADER_PARENT
from tests.support import BWRAP, build_submission, processes_with, replace_function

pytestmark = pytest.mark.slow  # one batch of 20 hostile learners (each attack alone: test_process_boundary ...)
MARKER = "313.131"  # sleep duration used by hostile children, to find strays in /proc
LIMITS = {"import_seconds": 2.0, "call_seconds": 5.0, "chapter_seconds": 10.0}  # a memory bomb reaches its cap within the call on a busy machine
CHAPTERS = ["ch03", "ch06"]
# Without the sandbox learner code can read what the grader's own account can: these need it.
SANDBOX_ONLY = {"reads_references", "reads_reference_file", "reads_quiz_keys", "reads_other_learner"}


def _h(body: str) -> dict:
    return {"ch06_measurement": replace_function("ch06_measurement", "H_jacobian", f"def H_jacobian(x, y):\n{body}\n")}


def _module(text: str) -> dict:
    return {"ch06_measurement": replace_function("ch06_measurement", "H_jacobian",
                                                 "def H_jacobian(x, y):\n    return np.zeros((2, 2))\n") + "\n" + text}


HOSTILE = {
    "loop_at_import": {"ch06_measurement": "while True:\n    pass\n"},
    "loop_in_function": _h("    while True:\n        pass"),
    "memory_bomb": _h("    block = bytearray(3 << 30)\n    return np.zeros((2, 2)) + len(block)"),
    "sys_exit_at_import": {"ch06_measurement": "import sys\nsys.exit(0)\n"},
    "os_exit_in_function": _h("    import os\n    os._exit(0)"),
    "prints_hundreds_of_mb": _h("    import sys\n    chunk = 'x' * (1 << 20)\n    for _ in range(400):\n"
                                "        sys.stdout.write(chunk)\n    return np.zeros((2, 2))"),
    # background Pythons (the sandbox holds no other program) that outlive the import
    "sleeping_children": _module(f"import subprocess, sys\nSLEEP = [sys.executable, '-c', 'import time; time.sleep({MARKER})']\n"
                                 "subprocess.Popen(SLEEP)\nsubprocess.Popen(SLEEP, start_new_session=True)\n"),
    "reads_references": _h("    from solutions.ch06_measurement import H_jacobian as reference\n"
                           "    return reference(x, y)"),
    "reads_reference_file": _h(f"    text = open({os.path.join(GRADER_PARENT, 'solutions', 'ch06_measurement.py')!r}).read()\n"
                               "    namespace = {}\n    exec(text, namespace)\n    return namespace['H_jacobian'](x, y)"),
    "reads_quiz_keys": _h(f"    open({os.path.join(GRADER_PARENT, 'quizzes', 'keys', 'ch06.yaml')!r}).read()\n"
                          "    return np.zeros((2, 2))"),
    "reads_other_learner": _h("    import glob, os\n    here = os.path.dirname(os.path.abspath(__file__))\n"
                              "    others = glob.glob(os.path.join(here, '..', '..', '*', 'exercises', 'ch06_measurement.py'))\n"
                              "    others = [p for p in others if os.path.realpath(p) != os.path.realpath(__file__)]\n"
                              "    namespace = {}\n    exec(open(others[0]).read(), namespace)\n"
                              "    return namespace['H_jacobian'](x, y)"),
    "writes_fake_results": _module("import os, json\nhere = os.path.dirname(os.path.abspath(__file__))\n"
                                   "for up in ('..', '../..', '../../..'):\n"
                                   "    try:\n"
                                   "        target = os.path.join(here, up, 'writes_fake_results', 'report.json')\n"
                                   "        os.makedirs(os.path.dirname(target), exist_ok=True)\n"
                                   "        open(target, 'w').write(json.dumps({'score': 999}))\n"
                                   "    except OSError:\n"
                                   "        pass\n"),
    "always_equal_subclass": _h("    class Yes(np.ndarray):\n        def __eq__(self, other):\n            return True\n"
                                "        __ne__ = lambda self, other: False\n    return np.zeros((2, 2)).view(Yes)"),
    "patches_numpy": _module("np.allclose = lambda *a, **k: True\nnp.testing.assert_allclose = lambda *a, **k: None\n"
                             "np.array_equal = lambda *a, **k: True\n"),
    # Writes forged "right answer" lines to every open descriptor, the result pipe among them.
    "forges_result_lines": _module("import os, json\nlines = b''.join((json.dumps({'event': 'returned', 'chapter': 'ch06',"
                                   " 'index': i, 'value': {'t': 'ndarray', 'dtype': 'float64', 'shape': [2, 2],"
                                   " 'data': [0.6, 0.8, -0.16, 0.12]}}) + '\\n').encode() for i in range(300))\n"
                                   "for fd in range(3, 256):\n    try:\n        os.write(fd, lines + b'{\"event\": \"done\"}\\n')\n"
                                   "    except OSError:\n        pass\n"),
    "returns_nan": _h("    return np.full((2, 2), np.nan)"),
    "returns_string": _h("    return '[[0.6, 0.8], [-0.16, 0.12]]'"),
    "wrong_shape": _h("    return np.array([0.6, 0.8, -0.16, 0.12])"),
}


@pytest.fixture(scope="module")
def batch(tmp_path_factory):
    if not BWRAP and os.environ.get("CI"):
        pytest.fail("CI must have bubblewrap (.ci/run installs it)")
    base = tmp_path_factory.mktemp("adversarial")
    submissions = base / "submissions"
    submissions.mkdir()
    for name in ("good_one", "good_two"):
        build_submission(submissions / name)
    for name, replacements in HOSTILE.items():
        build_submission(submissions / name, replacements)
    result = run_batch(submissions, base / "out", chapters=CHAPTERS, jobs=2, seed=5, html=False, limits=LIMITS)
    time.sleep(0.5)
    return base / "out", result


def _checks(out: Path, learner: str) -> dict:
    data = json.loads((out / learner / "report.json").read_text())
    return {c["id"]: c for ch in data["chapters"] for c in ch["checks"] if c["kind"] == "code"}, data


def test_the_batch_finishes_in_bounded_time(batch):
    """Every learner is graded, and what would run forever was stopped by its own limit (the import's 2 s, the
    call's 5 s), never by the learner's whole budget: so each learner costs at most their limits."""
    out, result = batch
    assert set(result.statuses.values()) <= {"graded"}, result.messages
    assert "longer than 2 s" in _checks(out, "loop_at_import")[1]["chapters"][1]["problems"][0]
    assert "stopped after 5 s" in _checks(out, "loop_in_function")[0]["H_worked_example"]["message"]
    for learner in result.statuses:
        messages = [c["message"] for c in _checks(out, learner)[0].values()]
        assert not any("for all chapters ran out" in m for m in messages), learner


def test_other_learners_are_graded_normally(batch):
    out, _ = batch
    for learner in ("good_one", "good_two"):
        checks, _ = _checks(out, learner)
        assert all(c["status"] == "pass" for c in checks.values()), learner


@pytest.mark.parametrize("learner", sorted(HOSTILE))
def test_no_false_pass_and_a_clear_message(batch, learner):
    if learner in SANDBOX_ONLY and BWRAP is None:
        pytest.skip("reading the grader's own files is only prevented by the bubblewrap sandbox")
    out, _ = batch
    checks, data = _checks(out, learner)
    h_checks = [c for c in checks.values() if c["function"] == "H_jacobian" and c["id"] != "H_raises_at_origin"]
    assert h_checks and all(c["status"] != "pass" for c in h_checks), [(c["id"], c["status"]) for c in h_checks]
    assert all(c["message"] for c in h_checks)
    ch03 = next(ch for ch in data["chapters"] if ch["chapter"] == "ch03")
    assert ch03["code_score"] == ch03["code_max_score"], f"{learner} broke another chapter"


def test_specific_messages(batch):
    out, _ = batch
    message = lambda learner, check="H_worked_example": _checks(out, learner)[0][check]["message"]  # noqa: E731
    assert "did not return in time" in message("loop_in_function")
    assert "could not be imported" in message("loop_at_import")
    assert "ended abruptly" in message("os_exit_in_function")
    # stopped at the memory cap; or, where a busy machine writes the bomb's pages more slowly than its call may
    # take, at its time limit (the cap itself, alone on its own limits: test_containment); never graded on
    bomb = message("memory_bomb")
    assert "ran out of memory: all its processes together may use at most" in bomb or (
        not BWRAP and "MemoryError" in bomb) or "did not return in time: stopped after" in bomb, bomb
    assert "ndarray subclass" in message("always_equal_subclass")
    assert "returned str" in message("returns_string")
    assert "not finite" in message("returns_nan")
    if BWRAP:
        assert "ModuleNotFoundError" in message("reads_references")


def test_fake_result_files_do_not_count(batch):
    out, _ = batch
    _, data = _checks(out, "writes_fake_results")
    assert data["score"] < data["max_score"]
    with (out / "gradebook.csv").open(newline="", encoding="utf-8") as handle:
        rows = list(csv.DictReader(handle))
    assert all("999" not in value for row in rows for key, value in row.items() if key != "grader"), rows


def test_no_stray_process_is_left(batch):
    assert processes_with(MARKER) == []


@pytest.mark.skipif(BWRAP is None and not os.environ.get("CI"), reason="bubblewrap (bwrap) is not installed")
def test_sandbox_hides_references_keys_and_other_learners(batch):
    out, _ = batch
    for learner in ("reads_reference_file", "reads_quiz_keys", "reads_other_learner"):
        message = _checks(out, learner)[0]["H_worked_example"]["message"]
        assert "FileNotFoundError" in message or "IndexError" in message, (learner, message)
