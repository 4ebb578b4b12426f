"""One grade everywhere, and every mistake named where it is (issue 30).

A learner's grade is computed once, in the history (gradebook.db), with its late penalty and overrides; every
export prints it, to the precision it prints: gradebook.csv, Canvas' and Moodle's gradebooks (their columns add
up to it), each results.json and report.json. Gradescope's late penalty is the batch's. And the mistakes a user
makes are named at their own file and line, with nothing else lost."""

from __future__ import annotations

import csv
import json
import os
import shutil
import sqlite3
import subprocess
import sys
import textwrap
from decimal import Decimal
from pathlib import Path

import pytest

from tests.support import REPO, build_submission, grade_json, not_root, replace_function, run_grade

CHAPTERS = "ch05,ch06"
DEADLINE = "2026-05-01T23:59:00+00:00"
COURSE = textwrap.dedent(f"""\
    course: one-grade
    seed: 424242
    deadline: "{DEADLINE}"
    late_penalty: {{per_day: 0.1, max: 0.5}}
    """)
WRONG_H = replace_function("ch06_measurement", "H_jacobian", "def H_jacobian(x, y):\n    r2 = x * x + y * y\n"
                           "    r = np.sqrt(r2)\n    return np.array([[x / r, y / r], [y / r2, x / r2]])\n")
# learner: (their files, submitted, the override rows naming them)
CLASS = {
    "ann": ({}, "2026-05-01T12:00:00+00:00", []),  # on time
    "bo": ({}, "2026-05-03T10:00:00+00:00", []),  # two days late: -20%
    "cy": ({"ch06_measurement": WRONG_H}, "2026-05-01T12:00:00+00:00",
           ["cy,ch06/H_worked_example,2,,regrade,the instructor", "cy,total,-3,,agreed penalty,bo"]),
    "di": ({"ch06_measurement": WRONG_H}, "2026-05-04T09:00:00+00:00",
           ["di,ch06,,0.5,integrity panel,the instructor", "di,total,-1.25,,agreed,bo"]),
}


def _decimal(text: str) -> Decimal:
    return Decimal(text) if text else Decimal(0)


@pytest.fixture(scope="module")
def graded(tmp_path_factory) -> Path:
    base = tmp_path_factory.mktemp("one-grade")
    submissions = base / "submissions"
    for learner, (files, _, _) in CLASS.items():
        root = build_submission(submissions / learner, files)
        shutil.copytree(REPO / "solutions" / "answers", root / "exercises" / "answers", dirs_exist_ok=True)
        (root / "exercises" / "answers" / "learner.yaml").write_text(f"learner: {learner}\n", encoding="utf-8")
    (base / "roster.csv").write_text("submission,learner,submitted\n" + "".join(
        f"{learner},{learner},{when}\n" for learner, (_, when, _) in CLASS.items()), encoding="utf-8")
    (base / "overrides.csv").write_text("learner,target,points,factor,reason,who\n" + "".join(
        f"{row}\n" for _, _, rows in CLASS.values() for row in rows), encoding="utf-8")
    (base / "course.yaml").write_text(COURSE, encoding="utf-8")
    done = run_grade("batch", submissions, "--out", base / "out", "--chapters", CHAPTERS, "--roster",
                     base / "roster.csv", "--overrides", base / "overrides.csv", "--course", base / "course.yaml",
                     "--lms", "canvas", "--lms", "moodle", "--no-html", "--jobs", "2")
    assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-3000:]
    return base / "out"


def _history(out: Path) -> dict[str, float]:
    with sqlite3.connect(out / "gradebook.db") as db:
        run = db.execute("SELECT max(id) FROM runs").fetchone()[0]
        return dict(db.execute("SELECT learner, score FROM results WHERE run = ?", (run,)))


def _rows(path: Path) -> list[dict]:
    with open(path, encoding="utf-8", newline="") as handle:
        return list(csv.DictReader(handle))


def test_every_export_prints_the_historys_grade(graded):
    """For learners on time, late, overridden and both: every export's total is gradebook.db's final score, as
    printed (grader.model.points_text: rounded once), and an LMS's columns add up to it."""
    from grader.model import points_text

    history = _history(graded)
    assert set(history) == set(CLASS)
    scores = {learner: Decimal(points_text(score)) for learner, score in history.items()}
    penalised = {a["target"] for learner in ("bo", "di") for a in
                 json.loads((graded / learner / "report.json").read_text(encoding="utf-8"))["adjustments"]}
    assert "total" in penalised  # the class has a late penalty and total overrides to carry
    for row in _rows(graded / "gradebook.csv"):
        assert Decimal(row["total"]) == scores[row["learner"]], row
    canvas = _rows(graded / "gradebook-canvas.csv")
    columns = [c for c in canvas[0] if c.startswith("ch0") or c.startswith("Late penalty")]
    for row in canvas[1:]:
        assert sum(_decimal(row[c]) for c in columns) == scores[row["Student"]], row
    moodle = _rows(graded / "gradebook-moodle.csv")
    parts = [c for c in moodle[0] if c.startswith(("ch0", "Late penalty"))]
    total = next(c for c in moodle[0] if c.startswith("Total"))
    for row in moodle:
        assert sum(_decimal(row[c]) for c in parts) == Decimal(row[total]) == scores[row["Learner id"]], row
    for learner in CLASS:
        report = json.loads((graded / learner / "report.json").read_text(encoding="utf-8"))
        results = json.loads((graded / learner / "results.json").read_text(encoding="utf-8"))
        assert Decimal(str(report["score"])) == Decimal(str(results["score"])) == scores[learner]
        assert "seed" not in results["extra_data"]["provenance"]  # the course seed stays the instructor's
    raw = Decimal(str(json.loads((graded / "bo" / "report.json").read_text(encoding="utf-8"))["raw_score"]))
    assert scores["bo"] == (raw * Decimal("0.8")).quantize(Decimal("0.0001"))  # two days late: -20%


def test_a_late_archive_scores_on_gradescope_as_in_the_batch(graded, tmp_path):
    """Gradescope's time (created_at, which the learner cannot write) against the assignment's due date gives the
    same penalty as the roster's time in grade batch."""
    root = tmp_path / "autograder"
    (root / "source").mkdir(parents=True)
    shutil.copy(graded.parent / "course.yaml", root / "source" / "course.yaml")
    settings = {"course": "one-grade", "chapters": CHAPTERS.split(","), "learner_field": "email",
                "time_budget": 60, "sandbox": "off"}
    (root / "source" / "autograder.json").write_text(json.dumps(settings), encoding="utf-8")
    shutil.copytree(graded.parent / "submissions" / "bo" / "exercises", root / "submission" / "exercises")
    metadata = {"id": 777, "created_at": CLASS["bo"][1], "assignment": {"due_date": DEADLINE},
                "users": [{"email": "bo", "id": 1, "name": "Bo"}]}
    (root / "submission_metadata.json").write_text(json.dumps(metadata), encoding="utf-8")
    done = subprocess.run(not_root([sys.executable, "-m", "grader.course.gradescope", "run", str(root)]), cwd=REPO,
                          capture_output=True, text=True, encoding="utf-8", timeout=600)
    assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-3000:]
    results = json.loads((root / "results" / "results.json").read_text(encoding="utf-8"))
    assert results["score"] == _history(graded)["bo"]
    assert any(a["kind"] == "late" for a in results["extra_data"]["adjustments"])


# ------------------------------------------------------------------------------ named where they are

def test_an_earlier_chapters_syntax_error_is_named_at_its_own_file_and_line(tmp_path):
    root = build_submission(tmp_path, {"ch06_measurement": (REPO / "solutions" / "ch06_measurement.py").read_text(
        encoding="utf-8").replace("solutions.", "exercises.") + "\ndef broken(:\n"})
    report = grade_json("ch08", "--submission", root, "--no-quiz")
    problem = report["chapters"][0]["problems"][0]
    lines = (root / "exercises" / "ch06_measurement.py").read_text(encoding="utf-8").count("\n")
    assert problem.startswith(f"{Path('exercises/ch06_measurement.py')} (imported by {Path('exercises/ch08_lab.py')}), "
                              f"line {lines}: SyntaxError"), problem


def test_a_missing_colon_costs_only_its_own_answer_named_at_its_line(quiz):
    from tests.support import RIGHT_CHOICE, RIGHT_FACTS

    results, problems = quiz("ch06", f"bearing_near_dish: {RIGHT_CHOICE}\n# a comment\n\nH_facts {RIGHT_FACTS}\n")
    assert results["bearing_near_dish"].status.value == "pass"
    facts = results["H_facts"].message
    assert "line 4, question H_facts: no ':' after the question id" in facts and "not answered" not in facts
    assert not any("not valid YAML" in p for p in problems), problems


@pytest.mark.parametrize("encoding", ["utf-16", "utf-8-sig"])
def test_files_saved_as_utf16_or_with_a_bom_are_read_and_said_so(tmp_path, encoding):
    from tests.support import RIGHT_CHOICE

    root = build_submission(tmp_path)
    chapter = root / "exercises" / "ch06_measurement.py"
    chapter.write_bytes(chapter.read_text(encoding="utf-8").encode(encoding))
    answers = root / "exercises" / "answers"
    answers.mkdir(exist_ok=True)
    (answers / "ch06.yaml").write_bytes(f"bearing_near_dish: {RIGHT_CHOICE}\n".encode(encoding))
    (answers / "learner.yaml").write_bytes("learner: alice\n".encode(encoding))
    report = grade_json("ch06", "--submission", root)
    chapter_result = report["chapters"][0]
    code = [c for c in chapter_result["checks"] if c["kind"] == "code"]
    assert all(c["status"] == "pass" for c in code), [c["message"] for c in code if c["status"] != "pass"]
    quiz = {c["function"]: c for c in chapter_result["checks"] if c["kind"] == "quiz"}
    assert quiz["bearing_near_dish"]["status"] == "pass"
    assert report["provenance"]["learner"] == "alice"
    assert sum("save it as UTF-8" in note for note in chapter_result["notes"]) == 2, chapter_result["notes"]


def test_a_misspelled_hidden_check_is_refused_by_every_command_that_reads_the_course(tmp_path):
    course = tmp_path / "course.yaml"
    course.write_text("course: c\nseed: 5\nhidden: [ch06/H_rows_orthogonl]\n", encoding="utf-8")
    (tmp_path / "subs" / "ann").mkdir(parents=True)
    commands = [("batch", tmp_path / "subs", "--out", tmp_path / "out"), ("gradescope", tmp_path / "ag.zip"),
                ("release", tmp_path / "handout")]
    for command in commands:
        done = run_grade(*command, "--course", course)
        assert done.returncode == 2, (command, done.stderr[-2000:])
        assert "line 3" in done.stderr and "did you mean ch06/H_rows_orthogonal?" in done.stderr, done.stderr


def test_the_notebook_handouts_readme_is_about_notebooks(tmp_path):
    from grader import course_config
    from grader.course import release

    for notebooks in (True, False):
        release._write_readme(tmp_path, Path("grader.whl"), course_config.Course(), {}, notebooks)
        text = (tmp_path / "README.md").read_text(encoding="utf-8")
        assert ("%grade ch06" in text and ".ipynb" in text and "[notebook]" in text) == notebooks
        assert ("Fill in a function in `exercises/chNN_*.py`" in text) != notebooks


def test_grade_says_early_whose_quiz_numbers_these_are_while_no_id_is_set(tmp_path):
    root = build_submission(tmp_path)
    done = run_grade("quiz", "ch06", "--submission", root)
    assert "are those of 'anonymous' until you put `learner: your-id`" in done.stdout, done.stdout[-2000:]


def test_grade_submit_asks_again_for_an_id_it_cannot_take(tmp_path):
    """At the prompt, an id with a path separator is refused with the reason, and the learner types another;
    an id with a space is an id (as grade batch takes it)."""
    import pty
    import select

    root = build_submission(tmp_path / "project")
    (root / "exercises" / "answers").mkdir(exist_ok=True)
    master, slave = pty.openpty()
    process = subprocess.Popen([sys.executable, "-m", "grader", "submit"], cwd=root, stdin=slave, stdout=slave,
                               stderr=slave)
    os.close(slave)
    seen, replies = b"", [b"dana/smith\n", b"dana smith\n"]
    while True:
        if not select.select([master], [], [], 120)[0]:
            break
        try:
            chunk = os.read(master, 65536)
        except OSError:
            break
        if not chunk:
            break
        seen += chunk
        if replies and seen.count(b"course lists you") > 2 - len(replies):
            os.write(master, replies.pop(0))
    process.wait(timeout=300)
    os.close(master)
    text = seen.decode(errors="replace")
    assert "contains a path separator" in text and process.returncode == 0, text[-3000:]
    assert (root / "dana smith.zip").is_file()
    assert "learner: dana smith" in (root / "exercises" / "answers" / "learner.yaml").read_text(encoding="utf-8")


# ------------------------------------------------------------------------------ smaller

def test_the_html_report_folds_functions_not_written_yet(tmp_path):
    page = tmp_path / "report.html"
    done = run_grade("ch06", "--submission", REPO, "--no-quiz", "--html", page)
    html = page.read_text(encoding="utf-8")
    from grader import checks

    functions = {c.function for c in checks.load("ch06").checks}
    assert html.count('<div class="check ') == len(functions)  # one line per function, not per check
    assert f"Wrote the HTML report: {page}" in done.stderr


def test_hidden_checks_are_counted_in_words():
    from grader.model import ChapterResult, Report
    from grader.render import html, text

    report = Report("x", [ChapterResult("ch06", "t", hidden_checks=1, hidden_points=1.0)])
    assert "1 hidden check (1 point) run" in text.render(report)
    assert "1 hidden check (1 point) runs when you submit" in html.render(report)


def test_usage_lines_say_grade_and_a_chapters_file_name_is_pointed_at_its_chapter():
    done = run_grade("ch06", "--bogus")
    assert done.returncode == 2 and done.stderr.startswith("Usage: python -m grader [OPTIONS] CHAPTER..."), done.stderr  # as typed
    done = run_grade("ch06_measurement.py")
    assert done.returncode == 2 and "`grade ch06`" in done.stderr, done.stderr


def test_grade_in_the_project_reports_the_projects_course():
    import yaml

    course = yaml.safe_load((REPO / "solutions" / "course.yaml").read_text(encoding="utf-8"))["course"]
    report = grade_json("ch06", "--solutions", "--no-quiz")
    assert report["provenance"]["course"] == course


def test_release_into_a_folder_that_is_not_empty_is_a_usage_error(tmp_path):
    (tmp_path / "out").mkdir()
    (tmp_path / "out" / "keep.txt").write_text("x", encoding="utf-8")
    done = run_grade("release", tmp_path / "out")
    assert done.returncode == 2 and "is not empty" in done.stderr, done.stderr


@pytest.mark.slow
def test_percent_grade_says_when_the_kernels_code_is_not_the_saved_file(tmp_path):
    """The notebook defines the chapter's functions (the kernel ran them) while the saved chapter file holds the
    stubs: %grade grades the kernel's code and says that grade ch06 and grade submit grade the saved file."""
    pytest.importorskip("IPython")
    project = tmp_path / "project"
    shutil.copytree(REPO / "exercises", project / "exercises")
    code = ("import os, sys\nos.chdir(sys.argv[1])\nfrom IPython.testing.globalipapp import start_ipython\n"
            "ip = start_ipython()\nip.run_line_magic('load_ext', 'grader')\n"
            "ip.run_cell(open(sys.argv[2], encoding='utf-8').read().replace('solutions.', 'exercises.'), "
            "store_history=True)\nprint(ip.run_line_magic('grade', 'ch06 --no-quiz').text)\n")
    done = subprocess.run([sys.executable, "-c", code, str(project), str(REPO / "solutions" / "ch06_measurement.py")],
                          capture_output=True, text=True, encoding="utf-8", timeout=300)
    assert "ch06 total: 27/27" in done.stdout, done.stdout[-2000:] + done.stderr[-2000:]
    assert "graded the code this notebook's kernel ran; the saved ch06_measurement.py has other code for" in done.stdout
    assert "save the notebook before you submit" in done.stdout


def test_points_are_rounded_once_wherever_they_are_set():
    """A check's and an adjustment's points are rounded as they are set: built, assigned, replaced, read back from
    a report's data; and a check still cannot be built without them."""
    import dataclasses

    from grader.model import Adjustment, ChapterResult, CheckResult, Status, rounded_points

    check = CheckResult("c", "f", "d", Status.PASS, 2 / 3, 1 / 3)
    assert (check.points, check.max_points) == (rounded_points(2 / 3), rounded_points(1 / 3)) == (0.6667, 0.3333)
    check.points = 1 / 7
    assert check.points == 0.1429 and dataclasses.replace(check, max_points=5 / 7).max_points == 0.7143
    assert ChapterResult.from_dict({"chapter": "ch06", "checks": [dict(check.to_dict(), points=1 / 9)]}).checks[
        0].points == 0.1111
    adjustment = Adjustment("total", -2 / 3, "late")
    assert adjustment.points == -0.6667
    adjustment.points = 1 / 6
    assert adjustment.points == 0.1667
    with pytest.raises(TypeError):
        CheckResult("c", "f", "d", Status.PASS)  # type: ignore[call-arg]


def test_a_late_penalty_waived_leaves_its_trace_everywhere_the_grade_is(tmp_path):
    """dee, two days late, has the penalty waived by an overrides row: the waiver is an adjustment of 0 points with its
    reason in report.json, report.html and results.json, the gradebook's adjustments cell and Moodle's feedback, and
    the history keeps what it did."""
    from click.testing import CliRunner

    from grader.faces.cli import main
    from tests.support import chapter_submission

    chapter_submission(tmp_path / "submissions" / "dee", "dee")
    (tmp_path / "roster.csv").write_text("submission,learner,submitted\ndee,dee,2026-05-03T12:00:00+00:00\n",
                                         encoding="utf-8")
    (tmp_path / "course.yaml").write_text(COURSE, encoding="utf-8")
    (tmp_path / "overrides.csv").write_text("learner,target,points,factor,reason,who\n"
                                            "dee,late,,0,accommodation: extension to Friday,the instructor\n",
                                            encoding="utf-8")
    out = tmp_path / "out"
    done = CliRunner().invoke(main, ["batch", str(tmp_path / "submissions"), "--out", str(out), "--chapters", "ch00",
                                     "--roster", str(tmp_path / "roster.csv"),
                                     "--course", str(tmp_path / "course.yaml"),
                                     "--overrides", str(tmp_path / "overrides.csv"), "--lms", "moodle"])
    assert done.exit_code == 0, done.output
    report = json.loads((out / "dee" / "report.json").read_text(encoding="utf-8"))
    [waiver] = report["adjustments"]
    assert waiver["kind"] == "late" and waiver["points"] == 0 and report["score"] == report["raw_score"]
    assert "2 days late" in waiver["reason"] and "waived by override: accommodation: extension to Friday" in \
        waiver["reason"] and waiver["who"] == "the instructor" and waiver["source"] == "overrides.csv, line 2"
    assert "accommodation: extension to Friday" in (out / "dee" / "report.html").read_text(encoding="utf-8")
    results = json.loads((out / "dee" / "results.json").read_text(encoding="utf-8"))
    assert results["extra_data"]["adjustments"] == report["adjustments"] and "late penalty: +0" in results["output"]
    with (out / "gradebook.csv").open(newline="", encoding="utf-8") as handle:
        [row] = list(csv.DictReader(handle))
    assert "late penalty +0 on total" in row["adjustments"] and "extension to Friday" in row["adjustments"]
    with (out / "gradebook-moodle.csv").open(newline="", encoding="utf-8") as handle:
        [row] = list(csv.DictReader(handle))
    assert row["Feedback"].startswith("Late penalty: +0 (2 days late") and "extension to Friday" in row["Feedback"]
    with sqlite3.connect(out / "gradebook.db") as db:
        [(applied,)] = db.execute("SELECT applied FROM overrides").fetchall()
    assert applied.startswith("waived a late penalty of -")
