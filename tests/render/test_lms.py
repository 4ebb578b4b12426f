"""What `grade batch` writes for instructors' systems, from one real batch: gradebooks (generic, Canvas,
Moodle) that read back through csv and pandas with every id exactly as given, hostile and Unicode ones
included; a roster as spreadsheets save it (byte-order mark, ';', extra columns, quoted cells); junit.xml
valid against Jenkins' junit-10.xsd with times, failure text and chapter-level errors; report.json and
results.json valid against their published schemas; and a submission whose learner.yaml names someone
else flagged wherever its grade shows."""

from __future__ import annotations

import csv
import io
import json
import zipfile
from pathlib import Path

import pytest

from grader.course.staging import folder_name
from grader.render import lms
from tests.support import (
    build_submission,
    hostile_module,
    replace_function,
    run_grade,
)

jsonschema = pytest.importorskip("jsonschema")
pandas = pytest.importorskip("pandas")
etree = pytest.importorskip("lxml.etree")

XSD = Path(__file__).resolve().parents[1] / "fixtures" / "junit-10.xsd"
HIDDEN = "ch06/H_rows_orthogonal"
COURSE = f"course: lms-test\nseed: 5550123\nquiz_feedback: recorded\nhidden: [{HIDDEN}]\n"
# submission folder -> learner id, as the roster gives them: formulas, Unicode, quotes, separators, and
# texts a spreadsheet or pandas would take for something else (a number, a date, missing, a boolean)
ROSTER = {"s01": "=1+2", "s02": "007", "s03": "NA", "s04": "null", "s05": 'O\'Brien, "Jr"', "s06": "a;b",
          "s07": "李 雷", "s08": "zoë", "s09": "ann+cs101@uni.edu", "s10": "-x+1", "s11": "TRUE", "s12": "1e5",
          "s13": "2026-01-02", "alice": "alice", "bob.zip": "bob", "carol": "carol", "hostile": "hostile",
          "dave.zip": "dave"}
FORMULAS = {"=1+2", "-x+1"}
CHAPTERS = ["ch03", "ch06"]


@pytest.fixture(scope="module")
def graded(tmp_path_factory):
    base = tmp_path_factory.mktemp("lms")
    submissions = base / "submissions"
    submissions.mkdir()
    for folder in [f"s{n:02d}" for n in range(1, 14)] + ["alice"]:
        build_submission(submissions / folder)
    answers = submissions / "alice" / "exercises" / "answers"
    answers.mkdir()
    (answers / "learner.yaml").write_text("learner: alice\n", encoding="utf-8")  # agrees: not flagged
    bob = build_submission(base / "bob", {"ch06_measurement": replace_function(
        "ch06_measurement", "H_jacobian", "def H_jacobian(x, y):\n    r2 = x * x + y * y\n    r = np.sqrt(r2)\n"
                                          "    return np.array([[x / r, y / r], [y / r2, x / r2]])\n")})
    with zipfile.ZipFile(submissions / "bob.zip", "w") as archive:
        for path in sorted((bob / "exercises").glob("*.py")):
            archive.write(path, f"exercises/{path.name}")
        archive.writestr("exercises/answers/learner.yaml", "learner: robert\n")  # someone else's numbers
    build_submission(submissions / "carol", {"ch03_jacobian": "def J(:\n"})  # does not import
    build_submission(submissions / "hostile", {"ch06_measurement": hostile_module()})
    (submissions / "dave.zip").write_bytes(b"not a zip")
    roster = base / "roster.csv"  # as a spreadsheet saves it: BOM, ';', other columns, quoted cells, CRLF
    buffer = io.StringIO()
    writer = csv.writer(buffer, delimiter=";", lineterminator="\r\n")
    writer.writerow(["Name", "Learner", "Submission", "Email; work"])
    for submission, learner in ROSTER.items():
        writer.writerow([f"Name of {learner}", learner, submission, "x@y; z"])
    roster.write_bytes(buffer.getvalue().encode("utf-8-sig"))
    (base / "course.yaml").write_text(COURSE, encoding="utf-8")
    out = base / "out"
    done = run_grade("batch", submissions, "--out", out, "--roster", roster, "--chapters", ",".join(CHAPTERS),
                     "--course", base / "course.yaml", "--lms", "canvas", "--lms", "moodle", "--no-html", "--jobs", "2")
    return out, done


def _shown(learner: str) -> str:
    return "'" + learner if learner in FORMULAS else learner


@pytest.mark.slow
def test_the_gradebook_round_trips_every_id_through_csv_and_pandas(graded):
    out, done = graded
    assert done.returncode == 1, done.stderr[-3000:]  # dave's zip cannot be read
    expected = {_shown(learner) for learner in ROSTER.values()}
    with open(out / "gradebook.csv", newline="", encoding="utf-8") as handle:
        rows = {row["learner"]: row for row in csv.DictReader(handle)}
    assert set(rows) == expected
    frame = pandas.read_csv(out / "gradebook.csv", dtype=str, keep_default_na=False, encoding="utf-8")
    assert sorted(frame["learner"]) == sorted(expected)
    assert rows["007"]["ch06_code"] == rows["李 雷"]["ch06_code"] == rows["alice"]["ch06_code"] != ""
    assert float(rows["alice"]["ch06_code"]) > 0 and rows["dave"]["total"] == ""
    # what a spreadsheet would run is neutralised, and only that: the rest is exactly as given
    assert all(not cell.startswith(("=", "+", "-", "@")) for cell in frame["learner"])


def test_canvas_and_moodle_gradebooks_have_their_imports_columns_and_points_possible(graded):
    out, _ = graded
    canvas = pandas.read_csv(out / "gradebook-canvas.csv", dtype=str, keep_default_na=False)
    titles = [lms._column(c) for c in CHAPTERS]
    assert list(canvas.columns) == ["Student", "ID", "SIS User ID", "SIS Login ID", "Section", *titles,
                                    lms.BEYOND_CHAPTERS]
    assert canvas.iloc[0]["Student"].strip() == "Points Possible" and canvas.iloc[0][lms.BEYOND_CHAPTERS] == "0"
    possible = {c: float(canvas.iloc[0][lms._column(c)]) for c in CHAPTERS}
    alice = json.loads((out / "alice" / "report.json").read_text(encoding="utf-8"))
    assert possible == {c["chapter"]: c["max_score"] for c in alice["chapters"]}  # code and quiz, as graded
    learners = canvas.iloc[1:].set_index("SIS Login ID")
    assert sorted(learners.index) == sorted(_shown(v) for v in ROSTER.values())
    assert learners.loc["zoë", titles[1]] == learners.loc["alice", titles[1]] != ""
    assert learners.loc["dave", titles[1]] == ""
    assert float(learners.loc["bob", titles[1]]) < float(learners.loc["alice", titles[1]])
    moodle = pandas.read_csv(out / "gradebook-moodle.csv", dtype=str, keep_default_na=False)
    assert list(moodle.columns) == ["Learner id", *[f"{t} (out of {possible[c]:g})" for t, c in zip(titles, CHAPTERS)],
                                    f"{lms.BEYOND_CHAPTERS} (out of 0)", f"Total (out of {sum(possible.values()):g})",
                                    "Feedback"]
    rows = moodle.set_index("Learner id")
    assert rows.loc["O'Brien, \"Jr\"", f"Total (out of {sum(possible.values()):g})"] != ""
    assert rows.loc["dave"].iloc[0] == "" and rows.loc["dave", "Feedback"].startswith("Not graded (unreadable): ")
    # what was flagged is for the instructor's eyes: in gradebook.csv, never in the column the learner reads
    assert "learner.yaml names 'robert'" not in rows.loc["bob", "Feedback"]
    gradebook = pandas.read_csv(out / "gradebook.csv", dtype=str, keep_default_na=False).set_index("learner")
    assert "learner.yaml names 'robert'" in gradebook.loc["bob", "message"]


def test_junit_is_valid_for_jenkins_with_time_failure_text_and_chapter_errors(graded):
    out, _ = graded
    schema = etree.XMLSchema(etree.parse(str(XSD)))
    document = etree.parse(str(out / "junit.xml"))
    schema.assertValid(document)
    root = document.getroot()
    suites = {s.get("name"): s for s in root.findall("testsuite")}
    assert "dave" not in suites and len(suites) == len(ROSTER) - 1
    assert all(float(s.get("time")) > 0 for s in suites.values())
    assert int(root.get("tests")) == sum(len(s.findall("testcase")) for s in suites.values())
    for suite in suites.values():
        cases = suite.findall("testcase")
        assert int(suite.get("tests")) == len(cases)
        assert int(suite.get("failures")) == sum(c.find("failure") is not None for c in cases)
        assert int(suite.get("errors")) == sum(c.find("error") is not None for c in cases)
    bob = {c.get("name"): c for c in suites["bob"].findall("testcase")}
    failure = bob["code:H_worked_example"].find("failure")
    assert failure.get("type") == "fail" and "H[1,0]" in failure.text and failure.get("message") in failure.text
    carol = {c.get("name"): c for c in suites["carol"].findall("testcase")}
    chapter = carol["ch03:chapter"].find("error")
    assert "SyntaxError" in chapter.text and chapter.get("type") == "chapter"
    errors = [c.find("error") for n, c in carol.items() if n.startswith("code:") and c.get("classname") == "carol.ch03"]
    assert errors and all(e is not None and e.get("type") == "error" for e in errors)
    error = errors[0]
    assert "see the chapter's message" in error.text and "The chapter's message:" in error.text
    assert "SyntaxError" in error.text  # the message it points to is right there
    assert suites["hostile"].find("system-out") is not None


def test_every_json_file_is_valid_against_its_published_schema(graded):
    out, _ = graded
    report_schema = jsonschema.Draft202012Validator(lms.schema("batch-report"), registry=_registry())
    results_schema = jsonschema.Draft202012Validator(lms.schema("gradescope-results"))
    reports = list(out.glob("*/report.json"))
    assert len(reports) == len(ROSTER) - 1
    for path in reports:
        report_schema.validate(json.loads(path.read_text(encoding="utf-8")))
    for path in out.glob("*/results.json"):
        results = json.loads(path.read_text(encoding="utf-8"))
        results_schema.validate(results)
        visibility = {t["extra_data"]["id"]: t["visibility"] for t in results["tests"]}
        assert visibility[HIDDEN] == "after_published" and visibility["ch06/H_worked_example"] == "visible"


def test_a_learner_yaml_naming_someone_else_is_flagged_wherever_the_grade_shows(graded):
    out, done = graded
    warning = "learner.yaml names 'robert', but this submission is graded as 'bob' (from the roster roster.csv, line"
    report = json.loads((out / "bob" / "report.json").read_text(encoding="utf-8"))
    assert report["batch"]["warnings"][0].startswith(warning)
    assert warning in json.loads((out / "bob" / "results.json").read_text(encoding="utf-8"))["output"]
    with open(out / "gradebook.csv", newline="", encoding="utf-8") as handle:
        rows = {row["learner"]: row for row in csv.DictReader(handle)}
    assert rows["bob"]["status"] == "graded" and rows["bob"]["message"].startswith(warning)
    assert rows["alice"]["message"] == ""  # its learner.yaml agrees
    summary = (out / "summary.html").read_text(encoding="utf-8")
    assert "id='flagged'" in summary and "1 flagged" in summary and "robert" in summary
    assert f"flagged bob: {warning}" in done.stderr and "1 flagged" in done.stdout
    assert not json.loads((out / folder_name("alice") / "report.json").read_text(encoding="utf-8"))["batch"]["warnings"]


def _registry():
    from referencing import Registry, Resource

    return Registry().with_resources((lms.schema(n)["$id"], Resource.from_contents(lms.schema(n)))
                                     for n in lms.SCHEMAS)


def test_moodles_feedback_is_the_learners_own_words_and_nothing_for_the_instructor():
    """Moodle shows its Feedback column to the learner: each adjustment with its reason, in sentences that start with
    a word (never escaped as a spreadsheet formula), and nothing flagged for the instructor's eyes."""
    from grader.model import LearnerResult

    adjusted = LearnerResult("ann", "graded", score=7, chapters={"ch00": {"code": 7, "quiz": 0, "score": 7, "max": 10}},
                             adjustments=[{"target": "total", "points": -3, "reason": "agreed penalty",
                                           "kind": "override", "who": "bo", "source": "o.csv, line 2"},
                                          {"target": "total", "points": -1.5, "reason": "1 day late", "kind": "late",
                                           "who": "", "source": "the course config"}],
                             flags=["learner.yaml names 'bo' ...; correct the roster or the file and grade again"])
    not_graded = LearnerResult("cy", "unreadable", "cy.zip: not a valid zip file")
    rows = list(csv.DictReader(io.StringIO(lms.moodle_gradebook([adjusted, not_graded], ["ch00"]))))
    assert rows[0]["Feedback"] == "Override: -3 (agreed penalty); Late penalty: -1.5 (1 day late)"
    assert rows[1]["Feedback"] == "Not graded (unreadable): cy.zip: not a valid zip file"
    assert not any(row["Feedback"].startswith(("'", "=", "+", "-", "@")) for row in rows)
    assert "correct the roster" not in lms.moodle_gradebook([adjusted], ["ch00"])


def test_the_class_summary_says_a_first_run_is_a_first_run():
    from grader.render.summary import Summary, change_text, moved_line

    assert change_text(("kim", None, 198, 198, "first graded")) == "first graded: 198"
    assert change_text(("carl", 182.7, 203, 20.3, "late penalty: none now")) == "182.7 -> 203: late penalty: none now"
    assert change_text(("al", 12, None, None, "not in this run's submissions")) == (
        "not in this run's submissions (was 12)")
    assert moved_line(Summary(None, changes=[("kim", None, 198, 198, "first graded")] * 16, first_run=True)) == (
        "the history's first run: 16 learners graded first")
    assert moved_line(Summary(None, changes=[], first_run=False)) == "0 scores moved since the last run"


def test_a_learners_testsuite_is_written_as_elementtree_writes_it_whatever_its_text_holds():
    """junit.xml's suites are written as text: byte for byte what ElementTree writes of the same elements, for text
    with every character XML escapes in attributes and in text (& < > " CR LF TAB), empty messages and output."""
    from xml.etree import ElementTree

    from grader.model import ChapterResult, CheckResult, Report, Status
    from grader.render.lms import _suite, check_message, chapter_status
    from grader.safe_text import for_xml

    hostile = 'a & b < c > d "e" \'f\'\r\ng\th\x01 zoë'
    checks = [CheckResult("ok", "f", "", Status.PASS, 1, 1),
              CheckResult("bad", "f", "", Status.FAIL, 0, 1, message=hostile),
              CheckResult("empty", "f", "", Status.FAIL, 0, 1, message=""),
              CheckResult("broke", "f", "", Status.ERROR, 0, 1, message="one\ntwo"),
              CheckResult("later", "f", "", Status.SKIP, 0, 1),
              CheckResult("quiz_q", "q", "", Status.RECORDED, 0, 1, kind="quiz", message=hostile)]
    report = Report("x", [ChapterResult("ch06", "t", checks, problems=[hostile]), ChapterResult("ch05", "t")],
                    grader=hostile, learner_id="a&b")
    for learner, extra in ((hostile, {"seconds": 1.23456, "output": hostile}), ("plain", {})):
        name = for_xml(learner)
        suite = ElementTree.Element("testsuite", name=name)
        cases = []
        for chapter in report.chapters:
            if chapter.problems:
                cases.append((f"{name}.{chapter.chapter}", f"{chapter.chapter}:chapter",
                              "error" if chapter_status(chapter) == "error" else "failure",
                              "\n".join(chapter.problems), "chapter"))
            for check in chapter.checks:
                tag = {Status.FAIL: "failure", Status.ERROR: "error", Status.SKIP: "skipped",
                       Status.RECORDED: "skipped"}.get(check.status)
                cases.append((f"{name}.{chapter.chapter}", f"{check.kind}:{check.id}", tag,
                              check_message(check, chapter), check.status.value))
        counts = {tag: sum(c[2] == tag for c in cases) for tag in ("failure", "error", "skipped")}
        suite.attrib.update(tests=str(len(cases)), failures=str(counts["failure"]), errors=str(counts["error"]),
                            skipped=str(counts["skipped"]), time=f"{extra.get('seconds', 0.0):.3f}")
        properties = ElementTree.SubElement(suite, "properties")
        for key, value in report.provenance().items():
            ElementTree.SubElement(properties, "property", name=key, value=for_xml("" if value is None else str(value)))
        for classname, case_name, tag, text, kind in cases:
            case = ElementTree.SubElement(suite, "testcase", classname=classname, name=for_xml(case_name))
            if tag:
                element = ElementTree.SubElement(case, tag, message=for_xml(text.splitlines()[0][:200] if text else ""),
                                                 type=kind)
                if tag != "skipped" or text:
                    element.text = for_xml(text)
        if extra.get("output"):
            ElementTree.SubElement(suite, "system-out").text = for_xml(extra["output"])
        written, found, _ = _suite(learner, report, extra)
        assert written == ElementTree.tostring(suite, encoding="unicode")
        assert found == {**counts, "tests": len(cases)}
