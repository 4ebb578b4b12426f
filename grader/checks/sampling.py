"""The reproducibility check shared by the functions that sample from np.random.default_rng(seed)."""

from __future__ import annotations

from grader.boundary.wire import Returned
from grader.judging.compare import Verdict, fail, passed, value_problem


def same_seed_same_value(got: list[Returned], label: str, seed: int, other: int) -> Verdict:
    """`got` = results for (seed, seed, other): the first two must be equal, the third differ.
    `label` has a `{}` where the seed goes."""
    for returned, s in zip(got, (seed, seed, other)):
        problem = value_problem(returned, (), label.format(s))
        if problem:
            return fail(problem)
    first, again, different = (float(r.as_array()) for r in got)
    if first != again:
        return fail(f"{label.format(seed)} gave {first!r}, then {again!r} with the same seed: draw the "
                    "samples from np.random.default_rng(seed), not from an unseeded generator.",
                    expected=first, got=again)
    if first == different:
        return fail(f"{label.format(seed)} and seed={other} both gave {first!r}: the seed must choose the samples.",
                    got=different)
    return passed()
