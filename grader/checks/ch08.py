"""Chapter 8: the linearization lab (Monte Carlo cloud vs linearized ellipse) and one EKF update.

Sampling functions are graded statistically and for reproducibility, never against the
reference's particular draws (a learner may draw N(mean, sigma^2 I) any correct way):
- sample_positions: over n = 4000 draws the sample mean of each coordinate must be within
  5 standard errors sigma/sqrt(n) of the mean, each sample variance within 5 sigma^2 sqrt(2/(n-1))
  of sigma^2, the covariance within 5 sigma^2/sqrt(n) of 0 (sigma is never near 1, so sigma^2 for
  sigma shows; the same noise on both coordinates shows as covariance sigma^2). Two Rng(seed) calls
  with the same seed must give identical arrays, another seed a different one.
- linearization_mismatch: the contract's properties (< 0.1 at (3, 4) and > 0.4 at (0.3, 0.2) with
  sigma 0.8, n = 5000: the reference's values over 300 seeds lie in 0.0015..0.065 and 0.52..0.57),
  the same seed twice gives the same value, and at further points (one whose cloud straddles
  +-pi, so bearings must be unwrapped) the value must lie within 6 standard deviations of the
  mean of the statistic, both estimated here from 20 simulated clouds of the same n (cached).
Closed forms (measure_samples, linearized_measurement_cov, sample_covariance, ekf_update) are
compared with the reference formula: rtol 1e-9 (ekf_update's P_new 1e-8, as the standard and
Joseph forms differ by rounding). sample_covariance gets n as small as 2 and 5, so dividing by n
instead of n - 1 is off by 20% or more. ekf_update's P_new must be symmetric (to 2e-6 of max |P|,
single-precision round-off: a P_new of entries near 1e-17 is symmetric enough) and P - P_new positive
semi-definite (eigenvalues >= -2e-6 max |P|), both computed here from the learner's output. Every
comparison allows at least single-precision round-off (grader.judging.compare.compare_arrays).
"""

from __future__ import annotations

import numpy as np

from grader.boundary.wire import Array, Rng, call
from grader.checks.base import chapter_checks
from grader.checks.derivatives import planar_point, vector_form
from grader.checks.sampling import FIXED, UNSEEDED, draws_mistake, same_seed_same_value
from grader.judging.compare import (
    SINGLE_PRECISION,
    Entries,
    Verdict,
    all_of,
    compare_arrays,
    exactly,
    expect,
    expect_raises,
    fail,
    fmt,
    passed,
    value_problem,
)
from grader.judging.diagnose import Evidence, Mistake, part_of
from grader.judging.expected import reference

CHECKS = chapter_checks("ch08")
CHECKS.uses("linearized_measurement_cov", "H_jacobian")
CHECKS.uses("measure_samples", "range_bearing")
CHECKS.uses("linearization_mismatch", "sample_positions", "measure_samples", "sample_covariance",
            "linearized_measurement_cov")
CHECKS.uses("ekf_update", "H_jacobian", "range_bearing")
REF = reference("ch08")

RTOL, ATOL = 1e-9, 1e-12
STANDARD_ERRORS = 5.0
SPREAD = 6.0
SIMULATED_CLOUDS = 20  # clouds simulated for each case of the mismatch statistic (solutions/oracle/ch08.py)
SYMMETRY = SINGLE_PRECISION  # relative to P: float32 round-off (jax, torch) is no asymmetry
MEAS = ("range", "bearing")
S_LIN = Entries("S_lin", rows=MEAS, cols=MEAS, product=True)
S_COV = Entries("S", rows=("column 0", "column 1"), cols=("column 0", "column 1"))
X_NEW = Entries("x_new", rows=("x", "y"))
P_NEW = Entries("P_new", rows=("x", "y"), cols=("x", "y"))


def _mat(m) -> str:
    """A matrix on one line: [[1, 2], [3, 4]]."""
    return "[" + ", ".join("[" + ", ".join(fmt(v) for v in row) + "]" for row in np.atleast_2d(np.asarray(m, dtype=float))) + "]"


def _show(values) -> str:
    return "(" + ", ".join(fmt(v) for v in np.asarray(values, dtype=float).ravel()) + ")"


def _sigma(rng: np.random.Generator) -> float:
    """A standard deviation never near 1, so that sigma and sigma^2 differ clearly."""
    return float(rng.choice([rng.uniform(0.3, 0.7), rng.uniform(1.4, 2.0)]))


def _seeds(rng: np.random.Generator, k: int) -> list[int]:
    return [int(s) for s in rng.choice(2**31, size=k, replace=False)]


def _measure_entries(n: int) -> Entries:
    return Entries("z", rows=tuple(f"sample {i}" for i in range(n)), cols=MEAS)


# ------------------------------------------------------------------------------ sample_positions

@CHECKS.check("sample_positions", points=1)
def sample_positions_shape_and_reproducible(ctx):
    """sample_positions returns n x 2 draws from the rng it is given: the same seed gives the same array"""
    rng = ctx.rng
    mean, sigma, n = planar_point(rng), _sigma(rng), int(rng.integers(20, 60))
    seed, other = _seeds(rng, 2)
    args = (tuple(float(v) for v in mean), sigma, n)
    got = yield [call("sample_positions", *args, Rng(s)) for s in (seed, seed, other)]
    label = f"sample_positions({_show(mean)}, {fmt(sigma)}, {n}, np.random.default_rng({{}}))"
    for g, s in zip(got, (seed, seed, other)):
        problem = value_problem(g, (n, 2), label.format(s))
        if problem:
            return fail(problem)
    first, again, different = (g.as_array() for g in got)
    if not np.array_equal(first, again):
        verdict = fail(f"{label.format(seed)} gave different samples in two calls with generators of the same seed.")
        verdict.name(Mistake(UNSEEDED.name, "draw the samples from the rng argument (e.g. rng.standard_normal), "
                                            "not from np.random or a new generator."))
        return verdict
    if np.array_equal(first, different):
        verdict = fail(f"{label.format(seed)} and {label.format(other)} gave the same samples.")
        verdict.name(Mistake(FIXED.name, "draw the samples from the rng argument, not from a generator you create "
                                         "yourself with a fixed seed."))
        return verdict
    return passed()


@CHECKS.check("sample_positions", points=1)
def sample_positions_statistics(ctx):
    """sample_positions draws have mean `mean` and covariance sigma^2 I (n = 4000, within 5 standard errors)"""
    rng = ctx.rng
    n = 4000
    cases = [(planar_point(rng, 1.0, 6.0), _sigma(rng), seed, form)
             for seed, form in zip(_seeds(rng, 3), ("tuple", "list", "array"))]
    got = yield [call("sample_positions", vector_form(m, form), s, n, Rng(seed)) for m, s, seed, form in cases]
    verdicts, clouds = [], []
    for g, (mean, sigma, seed, form) in zip(got, cases):
        label = f"sample_positions({_show(mean)}, {fmt(sigma)}, {n}, np.random.default_rng({seed}))"
        problem = value_problem(g, (n, 2), label)
        if problem:
            return fail(problem)
        samples = g.as_array()
        clouds.append((samples, mean, sigma))
        cov = np.cov(samples.T)
        var = sigma * sigma
        tests = [("mean x", samples[:, 0].mean(), mean[0], sigma / np.sqrt(n)),
                 ("mean y", samples[:, 1].mean(), mean[1], sigma / np.sqrt(n)),
                 ("variance of x", cov[0, 0], var, var * np.sqrt(2 / (n - 1))),
                 ("variance of y", cov[1, 1], var, var * np.sqrt(2 / (n - 1))),
                 ("covariance of x and y", cov[0, 1], 0.0, var / np.sqrt(n))]
        for what, value, want, error in tests:
            verdicts.append(compare_arrays(value, want, label=f"{label}: sample {what} (sigma^2 = {fmt(var)}; statistical, "
                                                              f"{STANDARD_ERRORS:g} standard errors)",
                                           rtol=0.0, atol=float(STANDARD_ERRORS * error)).also(exactly(g)))
    verdict = all_of(verdicts)
    if not verdict.passed and verdict.mistake is None:
        verdict.name(draws_mistake(clouds))  # the cloud's moments and shape, where no slip of the code is named
    return verdict


# ------------------------------------------------------------------------------ measure_samples

def _cloud(rng: np.random.Generator, center, sigma: float, n: int) -> np.ndarray:
    return np.asarray(center, dtype=float) + sigma * rng.standard_normal((n, 2))


def _measure_expected(samples: np.ndarray, ref_bearing: float) -> tuple:
    """(the right measurements, the raw atan2 bearings a missing unwrap gives), asked while planning."""
    return REF.measure_samples(samples, ref_bearing), REF.raw_bearings(samples)


def _measure_verdict(returned, wanted: tuple, label: str):
    expected, raw = wanted
    not_unwrapped = np.column_stack([expected[:, 0], raw])
    return expect(returned, expected, label=label, rtol=RTOL, atol=ATOL, entries=_measure_entries(len(expected)),
                  mistakes=[Mistake("not unwrapped", "these are the raw atan2 bearings: move each by whole turns, "
                                                     "b + 2 pi round((ref_bearing - b) / 2 pi), to lie within pi of "
                                                     "ref_bearing.", not_unwrapped)])


@CHECKS.check("measure_samples", points=1)
def measure_samples_worked_example(ctx):
    """measure_samples(np.array([[3, 4], [-1, -0.01]]), 3.1) is [[5, 0.9273], [1.00005, 3.1516]]"""
    samples = np.array([[3.0, 4.0], [-1.0, -0.01]])
    wanted = _measure_expected(samples, 3.1)
    got = yield call("measure_samples", Array(samples.tolist()), 3.1)
    return _measure_verdict(got, wanted, "measure_samples(np.array([[3, 4], [-1, -0.01]]), 3.1)")


@CHECKS.check("measure_samples", points=2)
def measure_samples_unwraps_around_ref_bearing(ctx):
    """measure_samples keeps a cloud in one piece around ref_bearing: clouds straddling +-pi, ref_bearing off by 2 pi"""
    rng = ctx.rng
    cases = []
    for i in range(2):  # ordinary clouds, ref_bearing the bearing of their centre
        center = planar_point(rng, 2.0, 5.0)
        cases.append((_cloud(rng, center, 0.4, 12), float(np.arctan2(center[1], center[0])), "ordinary cloud"))
    for side in (1.0, -1.0):  # clouds around the negative x axis, ref_bearing near +pi or -pi
        center = np.array([-rng.uniform(2.0, 4.0), side * rng.uniform(0.05, 0.2)])
        cloud = _cloud(rng, center, 0.5, 16)
        cloud[0, 1], cloud[1, 1] = abs(cloud[0, 1]) + 0.05, -abs(cloud[1, 1]) - 0.05  # both sides of the axis
        cases.append((cloud, float(np.arctan2(center[1], center[0])), "cloud straddling +-pi"))
    center = planar_point(rng, 2.0, 5.0)  # ref_bearing a whole turn away: bearings move by 2 pi
    cases.append((_cloud(rng, center, 0.3, 10), float(np.arctan2(center[1], center[0]) + rng.choice([-2, 2]) * np.pi),
                  "ref_bearing one turn away"))
    wanted = [_measure_expected(s, b) for s, b, _ in cases]
    got = yield [call("measure_samples", Array(s.tolist()), b) for s, b, _ in cases]
    return all_of([_measure_verdict(g, w, f"measure_samples({len(s)} samples around {_show(s.mean(axis=0))}, "
                                          f"ref_bearing={fmt(b)}) ({what})")
                   for g, w, (s, b, what) in zip(got, wanted, cases)])


# ------------------------------------------------------------------------------ linearized_measurement_cov

@CHECKS.check("linearized_measurement_cov", points=1)
def linearized_cov_worked_example(ctx):
    """linearized_measurement_cov(3, 4, sigma=0.8) is diag(0.64, 0.0256)"""
    got = yield call("linearized_measurement_cov", 3, 4, 0.8)
    return expect(got, np.diag([0.64, 0.0256]), label="linearized_measurement_cov(3, 4, 0.8)", rtol=RTOL, atol=ATOL,
                  entries=S_LIN)


@CHECKS.check("linearized_measurement_cov", points=1)
def linearized_cov_random_points(ctx):
    """linearized_measurement_cov = H (sigma^2 I) H^T at random points and sigmas"""
    rng = ctx.rng
    cases = [(float(x), float(y), _sigma(rng)) for x, y in (planar_point(rng) for _ in range(5))]
    cases.append((-2, 5, 1.5))
    calls = [call("linearized_measurement_cov", x, y, s) for x, y, s in cases]
    expected = [REF.linearized_measurement_cov(*c.args) for c in calls]
    got = yield calls
    return all_of([expect(g, want, rtol=RTOL, atol=ATOL, entries=S_LIN, label=c.label, mistakes=[
        Mistake("sigma not squared", "sigma multiplies the result once: Sigma = sigma^2 I.", want / c.args[2])])
        for g, want, c in zip(got, expected, calls)])


# ------------------------------------------------------------------------------ sample_covariance

UNCENTRED = "the mean is not subtracted: a covariance is made of the samples' deviations from their mean."
ROWS_AS_VARIABLES = Mistake("rows as variables", "np.cov takes each row as a variable: the columns are the "
                                                  "variables here, so pass z.T (or rowvar=False).")


@CHECKS.check("sample_covariance", points=2)
def sample_covariance_matches_np_cov(ctx):
    """sample_covariance equals np.cov(z.T): unbiased (divide by n - 1), for n = 2, 5, 7 and 300 correlated samples"""
    rng = ctx.rng
    cases = []
    for n in (5, 2, 7, 300, 5):
        mix = np.array([[1.0, 0.0], [rng.uniform(0.4, 0.9), rng.uniform(0.2, 0.5)]]) * rng.uniform(0.5, 3.0)
        z = rng.uniform(-5, 5, 2) + rng.standard_normal((n, 2)) @ mix.T
        cases.append(z)
    expected = [REF.sample_covariance(z) for z in cases]
    got = yield [call("sample_covariance", Array(z.tolist())) for z in cases]
    verdicts = []
    for g, want, z in zip(got, expected, cases):
        label = f"sample_covariance({len(z)} x 2 array z with mean {_show(z.mean(axis=0))})"
        n = len(z)
        raw = z.T @ z
        if n != 2 and g.ok and np.shape(g.as_array()) == (n, n):
            verdict = fail(value_problem(g, (2, 2), label))
            verdict.name(ROWS_AS_VARIABLES)
            verdicts.append(verdict)
            continue
        verdicts.append(expect(g, want, label=label, rtol=RTOL, atol=ATOL, entries=S_COV, mistakes=[
            Mistake("n, not n - 1", f"that is the biased covariance: divide by n - 1 = {n - 1}, not by n = {n}.",
                    want * (n - 1) / n),
            Mistake("mean not subtracted", UNCENTRED, raw / (n - 1)),
            Mistake("mean not subtracted", UNCENTRED, raw / n),
            Mistake(ROWS_AS_VARIABLES.name, ROWS_AS_VARIABLES.help, np.cov(z))]))
    return all_of(verdicts)


# ------------------------------------------------------------------------------ linearization_mismatch

@CHECKS.check("linearization_mismatch", points=2)
def mismatch_far_small_near_large(ctx):
    """linearization_mismatch with sigma 0.8, n 5000: < 0.1 at (3, 4) (the ellipse fits), > 0.4 at (0.3, 0.2) (it fails)"""
    seeds = _seeds(ctx.rng, 2)
    cases = [(3, 4, seeds[0], "<", 0.1), (0.3, 0.2, seeds[1], ">", 0.4)]
    got = yield [call("linearization_mismatch", x, y, 0.8, 5000, s) for x, y, s, _, _ in cases]
    for g, (x, y, s, side, bound) in zip(got, cases):
        label = f"linearization_mismatch({fmt(x)}, {fmt(y)}, 0.8, 5000, seed={s})"
        problem = value_problem(g, (), label)
        if problem:
            return fail(problem)
        value = float(g.as_array())
        if not np.isfinite(value) or not (value < bound if side == "<" else value > bound):
            why = ("far from the sensor the linearized ellipse should describe the cloud" if side == "<" else
                   "this close to the sensor the bearing is too nonlinear for the ellipse")
            verdict = Verdict(False, f"{label} = {fmt(value)}; expected {side} {bound:g} ({why}).", got=value,
                              evidence=exactly(g))
            return verdict
    return passed()


@CHECKS.check("linearization_mismatch", points=1)
def mismatch_reproducible(ctx):
    """linearization_mismatch draws from np.random.default_rng(seed): the same seed gives the same value, another seed another"""
    seed, other = _seeds(ctx.rng, 2)
    args = (2.0, -1.5, 0.6, 2000)
    got = yield [call("linearization_mismatch", *args, s) for s in (seed, seed, other)]
    label = "linearization_mismatch(2, -1.5, 0.6, 2000, seed={})"
    return same_seed_same_value(got, label, seed, other)


@CHECKS.check("linearization_mismatch", points=1)
def mismatch_matches_simulation(ctx):
    """linearization_mismatch is within 6 standard deviations of its simulated mean, also for a cloud straddling +-pi and at (0.3, 0.2)"""
    rng = ctx.rng
    cases = [(-float(rng.uniform(2.5, 3.5)), float(rng.choice([-1, 1]) * rng.uniform(0.1, 0.3)), 0.8, 2000),
             # sigma 2: the covariances' size far from 1, so that a mismatch not relative to norm(S_lin) shows
             (*(float(v) for v in planar_point(rng, 2.5, 4.0)), 2.0, 2500),
             (*(float(v) for v in planar_point(rng, 0.5, 0.8)), 0.8, 2000),
             # the contract's near point, where the statistic is narrow: a mismatch relative to the sampled
             # covariance (about 1.2 there, the right one 0.55) shows
             (0.3, 0.2, 0.8, 5000)]
    seeds = _seeds(rng, len(cases))
    distributions = [REF.mismatch_distribution(*case) for case in cases]
    got = yield [call("linearization_mismatch", x, y, s, n, seed) for (x, y, s, n), seed in zip(cases, seeds)]
    verdicts = []
    for g, (x, y, s, n), seed, (mean, spread) in zip(got, cases, seeds, distributions):
        label = f"linearization_mismatch({fmt(x)}, {fmt(y)}, {fmt(s)}, {n}, seed={seed})"
        problem = value_problem(g, (), label)
        if problem:
            return fail(problem)
        v = compare_arrays(g.as_array(), mean, label=f"{label} (statistical: the mean over {SIMULATED_CLOUDS} simulated "
                                                     f"clouds +- {SPREAD:g} standard deviations {fmt(spread)})",
                           rtol=0.0, atol=SPREAD * spread).also(exactly(g, mean))
        if not v.passed and np.hypot(x, y) > 2 and abs(np.arctan2(y, x)) > 2.5:
            v.message += "\n  (this cloud straddles +-pi: are the bearings unwrapped around atan2(y, x)?)"
        verdicts.append(v)
    return all_of(verdicts)


# ------------------------------------------------------------------------------ ekf_update

def spd2(rng: np.random.Generator, scales: tuple[float, float], correlation: float) -> np.ndarray:
    """A 2 x 2 covariance with standard deviations `scales` and the given correlation."""
    d = np.diag(scales)
    return d @ np.array([[1.0, correlation], [correlation, 1.0]]) @ d


def _ekf_case(rng: np.random.Generator, x: np.ndarray, z_point: np.ndarray | None = None):
    P = spd2(rng, tuple(rng.uniform(0.15, 0.6, 2)), float(rng.choice([-1, 1]) * rng.uniform(0.3, 0.7)))
    R = spd2(rng, (float(rng.uniform(0.05, 0.2)), float(rng.uniform(0.01, 0.05))),
             float(rng.choice([-1, 1]) * rng.uniform(0.2, 0.5)))
    if z_point is None:
        z_point = x + rng.uniform(-0.4, 0.4, 2)
    z = REF.range_bearing(*z_point) + np.array([rng.normal(0, 0.05), rng.normal(0, 0.01)])
    return x, P, z, R


def _ekf_call(x, P, z, R, form: str = "array"):
    """x and z as a list, tuple or array; P and R always arrays (the contract's matrix arguments)."""
    return call("ekf_update", vector_form(x, form), Array(P.tolist()), vector_form(z, form), Array(R.tolist()))


def _ekf_label(x, P, z, R) -> str:
    return f"ekf_update(x={_show(x)}, P={_mat(P)}, z={_show(z)}, R={_mat(R)})"


def ekf_parts(returned, label: str):
    """(x_new, P_new) as Returned values, or a failed Verdict saying why the result is not such a pair."""
    if not returned.ok:
        return fail(returned.problem())
    items = returned.items()
    if items is None or len(items) != 2:
        what = returned.type_name if items is None else f"{returned.encoded['t']} of {len(items)} items"
        return fail(f"{label} returned {what}; expected the tuple (x_new, P_new).")
    for index, item in enumerate(items):
        part_of(item, returned, index)  # the slips of the reference name its parts
    return items


EKF_SLIPS = {"innovation not wrapped": "the bearing innovation z - h(x) is not wrapped: bring it to [-pi, pi) "
                                       "before it multiplies the gain.",
             "innovation wrapped into [0, 2 pi)": "the bearing innovation is wrapped with % (2 pi), into [0, 2 pi): "
                                                  "a small negative residual becomes almost a whole turn; wrap it "
                                                  "into [-pi, pi).",
             "R missing": "R is missing from the innovation covariance: S = H P H^T + R.",
             "R as a standard deviation": "R is squared in the innovation covariance: R already holds variances "
                                          "(sigma^2), so S = H P H^T + R."}


def _ekf_verdict(returned, case, wanted: tuple, label: str):
    """(x_new, P_new) against wanted = (REF.ekf_update(*case), REF.ekf_mistakes(*case))."""
    parts = ekf_parts(returned, label)
    if not isinstance(parts, list):
        return parts
    (x_new, P_new), slips = wanted
    scale = float(np.max(np.abs(case[1])))
    x_verdict = expect(parts[0], x_new, label=f"x_new of {label}", rtol=RTOL, atol=ATOL, entries=X_NEW,
                       mistakes=[Mistake(name, EKF_SLIPS[name], slips[name][0]) for name in EKF_SLIPS])
    if not x_verdict.passed:
        return x_verdict
    return expect(parts[1], P_new, label=f"P_new of {label}", rtol=1e-8, atol=1e-12 * scale, entries=P_NEW) \
        .also(lambda only: Evidence(ruled_out=(x_verdict.weigh(only) or Evidence()).ruled_out))  # x_new tells too


@CHECKS.check("ekf_update", points=2)
def ekf_update_random_states(ctx):
    """ekf_update (x_new, P_new) for the stub's example and random states, covariances and measurements"""
    rng = ctx.rng
    cases = [(np.array([3.0, 4.0]), 0.1 * np.eye(2), np.array([5.1, 0.93]), np.diag([0.01, 0.001]))]
    cases += [_ekf_case(rng, planar_point(rng, 1.0, 4.5)) for _ in range(5)]
    forms = ["list", "array", "tuple", "list", "array", "tuple"]
    wanted = [(REF.ekf_update(*case), REF.ekf_mistakes(*case)) for case in cases]
    got = yield [_ekf_call(*case, form) for case, form in zip(cases, forms)]
    return all_of([_ekf_verdict(g, case, w, _ekf_label(*case)) for g, case, w in zip(got, cases, wanted)])


@CHECKS.check("ekf_update", points=1)
def ekf_update_wraps_bearing_innovation(ctx):
    """ekf_update wraps the bearing innovation to [-pi, pi): a state and a measurement on either side of +-pi"""
    rng = ctx.rng
    cases = []
    for side in (1.0, -1.0, 1.0):
        x = np.array([-rng.uniform(2.0, 4.0), side * rng.uniform(0.05, 0.2)])  # bearing near +pi or -pi
        z_point = np.array([x[0] + rng.uniform(-0.2, 0.2), -side * rng.uniform(0.1, 0.3)])  # across the axis
        case = _ekf_case(rng, x, z_point)
        case[2][1] = REF.range_bearing(*z_point)[1]  # the bearing exactly as atan2 gives it: the other sign
        cases.append(case)
    wanted = [(REF.ekf_update(*case), REF.ekf_mistakes(*case)) for case in cases]
    got = yield [_ekf_call(*case) for case in cases]
    return all_of([_ekf_verdict(g, case, w, _ekf_label(*case)) for g, case, w in zip(got, cases, wanted)])


@CHECKS.check("ekf_update", points=1)
def ekf_update_shrinks_covariance(ctx):
    """ekf_update's P_new is symmetric and no larger than P: P - P_new is positive semi-definite (checked on your output)"""
    rng = ctx.rng
    cases = [_ekf_case(rng, planar_point(rng, 1.0, 4.5)) for _ in range(5)]
    got = yield [_ekf_call(*case) for case in cases]
    for g, case in zip(got, cases):
        label = _ekf_label(*case)
        parts = ekf_parts(g, label)
        if not isinstance(parts, list):
            return parts
        problem = value_problem(parts[1], (2, 2), f"P_new of {label}")
        if problem:
            return fail(problem)
        P_new = parts[1].as_array()
        P = case[1]
        scale = float(np.max(np.abs(P)))
        if not np.all(np.isfinite(P_new)):
            return fail(f"P_new of {label} is not finite: {_mat(P_new)}.", got=P_new)
        if abs(P_new[0, 1] - P_new[1, 0]) > SYMMETRY * scale:  # relative to P: P_new may be tiny
            return fail(f"P_new of {label} is not symmetric: P_new[0,1] = {fmt(P_new[0, 1])}, P_new[1,0] = "
                        f"{fmt(P_new[1, 0])}.", got=P_new)
        lowest = float(np.linalg.eigvalsh(0.5 * ((P - P_new) + (P - P_new).T)).min())
        if lowest < -SYMMETRY * scale:
            return fail(f"P_new of {label} = {_mat(P_new)} is larger than P in some direction: P - P_new has the "
                        f"eigenvalue {fmt(lowest)} < 0 (a measurement can only shrink the uncertainty).", got=P_new)
        if float(np.linalg.eigvalsh(0.5 * (P_new + P_new.T)).min()) < -SYMMETRY * scale:
            return fail(f"P_new of {label} = {_mat(P_new)} is not positive semi-definite.", got=P_new)
    return passed()


@CHECKS.check("ekf_update", points=1)
def ekf_update_raises_at_origin(ctx):
    """ekf_update at x = (0, 0) raises ValueError (H is undefined at r = 0)"""
    got = yield call("ekf_update", Array([0.0, 0.0]), Array(np.eye(2).tolist()), Array([1.0, 0.5]),
                     Array(np.diag([0.01, 0.001]).tolist()))
    return expect_raises(got, "ValueError", label="ekf_update(x=(0, 0), I, (1, 0.5), diag(0.01, 0.001))",
                         why="H is undefined at r = 0")
