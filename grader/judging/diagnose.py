"""Name the mistake: a wrong value compared with the known wrong versions of the right one.

A `Mistake` is one misconception: a stable name, one sentence that says what to change, and the
value a learner who makes it would return. Four kinds feed a diagnosis, in this order of precedence:
- the mistakes a check knows for its function (F^T P F, a missing dt, a forward difference, ...),
  their values asked of the reference while the check plans, like any expected value;
- generic transforms of the right answer, which any vector or matrix can suffer (every sign, one
  row's or one column's or one entry's sign, transposed, rows or columns swapped), named with the
  result's own entry names (grader.judging.compare.Entries);
- the relations between the learner's value and the right one, whatever code gave it (an angle off by whole
  turns or in degrees in one entry, a constant factor, a square, a reciprocal, rows in another order:
  grader.judging.relations), weighed by grader.judging.compare;
- the mistakes generated from the reference (grader.judging.mutants: every single slip of its code), their
  values at the learner's own calls given by grader.judging.expected (live in the project, recorded in a
  handout) through `judging`, while a check judges.

Every comparison weighs every candidate (`weigh`): the learner's value equals it (matched), or the
candidate is told from the right value and from the learner's (ruled out), or it says nothing here
(its value is the right one, or unknown). A mistake is named (`explain`) only when it is matched at
every failing input of the check and ruled out at none; a generated one only when it is the only
generated slip that is (two that say the same sentence count as one).
"""

from __future__ import annotations

import contextlib
import contextvars
import math
from dataclasses import dataclass, field
from typing import Callable, Iterable, Iterator

import numpy as np


@dataclass(frozen=True)
class Mistake:
    name: str
    help: str
    value: object = None  # what a learner making this mistake returns (None: not known for this case)
    origin: str = "known"  # "known" (the check's own), "generic" (a transform), "relation" (grader.judging.relations)
    #                        or "generated" (grader.judging.mutants)
    key: str = ""  # what identifies it across a check's inputs, when its name does not (a mutant's key)

    @property
    def id(self) -> str:
        """The same mistake at every input of a check: a check's own by its name (its help may quote the input),
        a generic one by its name and help (which say which entry), a generated one by its key."""
        return self.key or (self.name if self.origin == "known" else f"{self.name}\n{self.help}")


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
    return [Mistake(m.name, m.help, m.value, "generic") for m in out]


SKETCHED = 64  # a generated slip's value of more entries than this is known by its Sketch


@dataclass(frozen=True)
class Sketch:
    """A large value known by its first entries, their sum and their sum of squares: what a generated slip of a
    function that returns thousands of samples keeps of its value (the record a handout carries stays small), and
    what a learner's value is compared with it by."""

    shape: tuple
    values: tuple

    @classmethod
    def of(cls, array: np.ndarray) -> Sketch:
        flat = np.asarray(array, dtype=float).ravel()
        return cls(tuple(np.shape(array)), tuple(float(v) for v in (*flat[:16], flat.sum(), (flat * flat).sum())))


@dataclass
class Evidence:
    """What one comparison says of each candidate mistake (by Mistake.id): the learner's value equals it here
    (`matched`, in the order of precedence), or it is told from both the right value and the learner's
    (`ruled_out`); a candidate in neither says nothing here."""

    matched: dict[str, Mistake] = field(default_factory=dict)
    ruled_out: set[str] = field(default_factory=set)


def weigh(got: np.ndarray, expected: np.ndarray, candidates, rtol: float, atol: float) -> Evidence:
    """Every candidate (with a value) against the learner's value `got` and the right value `expected`, within
    the comparison's own tolerance."""
    evidence = Evidence()
    # plain floats for small finite values: the same comparisons, without a dozen numpy calls per candidate
    plain = expected.size <= SMALL and bool(np.all(np.isfinite(expected)))
    got_list, expected_list = got.ravel().tolist(), expected.ravel().tolist()
    for mistake in candidates:
        if mistake.value is None or mistake.id in evidence.matched:
            continue  # no value; or a variant of a mistake already matched here
        if isinstance(mistake.value, Sketch):
            if mistake.value.shape != got.shape:
                continue
            small = weigh(np.array(Sketch.of(got).values), np.array(Sketch.of(expected).values),
                          [Mistake(mistake.name, mistake.help, list(mistake.value.values), mistake.origin, mistake.id)],
                          rtol, atol)
            if mistake.id in small.matched:
                evidence.matched[mistake.id] = mistake
                evidence.ruled_out.discard(mistake.id)
            elif mistake.id in small.ruled_out:
                evidence.ruled_out.add(mistake.id)
            continue
        try:
            value = np.asarray(mistake.value, dtype=float)
        except (TypeError, ValueError):
            continue
        if value.shape != got.shape:
            continue
        if plain and all(map(math.isfinite, values := value.ravel().tolist())):
            if within(values, expected_list, rtol, atol):
                continue  # this slip makes no difference here
            matches = within(got_list, values, rtol, atol)
        else:  # also a slip that gives NaN or inf here: it matches a value not finite in the same entries
            if _alike(value, expected, rtol, atol):
                continue
            matches = _alike(got, value, rtol, atol)
        if matches:
            evidence.matched[mistake.id] = mistake
            evidence.ruled_out.discard(mistake.id)
        else:
            evidence.ruled_out.add(mistake.id)
    return evidence


def _alike(got: np.ndarray, value: np.ndarray, rtol: float, atol: float) -> bool:
    """Within |got - value| <= atol + rtol |value| where value is finite, and NaN or the same infinity where it
    is not."""
    finite = np.isfinite(value)
    with np.errstate(invalid="ignore"):
        return bool(np.array_equal(np.isnan(got), np.isnan(value)) and np.all(got[np.isinf(value)] == value[np.isinf(value)])
                    and np.all(np.abs(got[finite] - value[finite]) <= atol + rtol * np.abs(value[finite])))


def weigh_text(got: str, right: str, candidates) -> Evidence:
    """weigh for a returned string: every candidate whose value is a string, compared exactly."""
    evidence = Evidence()
    for mistake in candidates:
        if not isinstance(mistake.value, str) or mistake.value == right:
            continue
        if mistake.value == got:
            evidence.matched[mistake.id] = mistake
        else:
            evidence.ruled_out.add(mistake.id)
    return evidence


def explain(failing: list[Evidence | None], passing: Iterable[Evidence | None] = ()) -> Mistake | None:
    """The mistake matched at every failing input and ruled out at none (the failing inputs' evidence, then,
    drawn only if needed, the passing ones'): the first of the check's own, generic ones or relations (a relation
    only over RELATED_INPUTS failing inputs or more), else the generated one, if only one generated sentence
    remains. None if nothing explains every failure."""
    if not failing or any(e is None for e in failing):
        return None
    common = [i for i in failing[0].matched if all(i in e.matched for e in failing[1:])]
    if not common:
        return None
    ruled = set().union(*(e.ruled_out for e in failing))
    common = [i for i in common if i not in ruled]
    if common:
        for evidence in passing:
            if evidence is not None:
                common = [i for i in common if i not in evidence.ruled_out]
    found = [failing[0].matched[i] for i in common]
    for mistake in found:
        if mistake.origin == "relation" and len(failing) < RELATED_INPUTS:
            continue  # one input may meet a relation by chance (r = 4 makes r^2 = 4 r)
        if mistake.origin != "generated":
            return mistake
    found = [m for m in found if m.origin == "generated"]
    if not found:
        return None
    said = {(m.name, m.help) for m in found}
    if len(said) == 1:
        return found[0]
    kinds = {m.name for m in found}  # slips of one kind in several places that give the same values here
    if len(kinds) == 1 and found[0].name in OF_A_KIND:
        return Mistake(found[0].name, OF_A_KIND[found[0].name], None, "generated", f"kind: {found[0].name}")
    return None


RELATED_INPUTS = 2  # failing inputs a relation (grader.judging.relations) must explain before it names the mistake

# What slips of one kind (grader.judging.mutants) have in common, said when several such slips explain the values alike.
OF_A_KIND = {
    "missing term": "your value misses one of its terms.",
    "missing factor": "your value misses one of its factors.",
    "missing divisor": "your value misses a division.",
    "sign": "one sign is wrong.",
    "factor 2": "a factor of 2 is missing or too many.",
    "power": "a power is off by one.",
    "sin for cos": "a sine and a cosine are mixed up.",
    "arguments swapped": "two arguments are swapped.",
    "point moved": "a function is evaluated at the wrong point.",
    "reduction": "the values are reduced the wrong way (mean, sum, largest or smallest).",
    "integer arithmetic": "integer arithmetic: convert the inputs to float first (np.asarray(x, dtype=float)).",
    "degrees": "an angle is in degrees: angles are in radians.",
    "step as given": "the step is not used exactly as given.",
    "reciprocal": "a ratio is upside down.",
    "order": "a matrix product is in the wrong order.",
    "transpose": "a transpose is missing.",
}


def diagnose(got: np.ndarray, expected: np.ndarray, mistakes, entries, rtol: float, atol: float) -> Mistake | None:
    """For one value (a quiz answer): the first of `mistakes`, then of the generic slips named with `entries`
    (if given), whose value `got` equals and that is not itself right, or None."""
    candidates = list(mistakes) + (generic(expected, entries) if entries is not None else [])
    return explain([weigh(got, expected, candidates, rtol, atol)])


def combined(failing: list[Evidence], passing: list[Evidence]) -> Evidence:
    """The evidence of several inputs as one (a check made of checks): matched where matched at every failing
    input, ruled out where ruled out at any."""
    ruled = set().union(*(e.ruled_out for e in failing + passing))
    common = {i: m for i, m in failing[0].matched.items() if all(i in e.matched for e in failing[1:])}
    return Evidence({i: m for i, m in common.items() if i not in ruled}, ruled)


# ------------------------------------------------------------------------------ mistakes generated from the reference

Lookup = Callable[[object, "set[str] | None"], list[Mistake]]
_JUDGING: contextvars.ContextVar[tuple[Lookup, dict] | None] = contextvars.ContextVar("judging", default=None)


@contextlib.contextmanager
def judging(lookup: Lookup) -> Iterator[None]:
    """While a check judges: `lookup(returned, keys)` gives the generated mistakes at the call that returned it
    (those of these keys only, unless keys is None)."""
    token = _JUDGING.set((lookup, {}))
    try:
        yield
    finally:
        _JUDGING.reset(token)


def part_of(part: object, whole: object, index: int) -> None:
    """`part` is item `index` of the value `whole` returned (x_new of ekf_update's (x_new, P_new)): its generated
    mistakes are item `index` of the whole's."""
    judging_now = _JUDGING.get()
    if judging_now is not None:
        judging_now[1][id(part)] = (part, whole, index)  # the part kept alive, so that its id stays its own


def generated(returned: object, only: set[str] | None = None) -> list[Mistake]:
    """The mistakes generated from the reference, with their values at the learner call that gave `returned`
    (or item of it: part_of), of the ids in `only` if given (the others are then not evaluated) ([] outside a
    check's judging, or where none is known)."""
    judging_now = _JUDGING.get()
    if judging_now is None or returned is None:
        return []
    lookup, parts = judging_now
    if id(returned) in parts:
        _, whole, index = parts[id(returned)]
        return [Mistake(m.name, m.help, m.value[index], m.origin, m.key) for m in generated(whole, only)
                if isinstance(m.value, (tuple, list)) and len(m.value) > index]
    return lookup(returned, only)


SMALL = 64  # entries up to which plain floats compare faster than numpy's calls


def within(values: list[float], reference: list[float], rtol: float, atol: float) -> bool:
    """|value - reference| <= atol + rtol |reference| for every entry, on plain floats (NaN is never within)."""
    return all(abs(v - r) <= atol + rtol * abs(r) for v, r in zip(values, reference))


def shape_mistake(got_shape: tuple, expected_shape: tuple, symbol: str, product: bool = False) -> Mistake | None:
    """The mistake behind a wrong shape with the right number of entries, or (a `product` A M A^T) a square matrix
    of another size; or None."""
    if product and len(got_shape) == len(expected_shape) == 2 and got_shape[0] == got_shape[1] and \
            expected_shape[0] == expected_shape[1] and got_shape != expected_shape:
        return Mistake("product in the wrong order", f"{symbol} is {got_shape[0]} x {got_shape[0]}, not "
                                                     f"{expected_shape[0]} x {expected_shape[0]}: a product in the "
                                                     "wrong order (A^T M A for A M A^T, or H^T H for H H^T) gives the "
                                                     "other size.")
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
