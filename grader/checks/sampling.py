"""What the functions that sample share: the reproducibility check (the same seed or generator gives the same
value, another a different one) with the generator mistakes it names, and the distribution mistakes a cloud of
draws shows by its moments and shape."""

from __future__ import annotations

import numpy as np

from grader.boundary.wire import Returned
from grader.judging.compare import Verdict, fail, passed, value_problem
from grader.judging.diagnose import Mistake

UNSEEDED = Mistake("unseeded generator", "the draws do not come from the generator the seed makes: use "
                                         "rng = np.random.default_rng(seed) (or the rng argument) for every draw, "
                                         "never np.random.* or default_rng() without the seed.")
FIXED = Mistake("a generator of your own", "the seed (or the rng argument) does not choose the draws: a generator "
                                           "of your own with a fixed seed, e.g. np.random.default_rng(0), draws "
                                           "the same every time.")

STANDARD_ERRORS = 5.0
UNIFORM_KURTOSIS = -0.8  # excess kurtosis: a normal cloud's is 0 (within 0.4 at n = 4000), a uniform one's -1.2

DRAWS = {
    "no spread": "every sample is the same point: draw each one, mean + sigma * rng.standard_normal((n, 2)).",
    "variance as the scale": "the draws spread by sigma^2, not sigma: the standard deviation multiplies "
                             "rng.standard_normal, mean + sigma * rng.standard_normal((n, 2)).",
    "square root of sigma as the scale": "the draws spread by sqrt(sigma), not sigma: sigma is already the "
                                         "standard deviation.",
    "uniform draws": "the draws are uniform, not normal: N(mean, sigma^2 I) is mean + sigma * "
                     "rng.standard_normal((n, 2)).",
    "mean left out": "the draws are centred on 0: add the mean, mean + sigma * rng.standard_normal((n, 2)).",
    "one draw for both coordinates": "x and y move together: both coordinates use the same normal draw; draw an "
                                     "n x 2 array, rng.standard_normal((n, 2)).",
}


def same_seed_same_value(got: list[Returned], label: str, seed: int, other: int) -> Verdict:
    """`got` = results for (seed, seed, other): the first two must be equal, the third differ.
    `label` has a `{}` where the seed goes."""
    for returned, s in zip(got, (seed, seed, other)):
        problem = value_problem(returned, (), label.format(s))
        if problem:
            return fail(problem)
    first, again, different = (float(r.as_array()) for r in got)
    if first != again:
        verdict = fail(f"{label.format(seed)} gave {first!r}, then {again!r} with the same seed.", expected=first,
                       got=again)
        verdict.name(UNSEEDED)
        return verdict
    if first == different:
        verdict = fail(f"{label.format(seed)} and seed={other} both gave {first!r}.", got=different)
        verdict.name(FIXED)
        return verdict
    return passed()


def _holds(value: np.ndarray, want: float, error: float) -> bool:
    return bool(np.all(np.abs(value - want) <= STANDARD_ERRORS * error))


def draws_mistake(clouds: list[tuple[np.ndarray, np.ndarray, float]]) -> Mistake | None:
    """The mistake every cloud (samples, mean, sigma) of N(mean, sigma^2 I) draws shows alike by its moments and
    shape, or None: a spread or a mean within STANDARD_ERRORS of what that mistake gives, an excess kurtosis below
    UNIFORM_KURTOSIS (uniform), a correlation above 0.999 (one draw for both), no spread at all; on both
    coordinates."""
    def shows(name: str, samples: np.ndarray, mean: np.ndarray, sigma: float) -> bool:
        n = len(samples)
        spread = samples.std(axis=0, ddof=1)
        centre = samples.mean(axis=0)
        if name == "variance as the scale":
            return _holds(spread, sigma * sigma, sigma * sigma / np.sqrt(2 * n)) and abs(sigma - 1) > 0.2
        if name == "square root of sigma as the scale":
            return _holds(spread, np.sqrt(sigma), np.sqrt(sigma) / np.sqrt(2 * n)) and abs(sigma - 1) > 0.2
        if name == "no spread":
            return bool(np.all(spread == 0))
        if name == "uniform draws":
            if not np.all(spread > 0):
                return False
            centred = (samples - centre) / spread
            return bool(np.all((centred ** 4).mean(axis=0) - 3.0 < UNIFORM_KURTOSIS))
        if name == "mean left out":
            return (_holds(centre, 0.0, spread.max() / np.sqrt(n)) and bool(np.any(np.abs(mean) > 0.5))
                    and _holds(spread, sigma, sigma / np.sqrt(2 * n)))
        if name == "one draw for both coordinates":
            return n > 2 and bool(np.all(spread > 0)) and abs(np.corrcoef(samples.T)[0, 1]) > 0.999
        return False

    for name, help in DRAWS.items():
        if clouds and all(shows(name, np.asarray(s, dtype=float), np.asarray(m, dtype=float), float(sigma))
                          for s, m, sigma in clouds):
            return Mistake(name, help)
    return None
