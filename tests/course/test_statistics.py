"""Item statistics (grader.course.statistics) in summary.html and summary.json: on a generated class of learners of known
ability, the bad question and the question that is harder for some learners' numbers are flagged, and no other."""

from __future__ import annotations

import base64
import html
import json
import math
import random
import re
import types
from collections import Counter
from pathlib import Path

import numpy as np
import pytest

from grader import checks as check_registry
from grader.chapters import BY_ID
from grader.course import outputs, statistics
from grader.course.history import History
from grader.model import ChapterResult, CheckResult, Report, Status
from grader.quiz import bank
from grader.render import lms

CHAPTERS = ["ch05", "ch06", "ch07"]
BAD = "ch06/quiz_bearing_near_dish"  # a wrong key: its key answer is chosen more by the weak, the strong pick option a
BY_NUMBERS = "ch06/quiz_bearing_variance"  # seed-dependent: much harder for learners whose r (from their seed) is below 2
AMBIGUOUS = "ch07/quiz_off_diagonals"  # an ambiguous option: those who know split between the key and one wrong option
BROKEN = "ch05/central_difference_uses_the_step_as_given"  # a broken check: it fails right answers, 1 in 20 passes
KNOWN_BAD = sorted([BAD, BY_NUMBERS, AMBIGUOUS, BROKEN])


def _sigmoid(value: float) -> float:
    return 1 / (1 + math.exp(-value))


class SimulatedClass:
    """Learners of known ability (standard normal) answering every code check and quiz question of CHAPTERS as a
    two-parameter logistic model has it: each item its own discrimination (1 to 2) and difficulty (-1 to 0.5), so
    that every item is moderately easy and tells strong learners from weak ones; wrong answers to a choice question
    pick a wrong option, the first ones more often. Two items are made bad on purpose: BAD (strong learners choose
    the wrong option a) and BY_NUMBERS (harder where the learner's own r is below 2)."""

    def __init__(self, learners: int, seed: int = 7) -> None:
        self.random = random.Random(seed)
        self.abilities = {f"learner-{i:03d}": self.random.gauss(0, 1) for i in range(learners)}
        self.keys = {chapter: bank.keys(chapter) for chapter in CHAPTERS}
        self.items = {}
        for chapter in CHAPTERS:
            for check in check_registry.load(chapter).checks:
                self.items[f"{chapter}/{check.id}"] = self._parameters()
            for question in bank.questions(chapter):
                self.items[f"{chapter}/quiz_{question.id}"] = self._parameters()

    def _parameters(self) -> tuple[float, float]:
        return self.random.uniform(1.0, 2.0), self.random.uniform(-1.0, 0.5)

    def _right(self, key: str, ability: float, learner: str, question=None) -> bool:
        slope, difficulty = self.items[key]
        if key == BAD:
            return self.random.random() < _sigmoid(-1.5 * ability)
        if key == BROKEN:
            return self.random.random() < 0.05
        chance = _sigmoid(slope * (ability - difficulty))
        if key == BY_NUMBERS and question.values_for(learner, "ch06")["r"] < 2:
            chance = _sigmoid(slope * (ability - difficulty) - 3.5)
        knows = self.random.random() < chance
        if key == AMBIGUOUS:  # half of those who know read it the other way: they pick wrong[-1] (_options)
            self.read_otherwise = knows and self.random.random() < 0.5
            return knows and not self.read_otherwise
        return knows

    def reports(self) -> dict[str, Report]:
        return {learner: self.report(learner, ability) for learner, ability in self.abilities.items()}

    def report(self, learner: str, ability: float) -> Report:
        chapters = []
        for chapter in CHAPTERS:
            results = []
            for check in check_registry.load(chapter).checks:
                right = self._right(f"{chapter}/{check.id}", ability, learner)
                results.append(CheckResult(check.id, check.function, check.description,
                                           Status.PASS if right else Status.FAIL, check.points if right else 0.0,
                                           check.points, "" if right else "wrong"))
            for question in bank.questions(chapter):
                key = f"{chapter}/quiz_{question.id}"
                right = self._right(key, ability, learner, question)
                result = CheckResult(f"quiz_{question.id}", question.id, question.prompt[:80],
                                     Status.PASS if right else Status.FAIL, question.points if right else 0.0,
                                     question.points, kind="quiz")
                if question.kind in ("choice", "multi"):
                    result.answer = {"options": self._options(question, self.keys[chapter][question.id], right,
                                                              ability, key == BAD, key == AMBIGUOUS)}
                results.append(result)
            chapters.append(ChapterResult(chapter, BY_ID[chapter].title, results))
        return Report(learner, chapters, seed=1, learner=learner, learner_id=learner, grader="simulated")

    def _options(self, question, key, right: bool, ability: float, bad: bool, ambiguous: bool) -> list[str]:
        keyed = [key.answer] if question.kind == "choice" else list(key.answer)
        wrong = [o for o in question.options if o not in keyed]
        if right:
            return sorted(keyed)
        if bad and "a" in wrong and self.random.random() < _sigmoid(2 * ability):
            pick = "a"
        elif ambiguous and self.read_otherwise:  # knew it, and read it the other way
            pick = wrong[-1]
        else:
            pick = self.random.choices(wrong, weights=[len(wrong) - i for i in range(len(wrong))])[0]
        return [pick] if question.kind == "choice" else sorted(set(keyed[1:]) | {pick})


def _statistics(reports: dict[str, Report]) -> dict:
    scores = statistics.collector(CHAPTERS)
    for learner, report in reports.items():
        scores.add(learner, report)
    return statistics.compute(scores)


@pytest.fixture(scope="module")
def class_of_200() -> dict:
    return _statistics(SimulatedClass(200).reports())


def test_a_class_of_200_flags_the_four_known_bad_items_each_with_its_evidence_and_no_other(class_of_200):
    found = class_of_200
    assert found["learners"] == 200 and not found["rough"]
    assert sorted(found["flagged"]) == KNOWN_BAD, {i["id"]: i["flags"] for i in found["items"] if i["flags"]}
    items = {item["id"]: item for item in found["items"]}
    for item in items.values():  # each flag says its evidence, and summary.json keeps it as numbers
        assert len(item["flags"]) == len(item["evidence"])
        for flag, evidence in zip(item["flags"], item["evidence"]):
            assert "confidence interval" in flag or "Holm" in flag
            if evidence["interval"] is not None:
                low, high = evidence["interval"]
                assert low <= evidence["estimate"] <= high
    bad = items[BAD]
    assert bad["discrimination"] < 0 and bad["upper_lower"] < 0
    said = next(flag for flag in bad["flags"] if "does not tell strong learners from weak" in flag)
    low, high = next(e["interval"] for e in bad["evidence"] if e["rule"] == "discrimination_low")
    assert high < statistics.DISCRIMINATION_LOW and f"{low:.2f} to {high:.2f}" in said
    option_a = next(o for o in bad["options"] if o["option"] == "a")
    assert not option_a["right"] and option_a["discrimination"] > 0
    assert any("wrong option a)" in flag and "is the key right" in flag for flag in bad["flags"])
    assert any(e["rule"] == "distractor" and e["option"] == "a" and e["interval"][0] > 0 for e in bad["evidence"])
    by_numbers = items[BY_NUMBERS]
    r = next(p for p in by_numbers["parameters"] if p["name"] == "r")
    assert r["differs"] and r["p_holm"] < statistics.PARAMETER_ALPHA / 10 and len(r["bins"]) == 4
    assert r["bins"][0]["facility"] < r["bins"][-1]["facility"] - 0.3  # the low r bin is the hard one
    assert sum(b["learners"] for b in r["bins"]) == 200
    assert [e["rule"] for e in by_numbers["evidence"]] == ["parameter"]  # not flagged for anything else
    assert [e["rule"] for e in items[AMBIGUOUS]["evidence"]] == ["distractor"]
    broken = items[BROKEN]
    assert [e["rule"] for e in broken["evidence"]] == ["facility_low"]
    assert broken["evidence"][0]["interval"][1] < statistics.FACILITY_LOW
    assert "does the check fail right answers" in broken["flags"][0]


@pytest.mark.parametrize("learners", [76, 120, 200])
def test_on_simulated_classes_the_known_bad_items_are_flagged_and_little_else(learners):
    """Twelve simulated classes of each size: the flags found beyond the known bad items, and the known bad items
    missed, summed over the twelve (the power the note states: an ambiguous option is the hardest to see)."""
    extra, missed = Counter(), Counter()
    for seed in range(1, 13):
        flagged = set(_statistics(SimulatedClass(learners, seed).reports())["flagged"])
        extra.update(flagged - set(KNOWN_BAD))
        missed.update(set(KNOWN_BAD) - flagged)
    assert sum(extra.values()) <= 2, extra  # at most a few, over 12 classes of some 180 items each
    assert missed[BAD] == 0 and missed[BROKEN] == 0
    assert missed[BY_NUMBERS] <= (3 if learners < 100 else 0)
    assert missed[AMBIGUOUS] <= {76: 8, 120: 5, 200: 4}[learners], missed


def test_every_item_has_facility_discrimination_and_upper_lower_as_defined(class_of_200):
    reports = SimulatedClass(200).reports()  # the same class again (same seed)
    items = {item["id"]: item for item in class_of_200["items"]}
    key = "ch06/H_worked_example"
    points = np.array([_points(report, key) for report in reports.values()])
    totals = np.array([sum(c.points for ch in report.chapters for c in ch.checks) for report in reports.values()])
    rest = totals - points
    assert items[key]["facility"] == pytest.approx(points.mean() / 2, abs=1e-4)
    assert items[key]["discrimination"] == pytest.approx(np.corrcoef(points, rest)[0, 1], abs=1e-4)
    order = np.argsort(rest, kind="stable")
    assert items[key]["upper_lower"] == pytest.approx((points[order[-54:]].mean() - points[order[:54]].mean()) / 2,
                                                      abs=1e-4)
    assert all(0 <= i["facility"] <= 1 and -1 <= i["discrimination"] <= 1 for i in class_of_200["items"])
    quiz = [i for i in class_of_200["items"] if i["kind"] == "quiz"]
    assert quiz and len(class_of_200["items"]) == sum(len(check_registry.load(c).checks) + len(bank.questions(c))
                                                      for c in CHAPTERS)


def _points(report: Report, key: str) -> float:
    chapter, check_id = key.split("/")
    return next(c.points for ch in report.chapters if ch.chapter == chapter for c in ch.checks if c.id == check_id)


def _left_blank(report: Report, chapter: str, question: str | None = None) -> Report:
    """The report with `chapter`'s quiz questions (or one of them) left blank, as grader.quiz says a blank one."""
    from grader.model import NOT_ANSWERED

    for ch in report.chapters:
        for check in ch.checks:
            if ch.chapter == chapter and check.kind == "quiz" and question in (None, check.function):
                check.status, check.points, check.message, check.answer = Status.FAIL, 0.0, NOT_ANSWERED, {}
    return report


def test_a_blank_quiz_question_is_no_wrong_answer():
    """Blank answers are counted apart and left out of an item's numbers: a question nobody answered is not
    "very hard", a learner who skipped a chapter's quiz does not lower its facility, and a blank is no failure."""
    reports = SimulatedClass(60, seed=3).reports()
    chapter = CHAPTERS[0]
    quiz = [c for c in next(iter(reports.values())).chapters[0].checks if c.kind == "quiz"]
    nobody = quiz[0].function
    answered = {learner: _points(report, f"{chapter}/{quiz[1].id}") / quiz[1].max_points
                for i, (learner, report) in enumerate(reports.items()) if i % 2 == 0}
    for i, report in enumerate(reports.values()):
        _left_blank(report, chapter, nobody)
        if i % 2:
            _left_blank(report, chapter)
    found = {item["id"]: item for item in _statistics(reports)["items"]}
    blank = found[f"{chapter}/{quiz[0].id}"]
    assert (blank["learners"], blank["unanswered"], blank["facility"], blank["flags"]) == (0, 60, None, [])
    half = found[f"{chapter}/{quiz[1].id}"]
    assert (half["learners"], half["unanswered"]) == (30, 30)
    assert half["facility"] == pytest.approx(sum(answered.values()) / len(answered), abs=1e-4)
    tally = outputs_tally(reports)
    row = next(c for c in tally["checks"] if c["id"] == f"{chapter}/{quiz[0].id}")
    assert (row["failed"], row["unanswered"]) == (0, 60)
    assert not [m for m in tally["messages"] if "not answered" in m["message"]]


def outputs_tally(reports: dict[str, Report]) -> dict:
    from grader.render.summary import Tally

    tally = Tally()
    for learner, report in reports.items():
        tally.add(learner, report)
    try:
        return tally.counts()
    finally:
        tally.close()


def test_a_code_check_is_never_flagged_for_being_easy(class_of_200):
    assert not [i["id"] for i in class_of_200["items"] if i["kind"] == "code" and
                any(f.startswith("very easy") for f in i["flags"])]
    assert _flagged_rules(_entry(kind="code", learners=500, facility=1.0, discrimination=0.3)) == []


def test_a_failure_message_is_grouped_by_what_it_says_after_its_lead_in():
    from grader.render.summary import first_line

    assert first_line("wrong at 6 of 6 inputs; the first:\nH(3, 4): 2 of 4 entries differ\n  H[0,0] ...") == \
        "wrong at 6 of 6 inputs; the first: H(3, 4): 2 of 4 entries differ"
    assert first_line("range_reading(3, 4): got 7, expected 5") == "range_reading(3, 4): got 7, expected 5"


def test_cronbach_alpha_per_chapter_is_high_for_items_of_one_ability(class_of_200):
    alphas = {c["chapter"]: c["alpha"] for c in class_of_200["chapters"]}
    assert set(alphas) == set(CHAPTERS) and all(0.8 < a < 1 for a in alphas.values()), alphas


def test_cronbach_alpha_of_a_known_table():
    # three items, four learners: the textbook computation by hand
    table = np.array([[1, 1, 1], [1, 1, 0], [0, 1, 0], [0, 0, 0]], dtype=float)
    k, items, total = 3, table.var(axis=0, ddof=1).sum(), table.sum(axis=1).var(ddof=1)
    assert statistics.cronbach_alpha(table)[0] == pytest.approx(k / (k - 1) * (1 - items / total))
    assert statistics.cronbach_alpha(np.ones((4, 3)))[0] is None  # totals that do not vary


def test_below_30_learners_the_statistics_are_rough_and_flag_nothing_and_below_5_there_are_none():
    simulated = SimulatedClass(12, seed=3)
    rough = _statistics(simulated.reports())
    assert rough["rough"] and rough["learners"] == 12 and rough["flagged"] == []
    assert all(item["facility"] is not None for item in rough["items"])
    few = dict(list(SimulatedClass(4).reports().items()))
    assert _statistics(few) is None


def _entry(**numbers) -> dict:
    return {"id": "ch06/quiz_x", "kind": "quiz", "learners": 100, "facility": 0.5, "discrimination": 0.4,
            "parameters": [], "options": [], "flags": [], "evidence": [], **numbers}


def _flagged_rules(entry: dict) -> list[str]:
    return [test.rule for test in statistics._tests(entry) if test.flagged]


def test_a_distractor_is_flagged_only_when_enough_learners_chose_it_and_surely_the_strong_ones():
    options = [{"option": "b", "right": False, "chosen": statistics.DISTRACTOR_LEARNERS - 1, "share": 0.04,
                "discrimination": 0.6}, {"option": "c", "right": True, "chosen": 90, "share": 0.9,
                                         "discrimination": 0.5}]
    assert _flagged_rules(_entry(options=options)) == []
    options[0].update(chosen=30, share=0.3)
    assert _flagged_rules(_entry(options=options)) == ["distractor"]
    options[0].update(discrimination=0.1)  # its interval reaches below 0: no evidence that the strong choose it
    assert _flagged_rules(_entry(options=options)) == []


def test_a_flag_needs_its_interval_wholly_beyond_the_rule_so_a_small_class_needs_a_clearer_case():
    assert _flagged_rules(_entry(facility=0.1, learners=40)) == []  # 95% CI 0.04 to 0.23: could be 0.2
    assert _flagged_rules(_entry(facility=0.1, learners=200)) == ["facility_low"]
    assert _flagged_rules(_entry(facility=0.0, learners=30)) == ["facility_low"]
    assert _flagged_rules(_entry(discrimination=-0.05, learners=76)) == []  # CI reaches above 0.1
    assert _flagged_rules(_entry(discrimination=-0.3, learners=76)) == ["discrimination_low"]
    assert _flagged_rules(_entry(facility=1.0, learners=60)) == []  # 95% CI 0.94 to 1: could be 0.95
    assert _flagged_rules(_entry(facility=1.0, learners=200)) == ["facility_high"]
    assert _flagged_rules(_entry(facility=1.0, learners=200, kind="code")) == []  # passing is a check's goal
    assert _flagged_rules(_entry(facility=0.0, learners=statistics.MIN_LEARNERS - 1)) == []


def test_the_intervals_are_fishers_for_a_correlation_and_wilsons_for_a_share():
    p, (low, high) = statistics.correlation_test(0.3, 103, 0.1)
    assert (low, high) == pytest.approx((math.tanh(math.atanh(0.3) - 0.196), math.tanh(math.atanh(0.3) + 0.196)),
                                        abs=1e-4)
    assert p == pytest.approx(0.5 * math.erfc(-(math.atanh(0.3) - math.atanh(0.1)) * 10 / math.sqrt(2)))  # P(Z <= z)
    _, (low, high) = statistics.share_test(0.5, 100, 0.2)
    assert (low, high) == pytest.approx((0.4038, 0.5962), abs=1e-4)  # Wilson's interval, as in the textbooks


def test_holm_correction_is_step_down_and_monotone():
    tested = [types.SimpleNamespace() for _ in range(4)]
    statistics.holm([0.01, 0.04, 0.03, 0.005], tested)
    assert [t.p_holm for t in tested] == pytest.approx([0.03, 0.06, 0.06, 0.02])


@pytest.mark.slow
def test_the_chi_square_and_fisher_tests_agree_with_scipy_on_random_tables():
    stats = pytest.importorskip("scipy.stats")  # the field's standard, installed with the test extra
    draw = random.Random(11)
    for _ in range(300):
        rows = draw.choice([2, 3, 4])
        table = [[draw.randint(0, 40), draw.randint(0, 40)] for _ in range(rows)]
        if any(sum(row) == 0 for row in table) or any(sum(column) == 0 for column in zip(*table)):
            continue
        statistic, _ = statistics.chi_square(table)
        expected = stats.chi2_contingency(np.array(table), correction=False)
        assert statistic == pytest.approx(expected[0], rel=1e-9)
        assert statistics.chi_square_tail(statistic, rows - 1) == pytest.approx(expected[1], rel=1e-9, abs=1e-300)
        if rows == 2:
            assert statistics.fisher_exact(table) == pytest.approx(stats.fisher_exact(table)[1], rel=1e-9)
    for freedom in range(1, 8):  # the tail far out, where 1 - cdf would have lost every digit
        assert statistics.chi_square_tail(80.0, freedom) == pytest.approx(stats.chi2.sf(80.0, freedom), rel=1e-9)


def _summary_of_a_batch(out: Path, reports: dict[str, Report]) -> tuple[dict, str]:
    """The class outputs grade batch writes for these reports, each recorded in the history as a batch records it,
    then rebuilt from it (grader.course.outputs.rebuild): (summary.json, summary.html)."""
    from grader.course.settings import RunSettings
    from grader.model import LearnerResult

    settings = RunSettings(tuple(CHAPTERS), 1, grader="simulated")
    out.mkdir(parents=True, exist_ok=True)
    with History(out / "gradebook.db") as history:
        run = history.start(settings)
        for learner, report in reports.items():
            history.record(run, LearnerResult.of(learner, report), judged=report)
        outputs.rebuild(out, history, run, settings)
    return (json.loads((out / "summary.json").read_text(encoding="utf-8")),
            (out / "summary.html").read_text(encoding="utf-8"))


def _validate_summary(data: dict) -> None:
    jsonschema = pytest.importorskip("jsonschema")
    jsonschema.Draft202012Validator(lms.schema("summary")).validate(data)


@pytest.mark.slow
def test_the_summary_of_a_batch_of_200_shows_the_statistics_and_a_figure_per_chapter(tmp_path):
    data, page = _summary_of_a_batch(tmp_path / "out", SimulatedClass(200).reports())
    _validate_summary(data)
    found = data["statistics"]
    assert found["learners"] == 200 and sorted(found["flagged"]) == KNOWN_BAD
    flagged = page.split("id='flagged-items'", 1)[1].split("<h3", 1)[0]
    assert all(item in flagged for item in KNOWN_BAD) and flagged.count("<li><strong>") == len(KNOWN_BAD)
    assert "wrong option a) is chosen more by strong learners" in html.unescape(flagged)
    assert "95% confidence interval" in flagged and ">None<" not in page and "n/a" in page  # never a Python None
    images = re.findall(r"<img src='data:image/svg\+xml;base64,([^']+)' alt='([^']+)'", page)
    assert len(images) == len(CHAPTERS)
    alts = {alt.split(":", 1)[0]: html.unescape(alt) for _, alt in images}
    assert set(alts) == set(CHAPTERS)
    assert "flagged: quiz_bearing_near_dish (facility" in alts["ch06"]
    assert "flagged: central_difference_uses_the_step_as_given (facility" in alts["ch05"]
    svg = base64.b64decode(images[1][0]).decode("utf-8")
    assert "quiz_bearing_variance" in svg  # the flagged items are labelled by name, the others by number
    assert "Cronbach's alpha" in page and "id='parameter-statistics'" in page and "id='option-statistics'" in page
    assert "Rough:" not in page


def test_a_batch_below_30_learners_shows_rough_statistics_without_flags_or_figures(tmp_path):
    data, page = _summary_of_a_batch(tmp_path / "out", SimulatedClass(12, seed=5).reports())
    _validate_summary(data)
    assert data["statistics"]["rough"] and data["statistics"]["flagged"] == []
    assert "Rough:" in page and "<img" not in page and "id='flagged-items'" not in page
    assert all(not p["differs"] for i in data["statistics"]["items"] for p in i["parameters"])


def test_a_batch_of_4_has_no_statistics(tmp_path):
    data, page = _summary_of_a_batch(tmp_path / "out", SimulatedClass(4).reports())
    _validate_summary(data)
    assert data["statistics"] is None and "Item statistics" not in page


def test_the_figure_places_every_item_and_names_the_flagged_ones():
    """The chapter's figure (drawn here, without a batch): an SVG with each item by its number, a flagged item by
    its name too, and a text alternative that says the same in numbers."""
    from grader.render import item_plots

    rules = {"facility_low": 0.2, "facility_high": 0.95, "discrimination_low": 0.1}
    items = [{"id": "ch06/H_worked_example", "chapter": "ch06", "facility": 0.6, "discrimination": 0.4, "flags": []},
             {"id": "ch06/quiz_bad", "chapter": "ch06", "facility": 0.5, "discrimination": -0.3,
              "flags": ["does not tell strong learners from weak ones"]}]
    drawn = item_plots.figures({"chapters": [{"chapter": "ch06"}], "items": items, "rules": rules, "learners": 40})
    figure = drawn["ch06"]
    svg = base64.b64decode(figure.uri.split(",", 1)[1]).decode("utf-8")
    assert "quiz_bad" in svg and "H_worked_example" not in svg  # flagged by name, the others by number
    assert "flagged: quiz_bad" in figure.alt


def _crowded_chapter(count: int = 32, seed: int = 3) -> list[dict]:
    """A chapter as a class of right and buggy submissions gives it: every check passed by 95 to 100%, the
    discriminations spread thin, long names flagged (the figure the issue found unreadable)."""
    draw = random.Random(seed)
    names = [check.id for check in check_registry.load("ch06").checks] + [f"quiz_{q.id}" for q in bank.questions("ch06")]
    return [{"id": f"ch06/{names[k % len(names)]}", "chapter": "ch06", "facility": round(draw.uniform(0.95, 1.0), 3),
             "discrimination": round(draw.uniform(-0.05, 0.45), 3),
             "flags": ["does not tell strong learners from weak ones"] if k % 7 == 3 else []} for k in range(count)]


def _text_boxes(fig) -> list[tuple[str, object]]:
    """Every visible text of a drawn figure (labels, title, axis labels, tick labels) and its legend, with their
    extents as matplotlib lays them out."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.text import Text

    renderer = FigureCanvasAgg(fig).get_renderer()
    fig.draw(renderer)
    legend = [legend for ax in fig.axes for legend in [ax.get_legend()] if legend is not None]
    left_out = {id(t) for legend in legend for t in legend.get_texts()}  # the legend is one box
    for ax in fig.axes:  # a tick outside the view is not drawn: only the labels of the ticks in view count
        for axis in (ax.xaxis, ax.yaxis):
            low, high = sorted(axis.get_view_interval())
            left_out |= {id(label) for at, label in zip(axis.get_majorticklocs(), axis.get_majorticklabels())
                         if not low <= at <= high}
            left_out |= {id(tick.label2) for tick in axis.get_major_ticks()}  # the unshown opposite side
    boxes = [(t.get_text(), t.get_window_extent(renderer)) for t in fig.findobj(Text)
             if t.get_visible() and t.get_text().strip() and id(t) not in left_out]
    return boxes + [("legend", legend.get_window_extent(renderer)) for legend in legend]


@pytest.mark.parametrize("case", ["class of 200", "crowded at facility 0.95-1", "one item"])
def test_the_figure_fits_its_data_and_no_label_overlaps_another_or_is_clipped(case, class_of_200):
    from grader.render import item_plots

    rules = {"facility_low": 0.2, "facility_high": 0.95, "discrimination_low": 0.1}
    chapters = {"class of 200": [[i for i in class_of_200["items"] if i["chapter"] == c] for c in CHAPTERS],
                "crowded at facility 0.95-1": [_crowded_chapter()],
                "one item": [_crowded_chapter(1)]}[case]
    for items in chapters:
        drawn = item_plots.canvas(items[0]["chapter"], items, rules, 200)
        fig, ax = drawn.figure, drawn.figure.axes[0]
        facility = [i["facility"] for i in items if i["discrimination"] is not None]
        low, high = ax.get_xlim()
        assert low <= min(facility) and max(facility) <= high  # every point in view ...
        assert high - low <= max(0.2, 1.3 * (max(facility) - min(facility)))  # ... on an axis fitted to them
        boxes = _text_boxes(fig)
        frame = fig.bbox
        for text, box in boxes:
            assert frame.x0 <= box.x0 and box.x1 <= frame.x1 and frame.y0 <= box.y0 and box.y1 <= frame.y1, \
                f"{text!r} is clipped: {box} outside {frame}"
        for k, (text, box) in enumerate(boxes):
            for other, other_box in boxes[k + 1:]:
                assert not box.overlaps(other_box), f"{text!r} overlaps {other!r}"
        labelled = sum(len(t.get_text().split(", ")) for t in ax.texts)
        assert labelled + sum(len(u.split(", ")) for u in drawn.unlabelled) == len(facility)
        assert len(drawn.unlabelled) <= len(items) // 4  # most items labelled; the rest named in the caption


def test_the_overlap_test_catches_labels_drawn_on_top_of_each_other():
    from matplotlib.figure import Figure as Canvas

    fig = Canvas(figsize=(4, 3))
    ax = fig.add_subplot()
    ax.annotate("7 H_rows_orthogonal", (0.5, 0.5))
    ax.annotate("8 H_jacobian_random_points", (0.5, 0.5))
    boxes = _text_boxes(fig)
    assert any(a.overlaps(b) for k, (_, a) in enumerate(boxes) for _, b in boxes[k + 1:])
    ax.annotate("clipped at the right edge", (0.99, 0.2))
    frame = fig.bbox
    assert any(box.x1 > frame.x1 for _, box in _text_boxes(fig))


def test_the_figures_drawn_by_two_forked_processes_are_those_drawn_here(monkeypatch):
    """A batch's end draws its chapters' figures in two forked processes (where forking is safe): each is byte for
    byte the one drawn in this process, in the chapters' order, and one that fails is a caption, as here."""
    from grader.render import item_plots
    from grader.system import fork_is_safe

    rules = {"facility_low": 0.2, "facility_high": 0.95, "discrimination_low": 0.1}
    items = [{"id": f"ch0{n}/item{k}", "chapter": f"ch0{n}", "facility": 0.1 * k, "discrimination": 0.05 * k - 0.1,
              "flags": ["too easy"] if k == 9 else []} for n in range(4) for k in range(1, 10)]
    chapters = [{"chapter": f"ch0{n}"} for n in range(4)] + [{"chapter": "ch09"}]
    items.append({"id": "ch09/broken", "chapter": "ch09", "facility": "not a number", "discrimination": 0.2,
                  "flags": []})
    statistics = {"chapters": chapters, "items": items, "rules": rules, "learners": 40}
    from grader.render import drawer

    pools = []
    two = drawer.two_processes
    monkeypatch.setattr(drawer, "two_processes", lambda: pools.append(two()) or pools[-1])
    drawn = item_plots.figures(statistics)
    here = [item_plots._one(job) for job in [(c["chapter"], [i for i in items if i["chapter"] == c["chapter"]], rules,
                                               40) for c in chapters]]
    assert list(drawn) == [c["chapter"] for c in chapters]
    assert [(f.uri, f.alt, f.caption) for f in drawn.values()] == [(f.uri, f.alt, f.caption) for f in here]
    assert drawn["ch09"].uri == "" and "could not be drawn" in drawn["ch09"].caption
    assert len(pools) == (1 if fork_is_safe() else 0)  # drawn by the two processes where they can be forked


def test_no_drawing_process_is_forked_while_another_thread_runs(monkeypatch):
    """A fork copies only the calling thread: where another one runs (it may hold a lock, an import's among them),
    the figures are drawn here instead, the same figures."""
    import threading

    from grader.render import drawer, item_plots
    from grader.system import forkable_now

    rules = {"facility_low": 0.2, "facility_high": 0.95, "discrimination_low": 0.1}
    items = [{"id": f"ch0{n}/item{k}", "chapter": f"ch0{n}", "facility": 0.1 * k, "discrimination": 0.05 * k,
              "flags": []} for n in range(2) for k in range(1, 4)]
    statistics = {"chapters": [{"chapter": "ch00"}, {"chapter": "ch01"}], "items": items, "rules": rules,
                  "learners": 40}
    alone = item_plots.figures(statistics)
    pools = []
    two = drawer.two_processes
    monkeypatch.setattr(drawer, "two_processes", lambda: pools.append(two()) or pools[-1])
    release = threading.Event()
    other = threading.Thread(target=release.wait, daemon=True)
    other.start()
    try:
        assert not forkable_now()
        beside = item_plots.figures(statistics)
    finally:
        release.set()
        other.join()
    assert pools == []
    assert [f.uri for f in beside.values()] == [f.uri for f in alone.values()]
