"""The answer reader accepts what people type, or says exactly how to write it: implicit products
(`6x - 9`, `2xy`, `2(x+1)`, `r cos(theta)`, `cos y`), the Unicode minus sign, `×` and `·`,
superscripts (`x²`, `r⁻²`), `π`, `θ`, `√`, and symbols a question derives (`r` for sqrt(x^2 + y^2));
`1/2x` and the like are refused as ambiguous with the two readings written out, and an unquoted
`- y/...` that YAML reads as a list is answered with how to quote it. Judged through real answer
files (and the real CLI), with the whitelist and its limits intact."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

from grader.model import Status
from grader.quiz.symbolic import AnswerError, check_text, normalize, parse
from tests.support import REPO, CpuTime, question_of, right_value, run_grade

# (chapter, question, the right answer as people type it)
TYPED_RIGHT = [
    ("ch01", "tangent_of_square", "6x - 9"),
    ("ch01", "tangent_of_square", "6(x - 3) + 9"),
    ("ch01", "tangent_of_square", "9 + 6·(x − 3)"),
    ("ch01", "tangent_of_square", "6×x − 9"),
    ("ch02", "partial_x", "2xy"),
    ("ch02", "partial_x", "2x y"),
    ("ch02", "partial_x", "2yx"),
    ("ch02", "partial_x", "2·x·y"),
    ("ch03", "dy_dtheta", "r cos(θ)"),
    ("ch03", "dy_dtheta", "rcos(theta)"),
    ("ch03", "dy_dtheta", "r cos θ"),
    ("ch04", "derivative_sin_square", "2x cos(x²)"),
    ("ch04", "derivative_sin_square", "2x·cos(x^2)"),
    ("ch07", "dx_dtheta", "-v sin(theta) dt"),
    ("ch07", "dx_dtheta", "−v·dt·sin(θ)"),
    ("ch07", "dx_dtheta", "-vdt sin(theta)"),
    ("ch09", "mixed_partial", "6xy²"),
    ("ch09", "mixed_partial", "6 x y^2"),
    ("ch09", "mixed_partial", "(2x)(3y²)"),
    ("ch08", "wrapped_innovation", "6.2 − 2π"),
    ("ch08", "unbiased", "−(−2)"),
    ("ch04", "pipeline", "[[2.866, −11.856], [3.464, −8]]"),
    ("ch04", "pipeline", "[[2 + √3/2, 2 − 8√3], [2√3, −8]]"),
]


# the symbols a question derives: `r` in questions about x and y (the key's explanation uses it)
DERIVED_RIGHT = [
    ("ch06", "dbearing_dx", "-y/r^2"),
    ("ch06", "dbearing_dx", "−y/r²"),
    ("ch06", "dbearing_dx", "-y r⁻²"),
    ("ch06", "dbearing_dx", "-y/(r r)"),
    ("ch00", "drange_dx", "x/r"),
    ("ch00", "drange_dx", "x r^-1"),
    ("ch00", "drange_dx", "x/√(x² + y²)"),
]


@pytest.mark.parametrize("chapter, question, text", TYPED_RIGHT + DERIVED_RIGHT)
def test_right_answers_as_people_type_them_pass(quiz, chapter, question, text):
    results, problems = quiz(chapter, f"{question}: {text}\n")
    assert not problems
    assert results[question].status == Status.PASS, results[question].message
    assert results[question].got == text


def test_a_derived_symbol_is_only_where_the_question_defines_it(quiz):
    results, _ = quiz("ch02", "partial_x: 2x r\n")
    assert results["partial_x"].status == Status.FAIL
    assert "unknown name 'r' (symbols allowed here: x, y)" in results["partial_x"].message


def test_sympy_decides_with_a_derived_symbol_replaced_by_its_definition():
    import sympy

    derived = {"r": "sqrt(x^2 + y^2)"}
    assert sympy.simplify(parse("-y/r^2", ("x", "y"), derived) - parse("-y/(x^2 + y^2)", ("x", "y"))) == 0


# (what is typed, what the message says); each costs only its own question
REFUSED = [
    ("1/2x", "`1/2x` is ambiguous: write 1/(2*x) or (1/2)*x"),
    ("y/2x", "`y/2x` is ambiguous: write y/(2*x) or (y/2)*x"),
    ("x^2y", "`x^2y` is ambiguous: write x^2*y or x^(2*y)"),
    ("sin x^2", "put the argument of sin in brackets: `sin x^2` can be read more than one way"),
    ("sin 2x", "put the argument of sin in brackets: `sin 2x` can be read more than one way"),
    ("x2 y", "unknown name 'x2' (symbols allowed here: x, y); write x^2 for a power or 2*x for a product"),
    ("2 sinx", "unknown name 'sinx' (symbols allowed here: x, y); write sin(x)"),
    ("2xz", "unknown name 'xz' (symbols allowed here: x, y)"),
    ("\uff58 + 1", "not plain ASCII"),  # fullwidth x
    ("-\u0443 + x", "not plain ASCII"),  # Cyrillic u, a look-alike of y
    ("x\u200b + 1", "not plain ASCII"),  # zero-width space
    ("x²³", "exponents above 10"),
    ("(x²)³", "power of a power"),
    ("2" + "\u00b2" * 250, "at most 200"),
]


@pytest.mark.parametrize("text, says", REFUSED)
def test_what_cannot_be_read_says_how_to_write_it(quiz, text, says):
    with CpuTime() as work:
        results, problems = quiz("ch02", f"gradient_at_point: a\npartial_x: \"{text}\"\n")
    assert work.seconds < 1.0  # read and refused: milliseconds of this process's CPU
    result = results["partial_x"]
    assert result.status == Status.FAIL and result.points == 0
    assert result.message.startswith("exercises/answers/ch02.yaml, line 2, question partial_x: ")
    assert says in result.message, result.message
    assert results["gradient_at_point"].status != Status.ERROR and not problems


def test_implicit_products_never_make_a_call_or_a_name_the_whitelist_refuses():
    # the reader only adds '*' between what is already allowed, and splits a name only into allowed symbols
    for hostile, says in [("__import__ ('os')", "only these functions"), ("x (1) (2)", None), ("exec (1)", "only these"),
                          ("xy.__class__", "Attribute"), ("2 lambda: 1", "cannot read"), ("x if y else 1", "IfExp")]:
        if says is None:
            assert normalize(hostile, ("x", "y")) == "x* (1)* (2)"
            continue
        with pytest.raises(AnswerError) as info:
            check_text(hostile, ("x", "y"))
        assert says in str(info.value), (hostile, str(info.value))


def test_an_unquoted_leading_minus_that_yaml_reads_as_a_list_says_to_quote_it(quiz):
    block = "dbearing_dx:\n  - y/(x^2 + y^2)\nbearing_variance:\n  - 0.25\n"
    results, _ = quiz("ch06", block)
    assert results["dbearing_dx"].message == (
        "exercises/answers/ch06.yaml, line 1, question dbearing_dx: YAML reads an answer that starts with '- ' as a "
        "list: put it in quotes, e.g. dbearing_dx: \"- y/(x^2 + y^2)\"")
    assert results["bearing_variance"].message.endswith("e.g. bearing_variance: \"- 0.25\"")
    same_line = "bearing_variance: 0.25\ndbearing_dx: - y/(x^2 + y^2)\n"
    results, problems = quiz("ch06", same_line)
    assert results["dbearing_dx"].message == (
        "exercises/answers/ch06.yaml, line 2, question dbearing_dx: YAML reads an answer that starts with '- ' as a "
        "list: put it in quotes, e.g. dbearing_dx: \"- y/(x^2 + y^2)\"")
    assert results["bearing_variance"].status == Status.FAIL and "tolerance" in results["bearing_variance"].message
    quoted = "dbearing_dx: \"- y/(x^2 + y^2)\"\n"
    results, _ = quiz("ch06", quoted)
    assert results["dbearing_dx"].status == Status.PASS


def test_a_block_list_is_still_a_vector(quiz):
    gx, gy = right_value("ch02", question_of("ch02", "bowl_gradient"))
    results, _ = quiz("ch02", f"bowl_gradient:\n  - {gx}\n  - {gy}\n")
    assert results["bowl_gradient"].status == Status.PASS


def test_typed_answers_need_no_sympy(tmp_path):
    """The fast path (normalize, whitelist, float evaluation) reads and judges every typed answer above
    without importing sympy."""
    code = ("import json, sys; from pathlib import Path; from grader.quiz import grade_quiz; folder = Path(sys.argv[1]); "
            "statuses = []\n"
            "for chapter, question, text in json.loads(sys.argv[2]):\n"
            "    (folder / f'{chapter}.yaml').write_text(f'{question}: {text}\\n', encoding='utf-8')\n"
            "    statuses += [r.status.value for r in grade_quiz(chapter, folder, 'alice', 'x')[0] if r.got]\n"
            "print(statuses.count('pass'), len(statuses), 'sympy' in sys.modules)")
    cases = TYPED_RIGHT + DERIVED_RIGHT
    done = subprocess.run([sys.executable, "-c", code, str(tmp_path), json.dumps(cases)], capture_output=True,
                          text=True, cwd=REPO, env=dict(os.environ, PYTHONPATH=str(REPO)), timeout=60)
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.split() == [str(len(cases)), str(len(cases)), "False"]


def test_cli_grades_an_implicit_product_and_a_unicode_answer(tmp_path):
    answers = tmp_path / "exercises" / "answers"
    answers.mkdir(parents=True)
    (answers / "ch02.yaml").write_text("partial_x: 2xy\n", encoding="utf-8")
    (answers / "ch06.yaml").write_text("dbearing_dx: −y/r²\n", encoding="utf-8")
    proc = run_grade("quiz", "ch02", "ch06", "--submission", tmp_path, "--learner", "alice", "--format", "json")
    checks = {c["function"]: c for ch in json.loads(proc.stdout)["chapters"] for c in ch["checks"]}
    assert checks["partial_x"]["status"] == "pass" and checks["dbearing_dx"]["status"] == "pass", proc.stdout


@pytest.mark.slow
def test_libyaml_and_the_pure_python_loader_read_an_answer_file_alike(tmp_path, monkeypatch):
    """Answer files are composed by libyaml where their nesting is provably shallow: the same answers, lines
    and source texts as the pure-Python loader gives, Unicode before them included; a deeply nested file goes
    to the pure-Python loader, whose RecursionError is caught, never to libyaml, whose crash would end the run."""
    import yaml

    from grader.quiz import answers

    text = ('# réponse: θ\nq1: "θ = 2π"\nq2: [1, 2.5, -3]\nq3: [[1, 2], [3, 4]]\nq4: 3/5\n'
            'q5: sqrt(x^2 + y^2)\nq6: b, c\n')
    path = tmp_path / "ch06.yaml"
    path.write_text(text, encoding="utf-8")
    loaders = []
    compose = yaml.compose

    def spying(stream, Loader):  # noqa: N803  (yaml's own argument name)
        loaders.append(Loader)
        return compose(stream, Loader=Loader)

    monkeypatch.setattr(yaml, "compose", spying)
    fast = answers.read(path, "ch06.yaml")
    assert loaders == [yaml.CSafeLoader]  # this file went to libyaml alone
    monkeypatch.setattr(answers, "FAST_LOADER", None)
    slow = answers.read(path, "ch06.yaml")
    assert loaders[1:] == [yaml.SafeLoader]
    monkeypatch.undo()
    assert fast.answers == slow.answers and fast.problems == slow.problems
    assert [(a.line, a.text) for a in fast.answers.values()] == \
        [(2, "θ = 2π"), (3, "[1, 2.5, -3]"), (4, "[[1, 2], [3, 4]]"), (5, "3/5"), (6, "sqrt(x^2 + y^2)"), (7, "b, c")]
    deep = "q1: " + "[" * 20_000 + "]" * 20_000 + "\n"
    assert sum(map(deep.count, answers.NESTING)) >= answers.C_DEPTH_BOUND  # not for libyaml
    path.write_text(deep, encoding="utf-8")
    assert "q1" in answers.read(path, "ch06.yaml").unreadable


def test_an_answer_file_read_again_gives_what_reading_it_gave_and_a_callers_changes_stay_its_own(tmp_path):
    """The same bytes read again are not parsed again, but each reader gets its own lists and dicts: one reader's
    change never reaches the next; other bytes under the same name are read afresh."""
    from grader.quiz import answers

    path = tmp_path / "ch06.yaml"
    path.write_text("q1: 3/5\nq2: [1, 2]\nq3 oops\n", encoding="utf-8")
    first = answers.read(path, "ch06.yaml")
    first.answers.pop("q1")
    first.problems.append("a reader's own")
    first.unreadable.clear()
    again = answers.read(path, "ch06.yaml")
    assert sorted(again.answers) == ["q1", "q2"] and "q3" in again.unreadable
    assert "a reader's own" not in again.problems
    path.write_text("q1: 4/5\n", encoding="utf-8")
    assert answers.read(path, "ch06.yaml").answers["q1"].text == "4/5"
