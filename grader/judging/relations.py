"""Relations between a wrong value and the right one, whatever code produced it.

A learner's value that is the right one off by whole turns in one entry, in degrees in one entry, scaled by a
constant (as a whole, or in one row or column), squared, square-rooted, inverted, with rows or columns in another
order, or with an entry or the identity left out tells what the learner did without looking at the code. Each
relation is a `Mistake` (origin "relation") whose value is the right value so transformed; `relations(got,
expected, entries)` lists them for one comparison, and grader.judging.diagnose names one only as it names any
candidate: matched at every failing input (two at least), ruled out at none. A whole-turn relation takes its turns,
and a proportional one its factor, from the learner's own value (they may differ from input to input); the others
are fixed transforms of the right value. The sentences say what the learner did, in the lesson's words.
"""

from __future__ import annotations

import itertools
import math

import numpy as np

from grader.judging.diagnose import Mistake

TURN = 2.0 * math.pi
MOST_TURNS = 3  # an entry off by more whole turns than this is not read as an unwrapped angle
LISTED = 8  # entries of a vector (columns of a matrix) up to which each gets relations of its own

FACTORS = (
    (2.0, "twice the right value: a factor 2 too many (or a division by 2 missing)"),
    (0.5, "half the right value: a factor 2 missing (or a division by 2 too many)"),
    (4.0, "4 times the right value: a factor 2 squared too many"),
    (0.25, "a quarter of the right value: a factor 2 squared missing"),
)


def _entry(entries, index: int, matrix: bool) -> str:
    """The name of a vector's entry or a matrix's column, for a sentence."""
    if not matrix:
        return entries.name((index,))
    name = entries.cols[index] if index < len(entries.cols) else ""
    if name and entries.derivative:
        name = f"d/d {name}"
    return f"column {index}" + (f" ({name})" if name else "") + f" of {entries.symbol}"


def _parts(expected: np.ndarray):
    """(index, selector, is a column) of each entry of a short vector or column of a narrow matrix; the whole
    value of a scalar."""
    if expected.ndim == 0:
        return [(None, (), False)]
    if expected.ndim == 1 and expected.size <= LISTED:
        return [(i, (i,), False) for i in range(expected.size)]
    if expected.ndim == 2 and expected.shape[1] <= LISTED:
        return [(j, (slice(None), j), True) for j in range(expected.shape[1])]
    return []


def whole_turns(got: np.ndarray, expected: np.ndarray, entries) -> list[Mistake]:
    """Each entry (column) off by whole turns of 2 pi where the learner's value is, right elsewhere."""
    out = []
    for index, where, column in _parts(expected):
        with np.errstate(invalid="ignore"):
            turns = np.round((got[where] - expected[where]) / TURN)
        if not np.all(np.isfinite(turns)) or not np.any(turns) or np.max(np.abs(turns)) > MOST_TURNS:
            continue
        value = expected.copy()
        value[where] = expected[where] + TURN * turns
        what = entries.symbol if index is None else _entry(entries, index, column)
        out.append(Mistake("whole turn", f"{what} is off by a whole turn (2 pi) at the inputs where it is wrong: "
                                         "the angle is right, but not brought into the range the function asks "
                                         "for.", value, "relation"))
    return out


def degrees(expected: np.ndarray, entries) -> list[Mistake]:
    """Each entry (column) in degrees where the rest is right."""
    out = []
    parts = _parts(expected)
    if len(parts) < 2:
        return out  # a single value in degrees is the generated "degrees" slip's, or the check's own
    for index, where, column in parts:
        if not np.any(expected[where]):
            continue
        value = expected.copy()
        value[where] = np.degrees(expected[where])
        what = _entry(entries, index, column)
        out.append(Mistake("one angle in degrees", f"{what} is in degrees while the rest is right: angles are in "
                                                   "radians (np.radians converts; np.arctan2 already returns "
                                                   "radians).", value, "relation"))
    return out


def scaled(expected: np.ndarray, entries) -> list[Mistake]:
    """The right value times a constant, squared, square-rooted or inverted, entry by entry."""
    symbol = entries.symbol
    out = [Mistake(f"factor {factor:g}", f"your {symbol} is {said}.", expected * factor, "relation")
           for factor, said in FACTORS]
    if np.any(np.abs(expected) != 1) and np.all(np.isfinite(expected)):
        out.append(Mistake("squared", f"your {symbol} is the right value squared: a power one too high (or a "
                                      "variance where a standard deviation belongs).", expected * expected,
                           "relation"))
        if np.all(expected >= 0):
            out.append(Mistake("square root", f"your {symbol} is the square root of the right value: a power one too "
                                              "low (or a standard deviation where a variance belongs).",
                               np.sqrt(expected), "relation"))
        if np.all(expected != 0):
            with np.errstate(all="ignore"):
                inverted = 1.0 / expected
            out.append(Mistake("reciprocal", f"your {symbol} is the reciprocal of the right value: a ratio is upside "
                                             "down.", inverted, "relation"))
    return out


def reordered(expected: np.ndarray, entries) -> list[Mistake]:
    """The rows (columns) of a matrix with three of them in another order (two: the generic swap)."""
    out = []
    if expected.ndim != 2:
        return out
    rows, cols = expected.shape
    if rows == 3:
        said = f" ({', '.join(entries.rows)})" if entries.rows else ""
        for order in itertools.permutations(range(3)):
            if order != (0, 1, 2):
                out.append(Mistake("rows reordered", f"the rows of {entries.symbol} are in another order: row i is "
                                                     f"output i{said}.", expected[list(order)], "relation"))
    if cols == 3:
        said = f" ({', '.join(entries.cols)})" if entries.cols else ""
        for order in itertools.permutations(range(3)):
            if order != (0, 1, 2):
                out.append(Mistake("columns reordered", f"the columns of {entries.symbol} are in another order: "
                                                        f"column j is input j{said}.", expected[:, list(order)],
                                   "relation"))
    return out


def within_a_line(expected: np.ndarray, entries) -> list[Mistake]:
    """A small matrix with the two entries of one row (column) swapped, one entry left out (0), or the identity
    left out of a square one."""
    out = []
    if expected.ndim != 2 or expected.size > LISTED * LISTED:
        return out
    rows, cols = expected.shape
    jacobian = entries.derivative
    if cols == 2:
        for i in range(rows):
            if expected[i, 0] != expected[i, 1]:
                value = expected.copy()
                value[i] = expected[i, ::-1]
                out.append(Mistake("row's entries swapped", f"the two entries of {_row(entries, i)} of "
                                                            f"{entries.symbol} are swapped" +
                                   (": column j is the derivative by input j." if jacobian else "."), value,
                                   "relation"))
    if rows == 2:
        for j in range(cols):
            if expected[0, j] != expected[1, j]:
                value = expected.copy()
                value[:, j] = expected[::-1, j]
                out.append(Mistake("column's entries swapped", f"the two entries of {_entry(entries, j, True)} are "
                                                               "swapped" + (": row i is output i." if jacobian else "."),
                                   value, "relation"))
    for i in range(rows):
        for j in range(cols):
            if expected[i, j] != 0:
                value = expected.copy()
                value[i, j] = 0.0
                out.append(Mistake("entry left out", f"{entries.name((i, j))} is 0: " +
                                   ("that derivative is missing." if jacobian else "that term is missing."), value,
                                   "relation"))
    if rows == cols and jacobian:
        out.append(Mistake("identity left out", f"your {entries.symbol} is the right one minus the identity: the "
                                                "map keeps its input and adds a change (x + ...), so its Jacobian "
                                                "starts from I.", expected - np.eye(rows), "relation"))
    return out


def proportional(got: np.ndarray, expected: np.ndarray, entries) -> list[Mistake]:
    """The right value with one column (row) of a matrix, or the whole vector or matrix, times a factor the
    learner's own value gives (a factor of that whole line missing or extra: r, dt, ...); the rest right. A line
    needs two entries or more that are not 0, so that the factor is a relation and not any wrong value."""
    out = []

    def factor(part_got: np.ndarray, part_expected: np.ndarray) -> float | None:
        if np.count_nonzero(part_expected) < 2 or not (np.all(np.isfinite(part_got))
                                                       and np.all(np.isfinite(part_expected))):
            return None
        with np.errstate(all="ignore"):
            c = float(part_got.ravel() @ part_expected.ravel() / (part_expected.ravel() @ part_expected.ravel()))
        return c if math.isfinite(c) and abs(abs(c) - 1.0) > 1e-6 and c != 0.0 else None

    def scaled_where(where, c: float) -> np.ndarray:
        value = expected.copy()
        value[where] = expected[where] * c
        return value

    whole = factor(got, expected)
    if whole is not None and expected.ndim in (1, 2):
        out.append(Mistake("proportional", f"your {entries.symbol} is a multiple of the right one: a factor of the "
                                           "whole value is missing or extra.", expected * whole, "relation"))
    if expected.ndim == 2 and max(expected.shape) <= LISTED:
        for j in range(expected.shape[1]):
            c = factor(got[:, j], expected[:, j])
            if c is not None:
                out.append(Mistake("column proportional", f"{_entry(entries, j, True)} is a multiple of the right one "
                                                          "(the rest is right): a factor of every entry in that column "
                                                          "is missing or extra.", scaled_where((slice(None), j), c),
                                   "relation"))
        for i in range(expected.shape[0]):
            c = factor(got[i], expected[i])
            if c is not None:
                out.append(Mistake("row proportional", f"{_row(entries, i)} of {entries.symbol} is a multiple of the "
                                                       "right one (the rest is right): a factor of every entry in that "
                                                       "row is missing or extra.", scaled_where((i,), c), "relation"))
    return out


def _row(entries, i: int) -> str:
    return f"row {i}" + (f" ({entries.rows[i]})" if i < len(entries.rows) else "")


def relations(got: np.ndarray, expected: np.ndarray, entries) -> list[Mistake]:
    """Every relation of this comparison, most specific first."""
    if got.shape != expected.shape or expected.size == 0:
        return []
    return [*whole_turns(got, expected, entries), *degrees(expected, entries), *reordered(expected, entries),
            *within_a_line(expected, entries), *scaled(expected, entries), *proportional(got, expected, entries)]


def tight(expected: np.ndarray, rtol: float, atol: float) -> bool:
    """Whether a comparison's tolerance is close enough for a relation to say anything: not a statistical one,
    whose band a constant factor may fall into by chance."""
    finite = expected[np.isfinite(expected)]
    scale = float(np.max(np.abs(finite), initial=0.0))
    return rtol <= 1e-5 and atol <= max(1e-9, 1e-5 * scale)
