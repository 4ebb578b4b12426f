"""What `grade` keeps between runs (grader.core.memo, grader.boundary.kept): the same answers get the same report as
when judged afresh, a changed function is judged again, nothing is reused without a wall around learner code,
and the kept sandbox is the sandbox the door builds, with the same walls."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path
from types import SimpleNamespace

import pytest

from grader.boundary import kept
from grader.boundary.spawn import INTERPRETER
from grader.core.memo import ENTRIES, Memo, _stamp_of
from tests.support import (BWRAP, REPO, WRONG_H, build_submission, replace_function, replace_functions,
                           run_grade)

needs_bwrap = pytest.mark.skipif(BWRAP is None, reason="the memo is used only where bubblewrap walls learner code off")

WRONG_BEARING = """def range_bearing(x, y):
    return np.array([np.hypot(x, y), np.arctan(y / x)])
"""


def _env(cache: Path | str) -> dict:
    return {**os.environ, "GRADER_CACHE_DIR": str(cache)}


def _report(root: Path, cache: Path | str, *args: str, flags=()) -> dict:
    done = run_grade("ch06", "ch07", "--submission", root, "--format", "json", *args, env=_env(cache), flags=flags)
    assert done.returncode in (0, 1), done.stderr[-3000:]
    return json.loads(done.stdout)


@needs_bwrap
@pytest.mark.parametrize("kind", ["right", "one bug", "stubs"])
def test_a_kept_verdict_is_the_verdict_judged_afresh(tmp_path, kind):
    if kind == "stubs":
        root = REPO  # the handout's own stubs, in exercises/
    else:
        replacements = {"ch06_measurement": replace_function("ch06_measurement", "range_bearing", WRONG_BEARING)}
        root = build_submission(tmp_path / "sub", replacements if kind == "one bug" else None)
    afresh = _report(root, "")
    cache = tmp_path / "cache"
    first, again = _report(root, cache), _report(root, cache)
    assert (cache / "results" / "ch06.json").is_file()  # kept: the second run judged nothing
    assert first == afresh and again == afresh


@needs_bwrap
def test_the_parent_imports_neither_numpy_nor_the_checks_when_the_answers_are_the_same(tmp_path):
    root = build_submission(tmp_path / "sub")
    cache = tmp_path / "cache"
    imported = []
    for _ in range(2):
        done = run_grade("ch06", "--submission", root, env=_env(cache), flags=("-X", "importtime"))
        assert done.returncode in (0, 1) and "ch06 total" in done.stdout, done.stderr[-3000:]
        imported.append({line.rsplit("|", 1)[1].strip() for line in done.stderr.splitlines() if "|" in line})
    assert {"numpy", "grader.checks", "yaml"} & imported[0] == {"numpy", "grader.checks", "yaml"}
    assert not {"numpy", "grader.checks", "grader.core.planning", "grader.quiz"} & imported[1]


@needs_bwrap
def test_a_changed_function_is_judged_again(tmp_path):
    root = build_submission(tmp_path / "sub")
    cache = tmp_path / "cache"
    assert _report(root, cache)["score"] == _report(root, cache)["score"]
    module = root / "exercises" / "ch06_measurement.py"
    module.write_text(replace_function("ch06_measurement", "range_bearing", WRONG_BEARING).replace(
        "solutions.", "exercises."), encoding="utf-8")
    changed = _report(root, cache)
    assert changed == _report(root, "")
    failing = [c["id"] for ch in changed["chapters"] for c in ch["checks"] if c["status"] == "fail"]
    assert any("range_bearing" in name for name in failing)


@needs_bwrap
def test_only_the_checks_whose_calls_answered_otherwise_are_judged_afresh(tmp_path):
    root = build_submission(tmp_path / "sub")
    cache = tmp_path / "cache"
    module = root / "exercises" / "ch06_measurement.py"

    def judged() -> tuple[dict, list[str]]:
        done = run_grade("ch06", "--submission", root, "--format", "json", "--no-quiz",
                         env={**_env(cache), "GRADER_TRACE": repr(time.time())})
        assert done.returncode in (0, 1), done.stderr[-3000:]
        return json.loads(done.stdout), [line.split("ms  ", 1)[1] for line in done.stderr.splitlines()
                                         if line.startswith("trace") and "judged afresh" in line]

    assert judged()[1] == []  # the first run judges the chapter whole, and keeps each check's verdict
    edits = [("range_bearing", WRONG_BEARING), ("H_jacobian", f"def H_jacobian(x, y):\n{WRONG_H}\n"),
             ("range_bearing", "def range_bearing(x, y):\n    return np.array([np.hypot(x, y), np.arctan2(y, x)])\n")]
    replaced: dict[str, str] = {}
    for function, body in edits:  # one function changed at a time, as a learner edits
        replaced[function] = body
        module.write_text(replace_functions("ch06_measurement", replaced), encoding="utf-8")
        report, traced = judged()
        afresh = run_grade("ch06", "--submission", root, "--format", "json", "--no-quiz", env=_env(""))
        assert report == json.loads(afresh.stdout)  # verdicts kept check by check, and the rest judged: as judged whole
        fresh, total = map(int, traced[0].removeprefix("ch06: ").split(" checks")[0].split(" of "))
        assert 0 < fresh < total, traced  # the checks of the changed function and of what calls it, or raises


@needs_bwrap
def test_changed_quiz_answers_are_judged_again(tmp_path):
    root = build_submission(tmp_path / "sub")
    (root / "exercises" / "answers").mkdir()
    cache = tmp_path / "cache"
    unanswered = _report(root, cache)
    (root / "exercises" / "answers" / "ch06.yaml").write_text("bearing_near_dish: c\n", encoding="utf-8")
    answered = _report(root, cache)
    assert answered == _report(root, "") and answered != unanswered


def test_nothing_is_kept_or_reused_where_learner_code_could_write_the_memo(tmp_path):
    root = build_submission(tmp_path / "sub")
    cache = tmp_path / "cache"
    _report(root, cache, "--no-sandbox")
    assert not (cache / "results").exists()


@needs_bwrap
def test_a_forged_or_broken_memo_is_a_miss_never_a_grade(tmp_path):
    root = build_submission(tmp_path / "sub", {"ch06_measurement": replace_function(
        "ch06_measurement", "range_bearing", WRONG_BEARING)})
    cache = tmp_path / "cache"
    right = _report(root, cache)
    values = sorted((cache / "results").glob("ch06.*.json"))  # each verdict kept in a file of its own
    assert values
    for kept_file in values:
        data = json.loads(kept_file.read_text(encoding="utf-8"))
        data["grader"] = "another grader"  # made by another grader (or its files since edited): not this one's word
        for check in data["value"]["chapter"]["checks"]:
            check["status"], check["points"] = "pass", check["max_points"]
        kept_file.write_text(json.dumps(data), encoding="utf-8")
    by_check = cache / "results" / "ch06-checks.json"  # and each check's last verdict
    data = json.loads(by_check.read_text(encoding="utf-8"))
    data["grader"] = "another grader"
    for _, value in data["checks"].values():
        value["check"]["status"], value["check"]["points"] = "pass", value["check"]["max_points"]
    by_check.write_text(json.dumps(data), encoding="utf-8")
    (root / "exercises" / "ch06_measurement.py").write_text(replace_functions("ch06_measurement", {
        "range_bearing": WRONG_BEARING, "H_jacobian": f"def H_jacobian(x, y):\n{WRONG_H}\n"}), encoding="utf-8")
    right = _report(root, "")  # another function changed too: judged check by check, had the forgery been taken
    assert _report(root, cache) == right
    for kept_file in [*(cache / "results").glob("ch06.*.json"), cache / "results" / "ch06.json"]:
        kept_file.write_text("{not json", encoding="utf-8")
    assert _report(root, cache) == right


def test_the_grader_stamp_changes_with_any_file_that_decides_a_verdict(tmp_path):
    (tmp_path / "checks").mkdir()
    check = tmp_path / "checks" / "ch06.py"
    check.write_text("A = 1\n", encoding="utf-8")
    before = _stamp_of([tmp_path])
    check.write_text("A = 22\n", encoding="utf-8")
    assert _stamp_of([tmp_path]) != before
    memo = Memo(tmp_path / "memo", "stamp")
    memo.keep_verdict("ch06", "key", {"chapter": {}})
    assert Memo(tmp_path / "memo", "stamp").verdict("ch06", "key") == {"chapter": {}}
    assert Memo(tmp_path / "memo", "another stamp").verdict("ch06", "key") is None
    memo.keep_verdict("../../elsewhere", "key", {"x": 1})  # only the memo's own file names
    assert not (tmp_path / "elsewhere.json").exists()
    memo.keep_verdict("ch06", "../x", {"x": 1})  # nor a key that is not a hash's
    assert Memo(tmp_path / "memo", "stamp").verdict("ch06", "../x") is None
    for n in range(ENTRIES + 3):  # each value in a file of its own, the oldest removed with its entry
        memo.keep_verdict("ch06", f"key{n}", {"n": n})
    assert sorted(p.name for p in (tmp_path / "memo").glob("ch06.*.json")) == \
        sorted(f"ch06.key{n}.json" for n in range(3, ENTRIES + 3))
    assert Memo(tmp_path / "memo", "stamp").verdict("ch06", f"key{ENTRIES + 2}") == {"n": ENTRIES + 2}


# ------------------------------------------------------------------------------------------- the kept sandbox

@needs_bwrap
def test_the_kept_sandbox_is_the_doors_and_holds_only_while_what_made_it_holds(tmp_path, monkeypatch):
    from grader.boundary.door import choose

    monkeypatch.setenv("GRADER_CACHE_DIR", str(tmp_path))
    built = choose("auto").command_prefix()
    remembered = choose("auto", remember=True).command_prefix()
    assert kept.wrapper("auto") == remembered
    assert kept.wrapper("off") is None
    monkeypatch.setenv("GRADER_SANDBOX", "off")  # what the door reads has changed: decided afresh
    assert kept.wrapper("auto") is None
    monkeypatch.delenv("GRADER_SANDBOX")
    assert kept.wrapper("auto") == remembered
    # the binds are the same but for the two prepared folders, which hold copies of what was bound one by one
    assert len(remembered) < len(built)
    assert {a for a in remembered if a.startswith("--unshare")} == {a for a in built if a.startswith("--unshare")}
    fields = (tmp_path / "launch" / "decision").read_text(encoding="utf-8").split("\0")
    watched, stamp = fields[2], int(fields[3])  # the first watched path, and its modification time then
    os.utime(watched, ns=(os.stat(watched).st_atime_ns, 12345))
    try:
        assert kept.wrapper("auto") is None  # a watched path changed
    finally:
        os.utime(watched, ns=(os.stat(watched).st_atime_ns, stamp))
    assert kept.wrapper("auto") == remembered


@needs_bwrap
def test_the_kept_sandbox_walls_off_what_the_door_walls_off(tmp_path, monkeypatch):
    from grader.boundary.door import choose
    from grader.system import child_path

    monkeypatch.setenv("GRADER_CACHE_DIR", str(tmp_path))
    choose("auto", remember=True).command_prefix()
    prefix = kept.wrapper("auto")
    grader = REPO / "grader"
    look = (f"import sys, os; sys.path[:] = {child_path()!r}; import numpy, grader.boundary.child\n"
            f"print(sorted(os.listdir({str(grader)!r})))\n"
            f"print([p for p in {[str(REPO / 'solutions'), str(grader / 'checks'), str(tmp_path / 'launch')]!r}"
            " if os.path.exists(p) and os.listdir(p)])\n")
    done = subprocess.run([*prefix, sys.executable, *INTERPRETER, "-c", look], capture_output=True, text=True,
                          timeout=120, check=False)
    assert done.returncode == 0, done.stderr
    listed, readable = done.stdout.splitlines()
    assert set(eval(listed)) <= {"__init__.py", "catalogue.py", "system.py", "boundary", "__pycache__"}
    assert eval(readable) == []


@needs_bwrap
def test_grade_starts_its_child_behind_the_kept_sandbox_and_grades_alike(tmp_path):
    root = build_submission(tmp_path / "sub")
    cache = tmp_path / "cache"
    reports = [_report(root, cache, "--no-quiz") for _ in range(2)]
    assert (cache / "launch" / "decision").is_file()
    assert len(list((cache / "launch").glob("tree-*"))) == 1
    assert reports[0] == reports[1] == _report(root, "", "--no-quiz")


# ------------------------------------------------------------------------------------------- a batch worker's memo

def test_a_worker_memo_judges_a_chapter_answered_alike_once(tmp_path, monkeypatch):
    from grader.core import grading
    from tests.support import open_session

    planned = []
    plan = grading._plan
    monkeypatch.setattr(grading, "_plan", lambda cid, *rest: planned.append(cid) or plan(cid, *rest))
    memo = Memo(None, "this worker")
    right = [build_submission(tmp_path / name) for name in ("ann", "bo")]
    buggy = build_submission(tmp_path / "cy", {"ch06_measurement": replace_function(
        "ch06_measurement", "range_bearing", WRONG_BEARING)})
    reports = [grading.judge_chapters(open_session(root), ["ch03", "ch06"], memo=memo) for root in (*right, buggy)]
    assert planned == ["ch03", "ch06", "ch06"]  # ann's chapters; bo's answers are ann's; cy's ch03 is theirs too
    alone = [grading.judge_chapters(open_session(root), ["ch03", "ch06"]) for root in (right[1], buggy)]
    assert [c.to_dict() for c in reports[1].chapters] == [c.to_dict() for c in alone[0].chapters]
    assert [c.to_dict() for c in reports[2].chapters] == [c.to_dict() for c in alone[1].chapters]
    assert reports[2].chapters[1].score < reports[1].chapters[1].score


def test_a_worker_encodes_a_chapters_kept_calls_once_and_sends_each_child_what_it_still_owes(tmp_path, monkeypatch):
    from grader.boundary import session as sessions
    from grader.boundary.wire import placed
    from grader.core import grading
    from tests.support import open_session

    encoded = []
    dumps = sessions.json.dumps
    monkeypatch.setattr(sessions.json, "dumps", lambda value, *a, **k: encoded.append(value) or dumps(value, *a, **k))
    sent = []
    run = sessions.Session.run
    monkeypatch.setattr(sessions.Session, "run", lambda self, requests: sent.append(
        (self._request(requests, {r.chapter: sessions.ChapterRun(r.chapter, results=[None] * len(r.calls))
                                  for r in requests}), requests)) or run(self, requests))
    memo = Memo(None, "this worker")
    encodings = []
    for name in ("ann", "bo", "cy"):
        encoded.clear()
        grading.judge_chapters(open_session(build_submission(tmp_path / name)), ["ch03", "ch06"], memo=memo)
        encodings.append(sum(isinstance(v, list) and bool(v) and isinstance(v[0], dict) and "index" in v[0]
                             for v in encoded))
    assert encodings[1:] == [2, 0]  # ann's calls planned and kept; encoded once for bo, for both chapters; cy: none
    assert memo.calls("ch06", next(iter(memo._read("ch06")["plans"]))) is sent[2][1][1].calls
    first, last = (json.loads(placed(text, "/tmp/x", True)) for text, _ in (sent[0], sent[2]))
    assert first == last and first["root"] == "/tmp/x" and first["confine"] is True
    assert [c["chapter"] for c in first["chapters"]] == ["ch03", "ch06"]
    assert first["chapters"][1]["calls"] == [c.to_json(i) for i, c in enumerate(sent[0][1][1].calls)]
    # a fresh child after a crash gets only the calls still unanswered, whatever was kept encoded
    request = sent[2][1][1]
    runs = {"ch06": sessions.ChapterRun("ch06", results=[object()] * 2 + [None] * (len(request.calls) - 2))}
    unstarted = SimpleNamespace(submission=SimpleNamespace(package="exercises"), prepared=SimpleNamespace(files={}),
                                limits=sessions.Limits())
    owed = json.loads(placed(sessions.Session._request(unstarted, [request], runs), "/r", False))
    assert [c["index"] for c in owed["chapters"][0]["calls"]] == list(range(2, len(request.calls)))


@pytest.mark.slow
def test_every_learner_of_a_batch_gets_the_report_they_get_alone(tmp_path):
    everyone = tmp_path / "everyone"
    for name, bug in (("ann", False), ("bo", True), ("cy", False), ("dee", True)):
        build_submission(everyone / name, {"ch06_measurement": replace_function(
            "ch06_measurement", "range_bearing", WRONG_BEARING)} if bug else None)

    def reports(submissions: Path, out: Path) -> dict:
        done = run_grade("batch", submissions, "--out", out, "--chapters", "ch03,ch06", "--jobs", "1", "--no-html")
        assert done.returncode in (0, 1), done.stderr[-3000:]
        found = {}
        for learner in ("ann", "bo", "cy", "dee"):
            path = out / learner / "report.json"
            if path.exists():
                found[learner] = json.loads(path.read_text(encoding="utf-8"))["chapters"]
        return found

    together = reports(everyone, tmp_path / "out")
    for learner in ("cy", "dee"):  # graded after ann and bo answered alike, and alone
        alone = tmp_path / f"{learner}-alone"
        alone.mkdir()
        (everyone / learner).rename(alone / learner)
        assert reports(alone, tmp_path / f"out-{learner}")[learner] == together[learner]


    def code(chapters: list) -> list:
        return [[c for c in chapter["checks"] if c["kind"] == "code"] for chapter in chapters]

    assert code(together["cy"]) == code(together["ann"]) and code(together["dee"]) == code(together["bo"])


@needs_bwrap
def test_a_kept_sandbox_that_no_longer_starts_is_dropped_and_the_command_still_grades(tmp_path):
    root = build_submission(tmp_path / "sub")
    cache = tmp_path / "cache"
    right = _report(root, "", "--no-quiz")
    _report(root, cache, "--no-quiz")
    decision = cache / "launch" / "decision"
    fields = decision.read_text(encoding="utf-8").split("\0")
    tree = next(p for p in fields if p.startswith(str(cache / "launch" / "tree-")))
    shutil.rmtree(tree)  # a cache cleaner took the prepared folders: the decision, which watches them, is made again
    assert _report(root, cache, "--no-quiz") == right
    fields = decision.read_text(encoding="utf-8").split("\0")
    broken = [f.replace("/usr/lib", "/nonexistent/lib") if f == "/usr/lib" else f for f in fields[2 + 2 * int(fields[1]):]]
    decision.write_text("\0".join(fields[:2 + 2 * int(fields[1])] + broken), encoding="utf-8")
    assert _report(root, cache, "--no-quiz") == right  # the kept command failed to start: dropped, graded afresh
    assert not decision.exists() or "/nonexistent/lib" not in decision.read_text(encoding="utf-8")


@needs_bwrap
@pytest.mark.slow
def test_the_html_report_is_the_same_from_kept_verdicts_and_their_plot_data(tmp_path):
    root = build_submission(tmp_path / "sub", {"ch06_measurement": replace_function(
        "ch06_measurement", "range_bearing", WRONG_BEARING)})
    cache = tmp_path / "cache"
    pages = []
    for name, kept_in, before in (("afresh", "", None), ("first", cache, None), ("kept", cache, None),
                                  ("drawn from kept data", cache, lambda: shutil.rmtree(cache / "figures"))):
        if before:
            before()
        page = tmp_path / f"{name}.html"
        done = run_grade("ch06", "ch07", "--submission", root, "--html", page, env=_env(kept_in))
        assert done.returncode == 1, done.stderr[-3000:]
        pages.append(page.read_bytes())
    assert (cache / "results" / "ch06.json").is_file() and (cache / "figures" / "ch06.json").is_file()
    assert pages[1:] == [pages[0]] * 3


def test_a_forged_verdict_is_never_read_where_learner_code_could_have_written_it(tmp_path):
    if BWRAP is None:
        pytest.skip("the forged entry is made from a walled run's")
    root = build_submission(tmp_path / "sub", {"ch06_measurement": replace_function(
        "ch06_measurement", "range_bearing", WRONG_BEARING)})
    cache = tmp_path / "cache"
    honest = _report(root, cache, "--no-quiz")
    for kept_file in (cache / "results").glob("ch06.*.json"):
        data = json.loads(kept_file.read_text(encoding="utf-8"))  # this grader's stamp: a forgery learner code could write
        for check in data["value"]["chapter"]["checks"]:
            check["status"], check["points"], check["message"] = "pass", check["max_points"], ""
        kept_file.write_text(json.dumps(data), encoding="utf-8")
    unwalled = _report(root, cache, "--no-quiz", "--no-sandbox")
    assert unwalled["chapters"][0]["score"] == honest["chapters"][0]["score"] < unwalled["chapters"][0]["max_score"]


def _traced(root: Path, cache: Path, *args: str) -> list[str]:
    import time

    done = run_grade("ch06", "--submission", root, *args, env={**_env(cache), "GRADER_TRACE": repr(time.time())},
                     flags=("-X", "importtime"))
    assert done.returncode in (0, 1) and "ch06" in done.stdout + done.stderr, done.stderr[-3000:]
    return done.stderr.splitlines()


@needs_bwrap
def test_files_found_to_answer_alike_plan_nothing_ahead_from_then_on(tmp_path):
    cache = tmp_path / "cache"
    first = build_submission(tmp_path / "first")
    _traced(first, cache)
    other = build_submission(tmp_path / "other")
    (other / "exercises" / "notes.py").write_text("# the learner's own notes\n", encoding="utf-8")  # other files

    def numpy_imported(lines: list[str]) -> bool:
        return any(line.startswith("import time:") and line.rsplit("|", 1)[-1].strip() == "numpy" for line in lines)

    assert numpy_imported(_traced(other, cache))  # new files: planned while the child ran, in case
    assert not numpy_imported(_traced(other, cache))  # known now to answer as kept: nothing planned ahead


@needs_bwrap
@pytest.mark.slow
def test_the_drawing_process_starts_only_where_a_figure_will_be_drawn(tmp_path):
    root = build_submission(tmp_path / "sub")
    cache = tmp_path / "cache"

    def drawing() -> list[str]:
        lines = _traced(root, cache, "--html", str(tmp_path / "report.html"))
        return [line for line in lines if line.startswith("trace") and "drawing process" in line]

    assert any("drawing process started" in line for line in drawing())  # a first run: started at once
    assert drawing() == []  # nothing changed: no drawing process, no matplotlib
    (cache / "figures" / "ch06.json").unlink()
    assert any("drawing process" in line for line in drawing())  # a figure missing: drawn
    assert drawing() == []
