"""Blame once: a wrong forward function costs its own points, never its derivative's; a function whose calls
entered a learner's wrong helper points at the helper, and one that never called it does not (the child says which
helpers each call entered, through any import form of an earlier chapter); and a submission in a private folder
(0700, as `mktemp -d` makes) grades normally, because its files travel to the sandboxed child in the request."""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

import pytest

from grader import boundary
from grader.boundary import Limits
from grader.core.grading import point_upstream
from grader.model import ChapterResult, CheckResult, Report, Status
from tests.support import (
    build_submission,
    checks_by_id,
    grade_checks,
    grade_code,
    replace_function,
    replace_functions,
)

WRONG_RANGE_BEARING = """
def range_bearing(x, y):
    return np.array([np.hypot(x, y), np.arctan2(x, y)], dtype=float)
"""
BROKEN_RANGE_BEARING = """
def range_bearing(x, y):
    raise RuntimeError("half written")
"""


@pytest.mark.parametrize("forward", [WRONG_RANGE_BEARING, BROKEN_RANGE_BEARING], ids=["wrong", "raises"])
def test_a_wrong_forward_function_costs_its_derivative_nothing(tmp_path, forward):
    root = build_submission(tmp_path, {"ch06_measurement": replace_function("ch06_measurement", "range_bearing",
                                                                            forward)})
    checks = grade_checks(root, "ch06")
    own = checks["H_jacobian_vs_own_range_bearing"]
    assert own.status == Status.SKIP and own.points == own.max_points, (own.status, own.message)
    assert "no points lost" in own.message and "fix range_bearing first" in own.message.replace("Fix", "fix")
    h_checks = [c for c in checks.values() if c.function == "H_jacobian"]
    assert sum(c.points for c in h_checks) == sum(c.max_points for c in h_checks)  # H is right: all its points
    assert any(c.status == Status.FAIL for c in checks.values() if c.function == "range_bearing")


def test_a_function_built_on_a_wrong_helper_points_at_the_helper(tmp_path):
    forward_gradient = """
    def gradient_fd(f, x, h=1e-5):
        x = np.asarray(x, dtype=float)
        base = float(f(x))
        out = np.zeros(x.size)
        for j in range(x.size):
            e = np.zeros_like(x)
            e[j] = h
            out[j] = (f(x + e) - base) / h
        return out
    """
    root = build_submission(tmp_path, {"ch09_choose_your_tool": replace_function("ch09_choose_your_tool", "gradient_fd",
                                                                                 forward_gradient)})
    report = grade_code(root, ["ch05", "ch09"])
    ch09 = checks_by_id(report.chapters[1])
    hessian = [c for c in ch09.values() if c.function == "hessian_fd" and c.status == Status.FAIL]
    assert hessian, "the reference hessian_fd uses gradient_fd: it must fail with it"
    assert all(c.message.startswith("hessian_fd calls your gradient_fd, which fails its own checks: fix it first.")
               and c.upstream == ["gradient_fd"] for c in hessian), [c.message[:120] for c in hessian]
    untouched = checks_by_id(report.chapters[0])  # ch05's jacobian_fd is right: nothing points at it
    assert all(c.status == Status.PASS for c in untouched.values())


# range_bearing_elevation whose range forgot z: it fails its own checks
WRONG_RANGE_BEARING_ELEVATION = """
def range_bearing_elevation(x, y, z):
    x, y, z = float(x), float(y), float(z)
    ground = np.hypot(x, y)
    return np.array([ground, np.arctan2(y, x), np.arctan2(z, ground)])
"""
# H3 written out, without range_bearing_elevation, and a factor forgotten: d elevation/d z over r, not r^2
H3_FORGOT_A_FACTOR = """
def H3_jacobian(x, y, z):
    x, y, z = float(x), float(y), float(z)
    rho2 = x * x + y * y
    if rho2 == 0:
        raise ValueError("the bearing is undefined where x = y = 0")
    rho = np.sqrt(rho2)
    r2 = rho2 + z * z
    r = np.sqrt(r2)
    return np.array([[x / r, y / r, z / r],
                     [-y / rho2, x / rho2, 0.0],
                     [-z * x / (r2 * rho), -z * y / (r2 * rho), rho / r]])
"""
# H3 as central differences of the learner's own range_bearing_elevation
H3_BY_DIFFERENCES = """
def H3_jacobian(x, y, z):
    p = np.array([x, y, z], dtype=float)
    if p[0] == 0 and p[1] == 0:
        raise ValueError("the bearing is undefined where x = y = 0")
    columns = []
    for j in range(3):
        e = np.zeros(3)
        e[j] = 1e-6
        columns.append((range_bearing_elevation(*(p + e)) - range_bearing_elevation(*(p - e))) / 2e-6)
    return np.stack(columns, axis=1)
"""
# H3 written out, its range taken from the learner's range_bearing_elevation (through a helper of its own)
H3_WITH_ITS_RANGE = """
def H3_jacobian(x, y, z):
    x, y, z = float(x), float(y), float(z)
    rho2 = x * x + y * y
    if rho2 == 0:
        raise ValueError("the bearing is undefined where x = y = 0")
    rho = np.sqrt(rho2)
    r = _range_of(x, y, z)
    r2 = r * r
    return np.array([[x / r, y / r, z / r],
                     [-y / rho2, x / rho2, 0.0],
                     [-z * x / (r2 * rho), -z * y / (r2 * rho), rho / r2]])


def _range_of(x, y, z):
    return float(range_bearing_elevation(x, y, z)[0])
"""


def _h3_submission(root, h3: str):
    """The reference submission with a wrong range_bearing_elevation and `h3` as H3_jacobian."""
    return build_submission(root, {"ch06_measurement": replace_functions(
        "ch06_measurement", {"range_bearing_elevation": WRONG_RANGE_BEARING_ELEVATION, "H3_jacobian": h3})})


def _h3_checks(tmp_path, h3: str, **options) -> dict:
    return grade_checks(_h3_submission(tmp_path, h3), "ch06", **options)


def test_a_function_that_never_calls_its_failing_helper_is_not_pointed_at_it(tmp_path):
    checks = _h3_checks(tmp_path, H3_FORGOT_A_FACTOR)
    assert any(c.status == Status.FAIL for c in checks.values() if c.function == "range_bearing_elevation")
    h3 = [c for c in checks.values() if c.function == "H3_jacobian" and c.status == Status.FAIL]
    assert h3, "H3 with a factor forgotten must fail"
    assert all(c.upstream == [] and "range_bearing_elevation, which fails" not in c.message
               and "builds on" not in c.message for c in h3), [(c.id, c.message[:120]) for c in h3]
    assert "H3[2,2] = d elevation/d z" in checks["H3_worked_example"].message  # its own mistake, named


@pytest.mark.parametrize("h3", [H3_BY_DIFFERENCES, H3_WITH_ITS_RANGE], ids=["differences", "its range"])
def test_a_function_that_calls_its_failing_helper_is_pointed_at_it(tmp_path, h3):
    checks = _h3_checks(tmp_path, h3)
    h3_failing = [c for c in checks.values() if c.function == "H3_jacobian" and c.status == Status.FAIL]
    assert h3_failing, "H3 built on a wrong range_bearing_elevation must fail"
    assert all(c.upstream == ["range_bearing_elevation"] and c.message.startswith(
        "H3_jacobian calls your range_bearing_elevation, which fails its own checks: fix it first.\n")
        for c in h3_failing), [(c.id, c.message[:120]) for c in h3_failing]


# H_jacobian with the bearing row's sign flipped: it fails its own checks (ch06)
WRONG_H = """
def H_jacobian(x, y):
    x, y = float(x), float(y)
    r2 = x * x + y * y
    if r2 == 0:
        raise ValueError("H is undefined at r = 0")
    r = np.sqrt(r2)
    return np.array([[x / r, y / r], [y / r2, -x / r2]])
"""
# ch08's linearized_measurement_cov, with H from the learner's ch06 in each form it may be reached by
IMPORTED_H = {
    "relative": ("from .ch06_measurement import H_jacobian", "H_jacobian(x, y)"),
    "plain": ("from ch06_measurement import H_jacobian", "H_jacobian(x, y)"),
    "module": ("import ch06_measurement as measurement", "measurement.H_jacobian(x, y)"),
    "inside": ("", "__import__('exercises.ch06_measurement', fromlist=['H_jacobian']).H_jacobian(x, y)"),
}
OWN_H_COVARIANCE = """
def linearized_measurement_cov(x, y, sigma):
    x, y = float(x), float(y)
    r2 = x * x + y * y
    return float(sigma) ** 2 * np.diag([1.0, 1.0 / r2]) * 1.5
"""


def _lab(imported: str, covariance_of_h: str) -> str:
    """ch08 with H_jacobian imported as `imported`, and linearized_measurement_cov computing H as `covariance_of_h`."""
    module = replace_function("ch08_lab", "linearized_measurement_cov", f"""
def linearized_measurement_cov(x, y, sigma):
    H = {covariance_of_h}
    return float(sigma) ** 2 * (H @ H.T) * 1.5
""")
    return module.replace("from .ch06_measurement import H_jacobian, range_bearing",
                          f"from .ch06_measurement import range_bearing\n{imported}")


@pytest.mark.parametrize("form", list(IMPORTED_H))
def test_a_helper_of_an_earlier_chapter_is_pointed_at_only_when_reached(tmp_path, form):
    imported, h = IMPORTED_H[form]
    wrong_h = replace_function("ch06_measurement", "H_jacobian", WRONG_H)
    reaching = build_submission(tmp_path / "reaching", {"ch06_measurement": wrong_h, "ch08_lab": _lab(imported, h)})
    own = build_submission(tmp_path / "own", {"ch06_measurement": wrong_h, "ch08_lab": replace_function(
        "ch08_lab", "linearized_measurement_cov", OWN_H_COVARIANCE)})
    for root, blamed in ((reaching, ["H_jacobian"]), (own, [])):
        report = grade_code(root, ["ch06", "ch08"])
        assert any(c.status == Status.FAIL for c in report.chapters[0].checks if c.function == "H_jacobian")
        covariance = [c for c in report.chapters[1].checks if c.function == "linearized_measurement_cov"
                      and c.status == Status.FAIL]
        assert covariance, "a covariance 1.5 times too large must fail"
        assert all(c.upstream == blamed and c.message.startswith("linearized_measurement_cov calls your H_jacobian")
                   == bool(blamed) for c in covariance), (root.name, [(c.id, c.message[:100]) for c in covariance])


def test_a_call_the_child_said_nothing_of_blames_no_helper(tmp_path):
    """A call that did not return in time tells nothing of what it entered: no blame, even of a helper it called."""
    looping = H3_BY_DIFFERENCES.replace("    return np.stack(columns, axis=1)", "    while True:\n        pass")
    checks = _h3_checks(tmp_path, looping, limits=Limits(call_seconds=0.5))
    h3 = [c for c in checks.values() if c.function == "H3_jacobian" and c.status == Status.FAIL]
    assert h3 and all(c.upstream == [] for c in h3), [(c.id, c.upstream, c.message[:100]) for c in h3]


def test_a_kept_verdict_is_kept_for_the_helpers_reached_too(tmp_path, monkeypatch):
    """Two learners whose H3 return the same values, one through their range_bearing_elevation, one without: a batch
    worker's memo gives the second no verdict of the first's, blame and all; a third who answers as the first gets
    the first's, blame and all."""
    from grader.core import grading
    from grader.core.grading import judge_chapters
    from grader.core.memo import Memo
    from tests.support import open_session

    planned = []
    plan = grading._plan
    monkeypatch.setattr(grading, "_plan", lambda cid, *rest: planned.append(cid) or plan(cid, *rest))

    calls_it = H3_FORGOT_A_FACTOR.replace("    rho = np.sqrt(rho2)", "    range_bearing_elevation(x, y, z)\n"
                                                                   "    rho = np.sqrt(rho2)")
    memo = Memo(None, "this worker")
    blamed = []
    for name, h3 in (("calls", calls_it), ("never", H3_FORGOT_A_FACTOR), ("calls again", calls_it)):
        report = judge_chapters(open_session(_h3_submission(tmp_path / name, h3)), ["ch06"], memo=memo)
        blamed.append(sorted(c.id for c in report.chapters[0].checks if c.upstream))
    assert blamed[0] and blamed[0] == blamed[2] and blamed[1] == [], blamed
    assert planned == ["ch06", "ch06"]  # the third's verdict was the first's, kept


def test_no_evidence_no_blame():
    """point_upstream blames only a helper some call of the check was seen to enter."""
    report = Report("r", chapters=[ChapterResult("ch06", "t", checks=[
        CheckResult("rbe", "range_bearing_elevation", "d", Status.FAIL, 0, 1, "wrong"),
        CheckResult("h3_a", "H3_jacobian", "d", Status.FAIL, 0, 1, "wrong a"),
        CheckResult("h3_b", "H3_jacobian", "d", Status.FAIL, 0, 1, "wrong b"),
        CheckResult("h3_c", "H3_jacobian", "d", Status.PASS, 1, 1, "")])])
    point_upstream(report, {"ch06": {"H3_jacobian": ("range_bearing_elevation",)}},
                   {"ch06": {"h3_b": ["range_bearing_elevation"], "h3_c": ["range_bearing_elevation"]}})
    a, b, c = report.chapters[0].checks[1:]
    assert (a.upstream, a.message) == ([], "wrong a")
    assert b.upstream == ["range_bearing_elevation"] and b.message.endswith("first.\nwrong b")
    assert c.upstream == [] and c.message == ""


@pytest.mark.skipif(os.geteuid() != 0, reason="a folder only root can read needs root to grade from")
def test_a_submission_in_a_private_folder_grades_normally():
    private = Path(tempfile.mkdtemp(prefix="private-"))  # 0700, as mktemp -d makes it
    try:
        assert oct(private.stat().st_mode & 0o777) == "0o700"
        root = build_submission(private / "work")
        os.chmod(private / "work", 0o700)
        chosen = boundary.choose("auto")
        assert chosen.sandboxed or not os.environ.get("CI"), "CI must have bubblewrap"
        report = grade_code(root, ["ch06"], boundary=chosen)
        assert report.chapters[0].score == report.chapters[0].max_score, report.chapters[0].problems
    finally:
        import shutil

        shutil.rmtree(private, ignore_errors=True)
