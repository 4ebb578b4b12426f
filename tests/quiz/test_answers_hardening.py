"""Quizzes under pressure: exponent and nesting bombs, YAML aliases, oversized and broken files,
where the learner id comes from, and no sympy on the fast path. (Missing keys or references:
test_quiz_recorded.py.)"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import pytest
from click.testing import CliRunner

from grader.chapters import CHAPTERS
from grader.faces.cli import main
from grader.model import Status
from grader.quiz import bank, learner_id, symbolic
from grader.quiz.judge import judge
from grader.quiz.symbolic import AnswerError, equivalent, number, parse
from tests.support import (
    REPO,
    RIGHT_CHOICE,
    RIGHT_FACTS,
    CpuTime,
    question_of,
    slow_but_the_first,
    sympy_workers,
    watch_simplifiers,
)

ALL = [c.id for c in CHAPTERS]
SYMBOLIC = [(c, q) for c in ALL for q in bank.questions(c) if q.kind == "symbolic"]


# ---------------------------------------------------------------- expressions that would hang sympy

@pytest.mark.parametrize("hostile, says", [
    ("9**(9*9*9*9*9*9*9*9)", "exponents above 10"),
    ("2^(10*10*10*10*10*10*10*10)", "exponents above 10"),
    ("9**(+-+99999999)", "exponents above 10"),
    ("x**(y*99999999)", "an exponent must be a number"),
    ("(x^2)^3", "power of a power"),
    ("2^(2^(2^22))", "power of a power"),
    ("1e999 * x", "finite"),
    ("atan2(x)", "takes 2 argument"),
    ("sqrt + x", "is a function"),
    ("x if y else 1", "IfExp"),
    ("x < y", "Compare"),
    ("(x := 1)", "NamedExpr"),
    ("sqrt(*[x])", "not allowed"),
    ("x\x00", "formula"),
    ("(" * 150 + "x" + ")" * 150, "at most 200"),
    ("__builtins__", "unknown name"),
    ("\uff58 + 1", "not plain ASCII"),  # fullwidth x
    ("x\u200b + 1", "not plain ASCII"),  # zero-width space
])
def test_expression_bombs_are_refused_before_sympy(hostile, says, monkeypatch):
    from sympy.parsing import sympy_parser

    def never(*args, **kwargs):
        raise AssertionError(f"{hostile!r} reached sympy")

    monkeypatch.setattr(sympy_parser, "parse_expr", never)
    with CpuTime() as work, pytest.raises(AnswerError) as info:
        parse(hostile, ("x", "y"))
    assert work.seconds < 1.0  # refused by reading alone: milliseconds of this process's CPU
    assert says in str(info.value)


@pytest.mark.parametrize("text", ["9**(9*9*9*9*9*9*9*9)", "exp(exp(exp(exp(10))))", "e^(99999*99999)",
                                  "sqrt(-1)", "1/0", "nan", "inf", "log(0)", "x"])
def test_numbers_that_are_not_finite_reals_are_refused_quickly(text):
    with CpuTime() as work, pytest.raises(AnswerError):
        number(text)
    assert work.seconds < 1.0  # no big-number arithmetic: milliseconds of this process's CPU


@pytest.mark.slow
def test_allowed_but_odd_expressions_are_decided_quickly_and_never_equal_by_default(monkeypatch):
    simplifiers = watch_simplifiers(monkeypatch)
    for answer in ["exp(exp(exp(exp(10))))", "sqrt(-1 - x^2)", "e^(x*99999)", "log(-x^2 - y^2)"]:
        with CpuTime() as work:
            assert not equivalent(answer, "-y/(x^2 + y^2)", ("x", "y"))
        assert work.seconds < 2.0, answer  # numbers here; sympy, if asked, in a process of its own
    assert all(s.process is None for s in simplifiers)  # each sympy process ended with its question
    assert sympy_workers() == []


def test_undecided_is_never_equal(monkeypatch):
    monkeypatch.setattr(symbolic, "_simplify_is_zero", lambda *args, **kwargs: None)  # e.g. a timeout
    assert not equivalent("sqrt(-1 - x^2)", "sqrt(-1 - x^2)", ("x",))  # undefined at every point


def test_simplify_decides_where_points_cannot():
    # undefined at every real point of the domain, so only simplify can say they are the same
    assert equivalent("sqrt(-1 - x^2)*2", "2*sqrt(-1 - x^2)", ("x",))


@pytest.mark.slow
def test_simplify_time_limit(monkeypatch):
    """sympy runs in a process of its own that is killed at the time limit (a thread could not be
    stopped: sympy works on this one for many seconds)."""
    monkeypatch.setattr(symbolic, "SIMPLIFY_SECONDS", 0.5)
    simplifiers = watch_simplifiers(monkeypatch)
    assert symbolic._simplify_is_zero("x*exp(exp(exp(exp(exp(1)))))", "-y/(x^2 + y^2)", ("x", "y")) is None
    # its process started, then was stopped without an answer at the time limit (there is no learner deadline)
    assert [(s.started, s.stopped, s.out_of_time) for s in simplifiers] == [(True, True, False)]
    assert sympy_workers() == []
    cpu = time.process_time()
    time.sleep(0.5)
    assert time.process_time() - cpu < 0.2  # nothing of it goes on in this process


@pytest.mark.slow
@pytest.mark.parametrize("chapter, question", SYMBOLIC, ids=lambda v: getattr(v, "id", v))
def test_symbolic_keys_and_known_wrong_answers_agree_with_sympy(chapter, question):
    import sympy

    from grader.quiz.judge import right_answer
    from grader.quiz.mistakes import wrong_expression

    key = bank.keys(chapter)[question.id]
    for learner in ("reference", "alice", "bob") if question.params else ("reference",):
        values = question.values_for(learner, chapter)  # a per-learner key and its mistakes with their numbers
        answer = right_answer(question, key, key.value_for(chapter, values), values)
        right = parse(answer, question.symbols)
        for wrong in key.wrong:
            mistake = wrong_expression(question, wrong, values)
            assert sympy.simplify(parse(mistake, question.symbols, question.derived) - right) != 0
            assert not equivalent(mistake, answer, question.symbols, question.domain, derived=question.derived)
        assert equivalent(answer, str(right), question.symbols, question.domain)


def test_vector_answers_go_through_the_same_whitelist(tmp_path):
    question, key = question_of("ch06", "H_at_point"), bank.keys("ch06")["H_at_point"]
    for hostile in ["[[9**(9*9*9*9*9*9*9*9), 1], [1, 1]]", "[[().__class__, 1], [1, 1]]",
                    "[[__import__('os'), 1], [1, 1]]", "1, 2; 3, x"]:
        with CpuTime() as work, pytest.raises(AnswerError):
            judge(question, key, hostile, [[1, 0], [0, 1]], seed=0)
        assert work.seconds < 1.0, hostile


# ------------------------------------------------------------------------------- answer files

def test_alias_bomb_is_refused_and_the_rest_graded(quiz):
    text = 'a0: &a0 ["1","1","1","1","1","1","1","1","1"]\n'
    for i in range(1, 12):
        text += f"a{i}: &a{i} [" + ",".join([f"*a{i - 1}"] * 9) + "]\n"
    text += f"H_at_point: *a11\nbearing_near_dish: {RIGHT_CHOICE}\n"
    with CpuTime() as work:
        results, problems = quiz("ch06", text)
    assert work.seconds < 2.0  # the aliases are never expanded (9^11 values)
    assert "line 13, question H_at_point: " in results["H_at_point"].message
    assert any("anchors and aliases" in p for p in problems), problems  # a1 ... a11: unknown ids too
    assert results["bearing_near_dish"].status == Status.PASS
    assert results["H_at_point"].status == Status.FAIL


@pytest.mark.parametrize("depth", slow_but_the_first([50, 30_000]))
def test_deeply_nested_answer_is_refused_without_crashing(quiz, depth):
    text = f"bearing_near_dish: {RIGHT_CHOICE}\nH_at_point: " + "[" * depth + "]" * depth + f"\nH_facts: {RIGHT_FACTS}\n"
    results, _ = quiz("ch06", text)
    assert "exercises/answers/ch06.yaml, line 2, question H_at_point" in results["H_at_point"].message
    assert results["bearing_near_dish"].status == Status.PASS and results["H_facts"].status == Status.PASS


def test_other_shapes_of_bad_answers(quiz):
    text = ("bearing_near_dish: {a: 1}\nH_at_point: [" + ", ".join(["1"] * 500) + "]\n"
            "H_facts: !!python/object:os.system x\ndbearing_dx: *nothing\n")
    results, problems = quiz("ch06", text)
    assert not problems  # each said at its own answer's line, the line 4 alias among them
    assert "line 1, question bearing_near_dish: a mapping" in results["bearing_near_dish"].message
    assert "line 2, question H_at_point: more than 100 values" in results["H_at_point"].message
    assert "line 3, question H_facts: could not determine a constructor" in results["H_facts"].message
    assert "line 4, question dbearing_dx: this answer is not valid YAML" in results["dbearing_dx"].message
    assert all(r.status == Status.FAIL and r.points == 0 for r in results.values())


def test_oversized_file_is_reported_not_read(quiz):
    results, problems = quiz("ch06", "bearing_near_dish: a\n" + "# padding\n" * 10_000)
    assert any("bytes" in p for p in problems)
    assert all(r.message == "not answered yet" for r in results.values())


def test_bytes_that_are_not_utf8_cost_only_their_answer(quiz):
    text = f"bearing_near_dish: {RIGHT_CHOICE}\ndbearing_dx: \xff\xfe\nH_facts: {RIGHT_FACTS}\n"
    results, _ = quiz("ch06", text.encode("latin-1"))
    assert results["bearing_near_dish"].status == Status.PASS and results["H_facts"].status == Status.PASS
    assert "line 2, question dbearing_dx" in results["dbearing_dx"].message
    assert "ASCII" in results["dbearing_dx"].message



def test_an_answer_file_in_windows_1252_is_read_with_a_note_at_its_line(quiz):
    """As a chapter file that is not UTF-8 (tests/test_submission_encodings.py): read as before, with a note at the
    line of the first such byte, in the report too; a UTF-16 or byte-order-mark file is read as such, with its own
    note alone."""
    text = f"bearing_near_dish: {RIGHT_CHOICE}\n# my answers, café\nH_facts: {RIGHT_FACTS}\ndbearing_dx: 2×x\n"
    cp1252 = ('exercises/answers/ch06.yaml, line 2 is not UTF-8 (byte 0xE9, "é" in Windows-1252): it was read with '
              "each such byte as an unknown character, so an answer that holds one is not what you wrote; save it as "
              "UTF-8 (in Notepad: Save as, Encoding: UTF-8)")
    for encoding, said in (("utf-16", "exercises/answers/ch06.yaml is saved as UTF-16"),
                           ("utf-8-sig", "exercises/answers/ch06.yaml is saved as UTF-8 with a byte-order mark"),
                           ("cp1252", cp1252)):
        notes: list[str] = []
        results, problems = quiz("ch06", text.encode(encoding), notes=notes)
        assert results["bearing_near_dish"].status == Status.PASS and results["H_facts"].status == Status.PASS
        assert not problems, problems
        assert len(notes) == 1 and notes[0].startswith(said), (encoding, notes)
    assert "line 4, question dbearing_dx" in results["dbearing_dx"].message  # × read as an unknown character
    done = CliRunner().invoke(main, ["quiz", "ch06", "--submission", str(quiz.folder.parents[1]), "--format", "json"])
    assert json.loads(done.output)["chapters"][0]["notes"] == [cp1252], done.output


def test_a_file_of_hostile_answers_is_graded_quickly_without_errors(quiz, tmp_path):
    text = "\n".join([
        "bearing_near_dish: \"__import__('os').system('touch pwned')\"",
        "H_at_point: \"[[x.__class__, 1], [1, 1]]\"",
        "dbearing_dx: \"lambda: 1\"",
        f"bearing_variance: \"{'9' * 10_000}\"",
        "H_facts: \"a, b, c, d, e\"",
    ]) + "\n"
    with CpuTime() as work:
        results, _ = quiz("ch06", text)
    assert work.seconds < 2.0
    assert all(r.status == Status.FAIL and r.points == 0 for r in results.values())
    for qid in ("bearing_near_dish", "H_at_point", "dbearing_dx", "bearing_variance"):
        assert "exercises/answers/ch06.yaml, line" in results[qid].message and qid in results[qid].message
    assert not (tmp_path / "pwned").exists() and not Path("pwned").exists()


def test_got_is_the_answer_as_written_and_expected_only_when_right(quiz):
    question = question_of("ch06", "H_at_point")
    right = bank.keys("ch06")["H_at_point"].value_for("ch06", question.values_for("alice", "ch06"))
    written = json.dumps(right.round(6).tolist())
    results, _ = quiz("ch06", f"H_at_point: {written}\ndbearing_dx: -y/rho\n")
    assert results["H_at_point"].got == written and results["H_at_point"].expected is not None
    assert results["dbearing_dx"].got == "-y/rho" and results["dbearing_dx"].expected is None
    assert "unknown name 'rho'" in results["dbearing_dx"].message


# ------------------------------------------------------------------------ per-learner numbers

def test_learner_numbers_are_pinned_and_the_same_in_a_fresh_interpreter():
    question = question_of("ch06", "H_at_point")
    here = {learner: question.values_for(learner, "ch06") for learner in ("alice", "bob", "reference")}
    code = ("import json; from grader.quiz import bank; q = [q for q in bank.questions('ch06') "
            "if q.id == 'H_at_point'][0]; print(json.dumps({l: q.values_for(l, 'ch06') "
            "for l in ('alice', 'bob', 'reference')}))")
    env = dict(os.environ, PYTHONHASHSEED="12345", PYTHONPATH=str(REPO))
    there = json.loads(subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                                      check=True, env=env).stdout)
    assert here == there
    assert bank.variant_seed("alice", "ch06", "H_at_point") == 0x0A4DF1E3878BEAFF  # sha256, pinned


def test_learner_id_sources(tmp_path):
    folder = tmp_path / "exercises" / "answers"
    folder.mkdir(parents=True)
    assert learner_id(folder, None) == ("anonymous", "default")
    (folder / "learner.yaml").write_text("learner: carol\n")
    assert learner_id(folder, None) == ("carol", "exercises/answers/learner.yaml")
    assert learner_id(folder, "dave") == ("dave", "--learner")
    (folder / "learner.yaml").write_text("learner: [carol\n")
    who, source = learner_id(folder, None)
    assert who == "anonymous" and "not valid YAML" in source
    (folder / "learner.yaml").write_text("a: &a [1,1,1,1,1,1,1,1]\nb: &b [*a,*a,*a,*a,*a,*a,*a,*a]\nlearner: *b\n")
    assert learner_id(folder, None)[0] == "anonymous"


def test_cli_names_the_learner_and_its_source(tmp_path):
    root = tmp_path / "project"
    answers = root / "exercises" / "answers"
    answers.mkdir(parents=True)
    shutil.copytree(REPO / "exercises", root / "exercises", dirs_exist_ok=True,
                    ignore=shutil.ignore_patterns("__pycache__"))
    (answers / "learner.yaml").write_text("learner: carol\n")
    runner = CliRunner()
    result = runner.invoke(main, ["quiz", "ch06", "--submission", str(root)])
    assert result.exit_code == 1, result.output
    assert "carol (from exercises/answers/learner.yaml)" in result.output.splitlines()[0]
    assert "error" not in result.output.lower()
    result = runner.invoke(main, ["quiz", "ch06", "--submission", str(root), "--learner", "dave", "--show"])
    numbers = question_of("ch06", "H_at_point").values_for("dave", "ch06")
    assert "dave (from --learner)" in result.output and f"({numbers['x']:g}, {numbers['y']:g})" in result.output


# --------------------------------------------------------------------------- speed of grade chNN

def test_quiz_path_of_grade_chapter_imports_no_sympy_even_for_right_symbolic_answers(repo_root):
    code = ("import sys; from pathlib import Path; from grader.model import Report, ChapterResult; "
            "from grader.quiz import add_quiz_results; "
            "r = Report('x', [ChapterResult(c, c) for c in ('ch00', 'ch06', 'ch09')]); "
            "add_quiz_results(r, Path(sys.argv[1]), 'solutions'); "
            "assert all(c.status.value == 'pass' for ch in r.chapters for c in ch.checks), r.to_dict(); "
            "print('sympy' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code, str(repo_root)], capture_output=True, text=True, check=False,
                         cwd=repo_root, env=dict(os.environ, PYTHONPATH=str(repo_root)))
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "False"
