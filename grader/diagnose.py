"""Name the mistake: a wrong value compared with the known wrong versions of the right one.

A `Mistake` is one misconception: a stable name, one sentence that says what to change, and the
value a learner who makes it would return. Two kinds feed `diagnose`:
- generic transforms of the right answer, which any vector or matrix can suffer (every sign, one
  row's or one column's or one entry's sign, transposed, rows or columns swapped), named with the
  result's own entry names (grader.compare.Entries);
- the mistakes a check knows for its function (F^T P F, a missing dt, a forward difference, ...),
  their values asked of the reference while the check plans, like any expected value.

A diagnosis is only ever offered for a value that failed, and only when the learner's value equals
the mistake's within the comparison's own tolerance and the mistake's value is not itself right.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Mistake:
    name: str
    help: str
    value: object = None  # what a learner making this mistake returns (None: not known for this case)


def known(values: dict, helps: dict) -> list[Mistake]:
    """The mistakes named in `helps` (name -> what to change), each with the value the reference gave for it
    in `values` (name -> value; a name it gave no value for is left out)."""
    return [Mistake(name, help, values[name]) for name, help in helps.items() if name in values]


def _row_name(entries, i: int) -> str:
    return f"row {i}" + (f" ({entries.rows[i]})" if i < len(entries.rows) else "")


def _column_name(entries, j: int) -> str:
    if j >= len(entries.cols):
        return f"column {j}"
    return f"column {j} (d/d {entries.cols[j]})" if entries.derivative else f"column {j} ({entries.cols[j]})"


def generic(expected: np.ndarray, entries) -> list[Mistake]:
    """The transforms of a right vector or matrix a slip produces, most specific first."""
    symbol = entries.symbol
    out: list[Mistake] = []
    if expected.ndim == 2:
        rows, cols = expected.shape
        if rows == cols and not np.allclose(expected, expected.T):
            where = (f": rows are the outputs ({', '.join(entries.rows)}), columns the inputs ({', '.join(entries.cols)})"
                     if entries.rows and entries.cols else "")
            out.append(Mistake("transpose", f"your {symbol} is transposed{where}.", expected.T))
        for i in range(rows):
            for j in range(cols):
                if expected[i, j] != 0:
                    flipped = expected.copy()
                    flipped[i, j] = -flipped[i, j]
                    out.append(Mistake("entry sign", f"{entries.name((i, j))} has the wrong sign.", flipped))
        for i in range(rows):
            flipped = expected.copy()
            flipped[i] = -flipped[i]
            out.append(Mistake("row sign", f"{_row_name(entries, i)} of {symbol} has the wrong sign.", flipped))
        for j in range(cols):
            flipped = expected.copy()
            flipped[:, j] = -flipped[:, j]
            out.append(Mistake("column sign", f"{_column_name(entries, j)} of {symbol} has the wrong sign.", flipped))
        if rows == 2:
            out.append(Mistake("rows swapped", f"the rows of {symbol} are swapped: row 0 is "
                                               f"{entries.rows[0] if entries.rows else 'the first output'}.",
                               expected[::-1]))
        if cols == 2:
            out.append(Mistake("columns swapped", f"the columns of {symbol} are swapped: column 0 is "
                                                  f"{'d/d ' if entries.derivative else ''}"
                                                  f"{entries.cols[0] if entries.cols else 'the first input'}.",
                               expected[:, ::-1]))
    elif expected.ndim == 1:
        for i in range(expected.size):
            if expected[i] != 0:
                flipped = expected.copy()
                flipped[i] = -flipped[i]
                out.append(Mistake("entry sign", f"{entries.name((i,))} has the wrong sign.", flipped))
        if expected.size == 2:
            out.append(Mistake("entries swapped", f"the two entries of {symbol} are swapped.", expected[::-1]))
    out.append(Mistake("every sign", f"every entry of {symbol} has the wrong sign." if expected.ndim else
                       f"{symbol} has the wrong sign.", -expected))
    return out


def diagnose(got: np.ndarray, expected: np.ndarray, mistakes, entries, rtol: float, atol: float) -> Mistake | None:
    """The first mistake (the check's own, then the generic ones) whose value `got` equals, or None."""
    candidates = list(mistakes) + (generic(expected, entries) if entries is not None else [])
    # plain floats for small finite values: the same comparisons, without a dozen numpy calls per candidate
    plain = expected.size <= SMALL and bool(np.all(np.isfinite(expected)))
    got_list, expected_list = got.ravel().tolist(), expected.ravel().tolist()
    for mistake in candidates:
        if mistake.value is None:
            continue
        value = np.asarray(mistake.value, dtype=float)
        if value.shape != got.shape:
            continue
        if plain:
            values = value.ravel().tolist()
            if not all(map(math.isfinite, values)) or within(values, expected_list, rtol, atol):
                continue  # not a value, or this slip makes no difference here
            if within(got_list, values, rtol, atol):
                return mistake
            continue
        if not np.all(np.isfinite(value)) or np.allclose(value, expected, rtol=rtol, atol=atol):
            continue
        if np.all(np.abs(got - value) <= atol + rtol * np.abs(value)):
            return mistake
    return None


SMALL = 64  # entries up to which plain floats compare faster than numpy's calls


def within(values: list[float], reference: list[float], rtol: float, atol: float) -> bool:
    """|value - reference| <= atol + rtol |reference| for every entry, on plain floats (NaN is never within)."""
    return all(abs(v - r) <= atol + rtol * abs(r) for v, r in zip(values, reference))


def shape_mistake(got_shape: tuple, expected_shape: tuple, symbol: str) -> Mistake | None:
    """The mistake behind a wrong shape with the right number of entries, or None."""
    if int(np.prod(got_shape)) != int(np.prod(expected_shape)) or got_shape == expected_shape:
        return None
    if len(expected_shape) == 1 and len(got_shape) == 2:
        return Mistake("row instead of flat", f"{symbol} has the right entries as a {got_shape[0]} x {got_shape[1]} "
                                              "matrix: return a flat array (np.ravel).")
    if len(expected_shape) == 2 and expected_shape[0] == 1 and len(got_shape) == 1:
        return Mistake("flat instead of row", f"a one-output {symbol} is 1 x {expected_shape[1]}, a row: return "
                                              f"shape {expected_shape} (reshape(1, -1)).")
    if len(expected_shape) == 2 and got_shape == expected_shape[::-1]:
        return Mistake("transposed shape", f"{symbol} has the transposed shape: rows are the outputs, columns the "
                                           "inputs.")
    return None
