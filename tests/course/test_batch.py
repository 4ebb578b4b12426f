"""grade batch: layouts, zips, roster, outputs in every format, resuming, and a killed run."""

from __future__ import annotations

import csv
import html
import json
import os
import signal
import sqlite3
import subprocess
import sys
import time
import zipfile
from pathlib import Path
from xml.etree import ElementTree

import pytest
from click.testing import CliRunner

from grader.course.staging import StagingError, discover, stage
from grader.faces.cli import main
from tests.support import (
    build_submission,
    code_points,
    replace_function,
    run_grade,
    run_on_terminal,
)

CHAPTERS = "ch03,ch06"


def _zip(folder: Path, target: Path, prefix: str = "") -> Path:
    with zipfile.ZipFile(target, "w") as archive:
        for path in sorted(folder.rglob("*.py")):
            archive.write(path, prefix + str(path.relative_to(folder)))
    return target


@pytest.fixture
def submissions(tmp_path):
    folder = tmp_path / "submissions"
    folder.mkdir()
    build_submission(folder / "alice")  # exercises/ layout, all right
    flat = build_submission(tmp_path / "flat")  # chapter files directly in the folder
    (folder / "bob").mkdir()
    for path in (flat / "exercises").glob("ch0*.py"):
        (folder / "bob" / path.name).write_text(path.read_text())
    wrong = build_submission(tmp_path / "wrong", {"ch06_measurement": replace_function(
        "ch06_measurement", "H_jacobian", "def H_jacobian(x, y):\n    r2 = x * x + y * y\n    r = np.sqrt(r2)\n"
                                          "    return np.array([[x / r, y / r], [y / r2, x / r2]])\n")})
    _zip(wrong, folder / "carol.zip", prefix="carol-main/")
    (folder / "dave.zip").write_bytes(b"this is not a zip")
    return folder


def _rows(path: Path) -> list[dict]:
    with path.open(newline="") as handle:
        return list(csv.DictReader(handle))


def _invoke(*args):
    result = CliRunner().invoke(main, ["batch", *map(str, args)])
    return result


@pytest.mark.slow
def test_batch_outputs_every_format(submissions, tmp_path):
    out = tmp_path / "out"
    result = _invoke(submissions, "--out", out, "--chapters", CHAPTERS, "--jobs", "2")
    assert result.exit_code == 1  # dave's zip cannot be read
    assert "dave: dave.zip: dave.zip is not a valid zip file" in result.output
    rows = _rows(out / "gradebook.csv")
    by_learner = {row["learner"]: row for row in rows}
    assert set(by_learner) == {"alice", "bob", "carol", "dave"}
    assert list(rows[0]) == ["learner", "ch03_code", "ch03_quiz", "ch06_code", "ch06_quiz", "total", "max_total",
                             "status", "message", "adjustments", "grader", "handout", "seed"]
    assert by_learner["alice"]["ch06_code"] == by_learner["bob"]["ch06_code"] == code_points("ch06")
    assert float(by_learner["carol"]["ch06_code"]) < float(code_points("ch06")) and by_learner["carol"]["ch03_code"] == code_points("ch03")
    assert by_learner["dave"]["status"] == "unreadable" and by_learner["dave"]["total"] == ""
    assert "not a valid zip file" in by_learner["dave"]["message"] and by_learner["alice"]["message"] == ""
    report = json.loads((out / "carol" / "report.json").read_text())
    assert report["chapters"][1]["chapter"] == "ch06"
    gradescope = json.loads((out / "carol" / "results.json").read_text())
    assert gradescope["score"] == report["score"]
    test = gradescope["tests"][0]
    assert {"name", "score", "max_score", "status", "output", "visibility"} <= set(test)
    assert any(t["status"] == "failed" and "H[1,0]" in t["output"] for t in gradescope["tests"])
    assert (out / "carol" / "report.html").read_text().count("<section class=\"chapter\"") == 2
    suites = ElementTree.parse(out / "junit.xml").getroot()
    assert {s.get("name") for s in suites} == {"alice", "bob", "carol"}
    carol = next(s for s in suites if s.get("name") == "carol")
    assert int(carol.get("failures")) > 0
    summary = (out / "summary.html").read_text()
    assert "id='histogram'" in summary and "id='failure-rates'" in summary and "id='messages'" in summary
    rates_section = summary[summary.index("id='failure-rates'"):summary.index("id='messages'")]
    rates = [int(r) for r in __import__("re").findall(r"(\d+)%</td>", rates_section)]
    assert rates == sorted(rates, reverse=True) and "ch06/H_worked_example" in rates_section
    worked = next(c for c in report["chapters"][1]["checks"] if c["id"] == "H_worked_example")
    assert worked["status"] == "fail" and html.escape(worked["message"].splitlines()[0][:160]) in summary


@pytest.mark.slow
def test_batch_plots_draw_each_learners_figures_from_their_own_values(tmp_path):
    """`--plots`: each learner's report.html has a figure per plotted chapter, drawn from what that learner's
    functions returned: a doubled measurement_covariance changes only ch06's figure."""
    import base64
    import re

    folder = tmp_path / "submissions"
    folder.mkdir()
    build_submission(folder / "alice")
    doubled = ("def measurement_covariance(x, y, sigma):\n"
               "    H = H_jacobian(x, y)\n"
               "    return 2 * float(sigma) ** 2 * (H @ H.T)\n")
    build_submission(folder / "erin", {"ch06_measurement": replace_function(
        "ch06_measurement", "measurement_covariance", doubled)})
    out = tmp_path / "out"
    result = _invoke(folder, "--out", out, "--chapters", "ch06,ch07", "--plots", "--jobs", "2")
    assert result.exit_code in (0, 1), result.output

    def figures(learner: str) -> dict[str, bytes]:
        page = (out / learner / "report.html").read_text(encoding="utf-8")
        uris = re.findall(r"data:image/svg\+xml;base64,([A-Za-z0-9+/=]+)", page)
        assert len(uris) == 2, (learner, len(uris))  # one plot each for ch06 and ch07, in page order
        return dict(zip(["ch06", "ch07"], (base64.b64decode(u) for u in uris)))

    alice, erin = figures("alice"), figures("erin")
    assert all(svg.lstrip().startswith(b"<?xml") and b"<svg" in svg for svg in [*alice.values(), *erin.values()])
    assert alice["ch07"] == erin["ch07"]  # the same values: the same figure
    assert alice["ch06"] != erin["ch06"]  # erin's own covariance


def test_roster_names_learners(submissions, tmp_path):
    roster = tmp_path / "roster.csv"
    roster.write_text("submission,learner\nalice,s1001\ncarol.zip,s1003\n")
    names = {e.learner for e in discover(submissions, roster)}
    assert {"s1001", "s1003", "bob", "dave"} == names


def test_roster_as_spreadsheets_save_it(submissions, tmp_path):
    """A byte-order mark, ';' between columns, other columns, capitals and CRLF line ends."""
    roster = tmp_path / "roster.csv"
    roster.write_bytes("Name;Learner;Submission\r\nA;zoë;alice\r\nC;ann+cs101@uni.edu;carol.zip\r\n"
                       .encode("utf-8-sig"))
    assert {e.learner for e in discover(submissions, roster)} == {"zoë", "ann+cs101@uni.edu", "bob", "dave"}


def test_a_roster_separated_by_semicolons_with_commas_inside_quoted_cells(submissions, tmp_path):
    roster = tmp_path / "roster.csv"
    roster.write_bytes('submission;learner;"Name, First, Middle"\nalice;"Lee, Ann";"Lee, Ann, B."\n'
                       .encode("utf-8-sig"))
    assert {e.learner for e in discover(submissions, roster)} == {"Lee, Ann", "bob", "carol", "dave"}


@pytest.mark.parametrize("content, says", [
    (b"folder,student\nalice,s1\n", "line 1: the header must name the columns submission and learner"),
    ("submission,learner\nalice,zo\u00eb\n".encode("latin-1"), "not UTF-8 text"),
])
def test_a_roster_that_cannot_be_read_is_a_usage_error(submissions, tmp_path, content, says):
    roster = tmp_path / "roster.csv"
    roster.write_bytes(content)
    result = _invoke(submissions, "--out", tmp_path / "out", "--roster", roster)
    assert result.exit_code == 2 and says in result.output and str(roster) in result.output, result.output
    assert not (tmp_path / "out").exists()


@pytest.mark.slow
def test_rerun_skips_unchanged_and_regrades_changed(submissions, tmp_path):
    out = tmp_path / "out"
    _invoke(submissions, "--out", out, "--chapters", CHAPTERS, "--no-html")
    first = (out / "alice" / "report.json").stat().st_mtime_ns
    again = _invoke(submissions, "--out", out, "--chapters", CHAPTERS, "--no-html")
    assert "3 unchanged" in again.output and "graded 0" in again.output
    assert (out / "alice" / "report.json").stat().st_mtime_ns == first
    target = submissions / "alice" / "exercises" / "ch03_jacobian.py"
    target.write_text(target.read_text() + "\n# changed\n")
    third = _invoke(submissions, "--out", out, "--chapters", CHAPTERS, "--no-html")
    assert "graded 1" in third.output
    assert (out / "alice" / "report.json").stat().st_mtime_ns != first


def test_zip_entries_outside_the_archive_are_never_extracted(tmp_path):
    target = tmp_path / "evil.zip"
    with zipfile.ZipFile(target, "w") as archive:
        archive.writestr("../../ch06_measurement.py", "x = 1\n")
        archive.writestr("/abs/ch03_jacobian.py", "x = 1\n")
        archive.writestr("exercises/ch00_range_sensor.py", "x = 1\n")
    from grader.course.staging import Entry

    root = stage(Entry("evil", target), tmp_path / "staging")
    assert sorted(p.name for p in (root / "exercises").glob("ch*.py")) == ["ch00_range_sensor.py"]
    assert not (tmp_path / "ch06_measurement.py").exists()


def test_oversized_zip_member_is_refused(tmp_path):
    target = tmp_path / "bomb.zip"
    with zipfile.ZipFile(target, "w", compression=zipfile.ZIP_DEFLATED) as archive:
        archive.writestr("ch06_measurement.py", "#" * (4 << 20))
    from grader.course.staging import Entry

    with pytest.raises(StagingError, match="bytes"):
        stage(Entry("bomb", target), tmp_path / "staging")


@pytest.mark.slow
def test_a_killed_run_loses_nothing_graded_and_never_leaves_half_files(submissions, tmp_path):
    out = tmp_path / "out"
    for i in range(6):
        build_submission(submissions / f"extra{i}")
    proc = subprocess.Popen([sys.executable, "-m", "grader", "batch", str(submissions), "--out", str(out),
                             "--chapters", CHAPTERS, "--jobs", "1", "--no-html"],
                            cwd=Path(__file__).resolve().parents[2], start_new_session=True,
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and len(list(out.glob("*/report.json"))) < 2:
        time.sleep(0.05)
    os.killpg(proc.pid, signal.SIGKILL)
    proc.wait()
    done = list(out.glob("*/report.json"))
    assert done, "nothing was graded before the kill"
    # every written report is whole; one without a hash could not be graded (its child did not start, twice, on a
    # busy machine): the next run grades it again, by design
    kept = [path for path in done if json.loads(path.read_text())["batch"].get("hash")]
    assert not (out / "gradebook.csv").exists() or _rows(out / "gradebook.csv") is not None
    with sqlite3.connect(out / "gradebook.db") as db:  # the history kept each learner graded before the kill
        assert db.execute("SELECT finished FROM runs").fetchall() == [(None,)]
        recorded = db.execute("SELECT count(*) FROM results WHERE status = 'graded'").fetchone()[0]
        assert len(kept) - 1 <= recorded <= len(kept)  # the last may have been killed between its files and its row
    result = _invoke(submissions, "--out", out, "--chapters", CHAPTERS, "--no-html")
    assert f"{recorded} unchanged" in result.output, (result.output, repr(result.exception))  # what the history kept
    rows = _rows(out / "gradebook.csv")
    assert len(rows) == 10 and all(r["status"] in ("graded", "unreadable") for r in rows)
    with sqlite3.connect(out / "gradebook.db") as db:
        assert [f is not None for (f,) in db.execute("SELECT finished FROM runs ORDER BY id")] == [False, True]


def test_two_submissions_with_the_same_id_keep_both(tmp_path):
    folder = tmp_path / "submissions"
    folder.mkdir()
    flat = build_submission(tmp_path / "flat")
    build_submission(folder / "alice")
    _zip(flat, folder / "alice.zip")
    entries = discover(folder)
    assert sorted(e.learner for e in entries) == ["alice", "alice-2"]
    assert len({e.source for e in entries}) == 2


def test_many_submissions_with_one_id_each_get_the_next_free_name(tmp_path):
    """The roster gives five submissions one id and a sixth, first in the folder's order, the name a third
    would be made unique as: no two share an id, each takes the first id-n still free, in the folder's order."""
    folder = tmp_path / "submissions"
    for name in ("0", "a1", "a2", "a3", "b1", "b2"):
        (folder / name).mkdir(parents=True)
    roster = tmp_path / "roster.csv"
    roster.write_text("submission,learner\n0,alice-3\n"
                      + "".join(f"{name},alice\n" for name in ("a1", "a2", "a3", "b1", "b2")))
    entries = discover(folder, roster)
    assert [(e.source.name, e.learner) for e in entries] == [
        ("0", "alice-3"), ("a1", "alice"), ("a2", "alice-2"), ("a3", "alice-4"), ("b1", "alice-5"), ("b2", "alice-6")]
    assert [e.origin.endswith("made unique") for e in entries] == [False, False, True, True, True, True]


@pytest.mark.slow
def test_class_outputs_do_not_depend_on_the_order_learners_finish_in(submissions, tmp_path, monkeypatch):
    """grade batch takes each learner into junit.xml and the summary's counts as they finish, in the batch's
    order, keeping few reports that finish early (HELD_REPORTS) and reading the others from the history again
    when their turn comes: every order of finishing gives what the batch wrote."""
    import io

    from grader.course import outputs
    from grader.course.history import History
    from grader.render import summary

    out = tmp_path / "out"
    _invoke(submissions, "--out", out, "--chapters", CHAPTERS, "--no-html")
    rows = {row["learner"]: row for row in _rows(out / "gradebook.csv")}
    learners = sorted(rows)
    statuses = {learner: row["status"] for learner, row in rows.items()}
    monkeypatch.setattr(outputs, "HELD_REPORTS", 1)
    taken = []
    with History(out / "gradebook.db") as history:
        run = history.last_finished()
        results = history.results(run)
        for order in (learners, learners[::-1], [learners[2], learners[0], learners[3], learners[1]]):
            collected = outputs.ClassOutputs(out, history, run, learners, CHAPTERS.split(","))
            for learner in order:
                collected.arrived(results[learner], history.report(results[learner]))
            collected.finish()
            text, json_text = io.StringIO(), io.StringIO()
            collected.junit.write(text)
            summary.write_json(summary.Summary(collected.tally, collected.not_graded, flagged=collected.flagged),
                               json_text)
            taken.append((text.getvalue(), json_text.getvalue(), [r.learner for r in collected.results.values()]))
            collected.close()
    assert taken[0][0] == (out / "junit.xml").read_text(encoding="utf-8")
    assert [statuses[learner] for learner in learners] == ["graded", "graded", "graded", "unreadable"]
    assert taken[0][2] == learners and list(json.loads(taken[0][1])["not_graded"]) == ["dave"]
    assert taken[1] == taken[0] and taken[2] == taken[0]


def test_the_summary_counts_failure_messages_as_a_counter_does():
    """summary.Messages keeps the messages per check and named mistake on disk, and ranks them as
    Counter.most_common: by count, ties in the order first seen (a lone surrogate kept)."""
    from collections import Counter

    from grader.render.summary import Messages

    seen = [("ch06/x", "", "b"), ("ch06/x", "", "a"), ("ch03/y", "", "b"), ("ch06/x", "", "a"),
            ("ch06/x", "sign", "a"), ("ch06/x", "", "lone \udcff"), ("ch06/x", "", "b"),
            *[("ch07/z", "", f"wrong at {i}") for i in range(30)], ("ch06/x", "", "lone \udcff")]
    counted = Messages()
    for check, mistake, message in seen:
        counted.add(check, mistake, message)
    assert counted.most_common(25) == Counter(seen).most_common(25)
    counted.close()


def test_restaging_drops_files_the_learner_no_longer_submits(tmp_path):
    from grader.course.staging import Entry

    source = build_submission(tmp_path / "learner")
    staged = stage(Entry("learner", source), tmp_path / "staging") / "exercises"
    assert (staged / "ch06_measurement.py").exists()
    (source / "exercises" / "ch06_measurement.py").unlink()
    (source / "exercises" / "ch03_jacobian.py").write_text("CHANGED = 1\n")
    stage(Entry("learner", source), tmp_path / "staging")
    assert not (staged / "ch06_measurement.py").exists()
    assert (staged / "ch03_jacobian.py").read_text() == "CHANGED = 1\n"


@pytest.mark.slow
def test_on_a_terminal_the_batch_shows_a_progress_bar_with_eta(submissions, tmp_path):
    returncode, text = run_on_terminal([sys.executable, "-m", "grader", "batch", str(submissions), "--out",
                                        str(tmp_path / "out"), "--chapters", CHAPTERS, "--no-html", "--jobs", "1"],
                                       Path(__file__).resolve().parents[2])
    assert returncode in (0, 1), text
    assert "] 1/4" in text and "] 4/4" in text and "ETA" in text and "/s" in text, text


@pytest.mark.slow
def test_fork_server_and_fresh_interpreters_give_the_same_verdicts(submissions, tmp_path, monkeypatch):
    """GRADER_FORK_SERVER=off (a fresh sandboxed interpreter per learner, the benchmark's baseline)
    and the fork server grade every learner alike."""
    from grader.course.batch import run_batch

    verdicts = {}
    for mode in ("fork", "off"):
        if mode == "off":
            monkeypatch.setenv("GRADER_FORK_SERVER", "off")
        out = tmp_path / mode
        result = run_batch(submissions, out, chapters=CHAPTERS.split(","), jobs=2, seed=4, html=False)
        verdicts[mode] = {
            learner: [(c["id"], c["status"], c["message"]) for ch in json.loads((out / learner / "report.json")
                      .read_text())["chapters"] for c in ch["checks"]]
            for learner, status in result.statuses.items() if status == "graded"}
    assert sorted(verdicts["fork"]) == ["alice", "bob", "carol"]
    assert verdicts["fork"] == verdicts["off"]
    assert any(status == "fail" for _, status, _ in verdicts["fork"]["carol"])


@pytest.mark.slow
def test_time_budget_bounds_all_of_a_learners_code(tmp_path):
    """--time-budget is one learner's time for the code of all chapters together: a learner whose every
    H_jacobian call takes 1.5 s (each within the 5 s call limit) is stopped after the budget, and the
    learner after them is graded as ever."""
    folder = tmp_path / "submissions"
    slow = replace_function("ch06_measurement", "H_jacobian", "def H_jacobian(x, y):\n    import time\n"
                            "    print('H_jacobian called', flush=True)\n    time.sleep(1.5)\n    return np.eye(2)\n")
    build_submission(folder / "slow", {"ch06_measurement": slow})
    build_submission(folder / "steady")
    done = run_grade("batch", folder, "--out", tmp_path / "out", "--chapters", "ch03,ch06", "--jobs", "1", "--no-html",
                     "--time-budget", "3")
    assert done.returncode == 0, done.stdout + done.stderr
    rows = {row["learner"]: row for row in _rows(tmp_path / "out" / "gradebook.csv")}
    assert rows["steady"]["ch06_code"] == code_points("ch06") and rows["slow"]["ch03_code"] == code_points("ch03")
    report = json.loads((tmp_path / "out" / "slow" / "report.json").read_text())
    messages = [c["message"] for c in report["chapters"][1]["checks"] if c["function"] == "H_jacobian"]
    assert any("3 s" in m and "ran out" in m for m in messages), messages
    # the budget's work: at most two calls of 1.5 s fit in 3 s, and a third was under way (without it: 14 and more)
    output = report["batch"]["learner_output"]
    assert 1 <= output.count("H_jacobian called") <= 3, output


@pytest.mark.slow
def test_a_learner_using_sympy_gets_full_marks_from_the_fork_server_that_preloaded_it(tmp_path):
    """A learner whose files name sympy is forked from a server that imported it (the learner's code finds it
    already imported), and one whose files do not from the lean server, which holds numpy only (its forks copy no
    sympy pages); one worker keeps both. The learner whose gradient differentiates with sympy at every call is
    graded as the reference is."""
    sympy_style = replace_function("ch02_gradient", "example_gradient", """
        def example_gradient(x, y):
            import sys
            print("sympy imported before the learner's code:", "sympy" in sys.modules)
            import sympy
            X, Y = sympy.symbols("x y")
            f = X ** 2 + X * Y
            return np.array([float(sympy.diff(f, v).subs({X: x, Y: y})) for v in (X, Y)])
        """)
    plain = replace_function("ch02_gradient", "example_gradient", """
        def example_gradient(x, y):
            import sys
            print("loaded before the learner's code:", "sym" + "py" in sys.modules)
            return np.array([2 * x + y, x])
        """)
    build_submission(tmp_path / "submissions" / "sam", {"ch02_gradient": sympy_style})
    build_submission(tmp_path / "submissions" / "nora", {"ch02_gradient": plain})
    done = run_grade("batch", tmp_path / "submissions", "--out", tmp_path / "out", "--chapters", "ch02", "--no-html",
                     "--jobs", "1")
    assert done.returncode in (0, 1), done.stderr[-2000:]
    rows = {row["learner"]: row for row in _rows(tmp_path / "out" / "gradebook.csv")}
    for learner in ("sam", "nora"):
        assert rows[learner]["status"] == "graded" and rows[learner]["ch02_code"] == code_points("ch02"), rows[learner]

    def output_of(learner: str) -> str:
        report = json.loads((tmp_path / "out" / learner / "report.json").read_text(encoding="utf-8"))
        return report["batch"]["learner_output"]

    assert "sympy imported before the learner's code: True" in output_of("sam"), output_of("sam")
    assert "sympy imported before the learner's code: False" not in output_of("sam"), output_of("sam")
    assert "loaded before the learner's code: False" in output_of("nora"), output_of("nora")
    assert "loaded before the learner's code: True" not in output_of("nora"), output_of("nora")
