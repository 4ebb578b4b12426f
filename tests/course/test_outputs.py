"""Every output shows the grade the history holds (grader.course.outputs.rebuild), after any sequence of batches,
resubmissions, overrides and waivers added or removed, a moved deadline and regrades: a property, tested by
Hypothesis's stateful testing (RuleBasedStateMachine) on a class of real submissions graded behind the real sandbox.

After every step each learner's line in gradebook.db agrees with gradebook.csv, Canvas' and Moodle's gradebooks,
changes.csv, junit.xml, summary.json and summary.html, their report.json, results.json (Gradescope's format) and
report.html, and the GitHub Classroom results of their report; a regrade with nothing named moves nobody. And the
check is seen to fail when any one export is left out of the rebuild."""

from __future__ import annotations

import csv
import io
import json
import shutil
import sqlite3
import tempfile
import textwrap
from decimal import Decimal
from pathlib import Path
from xml.etree import ElementTree

import pytest
from hypothesis import HealthCheck, settings
from hypothesis import strategies as st
from hypothesis.stateful import RuleBasedStateMachine, initialize, invariant, precondition, rule

from grader.course import outputs, regrade
from grader.course.batch import run_batch
from grader.course.history import FILE_NAME, History
from grader.course.staging import folder_name
from grader.course_config import from_text
from grader.model import points_text
from grader.render import lms
from grader.render.summary import change_text, escape
from tests.support import chapter_submission, replace_function

CHAPTER = "ch00"
LEARNERS = ("ann", "bo", "cy")
VARIANTS = {  # what a learner hands in for ch00_range_sensor.py
    "right": None,
    "wrong": replace_function("ch00_range_sensor", "range_reading",
                              "def range_reading(x, y):\n    return float(abs(x) + abs(y))\n"),
    "broken": replace_function("ch00_range_sensor", "mean_shift",
                               "def mean_shift(mean, sigma, n, seed):\n    raise RuntimeError('no')\n"),
}
CHECK = "ch00/superposition_gap_random_points"  # 2 points
OVERRIDES = {  # a row per kind: what it changes
    "check": "{who},ch00/superposition_gap_random_points,1,,regrade request,bo",
    "chapter": "{who},ch00,,0.5,integrity panel,the instructor",
    "total": "{who},total,-1.5,,agreed penalty,bo",
    "waiver": "{who},late,,0,accommodation: extension,the instructor",
}
SUBMITTED = {"ann": "2026-05-01T12:00:00+00:00", "bo": "2026-05-03T10:00:00+00:00", "cy": "2026-05-02T08:00:00+00:00"}


# ------------------------------------------------------------------------------------ the property, as a check

def disagreements(out: Path) -> list[str]:
    """Every place an output of OUT shows another grade than the history's last finished run (nothing: they agree)."""
    found = []
    with History(out / FILE_NAME) as history:
        run = history.last_finished()
        results = history.results(run)
        reports = {learner: history.report(result) for learner, result in results.items()}
        settings_ = history.settings(run)
    with sqlite3.connect(out / FILE_NAME) as db:
        moved = sorted((row[0], row[1], row[2], row[3], row[4]) for row in db.execute(
            "SELECT learner, before, after, delta, why FROM changes WHERE run = ?", (run,)))
    graded = {learner: result for learner, result in results.items() if result.status == "graded"}

    def table(name: str) -> list[dict]:
        return list(csv.DictReader(io.StringIO((out / name).read_text(encoding="utf-8"))))

    gradebook = {row["learner"]: row for row in table("gradebook.csv")}
    canvas = {row["SIS Login ID"]: row for row in table("gradebook-canvas.csv")[1:]}
    moodle = {row["Learner id"]: row for row in table("gradebook-moodle.csv")}
    changes = sorted((row["learner"], row["before"], row["after"], row["delta"], row["why"])
                     for row in table("changes.csv"))
    if changes != [(learner, points_text(b), points_text(a), points_text(d), why) for learner, b, a, d, why in moved]:
        found.append(f"changes.csv {changes} is not the history's {moved}")
    summary = json.loads((out / "summary.json").read_text(encoding="utf-8"))
    if sorted(map(tuple, ([c["learner"], c["before"], c["after"], c["delta"], c["why"]] for c in
                          summary["changes"]))) != moved:
        found.append("summary.json's changes are not the history's")
    if summary["learners"]["graded"] != len(graded):
        found.append(f"summary.json counts {summary['learners']['graded']} graded, the history {len(graded)}")
    scores = [r.score for r in graded.values()]
    if scores and summary["scores"]["mean"] != round(sum(scores) / len(scores), 3):
        found.append(f"summary.json's mean {summary['scores']['mean']} is not the history's")
    page = (out / "summary.html").read_text(encoding="utf-8")
    if any(escape(change_text(change)) not in page for change in moved):
        found.append("summary.html does not list the history's changes")
    suites = {suite.get("name"): suite for suite in ElementTree.parse(out / "junit.xml").getroot().iter("testsuite")}
    for learner, result in results.items():
        total = points_text(result.score)
        if gradebook.get(learner, {}).get("total") != total:
            found.append(f"gradebook.csv: {learner} {gradebook.get(learner, {}).get('total')!r}, the history {total!r}")
        moodle_total = next((v for k, v in moodle.get(learner, {}).items() if k.startswith("Total")), None)
        if moodle_total != total:
            found.append(f"gradebook-moodle.csv: {learner}'s total {moodle_total!r} is not the history's {total!r}")
        row = canvas.get(learner)
        cells = [row[k] for k in row if k.startswith(CHAPTER) or k == lms.BEYOND_CHAPTERS] if row else []
        if row is None or (result.score is not None and sum(Decimal(c or 0) for c in cells) != Decimal(total)):
            found.append(f"gradebook-canvas.csv: {learner}'s columns do not add up to the history's {total!r}")
        report = reports[learner]
        if result.status != "graded":
            continue
        adjustments = [a["reason"] for a in result.adjustments]
        if any(reason not in moodle[learner]["Feedback"] for reason in adjustments):
            found.append(f"gradebook-moodle.csv: {learner}'s feedback does not give every adjustment's reason")
        folder = out / folder_name(learner)
        data = json.loads((folder / "report.json").read_text(encoding="utf-8"))
        if data["score"] != result.score or [a["reason"] for a in data["adjustments"]] != adjustments:
            found.append(f"{learner}/report.json: {data['score']} and its adjustments, the history {result.score}")
        if json.loads((folder / "results.json").read_text(encoding="utf-8"))["score"] != result.score:
            found.append(f"{learner}/results.json's score is not the history's {result.score}")
        if settings_.html and f'id="total">{result.score:g} / {result.max_score:g}' not in (
                folder / "report.html").read_text(encoding="utf-8"):
            found.append(f"{learner}/report.html does not show the history's {result.score:g}")
        classroom = lms.classroom_data(report)
        if Decimal(points_text(sum(t["score"] for t in classroom["tests"]))) != Decimal(total):
            found.append(f"{learner}: GitHub Classroom's results add up to another grade than {total}")
        failing = sum(c.status.value in ("fail", "error") for ch in report.chapters for c in ch.checks)
        suite = suites.get(learner)
        if suite is None or int(suite.get("failures")) + int(suite.get("errors")) != failing + sum(
                bool(ch.problems) for ch in report.chapters):
            found.append(f"junit.xml: {learner}'s failures are not those of the history's report")
    return found


# ------------------------------------------------------------------------------------ the class and its instructor

class Course:
    """A class of three learners handing in ch00, a course file with a deadline, a roster with submission times and
    an overrides file, in a folder of their own; and the instructor's commands on them."""

    def __init__(self) -> None:
        self.root = Path(tempfile.mkdtemp(prefix="grade-outputs-"))
        self.out = self.root / "out"
        self.deadline_day = 1
        self.rows: list[str] = []
        for learner in LEARNERS:
            self.hand_in(learner, "right")
        (self.root / "roster.csv").write_text("submission,learner,submitted\n" + "".join(
            f"{learner},{learner},{SUBMITTED[learner]}\n" for learner in LEARNERS), encoding="utf-8")
        self.write_course()
        self.write_overrides()

    def hand_in(self, learner: str, variant: str) -> None:
        chapter_submission(self.root / "submissions" / learner, learner, text=VARIANTS[variant])

    def write_course(self) -> None:
        (self.root / "course.yaml").write_text(textwrap.dedent(f"""\
            course: outputs-course
            seed: 424242
            deadline: "2026-05-0{self.deadline_day}T23:59:00+00:00"
            late_penalty: {{per_day: 0.1, max: 0.5}}
            """), encoding="utf-8")

    def write_overrides(self) -> None:
        (self.root / "overrides.csv").write_text("learner,target,points,factor,reason,who\n"
                                                 + "".join(f"{row}\n" for row in self.rows), encoding="utf-8")

    @property
    def course(self):
        return from_text((self.root / "course.yaml").read_text(encoding="utf-8"), str(self.root / "course.yaml"))

    def batch(self):
        course = self.course
        return run_batch(self.root / "submissions", self.out, chapters=[CHAPTER], roster=self.root / "roster.csv",
                         jobs=1, seed=course.grading_seed, course=course, overrides=self.root / "overrides.csv",
                         lms_layouts=("canvas", "moodle"), limits={"learner_seconds": 20})

    def regrade(self, named: bool):
        return regrade.regrade(self.out, self.course if named else None,
                               overrides=self.root / "overrides.csv" if named else None, jobs=1)

    def close(self) -> None:
        shutil.rmtree(self.root, ignore_errors=True)


class Exports(RuleBasedStateMachine):
    """The instructor's steps, in any order; after each, every output agrees with the history."""

    @initialize()
    def start(self) -> None:
        """The class graded once: every step after it has outputs to keep true."""
        self.course = Course()
        self.course.batch()

    def teardown(self) -> None:
        self.course.close()

    @rule()
    def batch(self) -> None:
        self.course.batch()

    @rule(learner=st.sampled_from(LEARNERS), variant=st.sampled_from(sorted(VARIANTS)))
    def resubmit(self, learner: str, variant: str) -> None:
        self.course.hand_in(learner, variant)

    @rule(learner=st.sampled_from(LEARNERS), kind=st.sampled_from(sorted(OVERRIDES)))
    def add_override(self, learner: str, kind: str) -> None:
        self.course.rows.append(OVERRIDES[kind].format(who=learner))
        self.course.write_overrides()

    @precondition(lambda self: self.course.rows)
    @rule(data=st.data())
    def remove_override(self, data) -> None:
        self.course.rows.pop(data.draw(st.integers(0, len(self.course.rows) - 1)))
        self.course.write_overrides()

    @rule(day=st.integers(1, 4))
    def move_the_deadline(self, day: int) -> None:
        self.course.deadline_day = day
        self.course.write_course()

    @rule()
    def regrade_with_nothing_named(self) -> None:
        found = self.course.regrade(named=False)
        assert found.differences == [] and found.moved == [], [m.why for m in found.moved]

    @rule()
    def regrade_and_apply(self) -> None:
        found = self.course.regrade(named=True)
        regrade.apply(self.course.out, found, "the course file and overrides as they are now")

    @invariant()
    def every_output_shows_the_historys_grade(self) -> None:
        assert disagreements(self.course.out) == []


HEALTH = [HealthCheck.too_slow, HealthCheck.filter_too_much, HealthCheck.data_too_large]


class FastExports(Exports):
    pass


FastExports.TestCase.settings = settings(max_examples=2, stateful_step_count=6, deadline=None, database=None,
                                         suppress_health_check=HEALTH)
test_every_output_shows_the_historys_grade = FastExports.TestCase


class ManyExports(Exports):
    pass


ManyExports.TestCase.settings = settings(max_examples=15, stateful_step_count=12, deadline=None, database=None,
                                         suppress_health_check=HEALTH)
test_every_output_shows_the_historys_grade_over_many_steps = pytest.mark.slow(ManyExports.TestCase)


# ------------------------------------------------------------------------------------ the check can fail

EXPORTS = ["gradebook.csv", "gradebook-canvas.csv", "gradebook-moodle.csv", "changes.csv", "junit.xml",
           "summary.json", "summary.html", "report.json", "results.json", "report.html"]


@pytest.mark.parametrize("left_out", [pytest.param(name, marks=() if name == "gradebook-moodle.csv" else
                                                   pytest.mark.slow) for name in EXPORTS])
def test_the_check_fails_when_one_export_is_left_out_of_the_rebuild(monkeypatch, left_out):
    """A batch, then a resubmission (a verdict moves), an override and a waiver, and a batch again, with one file
    never written again after the first: the check names it."""
    course = Course()
    try:
        course.batch()
        assert disagreements(course.out) == []
        written = outputs.write_atomically

        def write_once(path, text):
            if Path(path).name != left_out or not Path(path).exists():
                written(path, text)

        writes_from = outputs.write_atomically_from

        def write_once_from(path, write, replace=True):
            if Path(path).name == left_out and Path(path).exists():
                return Path(path)
            return writes_from(path, write, replace)

        monkeypatch.setattr(outputs, "write_atomically", write_once)
        monkeypatch.setattr(outputs, "write_atomically_from", write_once_from)
        course.hand_in("bo", "wrong")
        course.rows += [OVERRIDES["total"].format(who="ann"), OVERRIDES["waiver"].format(who="bo")]
        course.write_overrides()
        course.batch()
        assert disagreements(course.out) != []
    finally:
        course.close()


# ------------------------------------------------------------------------------------ learners without a time

def test_learners_without_a_submission_time_are_said_once_and_a_bad_roster_time_once(tmp_path):
    """With a deadline and no roster, one line says how many learners are untimed and why (no line per learner); a
    learner whose roster time is not a date is told that, and not also that the roster gives no `submitted`."""
    for learner in LEARNERS:
        chapter_submission(tmp_path / "submissions" / learner, learner)
    (tmp_path / "course.yaml").write_text(textwrap.dedent("""\
        course: untimed-course
        seed: 424242
        deadline: "2026-05-01T23:59:00+00:00"
        late_penalty: {per_day: 0.1, max: 0.5}
        """), encoding="utf-8")
    course = from_text((tmp_path / "course.yaml").read_text(encoding="utf-8"), str(tmp_path / "course.yaml"))

    def batch(out: str, roster: Path | None = None):
        return run_batch(tmp_path / "submissions", tmp_path / out, chapters=[CHAPTER], roster=roster, jobs=1,
                         seed=course.grading_seed, course=course, html=False, limits={"learner_seconds": 20})

    done = batch("no-roster")
    assert done.flagged == {}, done.flagged
    told = [note for note in done.notes if "submission time" in note]
    assert told == ["no trusted submission time for 3 of 3 graded: no roster was given, and a late penalty trusts "
                    "only a roster's `submitted` column (or, with manifest_time: accept, the learner's own archive "
                    "manifest): ann, bo, cy"], done.notes
    roster = tmp_path / "roster.csv"
    roster.write_text("submission,learner,submitted\nann,ann,not a date\nbo,bo,2026-05-01T10:00:00+00:00\ncy,cy,\n",
                      encoding="utf-8")
    done = batch("roster", roster)
    assert done.flagged == {"ann": ["the roster's submission time 'not a date' (the roster roster.csv, line 2) is not "
                                    "a time (ISO 8601, e.g. 2026-05-01T23:59:00+02:00)"]}, done.flagged
    told = [note for note in done.notes if "submission time" in note]
    assert len(told) == 1 and told[0].startswith("no trusted submission time for 2 of 3 graded: no usable "
                                                 "`submitted` in the roster for them") and told[0].endswith(": ann, cy")


# ------------------------------------------------------------------------------------ the order of the rows

def _rows_in_order(out: Path) -> dict[str, list[str]]:
    """The learners of each class output, in the order its rows give them."""
    def column(name: str, key: str, skip: int = 0) -> list[str]:
        return [row[key] for row in csv.DictReader(io.StringIO((out / name).read_text(encoding="utf-8")))][skip:]

    return {"gradebook.csv": column("gradebook.csv", "learner"),
            "gradebook-canvas.csv": column("gradebook-canvas.csv", "SIS Login ID", skip=1),
            "gradebook-moodle.csv": column("gradebook-moodle.csv", "Learner id"),
            "junit.xml": [s.get("name") for s in ElementTree.parse(out / "junit.xml").getroot().iter("testsuite")],
            "changes.csv": column("changes.csv", "learner")}


def test_every_class_output_lists_the_learners_in_the_rosters_order_else_by_id(tmp_path):
    """Rows follow the roster (a submission it names not after, by id), without one the ids; never the folders' names
    (here the folders sort as cy, ann, bo, dee, then dee-x before dee)."""
    subs = tmp_path / "submissions"
    for folder, learner in (("a-folder", "cy"), ("b-folder", "ann"), ("c-folder", "bo")):
        chapter_submission(subs / folder, learner)
    shutil.make_archive(str(subs / "dee"), "zip", chapter_submission(tmp_path / "dee", "dee"))
    roster = tmp_path / "roster.csv"
    roster.write_text("submission,learner\nc-folder,bo\na-folder,cy\nb-folder,ann\n", encoding="utf-8")
    lms_layouts = ("canvas", "moodle")
    run_batch(subs, tmp_path / "out", chapters=[CHAPTER], roster=roster, jobs=1, seed=424242, html=False,
              lms_layouts=lms_layouts, limits={"learner_seconds": 20})
    in_order = _rows_in_order(tmp_path / "out")
    assert in_order == dict.fromkeys(in_order, ["bo", "cy", "ann", "dee"]), in_order
    found = regrade.regrade(tmp_path / "out", None, jobs=1)  # rebuilt from the history alone
    regrade.apply(tmp_path / "out", found, "rebuilt")
    assert _rows_in_order(tmp_path / "out")["gradebook.csv"] == ["bo", "cy", "ann", "dee"]
    for folder, learner in (("a-folder", "cy"), ("b-folder", "ann"), ("c-folder", "bo")):
        (subs / folder).rename(subs / learner)
    chapter_submission(subs / "dee-x", "dee-x")  # the folder dee-x/ sorts before dee.zip, the id dee-x after dee
    run_batch(subs, tmp_path / "no-roster", chapters=[CHAPTER], jobs=1, seed=424242, html=False,
              lms_layouts=lms_layouts, limits={"learner_seconds": 20})
    in_order = _rows_in_order(tmp_path / "no-roster")
    assert in_order == dict.fromkeys(in_order, ["ann", "bo", "cy", "dee", "dee-x"]), in_order
