"""The `grade` command through click's CliRunner and as a real subprocess."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest
from click.testing import CliRunner

from grader.chapters import CHAPTERS
from grader.faces.cli import main
from tests.support import (
    REPO,
    run_grade,
    run_on_terminal,
    slow_but_the_first,
)

CHECK_KEYS = {"id", "function", "description", "status", "points", "max_points", "message", "expected", "got"}


@pytest.fixture
def runner():
    return CliRunner()


def test_every_command_has_help(runner):
    result = runner.invoke(main, ["--help"])
    assert result.exit_code == 0
    for name, command in main.commands.items():
        assert command.help, f"command {name} has no help text"
        sub = runner.invoke(main, [name, "--help"])
        assert sub.exit_code == 0 and "Usage:" in sub.output


def test_list_names_every_chapter_file_and_points(runner):
    result = runner.invoke(main, ["list"])
    assert result.exit_code == 0
    for info in CHAPTERS:
        assert f"exercises/{info.module}.py" in result.output
    assert "H_jacobian" in result.output and "points" in result.output


@pytest.mark.parametrize("args", [["ch99"], ["run", "12"], ["chapter6"], []])
def test_usage_errors_exit_2(runner, args):
    result = runner.invoke(main, args)
    assert result.exit_code == 2, result.output


def test_solutions_full_marks_exit_0_and_json_schema(runner):
    result = runner.invoke(main, ["6", "--solutions", "--format", "json"])
    assert result.exit_code == 0, result.output
    data = json.loads(result.output)
    assert {"version", "submission", "score", "max_score", "chapters"} <= set(data)
    assert data["score"] == data["max_score"] > 0
    (chapter,) = data["chapters"]
    assert {"chapter", "title", "score", "max_score", "checks"} <= set(chapter)
    assert chapter["chapter"] == "ch06"
    for check in chapter["checks"]:
        assert CHECK_KEYS <= set(check)
        assert check["status"] == "pass"


def test_stubs_score_zero_with_not_implemented_and_exit_1(runner, repo_root, monkeypatch):
    monkeypatch.chdir(repo_root / "exercises")  # found by walking up to the project
    result = runner.invoke(main, ["ch06", "--format", "json"])
    assert result.exit_code == 1
    data = json.loads(result.output)
    code = [c for c in data["chapters"][0]["checks"] if c.get("kind", "code") == "code"]
    assert all(c["status"] == "fail" and c["points"] == 0 for c in code)
    assert all("not implemented yet" in c["message"] for c in code)


def test_text_output_has_a_line_per_check_and_a_total_without_colour(runner, repo_root, tmp_path):
    from tests.support import build_submission, replace_function

    root = build_submission(tmp_path, {"ch06_measurement": replace_function(
        "ch06_measurement", "H_jacobian", "def H_jacobian(x, y):\n    return np.zeros((2, 2))\n")})
    result = runner.invoke(main, ["ch06", "--submission", str(root)])
    assert result.exit_code == 1
    lines = result.output.splitlines()
    assert lines[0].startswith("Quiz answers graded for learner")
    assert lines[1].startswith("Your quiz numbers and option letters are those of 'anonymous'")  # no learner.yaml
    assert lines[2].startswith("ch06")
    assert any(line.strip().startswith("✗ [0/2] H at the lesson's point (3, 4)") for line in lines)
    assert any(line.strip().startswith("✓ [1/1] range_bearing at the lesson's point") for line in lines)
    assert "ch06 total: " in result.output
    assert "\x1b[" not in result.output


def test_untouched_stubs_say_where_to_start_and_fold_each_function_to_one_line(runner, repo_root):
    result = runner.invoke(main, ["ch06", "--submission", str(repo_root), "--no-quiz"])
    lines = result.output.splitlines()
    assert lines[0].startswith("Start here: write range_bearing in exercises/ch06_measurement.py")
    assert "range_bearing at the lesson's point (3, 4) gives (5, 0.9273)" in lines[0]
    from grader import checks

    registered = checks.load("ch06").checks
    functions = list(dict.fromkeys(c.function for c in registered))
    folded = [line.strip() for line in lines if "not implemented yet (" in line]
    assert folded == [f"✗ [0/{sum(c.points for c in registered if c.function == f):g}] {f}: not implemented yet "
                      f"({sum(c.function == f for c in registered)} checks; -v lists them)" for f in functions]
    verbose = runner.invoke(main, ["ch06", "--submission", str(repo_root), "--no-quiz", "-v"]).output
    assert verbose.count("is not implemented yet (it raises NotImplementedError)") == len(registered)  # all, with -v


def test_seed_changes_random_inputs_but_not_the_verdict(runner):
    outputs = []
    for seed in ("1", "2"):
        result = runner.invoke(main, ["ch06", "--solutions", "--format", "json", "--seed", seed])
        assert result.exit_code == 0
        outputs.append(json.loads(result.output))
    assert outputs[0]["seed"] == 1 and outputs[1]["seed"] == 2
    random_check = "H_jacobian_random_points"
    got = [next(c for c in o["chapters"][0]["checks"] if c["id"] == random_check)["got"] for o in outputs]
    assert got[0] != got[1]


def test_real_subprocess_all_solutions_full_marks(repo_root):
    proc = run_grade("all", "--solutions", "--format", "json", cwd=repo_root)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    data = json.loads(proc.stdout)
    assert [c["chapter"] for c in data["chapters"]] == [c.id for c in CHAPTERS]
    assert data["score"] == data["max_score"]
    for chapter in data["chapters"]:
        assert chapter["score"] == chapter["max_score"] > 0, chapter["chapter"]


@pytest.mark.parametrize("options", slow_but_the_first([["--no-sandbox"], ["--no-sandbox", "--no-quiz"], ["--no-quiz"]]))
def test_real_subprocess_sandbox_and_quiz_options_keep_full_marks(repo_root, options):
    proc = run_grade("ch06", "--solutions", "--format", "json", *options, cwd=repo_root)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    data = json.loads(proc.stdout)
    kinds = {c["kind"] for c in data["chapters"][0]["checks"]}
    assert data["score"] == data["max_score"] > 0
    assert kinds == ({"code"} if "--no-quiz" in options else {"code", "quiz"})


def test_real_subprocess_stubs_zero_and_no_error(repo_root):
    proc = run_grade("all", "--format", "json", cwd=repo_root)
    assert proc.returncode == 1
    data = json.loads(proc.stdout)
    statuses = {c["status"] for ch in data["chapters"] for c in ch["checks"]}
    assert data["score"] == 0 and "error" not in statuses and "pass" not in statuses


def test_real_subprocess_usage_error_goes_to_stderr_with_exit_2(repo_root):
    proc = run_grade("ch42", cwd=repo_root)
    assert proc.returncode == 2
    assert "unknown chapter" in proc.stderr and proc.stdout == ""


@pytest.mark.slow
def test_no_color_is_respected_even_on_a_terminal(repo_root):
    """Run under a pseudo-terminal: colour by default, none with NO_COLOR."""
    pytest.importorskip("pty")
    outputs = {}
    for label, extra in (("colour", {}), ("plain", {"NO_COLOR": "1"})):
        env = dict(os.environ)
        env.pop("NO_COLOR", None)
        env.update(extra)
        _, outputs[label] = run_on_terminal([sys.executable, "-m", "grader", "ch06", "--solutions"], repo_root, env)
    assert "\x1b[" in outputs["colour"]
    assert "\x1b[" not in outputs["plain"] and "ch06 total" in outputs["plain"]


# ------------------------------------------------------------------------------ help, usage errors, colour

def test_every_commands_help_shows_an_example(runner):
    for args in [[], *([name] for name in main.commands)]:
        result = runner.invoke(main, [*args, "--help"])
        assert result.exit_code == 0, args
        examples = result.output.split("Examples:", 1)
        assert len(examples) == 2, f"`grade {' '.join(args)} --help` shows no example"
        lines = [line.strip() for line in examples[1].splitlines() if line.strip()]
        assert lines and all(line.startswith("grade") for line in lines), lines
        if args:
            assert all(line.startswith(f"grade {args[0]}") or args[0] == "run" for line in lines), lines


@pytest.mark.parametrize("typo, meant", [("lst", "list"), ("relase", "release"), ("batc", "batch"),
                                         ("gradescop", "gradescope")])
def test_an_unknown_command_suggests_the_closest(runner, typo, meant):
    result = runner.invoke(main, [typo])
    assert result.exit_code == 2 and f"did you mean `grade {meant}`?" in result.output
    assert "unknown chapter" not in result.output


@pytest.mark.parametrize("jobs", ["-1", "0", "two"])
def test_bad_jobs_is_a_usage_error(runner, tmp_path, jobs):
    (tmp_path / "submissions" / "alice").mkdir(parents=True)
    result = runner.invoke(main, ["batch", str(tmp_path / "submissions"), "--out", str(tmp_path / "out"), "--jobs",
                                  jobs])
    assert result.exit_code == 2 and "--jobs" in result.output and "Traceback" not in result.output
    assert not (tmp_path / "out").exists()


def test_an_empty_submissions_folder_is_a_usage_error(runner, tmp_path):
    folder = tmp_path / "submissions"
    folder.mkdir()
    result = runner.invoke(main, ["batch", str(folder), "--out", str(tmp_path / "out"), "--no-sandbox"])
    assert result.exit_code == 2 and "holds no submission to grade" in result.output and "it is empty" in result.output
    (folder / ".DS_Store").write_bytes(b"\0")
    result = runner.invoke(main, ["batch", str(folder), "--out", str(tmp_path / "out"), "--no-sandbox"])
    assert result.exit_code == 2 and "it holds only what is skipped: .DS_Store: not a folder" in result.output
    assert not (tmp_path / "out").exists()


@pytest.mark.slow
def test_counts_have_the_right_plural(runner, tmp_path, repo_root):
    listed = runner.invoke(main, ["list"]).output
    assert " 1 points" not in listed and "(1 points" not in listed
    from tests.support import build_submission

    build_submission(tmp_path / "submissions" / "alice")
    result = runner.invoke(main, ["batch", str(tmp_path / "submissions"), "--out", str(tmp_path / "out"),
                                  "--chapters", "ch03", "--no-html", "--jobs", "1"])
    assert result.exit_code == 0, result.output
    assert "1 submission: 1 graded" in result.output
    assert "<p>1 learner graded;" in (tmp_path / "out" / "summary.html").read_text(encoding="utf-8")


@pytest.mark.parametrize("env, terminal, coloured", slow_but_the_first([
    ({"FORCE_COLOR": "1"}, False, True),  # force-color.org: any non-empty value, even into a pipe
    ({"FORCE_COLOR": ""}, False, False),  # empty: as if unset
    ({"NO_COLOR": ""}, True, True),  # no-color.org: an empty NO_COLOR does not count
    ({"NO_COLOR": "1", "FORCE_COLOR": "1"}, True, False),  # NO_COLOR wins, as in Python itself
]))
def test_no_color_and_force_color_as_their_specs_say(repo_root, env, terminal, coloured):
    full = dict(os.environ)
    for name in ("NO_COLOR", "FORCE_COLOR"):
        full.pop(name, None)
    full.update(env)
    command = [sys.executable, "-m", "grader", "ch03", "--solutions", "--no-quiz"]
    if terminal:
        _, output = run_on_terminal(command, repo_root, full)
    else:
        output = subprocess.run(command, cwd=repo_root, env=full, capture_output=True, text=True, timeout=120).stdout
    assert ("\x1b[" in output) is coloured and "ch03 total" in output


def test_grade_chapter_imports_nothing_heavy_it_does_not_use():
    """`grade ch06` with its quiz, in an environment that has jax (CI's test extras): no sympy, jinja2 or
    matplotlib, and no importlib.metadata (reading the autograd libraries' files through it cost 180 ms)."""
    done = subprocess.run([sys.executable, "-X", "importtime", "-m", "grader", "ch06", "--solutions"],
                          cwd=REPO, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    imported = {line.split("|")[-1].strip() for line in done.stderr.splitlines() if "|" in line}
    assert "grader.quiz" in imported  # the quiz was graded
    heavy = {m for m in imported if m.split(".")[0] in ("sympy", "jinja2", "matplotlib", "email")
             or m == "importlib.metadata"}
    assert not heavy, sorted(heavy)


@pytest.mark.parametrize("command", ["list", "batch"])
def test_the_launcher_turns_the_collector_back_on_before_the_command_runs(command):
    """grader.faces.launch imports with the collector off, then turns it on with what it imported frozen, before the
    command runs: a long-running one (batch, --watch) collects as ever."""
    script = (
        "import gc, sys\n"
        "import grader.faces.cli\n"
        "def command():\n"
        "    print(gc.isenabled(), gc.get_freeze_count() > 1000)\n"
        "grader.faces.cli.main = command\n"
        f"sys.argv = ['grade', {command!r}]\n"
        "from grader.faces.launch import main\n"
        "main()\n"
    )
    proc = subprocess.run([sys.executable, "-c", script], cwd=REPO, capture_output=True, text=True, timeout=60)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert proc.stdout.split() == ["True", "True"], proc.stdout + proc.stderr[-2000:]
