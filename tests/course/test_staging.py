"""The roster and the submissions folder, matched both ways (grader.course.staging.survey): a row naming no submission
and a submission no row names are each listed, with the closest name on the other side, in the command's output and
in summary.json; a row is never dropped silently."""

from __future__ import annotations

import json

from click.testing import CliRunner

from grader.course.staging import survey
from grader.faces.cli import main
from tests.support import chapter_submission


def _folder(tmp_path):
    submissions = tmp_path / "submissions"
    for name in ("bug-H-transposed", "ann-smith", "cy"):
        chapter_submission(submissions / name, name)
    roster = tmp_path / "roster.csv"
    roster.write_text("submission,learner\nann-smith,ann\nbug-H-transposd,yan\nzed,zed\n", encoding="utf-8")
    return submissions, roster


def test_a_roster_row_naming_no_submission_and_a_submission_no_row_names_are_both_found(tmp_path):
    submissions, roster = _folder(tmp_path)
    found = survey(submissions, roster)
    assert sorted(e.learner for e in found.entries) == ["ann", "bug-H-transposed", "cy"]
    assert [(u.kind, u.name, u.learner, u.line, u.close) for u in found.unmatched] == [
        ("row", "bug-H-transposd", "yan", 3, "bug-H-transposed"), ("row", "zed", "zed", 4, ""),
        ("submission", "bug-H-transposed", "bug-H-transposed", 0, "bug-H-transposd"),
        ("submission", "cy", "cy", 0, "")]
    assert found.unmatched[0].describe("roster.csv") == (
        "roster.csv, line 3: 'bug-H-transposd' (learner 'yan') names no submission in the submissions folder, so "
        "'yan' has no grade; did you mean 'bug-H-transposed'?")
    assert survey(submissions).unmatched == []  # without a roster, every submission is graded under its name


def test_grade_batch_lists_them_and_says_it_is_incomplete(tmp_path):
    submissions, roster = _folder(tmp_path)
    out = tmp_path / "out"
    done = CliRunner().invoke(main, ["batch", str(submissions), "--out", str(out), "--roster", str(roster),
                                     "--chapters", "ch00", "--no-html"])
    assert done.exit_code == 1, done.output  # two learners of the roster have no grade
    assert "2 roster rows naming no submission; 2 submissions no roster row names" in done.output
    assert "did you mean 'bug-H-transposed'?" in done.output and "did you mean 'bug-H-transposd'?" in done.output
    summary = json.loads((out / "summary.json").read_text(encoding="utf-8"))
    assert summary["roster"]["file"] == "roster.csv"
    assert [(u["kind"], u["name"], u["did_you_mean"]) for u in summary["roster"]["unmatched"]] == [
        ("row", "bug-H-transposd", "bug-H-transposed"), ("row", "zed", None),
        ("submission", "bug-H-transposed", "bug-H-transposd"), ("submission", "cy", None)]
    assert "names no submission" in (out / "summary.html").read_text(encoding="utf-8")


def test_the_hashes_made_from_the_staged_bytes_are_those_read_back_from_disk(tmp_path):
    """Staging reads each file once: the content hash and the files' hash are made from the bytes it staged, and are
    what reading the staged folder back gives, in the order of sorted paths (a folder before a name it prefixes)."""
    import hashlib

    from grader.course import submit
    from grader.course.staging import Entry, stage_files, staged_files
    from grader.course.workers import Grading, content_hash

    folder = chapter_submission(tmp_path / "ann", "ann", "ch06_measurement")
    for name in ("answers/ch06.yaml", "answers/ch05.yaml", "ch05_finite_differences.py"):
        (folder / "exercises" / name).write_text(f"# {name}\n", encoding="utf-8")
    root, files = stage_files(Entry("ann", folder), tmp_path / "staging")
    grading = Grading(("ch05", "ch06"), 7)
    assert content_hash("ann", grading, files) == content_hash("ann", grading, staged_files(root / "exercises"))
    assert submit.files_hash(root / "exercises", files) == submit.files_hash(root / "exercises")
    package = root / "exercises"
    by_path = [(p.relative_to(package).as_posix(), hashlib.sha256(p.read_bytes()).hexdigest())
               for p in sorted(package.rglob("*")) if p.is_file() and p.name != "__init__.py"]
    assert list(submit.staged_hashes(package, files).items()) == by_path  # Path order: answers/ before ch05...


def test_a_batch_keeps_each_learners_files_as_one_record_that_gives_them_back_exactly(tmp_path):
    """The record a batch keeps (one zip per learner) gives back exactly the bytes staged, as does the folder an
    older grader staged into; the same files are not written again, and a record replaces that older folder."""
    from grader.course.staging import Entry, keep, kept_files, record_path, stage_files, submitted_files

    folder = chapter_submission(tmp_path / "ann", "ann", "ch06_measurement")
    (folder / "exercises" / "answers" / "ch06.yaml").write_bytes("range_bearing: zoë\r\n".encode("utf-8"))
    files = submitted_files(Entry("ann", folder))
    staging = tmp_path / "staging"
    stage_files(Entry("ann", folder), staging)  # an older grader's layout: a folder per learner
    assert kept_files(staging, "ann") == files
    record = keep(staging, "ann", files)
    assert record == record_path(staging, "ann") and record.parent.name == ".records"
    assert not (staging / "ann").exists() and kept_files(staging, "ann") == files
    written = record.stat().st_mtime_ns, record.stat().st_ino
    keep(staging, "ann", files)
    assert (record.stat().st_mtime_ns, record.stat().st_ino) == written  # the same files: the record is left
    keep(staging, "ann", {**files, "answers/ch05.yaml": b"x: 1\n"})
    assert kept_files(staging, "ann")["answers/ch05.yaml"] == b"x: 1\n"
    assert kept_files(staging, "bo") is None


def test_a_reused_folder_holds_exactly_each_learners_files_in_turn_whether_it_is_read_back_or_known(tmp_path):
    """put() makes a folder hold exactly one learner's files after another's, files of the same name rewritten and
    others removed, both reading what it holds back and trusting what its only writer kept of it."""
    from grader.course.staging import put, staged_files

    turns = [{"__init__.py": b"", "ch06_measurement.py": b"a", "answers/ch06.yaml": b"x: 1\n"},
             {"__init__.py": b"", "ch06_measurement.py": b"b", "ch05_finite_differences.py": b"c"},
             {"__init__.py": b"", "ch06_measurement.py": b"b", "answers/learner.yaml": b"learner: bo\n"},
             {"__init__.py": b""}]
    held: dict[str, bytes] = {}
    for files in turns:
        put(files, tmp_path / "known" / "exercises", held)
        put(files, tmp_path / "read" / "exercises")
        assert staged_files(tmp_path / "known" / "exercises") == files == held
        assert staged_files(tmp_path / "read" / "exercises") == files


def test_a_record_gives_back_only_the_names_staging_writes(tmp_path):
    """A record written by someone else (an OUT copied from elsewhere) never names a file outside the package: an
    absolute path, '..' or a file staging would not stage is left out when it is read."""
    import zipfile

    from grader.course.staging import kept_files, record_path

    path = record_path(tmp_path, "ann")
    path.parent.mkdir(parents=True)
    with zipfile.ZipFile(path, "w") as archive:
        for name in ("exercises//etc/ch06_measurement.py", "exercises/../ch05_finite_differences.py",
                     "exercises/answers/../../x.yaml", "exercises/run.sh", "ch04_chain_rule.py",
                     "exercises/__init__.py", "exercises/ch06_measurement.py", "exercises/answers/ch06.yaml"):
            archive.writestr(name, b"x")
    assert sorted(kept_files(tmp_path, "ann")) == ["__init__.py", "answers/ch06.yaml", "ch06_measurement.py"]
