"""`grade selftest --seeds N`: the course checked at N seeds before learners meet it, not only at the public one.

Code: the reference solutions are graded at each seed (through the boundary, as a learner's code is) and must get
every check's points; while each check judges them, every comparison it makes is watched (grader.judging.compare.observing):
each mistake it could name there (the check's own, the generic slips of the value, the slips generated from the
reference) is told apart from the right value at the check's inputs when some comparison's value differs from the
right one beyond the comparison's tolerance. A mistake a check tells apart at some seeds and not at another fails
there: at that seed a learner making it passes the check (its inputs hit a point where the slip makes no
difference). One told apart at no seed is no mistake at those inputs (a slip of an entry that is always 0, a
generated slip that computes the same function); a check's own that is never told apart is listed as a note.

Quiz: for every parametrised question each seed is a learner draw (the learner id `selftest-<seed>`, whose numbers
grade quiz --show prints): the key must be finite, well-conditioned (its relative condition number in the numbers,
entry by entry where an entry is larger than ten times its tolerance's atol, at most KAPPA_MAX) and told apart from
every known wrong answer and generic slip by the key's own tolerance, as above (at some draws and not at another
fails there); a range that leaves no number, or an `avoid` that leaves none, fails at once. The reference answers
(solutions/answers, learner `reference`) must get every question's points (checked with the grader's own banks).

Each failure is reported once per item, at its first failing seed, with a command that reproduces it.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from grader.course_config import Course

KAPPA_MAX = 100.0  # a key more sensitive than this to its numbers loses more than two of the learner's digits
LEARNER_PREFIX = "selftest-"  # the learner id of a seed's quiz draw
DEFAULT_SEEDS = 25
# the references are trusted and quick (about 0.3 s a seed): limits a busy machine never reaches, so that a timeout
# says the references hang, never that other work held the cores
REFERENCE_SECONDS = 600.0


@dataclass
class Failure:
    """What fails for one item (a check or a quiz question) at its first failing seed, and how to see it again."""

    item: str  # "ch06/H_worked_example", "ch06/quiz_bearing_variance"
    seed: int
    problems: list[str]
    reproduce: str
    other_seeds: int = 0  # how many of the other seeds it fails at too


@dataclass
class Outcome:
    seeds: list[int]
    failures: list[Failure] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    counted: dict[str, int] = field(default_factory=dict)  # checks judged, comparisons weighed, quiz draws, ...

    @property
    def passed(self) -> bool:
        return not self.failures


def seeds_for(count: int, course: Course | None = None) -> list[int]:
    """`count` seeds: the public one, the course's, then 1, 2, 3 ... (the same list every time)."""
    from grader.course_config import PUBLIC_SEED

    chosen = list(dict.fromkeys([PUBLIC_SEED] + ([course.seed] if course is not None and course.seed else [])))
    candidate = 1
    while len(chosen) < count:
        if candidate not in chosen:
            chosen.append(candidate)
        candidate += 1
    return chosen[:count]


class Watch:
    """Per item and mistake: the seeds it was told apart at and those it was not; and per item and seed what else
    failed there. `failures` at the end: per item, its first failing seed."""

    def __init__(self) -> None:
        self.told: dict[tuple[str, str], list[set[int]]] = {}  # (item, mistake id) -> [told apart at, not at]
        self.names: dict[tuple[str, str], tuple[str, str]] = {}  # -> (its name in words, its origin)
        self.problems: dict[str, dict[int, list[str]]] = {}  # item -> seed -> problems
        self.reproduce: dict[tuple[str, int], str] = {}
        self.where: dict[tuple[str, int], str] = {}  # (item, seed) -> what its inputs were (a quiz draw's numbers)
        self.function: dict[str, str] = {}  # item -> the learner function it checks (a quiz question: itself)
        self.caught: dict[tuple[str, str], set[int]] = {}  # (function, mistake id) -> seeds some check told it apart

    def mistake(self, item: str, identity: str, name: str, origin: str, seed: int, apart: bool,
                function: str = "") -> None:
        """One comparison of `item` (a check of learner function `function`) at `seed` told mistake `identity`
        apart from the right value, or did not."""
        sets = self.told.setdefault((item, identity), [set(), set()])
        self.names.setdefault((item, identity), (name, origin))
        sets[0 if apart else 1].add(seed)
        self.function[item] = function or item
        if apart:
            self.caught.setdefault((function or item, identity), set()).add(seed)

    def problem(self, item: str, seed: int, text: str, reproduce: str = "") -> None:
        self.problems.setdefault(item, {}).setdefault(seed, []).append(text)
        if reproduce:
            self.reproduce.setdefault((item, seed), reproduce)

    def failures(self, order: list[int], command: Callable[[str, int], str],
                 report: set[int] | None = None) -> tuple[list[Failure], list[str]]:
        """Per item, its first failing seed in `order` (only seeds in `report`, where given), and the notes."""
        position = {seed: i for i, seed in enumerate(order)}
        notes, weak = [], {}
        problems = {item: {seed: list(found) for seed, found in by_seed.items()}
                    for item, by_seed in self.problems.items()}
        for (item, identity), (apart, hidden) in sorted(self.told.items()):
            name, origin = self.names[(item, identity)]
            hidden = hidden - apart  # told apart at another input of the same seed
            function = self.function.get(item, item)
            if apart and hidden and origin == "generated":  # grader.judging.mutants' slips: said, never a failure
                weak.setdefault("generated", []).append(f"{item} '{name}'")
            elif apart and hidden:
                for seed in sorted(hidden, key=lambda s: position.get(s, len(order))):
                    others = seed in self.caught.get((function, identity), set())
                    if others:  # another check of the same function tells it apart at this seed
                        weak.setdefault(item, []).append(f"'{name}' at seed {seed}")
                        continue
                    where = f" ({self.where[(item, seed)]})" if (item, seed) in self.where else ""
                    by = "" if function == item else f", nor does any other check of {function}"
                    problems.setdefault(item, {}).setdefault(seed, []).append(
                        f"the mistake '{name}' is not told apart from the right value at this seed's inputs{where}{by}, "
                        f"as it is at {len(apart)} other seeds: a learner making it gets the points")
            elif hidden and origin == "known" and report is None:
                notes.append(f"{item}: its own mistake '{name}' is told apart at none of the {len(hidden)} seeds "
                             "(remove it from the check, or give the check inputs where it shows)")
        if report is None:
            for item, said in weak.items():
                if item == "generated":
                    notes.append(f"{len(said)} slips generated from the references (grader.judging.mutants) are told apart at "
                                 f"some seeds and not at others, e.g. {', '.join(said[:3])}")
                else:
                    notes.append(f"{item} does not tell apart {', '.join(said[:3])}" + (" ..." if len(said) > 3 else "")
                                 + f"; another check of {self.function.get(item, item)} does")
        found = []
        for item, by_seed in sorted(problems.items()):
            by_seed = {s: p for s, p in by_seed.items() if report is None or s in report}
            if not by_seed:
                continue
            first = min(by_seed, key=lambda s: position.get(s, len(order)))
            found.append(Failure(item, first, by_seed[first], self.reproduce.get((item, first)) or command(item, first),
                                 len(by_seed) - 1))
        return found, notes


# ------------------------------------------------------------------------------------------------ the quiz

def _identity(mistake) -> str:
    return getattr(mistake, "key", "") or f"{mistake.name}\n{mistake.help}"


def check_quiz(chapters: list[str], seeds: list[int], watch: Watch, quiz_dir: Path | None = None) -> int:
    """Every parametrised question of `chapters` at every seed's learner draw (see the module's docstring);
    returns the number of draws judged."""
    from grader.quiz import bank

    drawn = 0
    for chapter in chapters:
        try:
            questions, keys = bank.questions(chapter, quiz_dir), bank.keys(chapter, quiz_dir) or {}
        except FileNotFoundError:
            continue
        for question in questions:
            key = keys.get(question.id)
            if not question.params or key is None:
                continue
            item = f"{chapter}/quiz_{question.id}"
            for seed in seeds:
                try:
                    values = question.values_for(f"{LEARNER_PREFIX}{seed}", chapter)
                except bank.BankError as exc:
                    watch.problem(item, seed, str(exc))
                    break
                drawn += 1
                shown = ", ".join(f"{name} = {value:g}" for name, value in values.items())
                watch.where[(item, seed)] = f"learner {LEARNER_PREFIX}{seed}: {shown}"
                for problem in _draw_problems(chapter, question, key, values, seed, watch, item):
                    watch.problem(item, seed, f"{problem} ({watch.where[(item, seed)]})")
    return drawn


def _value_of(mistake, shape: tuple) -> np.ndarray | None:
    """A mistake's value as a float array of `shape`; None where it has none, is not numbers or has another shape."""
    if mistake.value is None:
        return None
    try:
        value = np.asarray(mistake.value, dtype=float)
    except (TypeError, ValueError):
        return None
    return value if value.shape == shape else None


def _draw_problems(chapter: str, question, key, values: dict[str, float], seed: int, watch: Watch,
                   item: str) -> list[str]:
    """What is wrong with one learner's draw of one question; every mistake weighed into `watch`."""
    if question.kind == "symbolic":
        return _symbolic_problems(question, key, values, seed, watch, item)
    from grader.judging.diagnose import generic
    from grader.quiz import bank
    from grader.quiz.judge import right_numbers
    from grader.quiz.mistakes import entries, known_mistakes

    try:
        want = right_numbers(key.value_for(chapter, values), key, values)
    except bank.KeyUnavailable as exc:
        return [f"the key cannot be computed here: {exc}"]
    except (ValueError, ArithmeticError) as exc:
        return [f"the key cannot be computed for these numbers ({type(exc).__name__}: {exc})"]
    if not np.all(np.isfinite(want)):
        return [f"the key is not finite for these numbers: {want.tolist()}"]
    problems = []
    kappa, name = condition(chapter, key, values, want)
    if kappa > KAPPA_MAX:
        problems.append(f"the key is ill-conditioned in {name}: its relative condition number is {kappa:.3g} "
                        f"(at most {KAPPA_MAX:g}): a learner's rounding of intermediate values moves it by "
                        f"{kappa:.3g} times as much")
    limit = key.atol + key.rtol * np.abs(want)
    for origin, candidates in (("known", known_mistakes(key, want, values)),
                               ("generic", generic(want, entries(question)))):
        for mistake in candidates:
            value = _value_of(mistake, want.shape)
            if value is None or not np.all(np.isfinite(value)):
                continue
            watch.mistake(item, _identity(mistake), mistake.name, origin, seed,
                          apart=bool(np.any(np.abs(value - want) > limit)))
    return problems


def condition(chapter: str, key, values: dict[str, float], want: np.ndarray) -> tuple[float, str]:
    """(the key's largest relative condition number in one of the numbers, entry by entry over the entries larger
    than ten times the key's atol; that number's name), by central differences."""
    from grader.quiz.judge import right_numbers

    worst, name = 0.0, ""
    large = np.abs(want) > 10 * key.atol
    if not large.any():
        return worst, name
    for parameter, value in values.items():
        step = 1e-6 * max(abs(value), 1.0)
        up, down = dict(values), dict(values)
        up[parameter], down[parameter] = value + step, value - step
        try:
            slope = (right_numbers(key.value_for(chapter, up), key, up)
                     - right_numbers(key.value_for(chapter, down), key, down)) / (2 * step)
        except (ValueError, ArithmeticError):
            return math.inf, parameter
        kappa = float(np.max(np.abs(slope * value)[large] / np.abs(want)[large]))
        if not math.isfinite(kappa) or kappa > worst:
            worst, name = (math.inf if not math.isfinite(kappa) else kappa), parameter
    return worst, name


def _symbolic_problems(question, key, values: dict[str, float], seed: int, watch: Watch, item: str) -> list[str]:
    """A per-learner derivation: its key must have values in the question's domain, and each known wrong
    expression must not be the same function as the key with this learner's numbers."""
    from grader.quiz import bank
    from grader.quiz.symbolic import AnswerError, equivalent

    same = {"symbols": question.symbols, "domain": question.domain, "seed": bank.variant_seed("selftest", "", item),
            "derived": question.derived}
    right = str(key.answer)
    try:
        if equivalent(right, right, decide=False, bound=values, **same) is not True:
            return ["the key has no value at enough points of the question's domain for these numbers"]
    except AnswerError as exc:
        return [f"the key does not read: {exc}"]
    for wrong in key.wrong:
        try:
            alike = equivalent(str(wrong["answer"]), right, decide=False, bound=values, **same)
        except AnswerError:
            continue
        if alike is None:
            continue
        watch.mistake(item, f"{wrong['name']}\n{wrong['feedback']}", wrong["name"], "known", seed, apart=not alike)
    return []


def check_reference_answers(chapters: list[str], watch: Watch, seed: int) -> int:
    """The reference answers (solutions/answers, for learner `reference`) get every question's points; returns
    the number of questions judged."""
    from grader.judging.expected import ReferenceUnavailable, reference_function
    from grader.model import Status
    from grader.quiz import grade_quiz

    try:
        reference_function("ch00", "range_reading")
    except ReferenceUnavailable:
        return 0
    import solutions

    folder = Path(next(iter(solutions.__path__))) / "answers"
    judged = 0
    for chapter in chapters:
        try:
            results, problems = grade_quiz(chapter, folder, "reference", "solutions/answers")
        except FileNotFoundError:
            continue
        for problem in problems:
            watch.problem(f"{chapter}/quiz", seed, f"the reference answers: {problem}")
        for result in results:
            judged += 1
            if result.status is not Status.PASS or result.points < result.max_points:
                watch.problem(f"{chapter}/{result.id}", seed, f"the reference answer gets {result.status.value} "
                                                             f"({result.points:g}/{result.max_points:g}): "
                                                             f"{result.message.splitlines()[0] if result.message else ''}")
    return judged


# ------------------------------------------------------------------------------------------------ the code

def check_code(chapters: list[str], seeds: list[int], watch: Watch, course: Course | None = None,
               sandbox: str = "auto", generated: bool = False,
               progress: Callable[[int, int], None] | None = None) -> dict[str, int]:
    """The reference solutions graded at every seed, every check's comparisons watched (see the module's
    docstring; `generated`: also the slips grader.judging.mutants generates, about four times the time); returns what was
    counted."""
    from grader import boundary
    from grader import checks as check_registry
    from grader.boundary import Limits
    from grader.core import planning
    from grader.core.pipeline import switched_off
    from grader.model import Status
    from grader.submission import locate

    submission = locate(None, True)
    door = boundary.choose(sandbox, resident=True)
    limits = Limits(call_seconds=REFERENCE_SECONDS / 10, chapter_seconds=REFERENCE_SECONDS,
                    learner_seconds=REFERENCE_SECONDS, cpu_seconds=int(REFERENCE_SECONDS))
    off = switched_off(course, tuple(chapters)) if course is not None else frozenset()
    counted = {"checks judged": 0, "comparisons weighed": 0}
    try:
        for done, seed in enumerate(seeds, 1):
            plans = [planning.ChapterPlan(check_registry.load(c), seed, exclude=off) for c in chapters]
            session = door.open_session(submission, limits)
            try:
                runs = session.run([plan.request() for plan in plans])
            finally:
                session.close()
            for plan in plans:
                chapter = plan.chapter.info.id
                seen: dict[str, list] = {}
                for check, pending in plan.pending:
                    if pending.generator is not None:
                        pending.generator = _Watched(pending.generator, seen.setdefault(check.id, []), generated)
                judged = plan.judge(runs[chapter], f"solutions/{plan.chapter.info.module}.py")
                for problem in judged.problems:
                    watch.problem(chapter, seed, f"the reference: {problem.splitlines()[0]}",
                                  f"grade {chapter} --solutions --seed {seed}")
                for result in judged.checks:
                    item = f"{chapter}/{result.id}"
                    counted["checks judged"] += 1
                    counted["comparisons weighed"] += len(seen.get(result.id, ()))
                    if result.status is not Status.PASS or result.points < result.max_points:
                        first = result.message.strip().splitlines()[0] if result.message.strip() else ""
                        watch.problem(item, seed, f"the reference gets {result.status.value} "
                                                  f"({result.points:g}/{result.max_points:g}): {first}",
                                      f"grade {chapter} {result.function} --solutions --seed {seed}")
                    _weigh(item, f"{chapter}/{result.function}", seed, seen.get(result.id, ()), watch)
            if progress is not None:
                progress(done, len(seeds))
    finally:
        door.close()
    return counted


class _Watched:
    """A check's generator whose judging (the values sent into it) is watched: every comparison it makes then is
    kept in `seen` (grader.judging.compare.observing)."""

    def __init__(self, generator, seen: list, generated: bool = False) -> None:
        self.generator, self.seen, self.generated = generator, seen, generated

    def send(self, value: object) -> object:
        from grader.judging import compare

        with compare.observing(lambda comparison: self.seen.append(_weighed(comparison, self.generated))):
            return self.generator.send(value)

    def __getattr__(self, name: str) -> object:
        return getattr(self.generator, name)


def _weighed(comparison, generated: bool = False) -> list[tuple[str, str, str, bool]]:
    """Every mistake one comparison (grader.judging.compare.Comparison) could name, as (identity, name, origin, told apart):
    told apart where its value differs from the right one beyond the comparison's tolerance (as compare_arrays
    widens it) in some entry, or is not finite. Worked out while the check judges: the slips generated from the
    reference at the learner's call are known only then (grader.judging.diagnose.generated)."""
    from grader.judging import diagnose
    from grader.judging.compare import SINGLE_PRECISION

    expected = np.asarray(comparison.expected, dtype=float)
    rtol, atol = comparison.rtol, comparison.atol
    if not comparison.exact:
        scale = float(np.max(np.abs(expected[np.isfinite(expected)]), initial=0.0))
        rtol, atol = max(rtol, SINGLE_PRECISION), max(atol, SINGLE_PRECISION * scale)
    limit = atol + rtol * np.abs(expected)
    candidates = [("known", m) for m in comparison.mistakes]
    if comparison.entries is not None:
        candidates += [("generic", m) for m in diagnose.generic(expected, comparison.entries)]
    slips = getattr(diagnose, "generated", None) if generated else None  # grader.judging.mutants' slips, where asked for
    if slips is not None and comparison.source is not None:
        candidates += [("generated", m) for m in slips(comparison.source)]
    out = []
    for origin, mistake in candidates:
        value = _value_of(mistake, expected.shape)
        if value is None:
            continue
        apart = not np.all(np.isfinite(value)) or bool(np.any(~(np.abs(value - expected) <= limit)))
        out.append((_identity(mistake), mistake.name, getattr(mistake, "origin", origin) or origin, apart))
    return out


def _weigh(item: str, function: str, seed: int, seen: list, watch: Watch) -> None:
    """Every mistake of every comparison a check (of `function`) made at `seed` into `watch`."""
    for weighed in seen:
        for identity, name, origin, apart in weighed:
            watch.mistake(item, identity, name, origin, seed, apart, function)


# ------------------------------------------------------------------------------------------------ together

def run(chapters: list[str], seeds: list[int], course: Course | None = None, *, quiz_dir: Path | None = None,
        sandbox: str = "auto", code: bool = True, command: Callable[[str, int], str] | None = None,
        report: set[int] | None = None, generated: bool = False,
        progress: Callable[[int, int], None] | None = None) -> Outcome:
    """The selftest of `chapters` at `seeds`: the code (unless `code` is False) and the quiz. `command(item, seed)`
    is the command that reproduces an item's failure at a seed; `report`: only failures at these seeds (the
    others are checked to compare with)."""
    watch = Watch()
    outcome = Outcome(list(seeds))
    if code:
        outcome.counted.update(check_code(chapters, seeds, watch, course, sandbox, generated, progress))
    if quiz_dir is None:  # the reference answers are written for the grader's own banks
        outcome.counted["reference answers judged"] = check_reference_answers(chapters, watch, seeds[0])
    outcome.counted["quiz draws judged"] = check_quiz(chapters, seeds, watch, quiz_dir)
    outcome.failures, outcome.notes = watch.failures(seeds, command or (lambda item, seed: ""), report)
    return outcome
