"""Grades that cannot be gamed (issue 31): each attack of the red team, reproduced, and what it meets now.

1. Gradescope where bubblewrap cannot start, as root: learner code runs as an unprivileged user that cannot read
   the bundled references, keys or course file, so importing them earns nothing; right submissions keep their
   verdicts. With no barrier at all nothing is graded, unless the instructor built the autograder so.
2. Harvesting expected values: each Gradescope submission has inputs of its own, so a lookup table of the
   values seen gains nothing over 20 resubmissions (with one seed for all, it does).
3. A forged submission time in the learner's own manifest decides no penalty; every learner without a trusted
   time is listed.
4. A notebook line of 10^6 spaces costs linear time.
5. --similarity survives a file it cannot parse and compares notebooks.
6. An unusable Gradescope id is an error for the instructor, never a fallback; no seed in results.json.
7. overrides.csv numbers must be finite and within range; a bad row is named, the others apply."""

from __future__ import annotations

import ast
import json
import re
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from tests.support import (
    REPO,
    SYSTEM_PATH,
    CpuTime,
    GradescopeLayout,
    build_submission,
    not_root,
    replace_function,
    run_grade,
)

COURSE = "course: gaming\nseed: 8675309\nquiz_feedback: recorded\n"
FAILING_BWRAP = "#!/bin/sh\necho 'bwrap: No permissions to create new namespace' >&2\nexit 1\n"

# stubs that hand back the bundled references (the red team's 25 lines)
FROM_REFERENCES = textwrap.dedent("""\
    import importlib
    import numpy as np

    def _ref():
        return importlib.import_module("solutions.ch06_measurement")

    def range_bearing(x, y):
        return _ref().range_bearing(x, y)

    def H_jacobian(x, y):
        return _ref().H_jacobian(x, y)

    def measurement_covariance(x, y, sigma):
        return _ref().measurement_covariance(x, y, sigma)

    def range_bearing_elevation(x, y, z):
        return _ref().range_bearing_elevation(x, y, z)

    def H3_jacobian(x, y, z):
        return _ref().H3_jacobian(x, y, z)
    """)


@pytest.fixture(scope="module")
def gradescope():
    """A function grading a submission in a Gradescope layout for ch06 (root, the system's python3), by default
    with a `bwrap` that cannot start."""
    layout = GradescopeLayout(COURSE, "--chapters", "ch06")
    fake = layout.base / "fakebin"
    fake.mkdir()
    (fake / "bwrap").write_text(FAILING_BWRAP, encoding="utf-8")
    (fake / "bwrap").chmod(0o755)

    def grade(submission: dict[str, str], metadata: dict, bwrap_fails: bool = True) -> tuple[dict, str]:
        results, run = layout.grade(submission, metadata, path=f"{fake}:{SYSTEM_PATH}" if bwrap_fails else SYSTEM_PATH)
        return results, run.stdout

    yield grade
    layout.close()


def _metadata(submission_id: int | None = 4242, name: str = "Ann Lee") -> dict:
    data = {"created_at": "2026-11-20T10:00:00+00:00", "assignment": {"due_date": "2026-12-01T23:59:00+00:00"},
            "users": [{"email": "ann@uni.edu", "id": 1, "name": name}]}
    if submission_id is not None:
        data["id"] = submission_id
    return data


def _reference_files() -> dict[str, str]:
    return {p.name: p.read_text(encoding="utf-8").replace("solutions.", "exercises.")
            for p in (REPO / "solutions").glob("ch0*.py")}


def _code(results: dict) -> dict[str, tuple]:
    return {t["extra_data"]["id"]: (t["status"], t["score"]) for t in results["tests"] if " code:" in t["name"]}


@pytest.mark.slow
def test_without_bubblewrap_the_bundled_references_are_out_of_reach(gradescope):
    results, output = gradescope({"ch06_measurement.py": FROM_REFERENCES}, _metadata())
    assert "unprivileged user" in output, output
    assert results["score"] == 0, output
    messages = " ".join(t["output"] for t in results["tests"])
    assert "No module named 'solutions" in messages or "Permission denied" in messages, messages[:2000]
    assert "8675309" not in json.dumps(results) + output  # the course seed is shown nowhere


@pytest.mark.slow
def test_without_bubblewrap_a_right_submission_keeps_its_verdicts(gradescope):
    files = {"ch06_measurement.py": _reference_files()["ch06_measurement.py"]}
    dropped, output = gradescope(files, _metadata())
    sandboxed, with_bwrap = gradescope(files, _metadata(), bwrap_fails=False)
    assert "unprivileged user" in output and "bubblewrap sandbox" in with_bwrap
    assert _code(dropped) == _code(sandboxed) and all(s == "passed" for s, _ in _code(dropped).values())


# ------------------------------------------------------------------------------ 2. harvesting expected values

_LABEL = re.compile(r"H_jacobian\(([-\d.e]+), ([-\d.e]+)\)")
_ENTRY = re.compile(r"H\[(\d),(\d)\][^:]*: got [-\d.e]+, expected ([-\d.e]+)")


def _harvest(results: dict, table: dict) -> None:
    """What a learner can read off the visible feedback: for each input shown, the expected entries."""
    for test in results["tests"]:
        if test.get("visibility") == "after_published":
            continue
        label = None
        for line in test["output"].splitlines():
            found = _LABEL.search(line)
            if found:
                label = (float(found.group(1)), float(found.group(2)))
            entry = _ENTRY.search(line)
            if label is not None and entry:
                table.setdefault(label, {})[(int(entry.group(1)), int(entry.group(2)))] = float(entry.group(3))


def _lookup_submission(table: dict) -> dict[str, str]:
    """ch06 whose H_jacobian answers from the table (entries not seen: 0), everything else right."""
    source = replace_function("ch06_measurement", "H_jacobian", textwrap.dedent(f"""\
        def H_jacobian(x, y):
            table = {table!r}
            for (a, b), entries in table.items():
                if abs(a - x) < 1e-3 and abs(b - y) < 1e-3:
                    H = np.zeros((2, 2))
                    for (i, j), value in entries.items():
                        H[i, j] = value
                    return H
            return np.zeros((2, 2))
        """))
    return {"ch06_measurement.py": source}


def _h_points(results: dict) -> float:
    return sum(t["score"] for t in results["tests"] if " code:" in t["name"] and "H_jacobian" in t["tags"]
               and "worked_example" not in t["extra_data"]["id"])


@pytest.mark.slow
def test_a_lookup_table_of_seen_expected_values_gains_nothing_over_20_resubmissions(gradescope):
    """Each submission's inputs are its own (a seed drawn from the course seed, the learner and the submission's
    id): values read off one attempt's feedback answer none of the next. The same loop at one seed for every
    attempt (a metadata without ids) does gain: the measurement can see a gain."""
    gains, passed = {}, {}
    for per_submission in (True, False):
        table: dict = {}
        points = []
        for attempt in range(20 if per_submission else 6):
            metadata = _metadata(1000 + attempt if per_submission else None)
            results, _ = gradescope(_lookup_submission(table), metadata, bwrap_fails=False)
            points.append(_h_points(results))
            passed.setdefault(per_submission, []).append(sorted(
                (t["extra_data"]["id"], t["score"], t["name"][:30]) for t in results["tests"]
                if "H_jacobian" in t["tags"] and t["score"]))
            _harvest(results, table)
        gains[per_submission] = max(points) - points[0]
    assert gains[True] == 0, (gains, [p for p in passed[True] if any("worked" not in x[0] for x in p)])
    assert gains[False] > 0, (gains, passed[False])


# ------------------------------------------------------------------------------ 3. trusted submission times

def _manifest(packed: str, files: dict | None = None) -> str:
    return json.dumps({"learner": "zed", "course": "late-course", "handout": None, "grader": "x", "packed": packed,
                       "files": files or {}, "local": {}})


@pytest.mark.parametrize("manifest_time", ["ignore", "accept", "accept, edited after packing"])
@pytest.mark.slow
def test_a_time_from_the_learners_own_manifest_decides_nothing_unless_the_course_accepts_it(tmp_path, manifest_time):
    """The learner's own manifest time counts only where the course accepts it, and never from an archive edited
    after packing (its manifest's hashes fail): a learner who edits late would otherwise keep an early time."""
    from grader.course.submit import staged_hashes

    root = build_submission(tmp_path / "subs" / "zed")
    packed = staged_hashes(root / "exercises")  # every file as packed
    if manifest_time.endswith("edited after packing"):
        (root / "exercises" / "ch06_measurement.py").write_text("# edited after packing\n", encoding="utf-8")
    (root / "exercises" / "submission-manifest.json").write_text(_manifest("2026-05-01T10:00:00+00:00", packed),
                                                                 encoding="utf-8")
    build_submission(tmp_path / "subs" / "yan")  # no manifest, no roster time
    course = tmp_path / "course.yaml"
    course.write_text(f"course: late-course\nseed: 99\ndeadline: '2026-05-01T23:59:00+00:00'\n"
                      f"late_penalty: {{per_day: 0.1, max: 0.5}}\nmanifest_time: {manifest_time.split(',')[0]}\n",
                      encoding="utf-8")
    done = run_grade("batch", tmp_path / "subs", "--out", tmp_path / "out", "--chapters", "ch06", "--course", course,
                     "--no-html")
    assert done.returncode == 0, done.stderr[-3000:]
    summary = json.loads((tmp_path / "out" / "summary.json").read_text(encoding="utf-8"))
    zed = json.loads((tmp_path / "out" / "zed" / "report.json").read_text(encoding="utf-8"))["batch"]
    if manifest_time == "ignore":
        assert summary["untimed"] == ["yan", "zed"] and zed["submitted"] is None
        assert any("not accepted" in w for w in zed["warnings"])
    elif manifest_time.endswith("edited after packing"):
        assert summary["untimed"] == ["yan", "zed"] and zed["submitted"] is None and zed["time_from"] is None
        assert any("edited after packing, so that time is not trusted" in w for w in zed["warnings"]), zed["warnings"]
    else:
        assert zed["time_from"] == "manifest" and any("learner's own archive manifest" in w for w in zed["warnings"])
        assert summary["untimed"] == ["yan", "zed"]  # still listed: their only time is their own
    assert "no trusted submission time for 2 of 2 graded" in done.stderr


@pytest.mark.slow
def test_an_unparsable_roster_time_is_named_and_listed(tmp_path):
    build_submission(tmp_path / "subs" / "zed")
    roster = tmp_path / "roster.csv"
    roster.write_text("submission,learner,submitted\nzed,zed,yesterday noon\n", encoding="utf-8")
    course = tmp_path / "course.yaml"
    course.write_text("course: c\nseed: 99\ndeadline: '2026-05-01T23:59:00+00:00'\nlate_penalty: {per_day: 0.1}\n",
                      encoding="utf-8")
    done = run_grade("batch", tmp_path / "subs", "--out", tmp_path / "out", "--chapters", "ch06", "--course", course,
                     "--roster", roster, "--no-html")
    summary = json.loads((tmp_path / "out" / "summary.json").read_text(encoding="utf-8"))
    assert summary["untimed"] == ["zed"], done.stderr[-2000:]
    assert "'yesterday noon'" in done.stderr and "roster.csv, line 2" in done.stderr


# ------------------------------------------------------------------------------ 4. bounded parsing

def test_a_notebook_line_of_a_million_spaces_costs_linear_time():
    from grader import notebook

    def cost(spaces: int) -> float:
        cells = [{"cell_type": "code", "source": "x = 1\n" + " " * spaces + "\ny = 2\n", "metadata": {},
                  "outputs": [], "execution_count": None}]
        data = json.dumps({"nbformat": 4, "nbformat_minor": 5, "metadata": {}, "cells": cells}).encode()
        with CpuTime() as spent:
            for _ in range(3):
                notebook.convert(data, "ch06_measurement.ipynb")
        return spent.seconds

    small, large = cost(10_000), cost(1_000_000)
    assert large < 500 * max(small, 1e-4), (small, large)  # linear: about 100 times; the old pattern, cubic


def test_ipython_escapes_are_found_as_the_old_pattern_found_them():
    """The linear reading agrees with the regular expression it replaced on 50,000 random short lines."""
    import random

    from grader.notebook import is_escaped

    old = re.compile(r"^\s*(?:[%!?/,;]|[A-Za-z_][\w.]*\?{1,2}\s*$|[\w.,\s\[\]()]+?\s*=\s*[%!])")
    draw = random.Random(31)
    for _ in range(50_000):
        line = "".join(draw.choice("ab_ .,[]()=%!?/;\t1") for _ in range(draw.randint(0, 12)))
        assert bool(old.match(line)) == is_escaped(line), repr(line)


@pytest.mark.slow
def test_similarity_survives_a_file_it_cannot_parse_and_compares_notebooks(tmp_path):
    pytest.importorskip("copydetect")
    subs = tmp_path / "subs"
    build_submission(subs / "deep", {"ch06_measurement": "x = " + "(" * 100_000 + "1" + ")" * 100_000 + "\n"})
    own = replace_function("ch06_measurement", "H_jacobian", textwrap.dedent("""\
        def H_jacobian(x, y):
            squared = x * x + y * y
            length = np.sqrt(squared)
            first = np.array([x / length, y / length])
            second = np.array([-y / squared, x / squared])
            return np.vstack([first, second])
        """))
    for learner in ("nb1", "nb2"):
        root = build_submission(subs / learner)
        (root / "exercises" / "ch06_measurement.py").unlink()
        cells = [{"cell_type": "code", "source": own, "metadata": {}, "outputs": [], "execution_count": None}]
        (root / "exercises" / "ch06_measurement.ipynb").write_text(json.dumps(
            {"nbformat": 4, "nbformat_minor": 5, "metadata": {}, "cells": cells}), encoding="utf-8")
    build_submission(subs / "plain")
    done = run_grade("batch", subs, "--out", tmp_path / "out", "--chapters", "ch06", "--similarity", "--no-html")
    assert done.returncode in (0, 1), done.stderr[-3000:]
    summary = json.loads((tmp_path / "out" / "summary.json").read_text(encoding="utf-8"))
    assert any(sorted(p["learners"]) == ["nb1", "nb2"] for p in summary["similar"]), summary["similar"]


# ------------------------------------------------------------------------------ 6. Gradescope's metadata

def _autograder(tmp_path: Path, metadata: dict) -> tuple[dict, subprocess.CompletedProcess]:
    """The autograder run in the project's grader (no image built: the barrier turned off by its settings), on
    ch06 right, with `metadata`."""
    root = tmp_path / "autograder"
    (root / "source").mkdir(parents=True)
    (root / "source" / "course.yaml").write_text(COURSE, encoding="utf-8")
    settings = {"course": "gaming", "chapters": ["ch06"], "learner_field": "name", "time_budget": 60,
                "sandbox": "off"}
    (root / "source" / "autograder.json").write_text(json.dumps(settings), encoding="utf-8")
    (root / "submission").mkdir()
    (root / "submission" / "ch06_measurement.py").write_text(_reference_files()["ch06_measurement.py"],
                                                            encoding="utf-8")
    (root / "submission" / "answers").mkdir()
    (root / "submission" / "answers" / "learner.yaml").write_text("learner: someone-else\n", encoding="utf-8")
    (root / "submission_metadata.json").write_text(json.dumps(metadata), encoding="utf-8")
    run = subprocess.run(not_root([sys.executable, "-m", "grader.course.gradescope", "run", str(root)]), cwd=REPO,
                         capture_output=True, text=True, encoding="utf-8", timeout=600)
    return json.loads((root / "results" / "results.json").read_text(encoding="utf-8")), run


def test_an_unusable_gradescope_id_is_an_error_never_a_fallback(tmp_path):
    results, run = _autograder(tmp_path, _metadata(name="Ann Lee / CS101"))
    assert run.returncode == 1 and results["score"] == 0
    assert "NOT GRADED" in results["output"] and "contains a path separator" in results["output"]
    assert "someone-else" not in results["output"]


def test_results_json_holds_no_seed(tmp_path):
    results, run = _autograder(tmp_path, _metadata())
    assert run.returncode == 0, run.stdout[-2000:] + run.stderr[-2000:]
    assert "seed" not in results["extra_data"]["provenance"] and "8675309" not in json.dumps(results)
    assert results["extra_data"]["submission"] == "4242"


# ------------------------------------------------------------------------------ 7. overrides.csv numbers

@pytest.mark.slow
def test_override_numbers_must_be_finite_and_in_range(tmp_path):
    build_submission(tmp_path / "subs" / "ann")
    overrides = tmp_path / "overrides.csv"
    overrides.write_text("learner,target,points,factor,reason,who\n"
                         "ann,ch06/H_worked_example,nan,,x,bo\n"
                         "ann,total,inf,,x,bo\n"
                         "ann,total,1e308,,x,bo\n"
                         "ann,ch06,,-1,x,bo\n"
                         "ann,total,-1,,agreed,bo\n", encoding="utf-8")
    done = run_grade("batch", tmp_path / "subs", "--out", tmp_path / "out", "--chapters", "ch06", "--overrides",
                     overrides, "--no-html")
    assert done.returncode == 0, done.stderr[-3000:]
    for line in (2, 3, 4, 5):
        assert f"overrides.csv, line {line}:" in done.stderr, done.stderr
    report = json.loads((tmp_path / "out" / "ann" / "report.json").read_text(encoding="utf-8"))
    assert report["raw_score"] > 0 and report["score"] == report["raw_score"] - 1  # only the good row applied
    assert [a["source"] for a in report["adjustments"]] == ["overrides.csv, line 6"]
    ast.literal_eval(repr(report["score"]))  # a plain finite number


# ------------------------------------------------------------------------------ the dropped uid leaves nothing behind

PID_HOPPER = textwrap.dedent("""\
    import os

    import numpy as np


    def _hop():
        if os.fork():
            return
        os.setsid()
        while True:  # a new pid all the time: what a sweep of /proc in one pass misses
            if os.fork():
                os._exit(0)


    def range_bearing(x, y):
        _hop()
        return np.array([np.hypot(x, y), np.arctan2(y, x)])
    """)
# what outlived an earlier learner's run (in a container whose init reaps orphans): it kills every other process of
# its uid, the next learner's child as it starts
SURVIVOR = "import os, signal, time\nwhile True:\n    os.kill(-1, signal.SIGKILL)\n    time.sleep(0.02)\n"


@pytest.mark.slow
def test_without_bubblewrap_no_process_of_the_learners_uid_outlives_its_run(gradescope):
    """Where learner code runs as grader-learner, nothing of it survives a run: a process hopping from pid to pid is
    gone after it, and one left by an earlier run, which kills every new child of that uid as it starts, is gone
    before the next learner's child starts, so that learner is graded."""
    import pwd
    import shutil
    import time

    from grader.boundary.dropped import LEARNER_USER, processes_of

    user = pwd.getpwnam(LEARNER_USER)
    results, output = gradescope({"ch06_measurement.py": PID_HOPPER}, _metadata())
    assert "unprivileged user" in output and "NOT GRADED" not in output, output[-2000:]
    assert processes_of(user.pw_uid) == []
    python = shutil.which("python3", path=SYSTEM_PATH)  # the system's, which that user can run
    survivor = subprocess.Popen(["setpriv", f"--reuid={user.pw_uid}", f"--regid={user.pw_gid}", "--clear-groups",
                                 python, "-c", SURVIVOR], env={"PATH": SYSTEM_PATH})
    try:
        time.sleep(0.5)
        assert survivor.poll() is None
        right, output = gradescope({"ch06_measurement.py": _reference_files()["ch06_measurement.py"]}, _metadata())
        assert "NOT GRADED" not in output and all(s == "passed" for s, _ in _code(right).values()), output[-2000:]
        assert survivor.poll() is not None and processes_of(user.pw_uid) == []
    finally:
        survivor.kill()
        survivor.wait()


MEMORY_BOMB = textwrap.dedent("""\
    import os

    import numpy as np


    def range_bearing(x, y):
        for _ in range(6):  # six processes of 300 MiB each: each within its own limit, together far over
            if os.fork() == 0:
                block = np.ones(300 << 17)  # 300 MiB, written
                while True:
                    block[::4096] += 1
        while True:
            pass
    """)


@pytest.mark.slow
def test_without_bubblewrap_the_memory_of_all_the_learners_processes_together_is_capped(gradescope):
    """Where learner code runs as grader-learner, its processes together stay within the learner's memory: six of
    300 MiB are killed, the check says the memory ran out (not that the function hung), and nothing is left."""
    import pwd

    from grader.boundary.dropped import LEARNER_USER, processes_of

    results, output = gradescope({"ch06_measurement.py": MEMORY_BOMB}, _metadata())
    assert "all its processes together within 1024 MiB" in output, output[-2000:]
    messages = [t["output"] for t in results["tests"] if t["extra_data"]["id"] == "ch06/range_bearing_worked_example"]
    assert messages and "ran out of memory: all its processes together may use at most 1024 MiB" in messages[0], \
        messages
    assert processes_of(pwd.getpwnam(LEARNER_USER).pw_uid) == []
