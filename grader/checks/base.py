"""How a check is declared: a generator that yields the learner calls it needs, then judges them.

    @CHECKS.check("H_jacobian", points=2)
    def h_worked_example(ctx):
        '''H at the lesson's point (3, 4)'''
        got = yield call("H_jacobian", 3, 4)
        return expect(got, [[0.6, 0.8], [-0.16, 0.12]], label="H_jacobian(3, 4)", entries=H)

The docstring's first paragraph, on one line, is what the learner reads. Declaration order is report order.
A check raises `Skip("why")` when something it depends on failed.
"""

from __future__ import annotations

import functools
import re
from dataclasses import dataclass, field
from typing import Callable, Generator

from grader.chapters import BY_ID, ChapterInfo
from grader.checks.draws import Draws


class Skip(Exception):
    """The check cannot be judged because something it depends on failed; the message says what.

    `costs_nothing`: the check exists only to localise a fault (your H against the finite difference of
    your own range_bearing) and what it depends on is wrong: its points are not lost, the failure is
    charged once, where it is (blame once)."""

    def __init__(self, message: str, costs_nothing: bool = False) -> None:
        super().__init__(message)
        self.costs_nothing = costs_nothing


@dataclass(frozen=True)
class Context:
    """What a check may use to choose its inputs: the run's seed, drawn per check."""

    seed: int
    chapter: str
    check_id: str

    @functools.cached_property
    def rng(self) -> Draws:
        """This check's generator, the same for the same seed, chapter and check: one stream, which every draw
        continues (a fresh one at each use gave `[point(ctx.rng) for _ in range(8)]` eight equal points)."""
        return Draws(f"{self.seed}/{self.chapter}/{self.check_id}")


CheckBody = Callable[[Context], Generator]


@dataclass(frozen=True)
class Check:
    id: str
    function: str
    description: str
    points: float
    body: CheckBody
    exact_derivative: bool = False  # asks for a derivative exact to rounding (a course may switch these off)


@dataclass
class ChapterChecks:
    """One chapter's checks, in report order."""

    info: ChapterInfo
    checks: list[Check] = field(default_factory=list)

    builds_on: dict[str, tuple[str, ...]] = field(default_factory=dict)  # function -> learner functions it uses

    def uses(self, function: str, *helpers: str) -> None:
        """Declare that a learner's `function` is usually written with their own `helpers` (maybe of an
        earlier chapter): the child watches the function's calls for them, and where a failing check's calls
        entered a helper that fails too, the check points at the helper first."""
        self.builds_on[function] = tuple(helpers)

    def check(self, function: str, points: float = 1, description: str | None = None,
              id: str | None = None, exact_derivative: bool = False) -> Callable[[CheckBody], CheckBody]:
        """Register a check of learner function `function` worth `points`."""
        def register(body: CheckBody) -> CheckBody:
            text = description or first_paragraph(body.__doc__) or body.__name__
            check_id = id or body.__name__
            if any(c.id == check_id for c in self.checks):
                raise ValueError(f"duplicate check id {check_id} in {self.info.id}")
            self.checks.append(Check(check_id, function, text, float(points), body, exact_derivative))
            return body
        return register

    @property
    def exact_derivative_ids(self) -> frozenset[str]:
        """The "chNN/check_id" of this chapter's exact-derivative checks."""
        return frozenset(f"{self.info.id}/{c.id}" for c in self.checks if c.exact_derivative)

    @property
    def max_score(self) -> float:
        return sum(c.points for c in self.checks)


def first_paragraph(doc: str | None) -> str:
    """A docstring's first paragraph on one line: a description wrapped over two lines stays whole."""
    return " ".join(re.split(r"\n\s*\n", (doc or "").strip())[0].split())


def chapter_checks(chapter_id: str) -> ChapterChecks:
    """An empty check list for one chapter, to be filled by grader/checks/chNN.py."""
    return ChapterChecks(BY_ID[chapter_id])
