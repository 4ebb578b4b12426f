"""Running a course: a test course of right, buggy, unset-id, stale-handout, edited and copied submissions
graded end to end through the real CLI (`grade submit`, `grade batch`) four times over.

- the unset-id learner (learner.yaml empty, quiz worked out at home as 'anonymous') and the archives packed
  with an older handout or edited after packing are flagged with their reason, in the learner's report
  and the summary; the unset-id learner's report says whose numbers the answers fit;
- the copied pair (one function, variables renamed) tops the similarity list, with the lines it shares;
- an override applies and survives two more rebuilds; a late penalty follows the roster's time;
- changes.csv names exactly the learners whose score moved, and why;
- the named-mistake counts of summary.json match the corpus (benchmarks/misconceptions.py);
- every JSON written validates against its schema; the history holds every run, score and override.
"""

from __future__ import annotations

import csv
import json
import re
import sqlite3
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

from benchmarks.misconceptions import CODE
from grader.quiz.templates import reference_answers
from tests.support import (
    REPO,
    build_submission,
    replace_function,
    run_grade,
    run_on_terminal,
)

CHAPTER = "ch06"
CURRENT, OLDER = "0.1.0+handout.c0ffee000001", "0.1.0+handout.0bad00000000"
COURSE = (f"course: admin-course\nseed: 424242\nquiz_feedback: recorded\nhandout: {CURRENT}\n"
          "deadline: 2026-05-01T23:59:00+00:00\nlate_penalty: {per_day: 0.1, max: 0.5}\n")
# one-bug submissions of the misconception corpus: learner -> its entry
CORPUS = {"carol": "bearing row sign", "hank": "H transposed", "jo": "covariance with sigma"}
IVY_TRANSPOSED = """
def H_jacobian(x, y):
    x, y = float(x), float(y)
    if x == 0 and y == 0:
        raise ValueError("no H at the dish")
    rows = [[x, y], [-y, x]]
    scale = [np.hypot(x, y), x * x + y * y]
    return np.array([[rows[0][0] / scale[0], rows[1][0] / scale[1]], [rows[0][1] / scale[0], rows[1][1] / scale[1]]])
"""
GINA_COVARIANCE = """
def measurement_covariance(x, y, sigma):
    # the covariance of range and bearing, one entry at a time
    distance_squared = float(x) * float(x) + float(y) * float(y)
    if distance_squared == 0.0:
        raise ValueError("the dish itself: no bearing")
    variance = float(sigma) * float(sigma)
    covariance = np.zeros((2, 2), dtype=float)
    covariance[0, 0] = variance
    covariance[1, 1] = variance / distance_squared
    for index in range(2):
        covariance[index, 1 - index] = 0.0
    return covariance
"""
RENAMED = {"distance_squared": "d2", "variance": "var", "covariance": "cov", "index": "i"}
FRANK_COVARIANCE = re.sub(  # gina's, with every name in the body changed and its comment gone
    r"\b(distance_squared|variance|covariance|index)\b(?!\()", lambda m: RENAMED[m.group(1)],
    GINA_COVARIANCE.replace("    # the covariance of range and bearing, one entry at a time\n", ""))


def _learner(root: Path, learner: str, replacements: dict | None = None, answers_for: str | None = None,
             learner_yaml: str | None = None) -> Path:
    """A submission folder: the references but `replacements`, quiz answers worked out for `answers_for`."""
    build_submission(root, replacements)
    answers = root / "exercises" / "answers"
    answers.mkdir(parents=True, exist_ok=True)
    (answers / f"{CHAPTER}.yaml").write_text(reference_answers(CHAPTER, answers_for or learner), encoding="utf-8")
    (answers / "learner.yaml").write_text(learner_yaml if learner_yaml is not None else f"learner: {learner}\n",
                                          encoding="utf-8")
    return root


def _corpus(entry: str) -> dict:
    module, function, source, _ = CODE[entry]
    return {module: replace_function(module, function, source)}


def _rewrite(archive: Path, change) -> None:
    """Rewrite a zip's members through change(name, bytes) -> bytes."""
    with zipfile.ZipFile(archive) as old:
        members = [(name, old.read(name)) for name in old.namelist()]
    with zipfile.ZipFile(archive, "w") as new:
        for name, data in members:
            new.writestr(name, change(name, data))


def _rows(path: Path) -> dict[str, dict]:
    with path.open(newline="", encoding="utf-8") as handle:
        return {row["learner"]: row for row in csv.DictReader(handle)}


@pytest.fixture(scope="module")
def course(tmp_path_factory):
    base = tmp_path_factory.mktemp("course")
    work, submissions = base / "work", base / "submissions"
    submissions.mkdir()
    for name in ("alice", "bob"):
        _learner(submissions / name, name)
    for name, entry in CORPUS.items():
        _learner(submissions / name, name, _corpus(entry))
    _learner(submissions / "ivy", "ivy", {"ch06_measurement": replace_function("ch06_measurement", "H_jacobian",
                                                                                IVY_TRANSPOSED)})
    _learner(submissions / "gina", "gina", {"ch06_measurement": replace_function(
        "ch06_measurement", "measurement_covariance", GINA_COVARIANCE)})
    _learner(submissions / "frank", "frank", {"ch06_measurement": replace_function(
        "ch06_measurement", "measurement_covariance", FRANK_COVARIANCE)})
    _learner(submissions / "dave", "dave", answers_for="anonymous", learner_yaml="learner:\n")  # never set an id
    for name in ("stan", "eve"):  # they pack with grade submit
        packed = run_grade("submit", "--out", str(submissions / f"{name}.zip"), cwd=_learner(work / name, name))
        assert packed.returncode == 0, packed.stderr
        assert "The archive, graded again: " in packed.stdout and f"{name}.zip" in packed.stdout
    manifest = "exercises/submission-manifest.json"
    _rewrite(submissions / "stan.zip", lambda name, data: data if name != manifest else json.dumps(
        {**json.loads(data), "handout": OLDER, "handout_released": "2026-03-01T09:00:00+00:00"}).encode())
    _rewrite(submissions / "eve.zip", lambda name, data: data + b"\n# changed after packing\n"
             if name.endswith("ch06_measurement.py") else data)
    (base / "course.yaml").write_text(COURSE, encoding="utf-8")
    (base / "roster.csv").write_text("submission,learner,submitted\njo,jo,2026-05-03T10:00:00+00:00\n"
                                     "alice,alice,2026-05-01T20:00:00+00:00\n", encoding="utf-8")
    out = base / "out"

    def batch(*extra: str) -> subprocess.CompletedProcess:
        done = run_grade("batch", str(submissions), "--out", str(out), "--chapters", CHAPTER, "--course",
                      str(base / "course.yaml"), "--roster", str(base / "roster.csv"), "--no-html", "--jobs", "2",
                      *extra)
        assert done.returncode == 0, done.stdout + done.stderr
        return done

    runs = [batch("--similarity")]
    snapshots = [(out / "changes.csv").read_text(encoding="utf-8")]
    first_summary = json.loads((out / "summary.json").read_text(encoding="utf-8"))
    (out / "overrides.csv").write_text("learner,target,points,factor,reason,who\n"
                                       "hank,ch06/H_worked_example,2,,regrade request: the row order was unclear,bo\n"
                                       "nobody,total,1,,a learner not in this batch,bo\n", encoding="utf-8")
    fixed = submissions / "carol" / "exercises" / "ch06_measurement.py"
    fixed.write_text((REPO / "solutions" / "ch06_measurement.py").read_text(encoding="utf-8")
                     .replace("solutions.", "exercises."), encoding="utf-8")  # carol resubmits
    for _ in range(3):  # the override's run, then two rebuilds with nothing new
        runs.append(batch())
        snapshots.append((out / "changes.csv").read_text(encoding="utf-8"))
    return {"out": out, "runs": runs, "changes": snapshots, "submissions": submissions, "first": first_summary}


def _report(course, learner: str) -> dict:
    return json.loads((course["out"] / learner / "report.json").read_text(encoding="utf-8"))


@pytest.mark.slow
def test_the_unset_id_learner_is_flagged_and_told_whose_numbers_the_answers_fit(course):
    report = _report(course, "dave")
    quiz = [c for c in report["chapters"][0]["checks"] if c["kind"] == "quiz" and c["status"] == "fail"]
    assert quiz and all("the right answer for the numbers of learner 'anonymous'" in c["message"] for c in quiz)
    assert not any("not within the tolerance" in c["message"] for c in quiz)
    assert any("numbers of 'anonymous'" in w for w in report["batch"]["warnings"])
    assert "numbers of 'anonymous'" in _rows(course["out"] / "gradebook.csv")["dave"]["message"]


@pytest.mark.slow
def test_stale_and_edited_archives_are_flagged_with_their_reason(course):
    stan, eve = _report(course, "stan"), _report(course, "eve")
    assert any(f"packed with an older or other handout ({OLDER}, released 2026-03-01" in w and CURRENT in w
               for w in stan["batch"]["warnings"]), stan["batch"]["warnings"]
    assert stan["batch"]["manifest"]["learner"] == "stan" and stan["batch"]["manifest"]["local"]["score"] > 0
    assert any("edited after packing" in w and "ch06_measurement.py changed" in w for w in eve["batch"]["warnings"])
    summary = json.loads((course["out"] / "summary.json").read_text(encoding="utf-8"))
    assert {"dave", "stan", "eve"} <= set(summary["flagged"]) and "alice" not in summary["flagged"]
    assert summary["handouts"][OLDER] == 1
    page = (course["out"] / "summary.html").read_text(encoding="utf-8")
    assert "edited after packing" in page and OLDER in page


@pytest.mark.slow
def test_the_copied_pair_tops_the_similarity_list(course):
    similar = course["first"]["similar"]
    assert similar and similar[0]["learners"] == ["frank", "gina"], similar
    assert "ch06_measurement.measurement_covariance" in similar[0]["functions"]
    assert any("[1, 1] = var / d2" in block for block in similar[0]["shared"])  # frank's lines
    assert all(pair["score"] < similar[0]["score"] for pair in similar[1:])
    assert [line.strip() for line in course["runs"][0].stdout.splitlines() if "alike:" in line][0].startswith(
        "alike: frank and gina")


def test_similarity_ranks_a_renamed_copy_first_among_learners_who_wrote_alike(tmp_path):
    """grader.course.similarity on its own (the batch above runs it with --similarity): frank's renamed copy of gina's
    measurement_covariance makes them the most alike pair, above two learners who both handed in the references."""
    from grader.course import similarity

    staging = tmp_path / "staging"
    for name in ("alice", "bob"):
        build_submission(staging / name)
    for name, source in (("gina", GINA_COVARIANCE), ("frank", FRANK_COVARIANCE)):
        build_submission(staging / name, {"ch06_measurement": replace_function(
            "ch06_measurement", "measurement_covariance", source)})
    pairs, left_out = similarity.rank(staging, ["alice", "bob", "frank", "gina"])
    assert left_out == []
    assert pairs and (pairs[0].first, pairs[0].second) == ("frank", "gina"), [p.to_dict() for p in pairs]
    assert "ch06_measurement.measurement_covariance" in pairs[0].functions


@pytest.mark.slow
def test_an_override_survives_two_rebuilds_and_a_late_penalty_follows_the_roster(course):
    out = course["out"]
    hank = _report(course, "hank")
    assert [a["target"] for a in hank["adjustments"]] == ["ch06/H_worked_example"]
    assert hank["score"] == hank["raw_score"] + 2
    row = _rows(out / "gradebook.csv")["hank"]
    assert float(row["total"]) == hank["score"] and "regrade request" in row["adjustments"]
    jo = _report(course, "jo")
    late = [a for a in jo["adjustments"] if a["kind"] == "late"]
    assert late and "2 days late" in late[0]["reason"] and jo["score"] == pytest.approx(0.8 * jo["raw_score"])
    assert not [a for a in _report(course, "alice")["adjustments"] if a["kind"] == "late"]  # in time
    with sqlite3.connect(out / "gradebook.db") as db:
        runs = db.execute("SELECT id FROM runs WHERE finished IS NOT NULL ORDER BY id").fetchall()
        assert len(runs) == 4
        applied = db.execute("SELECT run, applied FROM overrides WHERE learner = 'hank' ORDER BY run").fetchall()
        assert applied == [(2, "+2"), (3, "+2"), (4, "+2")]
        scores = db.execute("SELECT run, score FROM results WHERE learner = 'hank' ORDER BY run").fetchall()
        assert [s for _, s in scores] == [hank["raw_score"]] + [hank["score"]] * 3
        assert db.execute("SELECT count(*) FROM results").fetchone()[0] == 4 * 11
    assert any("overrides.csv, line 3: no learner 'nobody'" in line for line in course["runs"][1].stderr.splitlines())


@pytest.mark.slow
def test_changes_csv_names_exactly_the_learners_whose_score_moved(course):
    first, second, third, fourth = (list(csv.DictReader(text.splitlines())) for text in course["changes"])
    assert {r["learner"] for r in first} == {"alice", "bob", "carol", "dave", "eve", "frank", "gina", "hank", "ivy",
                                             "jo", "stan"} and {r["why"] for r in first} == {"first graded"}
    moved = {r["learner"]: r for r in second}
    assert set(moved) == {"carol", "hank"}
    assert moved["hank"]["why"].startswith("override +2 on ch06/H_worked_example") and moved["hank"]["delta"] == "2"
    assert moved["carol"]["why"].startswith("resubmission") and float(moved["carol"]["delta"]) > 0
    assert third == [] and fourth == []
    assert "2 scores moved" in course["runs"][1].stdout and "0 scores moved" in course["runs"][3].stdout


@pytest.mark.slow
def test_the_named_mistake_counts_match_the_corpus(course):
    summary = json.loads((course["out"] / "summary.json").read_text(encoding="utf-8"))
    counted = {(m["chapter"], m["function"], m["mistake"]): m["learners"] for m in summary["mistakes"]
               if m["kind"] == "code"}
    expected: dict = {}
    for learner, entry in {**{k: v for k, v in CORPUS.items() if k != "carol"}, "ivy": "H transposed"}.items():
        module, function, _, name = CODE[entry]
        key = (module[:4], function, name)
        expected[key] = expected.get(key, 0) + 1
    assert counted == expected  # carol fixed hers; ivy's other code makes the same mistake
    upstream = {c["id"]: c for c in summary["checks"]}
    assert any(c["failed_upstream"] for c in upstream.values())  # H's failures make covariance fail, apart


@pytest.mark.slow
def test_every_json_validates_against_its_schema(course):
    jsonschema = pytest.importorskip("jsonschema")
    from referencing import Registry, Resource

    from grader.render import lms

    registry = Registry().with_resources((lms.schema(n)["$id"], Resource.from_contents(lms.schema(n)))
                                         for n in lms.SCHEMAS)

    def valid(name: str, path: Path) -> None:
        jsonschema.Draft202012Validator(lms.schema(name), registry=registry).validate(
            json.loads(path.read_text(encoding="utf-8")))

    valid("summary", course["out"] / "summary.json")
    for folder in course["out"].iterdir():
        if (folder / "report.json").is_file():
            valid("batch-report", folder / "report.json")
            valid("gradescope-results", folder / "results.json")


def test_submit_asks_for_the_id_on_a_terminal_and_writes_it_into_learner_yaml(tmp_path):
    folder = _learner(tmp_path / "asked", "x", learner_yaml="# your id\nlearner:\n")
    status, said = run_on_terminal([sys.executable, "-m", "grader", "submit"], folder, timeout=300,
                                   reply=(b"Your learner id", b"ada.lovelace\n"))
    assert status == 0, said
    assert (folder / "exercises" / "answers" / "learner.yaml").read_text(encoding="utf-8") == \
        "# your id\nlearner: ada.lovelace\n"
    assert (folder / "ada.lovelace.zip").is_file() and "check your answers" in said


def test_submit_refuses_without_an_id_or_with_one_that_disagrees(tmp_path):
    unset = _learner(tmp_path / "unset", "x", learner_yaml="learner:\n")
    refused = run_grade("submit", cwd=unset)
    assert refused.returncode == 2 and "no learner id" in refused.stderr and not list(unset.glob("*.zip"))
    other = _learner(tmp_path / "other", "ann")
    refused = run_grade("submit", "--learner", "bea", cwd=other)
    assert refused.returncode == 2 and "learner.yaml names 'ann' but --learner gives 'bea'" in refused.stderr


# ------------------------------------------------------------------------------ the pieces, one at a time

@pytest.fixture(scope="module")
def solutions_report():
    """ch05 and ch06 of the references, graded once in a course whose ch06 quiz is practice."""
    from grader.core.pipeline import Request, build_report
    from grader.course_config import Course
    from grader.submission import solutions_submission
    from tests.support import unbarred

    course = Course(id="practice-course", quiz_feedback="recorded", quiz_feedback_by={"ch06": "immediate"})
    session = unbarred().open_session(solutions_submission())
    return build_report(session, Request(("ch05", "ch06"), 20261122), course)


def test_a_practice_quiz_is_judged_never_counted_and_a_counted_one_never_shown_at_once(solutions_report):
    from grader.render import lms

    ch05, ch06 = solutions_report.chapters
    practice = [c for c in ch06.checks if c.kind == "quiz"]
    assert practice and all(c.practice and c.max_points == 0 and c.status.value == "pass" for c in practice)
    assert ch06.max_score_of("quiz") == 0 and ch05.max_score_of("quiz") > 0
    tests = {t["extra_data"]["id"]: t for t in lms.gradescope_data(solutions_report)["tests"]}
    assert {tests[f"ch06/{c.id}"]["visibility"] for c in practice} == {"visible"}
    assert {t["visibility"] for i, t in tests.items() if i.startswith("ch05/quiz_")} == {"after_published"}


def test_every_output_says_what_made_it(solutions_report, tmp_path):
    from grader.render import html, json_report, lms, text

    made = solutions_report.provenance()
    assert made["grader"].startswith("0.1.0+g") and made["seed"] == 20261122 and made["learner"] == "reference"
    assert made["course"] == "practice-course"
    footer = text.render(solutions_report).rstrip().splitlines()[-1]
    assert footer == (f"Graded by grader {made['grader']}, handout none, course practice-course, seed 20261122, "
                      "learner reference.")
    data = json.loads(json_report.render(solutions_report))
    assert data["provenance"] == made and data["version"] == "1.3"
    assert all(c["stable_id"] == f"{ch['chapter']}/{c['id']}" for ch in data["chapters"] for c in ch["checks"])
    assert footer in html.render(solutions_report)
    # Gradescope's results.json says all but the seed (each submission's own seed is drawn from the course's)
    assert json.loads(lms.gradescope(solutions_report))["extra_data"]["provenance"] == {
        k: v for k, v in made.items() if k != "seed"}
    assert made["grader"] in lms.junit([("x", solutions_report)])


@pytest.mark.parametrize("text, says", [
    ("quiz_feedback: {default: recorded, ch42: immediate}\n", "line 1: quiz_feedback names 'ch42'"),
    ("seed: 5\ndeadline: 2026-05-01T23:59:00\n", "line 2: deadline needs its time zone"),
    ("late_penalty: {per_day: 0.1}\n", "line 1: a late penalty needs a deadline"),
    ("deadline: 2026-05-01T23:59:00+02:00\nlate_penalty: {per_day: 2}\n", "line 2: per_day and max are shares"),
    ("handout: 7\n", "line 1: handout is the id of the current handout"),
])
def test_a_course_config_that_cannot_be_used_names_its_file_and_line(tmp_path, text, says):
    from grader import course_config

    path = tmp_path / "course_config.yaml"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(course_config.CourseError, match=says):
        course_config._from_yaml(path)


def test_a_course_config_gives_quiz_feedback_per_chapter_and_the_deadline(tmp_path):
    from grader import course_config

    path = tmp_path / "course_config.yaml"
    path.write_text("quiz_feedback: {default: immediate, ch06: recorded}\nhandout: 0.1.0+handout.abc\n"
                    "deadline: 2026-05-01T23:59:00+02:00\nlate_penalty: {per_day: 0.1, max: 0.3, grace_minutes: 10}\n",
                    encoding="utf-8")
    loaded = course_config._from_yaml(path)
    assert loaded.practice("ch05") and not loaded.practice("ch06") and loaded.current_handout == "0.1.0+handout.abc"
    at = course_config.datetime.fromisoformat
    assert loaded.late.fraction(at("2026-05-02T00:05:00+02:00")) == (0.0, 0)  # within the grace minutes
    assert loaded.late.fraction(at("2026-05-02T00:10:00+02:00")) == (0.1, 1)  # 11 minutes late, 1 after the grace
    assert loaded.late.fraction(at("2026-05-05T00:00:00+02:00")) == (0.3, 3)  # capped at max
