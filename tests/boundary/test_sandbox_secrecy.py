"""Learner code cannot reach an answer, by any route, in `grade chNN` and in `grade batch`: importing
the references, reading the grader's own checks, keys or data through its `__file__`, walking `/`
for another copy of the chapter files, or submitting a symbolic link to the references. The
sandbox is an allow-list, so these hold wherever the course keeps its files (here: the project
itself, with its references and keys beside the grader). Needs bubblewrap, as CI has."""

from __future__ import annotations

import json
import os
import shutil

import pytest

from grader.boundary.sandbox import CHILD_MODULES
from grader.course.batch import run_batch
from tests.support import (
    BWRAP,
    REPO,
    build_submission,
    replace_function,
    run_grade,
    slow_but_the_first,
)

pytestmark = pytest.mark.skipif(BWRAP is None and not os.environ.get("CI"),
                                reason="the routes to the answers are closed by the bubblewrap sandbox")


def _h(body: str) -> dict:
    return {"ch06_measurement": replace_function("ch06_measurement", "H_jacobian", f"def H_jacobian(x, y):\n{body}\n")}


# Each route ends in `raise ValueError(<what it reached>)` or returns the reference's answer.
ROUTES = {
    "imports_solutions": _h("    from solutions.ch06_measurement import H_jacobian as reference\n"
                            "    return reference(x, y)"),
    "reads_through_grader_file": _h(
        "    import os, grader\n"
        "    here = os.path.dirname(os.path.abspath(grader.__file__))\n"
        "    tried = [os.path.join(here, 'checks', 'ch06.py'), os.path.join(here, 'expected.py'),\n"
        "             os.path.join(here, 'quizzes', 'keys', 'ch06.yaml'), os.path.join(here, 'data'),\n"
        "             os.path.join(here, '..', 'quizzes', 'keys', 'ch06.yaml'),\n"
        "             os.path.join(here, '..', 'solutions', 'ch06_measurement.py')]\n"
        "    files = [os.path.relpath(os.path.join(folder, n), here)\n"
        "             for folder, _, names in os.walk(here) for n in names]\n"
        "    pyc = [p for p in files if '__pycache__' in p.split(os.sep) and p.endswith('.pyc')]\n"
        "    compiled = sorted(p.replace('__pycache__' + os.sep, '').split('.')[0] for p in pyc)\n"
        "    raise ValueError('reached ' + repr([p for p in tried if os.path.exists(p)]) + ' beside '\n"
        "                     + ' '.join(sorted(set(files) - set(pyc))) + ' compiled ' + ' '.join(compiled))"),
    # everything but the system's shared libraries (bound whole; their Python package folders are emptied)
    "walks_the_file_system": _h(
        "    import os\n"
        "    own = os.path.realpath(__file__)\n"
        "    wanted = ('ch06_measurement.py', 'ch06.yaml', 'ch06.json', 'course.yaml')\n"
        "    found = []\n"
        "    for folder, subfolders, files in os.walk('/'):\n"
        "        if folder in ('/proc', '/sys', '/dev', '/usr/lib', '/usr/lib64', '/usr/lib32'):\n"
        "            subfolders[:] = []\n"
        "            continue\n"
        "        found += [os.path.join(folder, n) for n in files if n in wanted\n"
        "                  and os.path.realpath(os.path.join(folder, n)) != own]\n"
        "        found += [os.path.join(folder, n) for n in subfolders if n in ('solutions', 'keys', 'oracle')]\n"
        "    raise ValueError('found ' + repr(sorted(found)))"),
}


def _message(report: dict, check: str = "H_worked_example") -> str:
    ch06 = next(c for c in report["chapters"] if c["chapter"] == "ch06")
    return next(c for c in ch06["checks"] if c["id"] == check)["message"]


def _assert_closed(route: str, report: dict) -> None:
    ch06 = next(c for c in report["chapters"] if c["chapter"] == "ch06")
    h_checks = [c for c in ch06["checks"] if c["function"] == "H_jacobian" and c["id"] != "H_raises_at_origin"]
    assert h_checks and all(c["status"] == "fail" for c in h_checks), (route, [(c["id"], c["status"]) for c in h_checks])
    message = _message(report)
    if route == "imports_solutions":
        assert "ModuleNotFoundError: No module named 'solutions'" in message, message
    elif route == "reads_through_grader_file":
        # the modules the child runs (grader/ and grader/boundary/), and their compiled files where the grader has
        # them: nothing else
        reached, beside = message.split(" beside ", 1)
        assert reached.endswith("reached []"), message
        sources, compiled = beside.split(" (line ")[0].split(" compiled ")
        assert sources.split() == sorted(CHILD_MODULES), message
        assert all(f"{stem}.py" in CHILD_MODULES for stem in compiled.split()), message
    else:
        assert "found []" in message, message


# the fast lane: what the sandbox shows of the grader itself (CHILD_MODULES); the other routes in the full suite
@pytest.mark.parametrize("route", slow_but_the_first(sorted(ROUTES, key=lambda r: r != "reads_through_grader_file")))
def test_grade_chapter_in_the_project_closes_every_route(tmp_path, route):
    """`grade ch06` run by the instructor in the project, references and keys beside the grader."""
    submission = build_submission(tmp_path / route, ROUTES[route])
    done = run_grade("ch06", "--submission", submission, "--no-quiz", "--format", "json")
    _assert_closed(route, json.loads(done.stdout))


@pytest.mark.slow
def test_batch_closes_every_route_and_refuses_linked_submissions(tmp_path):
    submissions = tmp_path / "submissions"
    submissions.mkdir()
    for route, files in ROUTES.items():
        build_submission(submissions / route, files)
    (submissions / "linked").symlink_to(REPO / "solutions", target_is_directory=True)  # the references, linked
    inner = build_submission(submissions / "linked_inside")
    shutil.rmtree(inner / "exercises")
    (inner / "exercises").symlink_to(REPO / "solutions", target_is_directory=True)
    build_submission(submissions / "honest")
    result = run_batch(submissions, tmp_path / "out", chapters=["ch06"], jobs=2, seed=11, html=False)
    for route in ROUTES:
        report = json.loads((tmp_path / "out" / route / "report.json").read_text(encoding="utf-8"))
        _assert_closed(route, report)
    assert result.statuses["linked"] == "unreadable" and "symbolic link" in result.messages["linked"]
    assert result.statuses["linked_inside"] == "unreadable"
    assert "no chapter files" in result.messages["linked_inside"]
    assert not (tmp_path / "out" / "linked" / "report.json").exists()
    honest = json.loads((tmp_path / "out" / "honest" / "report.json").read_text(encoding="utf-8"))
    assert honest["chapters"][0]["code_score"] == honest["chapters"][0]["code_max_score"]
    assert "an allow-list" in (tmp_path / "out" / "summary.html").read_text(encoding="utf-8")


@pytest.mark.slow
def test_without_the_sandbox_the_isolation_line_says_answers_are_readable(tmp_path):
    submission = build_submission(tmp_path / "any")
    env = dict(os.environ, GRADER_SANDBOX="off")
    done = run_grade("ch06", "--submission", submission, "--no-quiz", "-v", env=env)
    assert "no sandbox" in done.stderr and "answers included" in done.stderr
    submissions = tmp_path / "submissions"
    shutil.copytree(submission, submissions / "any")
    batch = run_grade("batch", submissions, "--out", tmp_path / "out", "--chapters", "ch06", "--no-html", env=env)
    assert batch.stderr.count("answers included") == 2  # before and after the batch
    assert "answers included" in (tmp_path / "out" / "summary.html").read_text(encoding="utf-8")
    sandboxed = run_grade("ch06", "--submission", submission, "--no-quiz", "-v")
    assert "an allow-list" in sandboxed.stderr and "no answers" in sandboxed.stderr
