"""The process boundary: learner code runs only in the child; broken chapters never stop the rest."""

from __future__ import annotations

import json
import os
import time

import numpy as np
import pytest

from grader.boundary import Limits
from grader.model import Status
from tests.support import (
    checks_by_id,
    grade_checks,
    grade_code,
    not_root,
    open_session,
    replace_function,
)

FAST = Limits(import_seconds=2.0, call_seconds=2.0, chapter_seconds=8.0)


def test_syntax_error_is_reported_with_file_and_line_and_other_chapters_are_graded(submission_factory):
    root = submission_factory({"ch06_measurement": "import numpy as np\n\ndef range_bearing(x, y)\n    return 1\n"})
    report = grade_code(root, ["ch03", "ch06"], limits=FAST)
    ch03, ch06 = report.chapters
    assert ch03.score == ch03.max_score > 0
    assert ch06.score == 0
    assert "exercises/ch06_measurement.py, line 3" in ch06.problems[0]
    assert "SyntaxError" in ch06.problems[0]
    assert {c.status for c in ch06.checks} == {Status.ERROR}


@pytest.mark.slow
def test_endless_loop_at_import_times_out_and_the_next_chapter_is_graded(submission_factory):
    root = submission_factory({"ch03_jacobian": "while True:\n    pass\n"})
    report = grade_code(root, ["ch03", "ch06"], limits=FAST)
    ch03, ch06 = report.chapters
    # stopped at the import's own limit (2 s), not the chapter's (8 s) or the learner's
    assert "could not be imported" in ch03.problems[0] and "longer than 2 s" in ch03.problems[0]
    assert ch06.score == ch06.max_score


@pytest.mark.parametrize("exit_code", ["import sys\nsys.exit(0)\n", "raise SystemExit('bye')\n"])
def test_sys_exit_at_import_is_reported(submission_factory, exit_code):
    root = submission_factory({"ch06_measurement": exit_code})
    report = grade_code(root, ["ch06", "ch03"], limits=FAST)
    ch06, ch03 = report.chapters
    assert "sys.exit()" in ch06.problems[0]
    assert ch03.score == ch03.max_score


def test_exception_at_import_names_the_line(submission_factory):
    root = submission_factory({"ch06_measurement": "import numpy as np\nx = 1 / 0\n"})
    ch06 = grade_code(root, ["ch06"], limits=FAST).chapters[0]
    assert "ch06_measurement.py, line 2 raised ZeroDivisionError" in ch06.problems[0]


def test_os_exit_inside_one_function_costs_only_that_function(submission_factory):
    source = replace_function("ch06_measurement", "measurement_covariance",
                              "def measurement_covariance(x, y, sigma):\n    import os\n    os._exit(3)\n")
    root = submission_factory({"ch06_measurement": source})
    ch06 = grade_code(root, ["ch06"], limits=FAST).chapters[0]
    checks = checks_by_id(ch06)
    assert checks["covariance_worked_example"].status == Status.FAIL
    assert "ended abruptly" in checks["covariance_worked_example"].message
    assert "exit status 3" in checks["covariance_worked_example"].message
    assert checks["H_worked_example"].status == Status.PASS
    assert checks["range_bearing_all_quadrants"].status == Status.PASS


@pytest.mark.slow
def test_endless_loop_in_one_function_times_out_and_the_rest_is_graded(submission_factory):
    source = replace_function("ch06_measurement", "H_jacobian",
                              "def H_jacobian(x, y):\n    while True:\n        pass\n")
    root = submission_factory({"ch06_measurement": source})
    ch06 = grade_code(root, ["ch06"], limits=FAST).chapters[0]
    checks = checks_by_id(ch06)
    # two calls ran into the call's limit (2 s), H_jacobian's first and measurement_covariance's (which calls it);
    # every later call of either was not run, and the chapter's limit (8 s) was never reached
    stopped = [c.id for c in ch06.checks if "stopped after 2 s" in c.message]
    assert stopped == ["H_worked_example", "covariance_worked_example"], [(c.id, c.message) for c in ch06.checks]
    assert not any("8 s" in c.message for c in ch06.checks)
    timed_out = [c for c in ch06.checks if c.function == "H_jacobian"]
    assert all(c.status in (Status.FAIL, Status.SKIP) for c in timed_out)
    assert any("did not return in time" in c.message for c in timed_out)
    assert checks["range_bearing_worked_example"].status == Status.PASS
    # the reference measurement_covariance calls H_jacobian, so it loops too and is stopped
    assert "did not return in time" in checks["covariance_worked_example"].message


@pytest.mark.parametrize("body, wrong_type", [
    ("class M(np.ndarray):\n        def __eq__(self, other): return True\n"
     "    return np.array([[0.6, 0.8], [-0.16, 0.12]]).view(M)", "ndarray subclass"),
    ("return np.matrix([[0.6, 0.8], [-0.16, 0.12]])", "ndarray subclass"),
    ("class Liar:\n        def __eq__(self, other): return True\n        __array__ = None\n    return Liar()", "Liar"),
    ("return '[[0.6, 0.8], [-0.16, 0.12]]'", "str"),
    ("return None", "None"),
    ("return [[0.6, 0.8], [-0.16, 0.12]]", "list"),
    ("return np.array([[0.6, 0.8], [-0.16, 0.12]], dtype=object)", "dtype object"),
])
def test_wrong_types_are_never_compared(submission_factory, body, wrong_type):
    source = replace_function("ch06_measurement", "H_jacobian", f"def H_jacobian(x, y):\n    {body}\n")
    root = submission_factory({"ch06_measurement": source})
    checks = grade_checks(root, "ch06", limits=FAST)
    example = checks["H_worked_example"]
    assert example.status == Status.FAIL
    assert wrong_type in example.message


def test_wrong_shape_and_nan_are_named(submission_factory):
    shape = replace_function("ch06_measurement", "H_jacobian",
                             "def H_jacobian(x, y):\n    return np.array([0.6, 0.8, -0.16, 0.12])\n")
    nan = replace_function("ch06_measurement", "H_jacobian",
                           "def H_jacobian(x, y):\n    return np.array([[0.6, 0.8], [np.nan, 0.12]])\n")
    shape_check = grade_checks(submission_factory({"ch06_measurement": shape}), "ch06", limits=FAST)
    nan_check = grade_checks(submission_factory({"ch06_measurement": nan}), "ch06", limits=FAST)
    assert "returned shape (4,); expected shape (2, 2)" in shape_check["H_worked_example"].message
    assert "not finite: H[1,0] = d bearing/d x = nan" in nan_check["H_worked_example"].message


def test_learner_traceback_is_trimmed_to_learner_frames(submission_factory):
    source = replace_function("ch06_measurement", "H_jacobian",
                              "def H_jacobian(x, y):\n    return helper(x)\n\n\ndef helper(x):\n    return x[0]\n")
    checks = grade_checks(submission_factory({"ch06_measurement": source}), "ch06", limits=FAST)
    example = checks["H_worked_example"]
    assert "raised TypeError" in example.message
    trace = example.details["traceback"]
    assert 'File "exercises/ch06_measurement.py"' in trace and "in helper" in trace
    assert "grader" not in trace and "child.py" not in trace


def test_learner_output_does_not_reach_our_stdout(submission_factory, capfd):
    source = replace_function("ch06_measurement", "range_bearing",
                              "def range_bearing(x, y):\n    print('HELLO FROM LEARNER')\n"
                              "    return np.array([np.hypot(x, y), np.arctan2(y, x)])\n")
    report = grade_code(submission_factory({"ch06_measurement": source}), ["ch06"], limits=FAST)
    out, err = capfd.readouterr()
    assert "HELLO FROM LEARNER" not in out + err
    assert "HELLO FROM LEARNER" in report.learner_output
    assert report.chapters[0].score == report.chapters[0].max_score


def test_missing_chapter_file_is_reported_not_crashing(tmp_path):
    (tmp_path / "exercises").mkdir()
    (tmp_path / "exercises" / "ch06_measurement.py").write_text("raise NotImplementedError\n")
    report = grade_code(tmp_path, ["ch03", "ch06"], limits=FAST)
    ch03, ch06 = report.chapters
    assert "exercises/ch03_jacobian.py was not found" in ch03.problems[0]
    assert "raised NotImplementedError" in ch06.problems[0]


def test_child_runs_in_another_process(submission_factory):
    source = replace_function("ch06_measurement", "range_bearing",
                              "def range_bearing(x, y):\n    import os\n    return np.array([os.getpid(), 0.0])\n")
    report = grade_code(submission_factory({"ch06_measurement": source}), ["ch06"], limits=FAST)
    got = checks_by_id(report.chapters[0])["range_bearing_worked_example"].got
    assert got[0] != os.getpid()


GC_STATE = replace_function("ch06_measurement", "range_bearing", "def range_bearing(x, y):\n    import gc\n"
                            "    return np.array([float(gc.isenabled()), float(gc.get_freeze_count())])\n")


def test_learner_code_runs_with_the_collector_on_and_the_childs_own_objects_frozen(submission_factory):
    """The child starts with the collector off (numpy's import and the request make no garbage) and turns it on
    for learner code, with what it made frozen: the learner's collections never walk it."""
    report = grade_code(submission_factory({"ch06_measurement": GC_STATE}), ["ch06"], limits=FAST)
    enabled, frozen = checks_by_id(report.chapters[0])["range_bearing_worked_example"].got
    assert enabled == 1.0 and frozen > 10_000, (enabled, frozen)


@pytest.mark.parametrize("value", [
    np.arange(40, dtype=np.float64).reshape(5, 8) / 3.0,  # large: travels as float64 bytes
    np.array([[0.1, -2.5], [1e-300, 7.0]]),  # small: travels as numbers
    np.arange(30, dtype=np.int64) - 15,
    np.array([np.nan, np.inf, -0.0] * 7),
])
def test_arrays_cross_the_process_boundary_exactly(value):
    from grader.boundary.wire import VALUE, Returned, encode_value

    wire = json.loads(json.dumps(encode_value(value)))  # what the pipe carries
    got = Returned(VALUE, "f", wire).as_array()
    assert type(got) is np.ndarray and got.dtype == np.float64 and got.shape == value.shape
    assert np.array_equal(got, value.astype(np.float64), equal_nan=True)
    assert np.array_equal(np.signbit(got), np.signbit(value))


def test_a_malformed_array_from_the_child_is_no_value():
    from grader.boundary.wire import VALUE, Returned

    for encoded in ({"t": "ndarray", "dtype": "float64", "shape": [3], "f8": "not base64!"},
                    {"t": "ndarray", "dtype": "float64", "shape": [3], "f8": "AAAA"},
                    {"t": "ndarray", "dtype": "float64", "shape": [4], "f8": "AAAAAAAAAAA="},
                    {"t": "ndarray", "dtype": "float64", "shape": [3], "f8": 12}):
        assert Returned(VALUE, "f", encoded).as_array() is None, encoded


def test_the_sessions_meanwhile_work_runs_while_the_child_runs_the_calls(submission_factory, tmp_path):
    """The quiz is judged while the child runs the code's calls (Session.meanwhile): here the learner's module
    waits, at import, for a file that only the meanwhile work writes, so grading finishes only if that work runs
    after the request is sent and before the results are awaited."""
    from grader.core.grading import judge_chapters

    signal_file = tmp_path / "meanwhile-ran"
    root = submission_factory({"ch00_range_sensor": (
        "import os, time\n"
        "import numpy as np\n"
        f"for _ in range(400):\n"
        f"    if os.path.exists({str(signal_file)!r}):\n"
        "        break\n"
        "    time.sleep(0.025)\n"
        "else:\n"
        "    raise RuntimeError('the meanwhile work never ran')\n"
        "def range_reading(x, y):\n"
        "    return float(np.hypot(x, y))\n")})
    session = open_session(root)  # no sandbox: the learner's module sees tmp_path
    ran = []
    session.meanwhile.append(lambda: (ran.append(True), signal_file.write_text("yes", encoding="utf-8")))
    report = judge_chapters(session, ["ch00"])
    chapter = report.chapters[0]
    assert ran == [True]
    assert not chapter.problems, chapter.problems
    assert {c.status.value for c in chapter.checks if c.function == "range_reading"} == {"pass"}


def test_the_grade_command_runs_no_blas_threads_beside_the_learners_child(submission_factory, tmp_path):
    """The grader's own numpy is single-threaded: OpenBLAS' pool (one thread per further core) would busy-wait
    beside the learner's child on the same cores. While the child runs slow calls, `grade` has its main
    thread only. (On a one-core machine OpenBLAS starts no pool either way.)"""
    import subprocess
    import sys

    calling = tmp_path / "calling"
    root = submission_factory({"ch00_range_sensor": (
        "import pathlib, time\nimport numpy as np\n"
        "def range_reading(x, y):\n"
        f"    pathlib.Path({str(calling)!r}).touch()\n"
        "    time.sleep(0.2)\n"
        "    return float(np.hypot(x, y))\n")})
    grade_process = subprocess.Popen(not_root([sys.executable, "-m", "grader", "ch00", "--submission", str(root),
                                               "--no-quiz", "--no-sandbox"]),
                                     stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                                     env={k: v for k, v in os.environ.items() if not k.endswith("_NUM_THREADS")})
    threads = []
    try:
        deadline = time.monotonic() + 60
        while not calling.exists() and grade_process.poll() is None and time.monotonic() < deadline:
            time.sleep(0.02)
        time.sleep(0.1)  # the request is written: the thread that wrote it has ended
        for _ in range(10):
            threads.append(len(os.listdir(f"/proc/{grade_process.pid}/task")))
            time.sleep(0.05)
    finally:
        grade_process.kill()
        grade_process.wait()
    assert calling.exists(), "the learner's function was never called"
    assert max(threads) == 1, f"threads of `grade` while its child ran: {threads}"
