"""Item statistics (grader.course.statistics) in summary.html and summary.json: on a generated class of learners of known
ability, the bad question and the question that is harder for some learners' numbers are flagged, and no other."""

from __future__ import annotations

import base64
import html
import json
import math
import random
import re
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
BAD = "ch06/quiz_bearing_near_dish"  # its key answer is chosen more by the weak: strong learners pick option a
BY_NUMBERS = "ch06/quiz_bearing_variance"  # much harder for learners whose r is below 2


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
        chance = _sigmoid(slope * (ability - difficulty))
        if key == BY_NUMBERS and question.values_for(learner, "ch06")["r"] < 2:
            chance = _sigmoid(slope * (ability - difficulty) - 3.5)
        return self.random.random() < chance

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
                                                              ability, key == BAD)}
                results.append(result)
            chapters.append(ChapterResult(chapter, BY_ID[chapter].title, results))
        return Report(learner, chapters, seed=1, learner=learner, learner_id=learner, grader="simulated")

    def _options(self, question, key, right: bool, ability: float, bad: bool) -> list[str]:
        keyed = [key.answer] if question.kind == "choice" else list(key.answer)
        wrong = [o for o in question.options if o not in keyed]
        if right:
            return sorted(keyed)
        if bad and "a" in wrong and self.random.random() < _sigmoid(2 * ability):
            pick = "a"
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


def test_a_class_of_200_flags_the_bad_question_and_the_one_harder_for_some_numbers_and_no_other(class_of_200):
    found = class_of_200
    assert found["learners"] == 200 and not found["rough"]
    assert sorted(found["flagged"]) == sorted([BAD, BY_NUMBERS]), {i["id"]: i["flags"] for i in found["items"]
                                                                   if i["flags"]}
    items = {item["id"]: item for item in found["items"]}
    bad = items[BAD]
    assert bad["discrimination"] < 0 and bad["upper_lower"] < 0
    assert any("does not tell strong learners from weak" in flag for flag in bad["flags"])
    option_a = next(o for o in bad["options"] if o["option"] == "a")
    assert not option_a["right"] and option_a["discrimination"] > statistics.DISTRACTOR_HIGH
    assert any("wrong option a)" in flag for flag in bad["flags"])
    by_numbers = items[BY_NUMBERS]
    r = next(p for p in by_numbers["parameters"] if p["name"] == "r")
    assert r["differs"] and r["p_holm"] < statistics.PARAMETER_ALPHA / 10 and len(r["bins"]) == 4
    assert r["bins"][0]["facility"] < r["bins"][-1]["facility"] - 0.3  # the low r bin is the hard one
    assert sum(b["learners"] for b in r["bins"]) == 200
    assert by_numbers["discrimination"] > statistics.DISCRIMINATION_LOW  # not flagged for anything else


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
    assert statistics._flags({"kind": "code", "learners": 50, "facility": 0.99, "discrimination": 0.3,
                              "options": [], "parameters": []}) == []


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


def test_a_distractor_is_flagged_only_when_enough_learners_chose_it():
    found = statistics._flags({"facility": 0.5, "discrimination": 0.4, "parameters": [], "options": [
        {"option": "b", "right": False, "chosen": statistics.DISTRACTOR_LEARNERS - 1, "discrimination": 0.6},
        {"option": "c", "right": True, "chosen": 90, "discrimination": 0.5}]})
    assert found == []


def test_holm_correction_is_step_down_and_monotone():
    tested = [{"p": p} for p in (0.01, 0.04, 0.03, 0.005)]
    statistics._holm(tested)
    assert [t["p_holm"] for t in tested] == pytest.approx([0.03, 0.06, 0.06, 0.02])
    assert [t["differs"] for t in tested] == [True, False, False, True]


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
    assert found["learners"] == 200 and sorted(found["flagged"]) == sorted([BAD, BY_NUMBERS])
    flagged = page.split("id='flagged-items'", 1)[1].split("</table>", 1)[0]
    assert BAD in flagged and BY_NUMBERS in flagged and flagged.count("<tr>") == 3  # a header and the two
    assert "wrong option a) is chosen more by strong learners" in html.unescape(flagged)
    images = re.findall(r"<img src='data:image/svg\+xml;base64,([^']+)' alt='([^']+)'", page)
    assert len(images) == len(CHAPTERS)
    alts = {alt.split(":", 1)[0]: html.unescape(alt) for _, alt in images}
    assert set(alts) == set(CHAPTERS)
    assert "flagged: quiz_bearing_near_dish (facility" in alts["ch06"] and "flagged:" not in alts["ch05"]
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
        assert not drawer.forkable()
        beside = item_plots.figures(statistics)
    finally:
        release.set()
        other.join()
    assert pools == []
    assert [f.uri for f in beside.values()] == [f.uri for f in alone.values()]
