"""How a number reads in a learner-facing message: one leaf both the process boundary's labels
(grader.boundary.wire) and every comparison's message (grader.judging.compare) use."""

from __future__ import annotations


def fmt(value: float, zero_below: float = 0.0, digits: int = 6) -> str:
    """A number as a learner reads it: up to `digits` significant digits; 0 for anything no larger than
    `zero_below` (a value meant as 0 that rounding left at 3.8e-17)."""
    value = float(value)
    if value == 0 or abs(value) <= zero_below:
        return "0"
    return f"{value:.{digits}g}"


def fmt_array(values) -> str:
    """An array as a learner reads it: [[0.6, 0.8], [-0.16, 0.12]], each entry as fmt writes it."""
    import numpy as np

    values = np.asarray(values, dtype=float)
    if values.ndim == 0:
        return fmt(values)
    return np.array2string(values, precision=6, separator=", ", suppress_small=False,
                           formatter={"float_kind": fmt})
