"""Relations between a wrong value and the right one (grader.judging.relations), whatever code produced it: an
angle off by whole turns or in degrees in one entry, a constant factor, a square or square root, a reciprocal, rows
or columns in another order; named only where they explain every failing input, and before a generated slip."""

from __future__ import annotations

import numpy as np
import pytest

from grader.judging.compare import Entries, all_of, compare_arrays
from grader.judging.relations import relations
from grader.model import Status
from tests.support import build_submission, grade_code, replace_function

Z3 = Entries("z", rows=("range", "bearing", "elevation"))
H3 = Entries("H3", rows=("range", "bearing", "elevation"), cols=("x", "y", "z"), derivative=True)


def _checks(tmp_path, module: str, function: str, source: str) -> dict:
    root = build_submission(tmp_path / "slip", {module: replace_function(module, function, source)})
    return {c.id: c for c in grade_code(root, [module[:4]]).chapters[0].checks if c.function == function}


def test_a_bearing_wrapped_by_hand_is_off_by_a_whole_turn(tmp_path):
    """atan(y/x) + pi where x < 0, never wrapped back: right in three quadrants, a whole turn off in the third."""
    checks = _checks(tmp_path, "ch06_measurement", "range_bearing", """
        def range_bearing(x, y):
            bearing = np.arctan(y / x)
            if x < 0:
                bearing = bearing + np.pi
            return np.array([np.sqrt(x * x + y * y), bearing])
        """)
    check = checks["range_bearing_all_quadrants"]
    assert check.status == Status.FAIL and check.mistake == "whole turn"
    assert check.help.startswith("z[1] (bearing) is off by a whole turn (2 pi) at the inputs where it is wrong")
    assert checks["range_bearing_worked_example"].status == Status.PASS


def test_one_angle_in_degrees_is_named_with_its_entry(tmp_path):
    checks = _checks(tmp_path, "ch06_measurement", "range_bearing_elevation", """
        def range_bearing_elevation(x, y, z):
            ground = np.hypot(x, y)
            return np.array([np.sqrt(x * x + y * y + z * z), np.arctan2(y, x), np.degrees(np.arctan2(z, ground))])
        """)
    check = checks["range_bearing_elevation_random_points"]
    assert check.status == Status.FAIL and check.mistake == "one angle in degrees"
    assert check.help.startswith("z[2] (elevation) is in degrees while the rest is right: angles are in radians")


def _named(pairs, entries):
    """The mistake all_of names for (learner's value, right value) pairs."""
    return all_of([compare_arrays(got, right, label="v", entries=entries) for got, right in pairs]).mistake


def test_a_relation_explains_every_failing_input_or_is_not_given():
    """A relation matched at every failing input is named; one contradicted at another failing input, or met at a
    single input only (where chance may meet it), is not."""
    right, other = np.array([5.0, 0.9, 0.1]), np.array([4.0, -2.5, 0.3])
    turned = [(r + [0.0, 2 * np.pi, 0.0], r) for r in (right, other)]
    assert _named(turned, Z3).name == "whole turn"
    assert _named(turned[:1], Z3) is None
    assert _named([turned[0], (right * [1.0, 1.0, 3.0], right)], Z3) is None


def test_rows_of_a_three_by_three_jacobian_in_another_order():
    rng = np.random.default_rng(5)
    pairs = [(m[[1, 2, 0]], m) for m in (rng.uniform(-3, 3, (3, 3)) for _ in range(2))]
    mistake = _named(pairs, H3)
    assert mistake.name == "rows reordered"
    assert mistake.help == "the rows of H3 are in another order: row i is output i (range, bearing, elevation)."


@pytest.mark.parametrize(("transform", "name"), [
    (lambda v: 2 * v, "factor 2"), (lambda v: v / 2, "factor 0.5"), (lambda v: v * v, "squared"),
    (np.sqrt, "square root"), (lambda v: 1 / v, "reciprocal")])
def test_a_scaled_value_is_named_by_its_relation(transform, name):
    pairs = [(transform(m), m) for m in (np.array([[0.04, 0.3], [0.3, 2.5]]), np.array([[1.7, 0.2], [0.2, 0.9]]))]
    assert _named(pairs, Entries("S")).name == name


def test_the_identity_left_out_is_said_of_a_jacobian_only():
    """F - I for F is the increment's Jacobian; the same difference in a covariance is no such mistake."""
    pairs = [(m - np.eye(2), m) for m in (np.array([[1.0, 0.3], [0.0, 1.0]]), np.array([[1.0, -0.7], [0.0, 1.0]]))]
    assert _named(pairs, Entries("F", rows=("x'", "y'"), cols=("x", "y"), derivative=True)).name == "identity left out"
    assert _named(pairs, Entries("S")) is None or _named(pairs, Entries("S")).name != "identity left out"


def test_no_relation_in_a_statistical_band():
    """A statistical comparison's band is wide: a constant factor that falls in it by chance is no relation."""
    pairs = [(np.asarray(0.25 * v), np.asarray(v)) for v in (0.31, 0.29)]
    verdict = all_of([compare_arrays(got, right, label="v", rtol=0.0, atol=0.05) for got, right in pairs])
    assert not verdict.passed and verdict.mistake is None


def test_no_relation_is_the_right_value_itself():
    """Every relation differs from the right value wherever it is offered (a relation equal to it says nothing)."""
    rng = np.random.default_rng(3)
    for shape in ((), (2,), (3,), (2, 2), (3, 3), (40, 2)):
        right = rng.uniform(0.2, 3.0, shape) * rng.choice([-1.0, 1.0], shape)
        got = right + 2 * np.pi * (rng.random(shape) < 0.3)
        for relation in relations(np.asarray(got), np.asarray(right), Entries("v")):
            assert not np.allclose(relation.value, right), relation
