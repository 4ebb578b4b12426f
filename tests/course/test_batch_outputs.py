"""Every output of `grade batch` survives every input: learner ids that name class outputs
(gradebook.csv, junit.xml, summary.html, .staging), ids with any Unicode, '+', '@', '.', a name that
is not UTF-8, spreadsheet formulas, control characters; a roster with a byte-order mark and ';'
separators and a bad id in it; hidden entries and stray files; escape sequences in an exception and in
a zip entry's name. Ids stay exactly as given in the gradebook, every skipped entry is listed with its
reason, and every file is valid in its format."""

from __future__ import annotations

import csv
import json
import os
import re
import subprocess
import sys
import zipfile
from pathlib import Path
from xml.etree import ElementTree

import pytest

from grader.course.staging import folder_name
from grader.ids import id_problem
from tests.support import REPO, build_submission, code_points, hostile_module

RIGHT = ("gradebook.csv", "junit.xml", "zoë", "ann+cs101@uni.edu", "=1+2")


@pytest.mark.parametrize("learner, folder", [
    ("alice", "alice"), ("ann+cs101@uni.edu", "ann+cs101@uni.edu"), ("zoë", "zo%C3%AB"),
    ("gradebook.csv", "gradebook%2Ecsv"), ("JUnit.XML", "JUnit%2EXML"), ("summary.html", "summary%2Ehtml"),
    (".staging", "%2Estaging"), (".alice", "%2Ealice"), ("a b/c", "a%20b%2Fc"), ("100%", "100%25"),
    ("-x+1", "%2Dx+1"), ("=1+2", "%3D1+2"),
    ("caf\udce9", "caf%ED%B3%A9"),
])
def test_folder_names_are_plain_ids_or_percent_encoded(learner, folder):
    assert folder_name(learner) == folder


def test_folder_names_never_collide_and_stay_short():
    ids = ["a.b", "a%2Eb", "a b", "a%20b", "gradebook.csv", "gradebook%2Ecsv", "x" * 300, "x" * 299 + "y", "é",
           "%C3%A9", "-a", "%2Da"]
    names = [folder_name(i) for i in ids]
    assert len(set(names)) == len(ids)
    assert all(len(n) <= 160 and not n.startswith(".") and "/" not in n for n in names)


@pytest.mark.parametrize("learner, problem", [
    ("", "is empty"), ("  ", "is empty"), (".", "is '.'"), ("..", "is '..'"), ("a/b", "path separator"),
    ("a\\b", "path separator"), ("\x1b[2J", "U+001B"), ("a\nb", "U+000A"), ("bidi\u202e", "U+202E"),
])
def test_unusable_ids(learner, problem):
    assert problem in id_problem(learner)


@pytest.mark.parametrize("learner", ["alice", "zoë", "ann+cs101@uni.edu", "=1+2", ".staging", "Ça va", "李"])
def test_usable_ids(learner):
    assert id_problem(learner) is None


@pytest.fixture(scope="module")
def batch(tmp_path_factory):
    base = tmp_path_factory.mktemp("outputs")
    submissions = base / "submissions"
    submissions.mkdir()
    for name in RIGHT + ("s1", "s2", "s3", ".bob"):
        build_submission(submissions / name)
    flat = build_submission(base / "flat")
    with zipfile.ZipFile(submissions / "summary.html.zip", "w") as archive:  # the id summary.html
        for path in sorted((flat / "exercises").glob("*.py")):
            archive.write(path, f"exercises/{path.name}")
    build_submission(Path(os.fsdecode(os.fsencode(submissions) + b"/caf\xe9")))  # not UTF-8
    build_submission(submissions / "hostile", {"ch06_measurement": hostile_module()})
    build_submission(submissions / "\x1b[2Jevil")
    build_submission(submissions / ".alice")
    (submissions / ".DS_Store").write_bytes(b"\0\0\0\1Bud1")
    (submissions / "notes.txt").write_text("grade these\n")
    with zipfile.ZipFile(submissions / "zipper.zip", "w", compression=zipfile.ZIP_DEFLATED) as archive:
        archive.writestr("\x1b[2J\x1b[32mOK/ch06_measurement.py", "#" * (2 << 20))
    roster = base / "roster.csv"  # as a spreadsheet saves it in many locales: a BOM and ';'
    roster.write_bytes("submission;learner\r\ns1;.staging\r\ns2;../../etc\r\ns3;-x+1\r\n.bob;bob\r\n"
                       .encode("utf-8-sig"))
    out = base / "out"
    command = [sys.executable, "-m", "grader", "batch", str(submissions), "--out", str(out), "--chapters", "ch06",
               "--roster", str(roster), "--jobs", "2", "--no-html"]
    first = subprocess.run(command, cwd=REPO, capture_output=True, timeout=300)
    again = subprocess.run(command, cwd=REPO, capture_output=True, timeout=300)
    return out, first, again, roster


def _gradebook(out: Path) -> dict[str, dict]:
    with open(out / "gradebook.csv", newline="", encoding="utf-8") as handle:
        return {row["learner"]: row for row in csv.DictReader(handle)}


@pytest.mark.slow
def test_every_id_kept_as_given_and_every_class_output_intact(batch):
    out, first, _, _ = batch
    assert first.returncode == 1, first.stderr.decode(errors="replace")[-3000:]  # zipper, and the bad roster id
    rows = _gradebook(out)
    assert set(rows) == {"gradebook.csv", "junit.xml", "summary.html", "zoë", "ann+cs101@uni.edu", "'=1+2",
                         "caf\ufffd", "hostile", "zipper", ".staging", "'-x+1", "bob"}
    for learner in ("gradebook.csv", "junit.xml", "summary.html", "zoë", "ann+cs101@uni.edu", "'=1+2", "caf\ufffd",
                    ".staging", "'-x+1", "bob"):
        assert rows[learner]["status"] == "graded" and rows[learner]["ch06_code"] == code_points("ch06"), rows[learner]
    assert rows["zipper"]["status"] == "unreadable" and rows["zipper"]["total"] == ""
    assert (out / "gradebook.csv").is_file() and (out / "summary.html").is_file() and (out / "junit.xml").is_file()
    for learner in ("gradebook.csv", "junit.xml", "summary.html", "zoë", ".staging", "=1+2", "-x+1", "caf\ufffd"):
        data = json.loads((out / folder_name(learner) / "report.json").read_bytes().decode("utf-8"))
        assert data["submission"] == learner and f"{data['chapters'][0]['code_score']:g}" == code_points("ch06")
    assert (out / "gradebook%2Ecsv" / "results.json").is_file() and (out / "zo%C3%AB" / "report.json").is_file()


@pytest.mark.slow
def test_every_file_is_valid_in_its_format(batch):
    out, _, _, _ = batch
    suites = ElementTree.parse(out / "junit.xml").getroot()
    assert "hostile" in {s.get("name") for s in suites} and "caf\ufffd" in {s.get("name") for s in suites}
    for path in out.glob("*/*.json"):
        text = path.read_bytes().decode("utf-8")  # strict
        json.loads(text)
        assert not re.search(r"\\ud[89a-f][0-9a-f]{2}", text, re.I), path  # no lone surrogate, even escaped
    hostile = json.loads((out / "hostile" / "report.json").read_text(encoding="utf-8"))
    assert any("all good" in c["message"] for c in hostile["chapters"][0]["checks"])
    summary = (out / "summary.html").read_bytes().decode("utf-8")
    assert "\x1b" not in summary and "\x1b" not in (out / "gradebook.csv").read_text(encoding="utf-8")


@pytest.mark.slow
def test_skipped_entries_are_listed_with_their_reasons(batch):
    out, first, _, roster = batch
    said = first.stdout.decode("utf-8") + first.stderr.decode("utf-8")
    assert "\x1b" not in said
    summary = (out / "summary.html").read_text(encoding="utf-8")
    expected = {
        ".alice": "hidden (dot-named)",
        ".DS_Store": "not a folder or a .zip file",
        "notes.txt": "not a folder or a .zip file",
        "s2": f"{roster}, line 3: the learner id '../../etc' contains a path separator",
        "evil": "contains the control character U+001B",  # its escape sequence is not shown
    }
    for name, reason in expected.items():
        assert re.search(rf"skipped \S*{re.escape(name)}: .*{re.escape(reason)}", said), (name, said)
        assert reason.replace("'", "&#x27;") in summary and name in summary
    assert "id='skipped'" in summary and "5 skipped" in summary
    assert "zipper: zipper.zip: " in said and "OK/ch06_measurement.py is" in said  # the name, without its escapes


@pytest.mark.slow
def test_a_rerun_finds_every_learner_unchanged_in_the_new_layout(batch):
    _, _, again, _ = batch
    said = again.stdout.decode("utf-8")
    assert "11 unchanged" in said and "graded 0" in said, said


def test_what_a_learner_reads_never_holds_the_course_seed(tmp_path):
    """report.html, report.json and results.json are the learner's to read: the course seed is in none of them (a
    learner who knows it could work out every expected value); the instructor's gradebook keeps it."""
    from click.testing import CliRunner

    from grader.faces.cli import main
    from tests.support import chapter_submission

    chapter_submission(tmp_path / "submissions" / "ann", "ann")
    (tmp_path / "course.yaml").write_text("course: secret-seed\nseed: 424242\n", encoding="utf-8")
    out = tmp_path / "out"
    done = CliRunner().invoke(main, ["batch", str(tmp_path / "submissions"), "--out", str(out), "--chapters", "ch00",
                                     "--course", str(tmp_path / "course.yaml")])
    assert done.exit_code == 0, done.output
    for name in ("report.html", "report.json", "results.json"):
        assert "424242" not in (out / "ann" / name).read_text(encoding="utf-8"), name
    report = json.loads((out / "ann" / "report.json").read_text(encoding="utf-8"))
    assert report["seed"] is None and report["provenance"]["seed"] is None
    assert "seed not shown" in (out / "ann" / "report.html").read_text(encoding="utf-8")
    assert (out / "gradebook.csv").read_text(encoding="utf-8").splitlines()[1].endswith(",424242")
