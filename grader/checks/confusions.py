"""Formulas learners confuse with the right one, shared by several chapters' checks: each a Mistake whose value
is what the other formula gives on the same input (grader.judging.diagnose weighs it like any of a check's own)."""

from __future__ import annotations

import numpy as np

from grader.judging.diagnose import Mistake

NORM_HELP = {
    "taxicab range": "the range is |x| + |y|{z}, the taxicab distance: it is the straight-line distance, "
                     "sqrt(x^2 + y^2{z2}).",
    "largest coordinate for the range": "the range is the largest of |x|, |y|{z}: it is the straight-line "
                                        "distance, sqrt(x^2 + y^2{z2}).",
    "squared range": "the range is x^2 + y^2{z2}, the squared distance: take the square root.",
}


def other_norms(point, right: np.ndarray, index: int | None = None) -> list[Mistake]:
    """`right` (a range, or a vector whose entry `index` is the range of `point`) with the range measured by
    another norm: the taxicab one, the largest coordinate, or squared."""
    coordinates = np.abs(np.asarray(point, dtype=float))
    z, z2 = (", |z|", " + z^2") if coordinates.size == 3 else ("", "")
    values = {"taxicab range": float(coordinates.sum()), "largest coordinate for the range": float(coordinates.max()),
              "squared range": float(coordinates @ coordinates)}
    out = []
    for name, value in values.items():
        wrong = np.array(right, dtype=float)
        if index is None:
            wrong = np.asarray(value)
        else:
            wrong[index] = value
        out.append(Mistake(name, NORM_HELP[name].format(z=z, z2=z2), wrong))
    return out


def backward_difference(forward: float, central: float) -> float:
    """(f(x) - f(x - h)) / h from the forward and central quotients of the same f, x and h."""
    return 2.0 * central - forward


STENCIL_HELP = {
    "backward difference": "that is the backward difference (f(x) - f(x-h))/h: the {own} one is {formula}.",
    "precedence": "/ 2 * h multiplies by h: (f(x+h) - f(x-h)) / 2 * h is the central difference times h^2; "
                  "write / (2 * h).",
}
