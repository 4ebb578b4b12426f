"""Item statistics of a class: which quiz questions and code checks work, from the judged results of a batch.

Every quiz question and every code check is an item, and a learner's points on it its score. Per item:
its facility (the mean share of its points, Moodle's facility index), its discrimination (the correlation of
its score with the rest of the learner's score, the points of every other item: point-biserial for an item
that is all or nothing) and the upper-lower index (its facility among the 27% with the highest rest score
minus that among the 27% with the lowest). Per option of a choice or multi question: the share of the
learners who chose it and its own discrimination (choosing it against the rest score). Per chapter:
Cronbach's alpha of its items. Per parametrised quiz question (grader.quiz.bank: each learner has their
own numbers) and per parameter: the facility in bins of the parameter's values, and whether it differs
between the bins beyond chance (a chi-square test of homogeneity, Fisher's exact test on two bins where a
bin would expect fewer than 5 learners in a cell; Holm's correction over every parameter tested in the
class). The two tests are written out here (closed forms, exact for the tables they meet: a k x 2 table has
k - 1 <= 3 degrees of freedom) instead of imported from scipy.stats, whose import alone takes seconds per batch;
tests/course/test_statistics.py checks them against scipy.stats on random tables.

A quiz question left blank is no wrong answer: its learners are counted apart (`unanswered`) and left out of
its numbers. Computed for a class of MIN_LEARNERS or more; below RELIABLE_LEARNERS the numbers are rough and
nothing is flagged. An item is flagged only with evidence: where its CONFIDENCE interval (Wilson's for a facility,
Fisher's z for a correlation) lies wholly beyond a rule's bound, or a parameter's test is significant after Holm's
correction; never an item answered by fewer than MIN_LEARNERS, nor a code check for being easy. The rules are the
constants below, stated in the instructor's guide. Reads only judged results (grader.model.Report) and the
question banks (whose numbers each learner had); never a key.
"""

from __future__ import annotations

import math
from array import array
from dataclasses import dataclass, field

import numpy as np

from grader.model import Report, Status

MIN_LEARNERS = 5  # below this, no statistics at all
RELIABLE_LEARNERS = 30  # below this, rough: shown, never flagged
FACILITY_HIGH, FACILITY_LOW = 0.95, 0.2  # flagged: a quiz question surely easier than FACILITY_HIGH, an item harder than LOW
DISCRIMINATION_LOW = 0.1  # flagged: an item that surely tells strong learners from weak ones less than this
DISTRACTOR_LEARNERS = 5  # flagged: a wrong option surely chosen more by strong learners, chosen by at least this many
CONFIDENCE = 0.95  # a flag's evidence: the item's CONFIDENCE interval lies wholly beyond the rule's bound
PARAMETER_ALPHA = 0.05  # ... or, for facility by parameter, p below this after Holm's correction over the class's tests
UPPER_LOWER_SHARE = 0.27  # the upper and lower groups of the upper-lower index
MIN_EXPECTED = 5  # a chi-square test where every cell expects at least this many learners, else Fisher's on 2 bins
_Z = 1.959963984540054  # the normal quantile of a two-sided CONFIDENCE interval

RULES = {"facility_high": FACILITY_HIGH, "facility_low": FACILITY_LOW, "discrimination_low": DISCRIMINATION_LOW,
         "distractor_learners": DISTRACTOR_LEARNERS, "confidence": CONFIDENCE, "parameter_alpha": PARAMETER_ALPHA,
         "min_learners": MIN_LEARNERS, "reliable_learners": RELIABLE_LEARNERS}


@dataclass
class _Item:
    key: str  # "ch06/quiz_bearing_variance"
    chapter: str
    question: str  # the check's function: a quiz question's id
    kind: str  # "code" or "quiz"
    description: str
    max_points: float


@dataclass
class ItemScores:
    """Every graded learner's points per item, added report by report (add) and computed at the end (compute):
    a row of numbers per learner, never a report. `questions` are the quiz questions by (chapter, question id)
    (grader.quiz.bank.Question: their parameters), `catalogue` the class summary's grader.quiz.ClassQuestion
    (each option's text and which are right)."""

    questions: dict = field(default_factory=dict)
    catalogue: dict = field(default_factory=dict)
    items: dict[str, _Item] = field(default_factory=dict)
    positions: dict[str, int] = field(default_factory=dict)  # item -> its column
    learners: list[str] = field(default_factory=list)  # whose numbers each learner's quiz had
    rows: list[array] = field(default_factory=list)  # points per item (by its position in items), NaN: not judged
    unanswered: dict[str, int] = field(default_factory=dict)  # item -> learners who left it blank (NaN in rows)
    chosen: dict[str, dict[int, tuple[str, ...]]] = field(default_factory=dict)  # item -> row -> options chosen

    def __len__(self) -> int:
        return len(self.rows)

    def add(self, learner: str, report: Report) -> None:
        """Count one graded learner's report (its checks' points as graded, before any override)."""
        row = len(self.rows)
        points: dict[int, float] = {}
        for chapter in report.chapters:
            for check in chapter.checks:
                if not check.status.counted or check.max_points <= 0:  # recorded, or a practice question
                    continue
                key = f"{chapter.chapter}/{check.id}"
                if key not in self.items:
                    asked = self.catalogue.get((chapter.chapter, check.function)) if check.kind == "quiz" else None
                    self.items[key] = _Item(key, chapter.chapter, check.function, check.kind,
                                            asked.template if asked else check.description, check.max_points)
                    self.positions[key] = len(self.positions)
                if check.unanswered:  # left blank: not a wrong answer; out of the item's numbers, counted apart
                    self.unanswered[key] = self.unanswered.get(key, 0) + 1
                    continue
                points[self.positions[key]] = float(check.points)
                if check.kind == "quiz" and check.status in (Status.PASS, Status.FAIL) and "options" in check.answer:
                    self.chosen.setdefault(key, {})[row] = tuple(str(o) for o in check.answer["options"])
        values = array("d", [math.nan] * len(self.items))
        for index, value in points.items():
            values[index] = value
        self.rows.append(values)
        self.learners.append(report.learner_id or learner)

    def matrix(self) -> np.ndarray:
        """Learners x items: the points, NaN where a learner's item was not judged."""
        width = len(self.items)
        out = np.full((len(self.rows), width), np.nan)
        for i, row in enumerate(self.rows):
            out[i, :len(row)] = row
        return out


def collector(chapters: list[str], catalogue: dict | None = None) -> ItemScores:
    """An empty ItemScores for a batch of `chapters`: their quiz questions (whose parameters each learner drew)
    and the class summary's question catalogue (grader.quiz.class_questions, given where the batch has it)."""
    from grader.quiz import bank, class_questions

    questions = {}
    for chapter in chapters:
        try:
            questions.update({(chapter, q.id): q for q in bank.questions(chapter)})
        except (OSError, ValueError):  # a chapter without a bank, or one that cannot be read: no parameters
            continue
    return ItemScores(questions, class_questions(list(chapters)) if catalogue is None else catalogue)


def compute(scores: ItemScores) -> dict | None:
    """The statistics of the class as plain data (summary.json's `statistics`), or None for fewer than
    MIN_LEARNERS learners."""
    n = len(scores)
    if n < MIN_LEARNERS or not scores.items:
        return None
    rough = n < RELIABLE_LEARNERS
    points = scores.matrix()
    judged = ~np.isnan(points)
    total = np.where(judged, points, 0.0).sum(axis=1)
    items = [_item_statistics(item, points[:, j], judged[:, j], total, scores)
             for j, item in enumerate(scores.items.values())]
    method = _parameter_tests(items, scores, points, judged)
    tests = [test for entry in items for test in _tests(entry)]
    by_parameter = [test for test in tests if test.target is not None]
    holm([test.p for test in by_parameter], by_parameter)
    for test in tests:
        if test.target is not None:  # a parameter's own record of its test
            test.target["p_holm"] = _rounded(test.p_holm, 6)
            test.target["differs"] = not rough and test.flagged
        if not rough and test.flagged:
            test.entry["flags"].append(test.said())
            test.entry["evidence"].append(test.evidence())
    chapters = []
    for chapter in dict.fromkeys(item.chapter for item in scores.items.values()):
        columns = [j for j, item in enumerate(scores.items.values()) if item.chapter == chapter]
        alpha, complete = cronbach_alpha(points[:, columns])
        chapters.append({"chapter": chapter, "items": len(columns), "learners": complete,
                         "alpha": _rounded(alpha)})
    return {"learners": n, "rough": rough, "rules": dict(RULES), "parameter_test": method,
            "chapters": chapters, "items": items, "flagged": [entry["id"] for entry in items if entry["flags"]]}


def _item_statistics(item: _Item, column: np.ndarray, judged: np.ndarray, total: np.ndarray,
                     scores: ItemScores) -> dict:
    x = column[judged]
    rest = total[judged] - x
    facility = float(np.mean(x) / item.max_points) if x.size else None
    entry = {"id": item.key, "chapter": item.chapter, "kind": item.kind, "description": item.description,
             "max_points": item.max_points, "learners": int(x.size),
             "unanswered": scores.unanswered.get(item.key, 0), "facility": _rounded(facility),
             "discrimination": _rounded(correlation(x, rest)),
             "upper_lower": _rounded(upper_lower(x / item.max_points, rest)), "options": [], "parameters": [],
             "flags": [], "evidence": []}
    chosen = scores.chosen.get(item.key)
    if chosen:
        rows = np.flatnonzero(judged)
        position = {int(r): i for i, r in enumerate(rows)}
        answered = [position[r] for r in chosen if r in position]
        asked = scores.catalogue.get((item.chapter, item.question))
        names = list(asked.options) if asked else sorted({o for options in chosen.values() for o in options})
        for option in names:
            picked = np.array([option in chosen[int(rows[i])] for i in answered], dtype=float)
            entry["options"].append({
                "option": option, "text": asked.options.get(option, "") if asked else "",
                "right": bool(asked and option in asked.right), "chosen": int(picked.sum()),
                "share": _rounded(float(picked.mean()) if picked.size else None),
                "discrimination": _rounded(correlation(picked, rest[answered]))})
    return entry


def correlation(x: np.ndarray, y: np.ndarray) -> float | None:
    """Pearson's correlation of x and y (point-biserial where x is 0 or 1); None where either does not vary."""
    if x.size < 2:
        return None
    dx, dy = x - x.mean(), y - y.mean()
    scale = math.sqrt(float(dx @ dx) * float(dy @ dy))
    if scale <= 1e-12 * max(1.0, float(np.abs(x).max()) * float(np.abs(y).max())) * x.size:
        return None
    return max(-1.0, min(1.0, float(dx @ dy) / scale))


def upper_lower(share: np.ndarray, rest: np.ndarray) -> float | None:
    """The item's facility among the learners with the highest rest scores (UPPER_LOWER_SHARE of them) minus
    that among those with the lowest (ties in the order of the class)."""
    group = max(1, round(UPPER_LOWER_SHARE * share.size))
    if share.size < 2 * group:
        return None
    order = np.argsort(rest, kind="stable")
    return float(share[order[-group:]].mean() - share[order[:group]].mean())


def cronbach_alpha(points: np.ndarray) -> tuple[float | None, int]:
    """(Cronbach's alpha of the items in the columns of `points`, over the learners judged on every one of
    them; how many those are). None for fewer than two items or learners, or totals that do not vary."""
    complete = points[~np.isnan(points).any(axis=1)]
    k = complete.shape[1]
    if k < 2 or complete.shape[0] < 2:
        return None, int(complete.shape[0])
    spread = float(complete.sum(axis=1).var(ddof=1))
    if spread <= 0:
        return None, int(complete.shape[0])
    return k / (k - 1) * (1 - float(complete.var(axis=0, ddof=1).sum()) / spread), int(complete.shape[0])


# ------------------------------------------------------------------------------------ facility by parameter

def _bins(values: np.ndarray, learners: int) -> np.ndarray:
    """Each value's bin: 2 to 4 bins of about equal numbers of learners (by quantiles of the values)."""
    count = 4 if learners >= 120 else 3 if learners >= 60 else 2
    edges = np.unique(np.quantile(values, np.linspace(0, 1, count + 1)[1:-1]))
    return np.searchsorted(edges, values, side="right")


def _parameter_tests(items: list[dict], scores: ItemScores, points: np.ndarray, judged: np.ndarray) -> str:
    """Fill in each parametrised question's `parameters`: its facility per bin of each parameter's values, and the
    test of whether full marks are as frequent in every bin; returns how it was tested."""
    for j, (item, entry) in enumerate(zip(scores.items.values(), items)):
        question = scores.questions.get((item.chapter, item.question)) if item.kind == "quiz" else None
        if question is None or not question.params:
            continue
        rows = np.flatnonzero(judged[:, j])
        if rows.size < 2:
            continue
        share = points[rows, j] / item.max_points
        right = share >= 1 - 1e-9
        drawn = [question.values_for(scores.learners[r], item.chapter) for r in rows]
        for name in question.params:
            values = np.array([d.get(name, math.nan) for d in drawn])
            bins = _bins(values, rows.size)
            result = {"name": name, "bins": [
                {"low": float(values[bins == b].min()), "high": float(values[bins == b].max()),
                 "learners": int((bins == b).sum()), "facility": _rounded(float(share[bins == b].mean()))}
                for b in np.unique(bins)], "test": None, "p": None, "p_holm": None, "differs": False}
            if len(result["bins"]) > 1:
                result["test"], result["p"] = _test(bins, right, values)
            entry["parameters"].append(result)
    return ("a chi-square test of homogeneity of full marks across the bins, or Fisher's exact test on two bins "
            f"(below and above the median) where a cell would expect fewer than {MIN_EXPECTED} learners")


def _test(bins: np.ndarray, right: np.ndarray, values: np.ndarray) -> tuple[str, float]:
    """(the test used, its p-value) of whether full marks are as frequent in every bin."""
    table = [[int(np.sum(right & (bins == b))), int(np.sum(~right & (bins == b)))] for b in np.unique(bins)]
    if sum(row[0] for row in table) == 0 or sum(row[1] for row in table) == 0:
        return "none needed (every learner alike)", 1.0
    statistic, smallest = chi_square(table)
    if smallest >= MIN_EXPECTED:
        return "chi-square", chi_square_tail(statistic, len(table) - 1)
    halves = values > np.median(values)
    if halves.all() or not halves.any():
        halves = values >= np.median(values)
    return "Fisher's exact (2 bins)", fisher_exact([[int(np.sum(right & ~halves)), int(np.sum(~right & ~halves))],
                                                    [int(np.sum(right & halves)), int(np.sum(~right & halves))]])


def chi_square(table: list[list[int]]) -> tuple[float, float]:
    """(Pearson's chi-square statistic of a contingency table of counts, without continuity correction; the
    smallest count a cell would expect)."""
    rows = [sum(row) for row in table]
    columns = [sum(column) for column in zip(*table)]
    total = sum(rows)
    statistic, smallest = 0.0, math.inf
    for i, row in enumerate(table):
        for j, observed in enumerate(row):
            expected = rows[i] * columns[j] / total
            smallest = min(smallest, expected)
            statistic += (observed - expected) ** 2 / expected if expected > 0 else 0.0
    return statistic, smallest


def chi_square_tail(statistic: float, freedom: int) -> float:
    """P(X >= statistic) for X chi-square distributed with a whole number of degrees of freedom, in closed form
    (Abramowitz and Stegun 26.4.4 and 26.4.5)."""
    if statistic <= 0:
        return 1.0
    half = statistic / 2
    if freedom % 2 == 0:
        term = total = math.exp(-half)
        for i in range(1, freedom // 2):
            term *= half / i
            total += term
        return min(1.0, total)
    root = math.sqrt(statistic)
    tail = math.erfc(root / math.sqrt(2))  # 2 Q(root)
    term = math.exp(-half) * math.sqrt(2 / math.pi) / root  # 2 phi(root) / root, times root^(2r - 1) / (2r - 1)!!
    for r in range(1, (freedom + 1) // 2):
        term *= statistic / (2 * r - 1)
        tail += term
    return min(1.0, tail)


def fisher_exact(table: list[list[int]]) -> float:
    """The two-sided p-value of Fisher's exact test of a 2 x 2 table: the probability, given its margins, of every
    table no more likely than this one (as scipy.stats.fisher_exact computes it)."""
    (a, b), (c, d) = table
    first_row, first_column, total = a + b, a + c, a + b + c + d
    ways = math.comb(total, first_column)

    def chance(k: int) -> float:
        return math.comb(first_row, k) * math.comb(total - first_row, first_column - k) / ways

    observed = chance(a)
    low, high = max(0, first_column - (total - first_row)), min(first_row, first_column)
    return min(1.0, sum(p for p in map(chance, range(low, high + 1)) if p <= observed * (1 + 1e-7)))


def holm(p_values: list[float], tests: list) -> None:
    """Holm's step-down correction of `p_values` over their family: each test's `p_holm`, monotone in p."""
    order = sorted(range(len(p_values)), key=lambda i: p_values[i])
    running = 0.0
    for rank, i in enumerate(order):
        running = max(running, min(1.0, (len(p_values) - rank) * p_values[i]))
        tests[i].p_holm = running


# ------------------------------------------------------------------------------------ flags and their evidence

@dataclass
class _Test:
    """One rule's test of one item: its estimate, CONFIDENCE interval and one-sided p-value; flagged where the
    interval lies wholly beyond the rule's bound (p below (1 - CONFIDENCE) / 2), a parameter's test where its p
    after Holm's correction over every parameter tested in the class is below PARAMETER_ALPHA."""

    entry: dict
    rule: str  # a key of RULES (or "parameter")
    estimate: float
    interval: tuple[float, float] | None
    p: float
    words: str  # what is flagged, with the estimate: "very hard: facility 0.02"
    advice: str = ""
    detail: dict = field(default_factory=dict)  # the option or parameter tested
    target: dict | None = None  # a parameter's record, which shows its p after Holm too
    p_holm: float | None = None

    @property
    def flagged(self) -> bool:
        if self.target is not None:
            return self.p_holm is not None and self.p_holm < PARAMETER_ALPHA
        return self.p < (1 - CONFIDENCE) / 2

    def said(self) -> str:
        if self.interval is None:
            evidence = f"{self.entry['learners']} learners; p = {self.p_holm:.2g} after Holm's correction"
        else:
            evidence = (f"{CONFIDENCE:.0%} confidence interval {self.interval[0]:.2f} to {self.interval[1]:.2f}, "
                        f"{self.entry['learners']} learners")
        return f"{self.words} ({evidence})" + (f": {self.advice}" if self.advice else "")

    def evidence(self) -> dict:
        return {"rule": self.rule, "estimate": _rounded(self.estimate), "interval":
                None if self.interval is None else [_rounded(self.interval[0]), _rounded(self.interval[1])],
                "learners": self.entry["learners"], "p": _rounded(self.p, 8),
                "p_holm": None if self.p_holm is None else _rounded(self.p_holm, 8), **self.detail}


def _normal_below(z: float) -> float:
    """P(Z <= z) for a standard normal Z."""
    return 0.5 * math.erfc(-z / math.sqrt(2))


def correlation_test(r: float, n: int, bound: float) -> tuple[float, tuple[float, float]]:
    """(the one-sided p-value that the correlation behind r, of n pairs, is at least `bound`; r's CONFIDENCE
    interval), by Fisher's z-transformation."""
    z = math.atanh(max(-0.999999, min(0.999999, r)))
    spread = 1 / math.sqrt(n - 3)
    return _normal_below((z - math.atanh(bound)) / spread), (math.tanh(z - _Z * spread), math.tanh(z + _Z * spread))


def share_test(share: float, n: int, bound: float) -> tuple[float, tuple[float, float]]:
    """(the one-sided p-value that the share behind `share`, of n learners, is at least `bound` (a score test,
    conservative for partial points); its Wilson CONFIDENCE interval)."""
    p_value = _normal_below((share - bound) / math.sqrt(bound * (1 - bound) / n))
    centre = (share + _Z * _Z / (2 * n)) / (1 + _Z * _Z / n)
    half = _Z / (1 + _Z * _Z / n) * math.sqrt(max(0.0, share * (1 - share)) / n + _Z * _Z / (4 * n * n))
    return p_value, (max(0.0, centre - half), min(1.0, centre + half))


def _tests(entry: dict) -> list[_Test]:
    """Every rule's test of one item (the instructor's guide states the rules): none for an item answered by fewer
    than MIN_LEARNERS (a blank answer is no evidence), none for a code check being easy (passing is its goal)."""
    n = entry["learners"]
    if n < MIN_LEARNERS:
        return []
    tests = []
    facility, discrimination = entry["facility"], entry["discrimination"]
    code = entry["kind"] == "code"
    if discrimination is not None and n > 3:
        p, interval = correlation_test(discrimination, n, DISCRIMINATION_LOW)
        tests.append(_Test(entry, "discrimination_low", discrimination, interval, p,
                           f"does not tell strong learners from weak ones: discrimination {discrimination:+.2f}, "
                           f"below {DISCRIMINATION_LOW:g}",
                           "does the check fail right answers?" if code else "is the key right?"))
    for option in entry["options"]:
        answered = round(option["chosen"] / option["share"]) if option["share"] else 0
        if option["right"] or option["chosen"] < DISTRACTOR_LEARNERS or option["discrimination"] is None \
                or answered <= 3:
            continue
        p, interval = correlation_test(-option["discrimination"], answered, 0.0)  # p that it is at most 0
        tests.append(_Test(entry, "distractor", option["discrimination"], (-interval[1], -interval[0]), p,
                           f"the wrong option {option['option']}) is chosen more by strong learners: its "
                           f"discrimination {option['discrimination']:+.2f}, chosen by {option['chosen']}",
                           "is the key right, the option ambiguous?", {"option": option["option"]}))
    if facility is not None:
        p, interval = share_test(facility, n, FACILITY_LOW)
        tests.append(_Test(entry, "facility_low", facility, interval, p,
                           f"very hard: facility {facility:.2f}, below {FACILITY_LOW:g}",
                           "does the check fail right answers, or is the task unclear?" if code else ""))
        if not code:
            p, interval = share_test(1 - facility, n, 1 - FACILITY_HIGH)
            tests.append(_Test(entry, "facility_high", facility, (1 - interval[1], 1 - interval[0]), p,
                               f"very easy: facility {facility:.2f}, above {FACILITY_HIGH:g}"))
    for parameter in entry["parameters"]:
        if parameter["p"] is None:
            continue
        by_bin = ", ".join(f"{_values(b['low'], b['high'])}: {b['facility']:.2f}" for b in parameter["bins"])
        spread = [b["facility"] for b in parameter["bins"] if b["facility"] is not None]
        tests.append(_Test(entry, "parameter", max(spread) - min(spread), None, parameter["p"],
                           f"harder for some learners' numbers: facility by {parameter['name']} {by_bin}, by "
                           f"{parameter['test'].replace('chi-square', 'a chi-square test')}", "is the key right for every number drawn?",
                           {"parameter": parameter["name"]}, target=parameter))
    return tests


def _values(low: float, high: float) -> str:
    """A bin's values as a person reads them: "0.5 to 1.6", or "0.5" where it holds one value."""
    return f"{low:g}" if low == high else f"{low:g} to {high:g}"


def _rounded(value: float | None, digits: int = 4) -> float | None:
    return None if value is None or not math.isfinite(value) else round(float(value), digits)
