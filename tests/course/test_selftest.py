"""grade selftest: the course holds at many seeds (the references get full marks, every mistake a check names is
told apart at its inputs, every parametrised question's key is finite, well-conditioned and told apart from its
wrong answers for every learner draw); a planted ill-conditioned parameter range fails, naming its seed, with a
command that reproduces it; a check whose random inputs repeat one point is found."""

from __future__ import annotations

import re
import shutil
from pathlib import Path

import pytest

from grader.course import selftest
from grader.quiz import bank
from tests.support import run_grade

# a question planted in a copy of the banks: the tangent line's error at x next to a = 8.5, where the error is a
# few 1e-5 and moves by its own size when x moves by a hundredth: ill-conditioned
PLANTED_QUESTION = """  - id: error_value
    kind: numeric
    prompt: For f = sqrt, how far is the tangent line at a = {a} from sqrt(x) at x = {x}?
    params: {a: [8.5, 8.5], x: [8, 9]}
    avoid: {"x - a": 0}
    format: a number (3 significant digits are enough), e.g. `0.0125`
"""
PLANTED_KEY = """error_value:
  compute: {function: linearization_error, args: [$sqrt, $sqrt_prime, a, x]}
  rtol: 5.0e-3  # 3 significant digits
  atol: 1.0e-7
"""


@pytest.fixture
def planted(tmp_path) -> Path:
    banks = tmp_path / "quizzes"
    shutil.copytree(bank.QUIZ_DIR, banks, ignore=shutil.ignore_patterns("__pycache__", "*.md"))
    with (banks / "ch01.yaml").open("a", encoding="utf-8") as handle:
        handle.write(PLANTED_QUESTION)
    with (banks / "keys" / "ch01.yaml").open("a", encoding="utf-8") as handle:
        handle.write(PLANTED_KEY)
    return banks


def test_the_planted_range_fails_at_the_draws_next_to_a_and_only_there(planted):
    watch = selftest.Watch()
    seeds = selftest.seeds_for(40)
    assert selftest.check_quiz(["ch01"], seeds, watch, planted) == 2 * 40
    failures, _ = watch.failures(seeds, lambda item, seed: "")
    assert [f.item for f in failures] == ["ch01/quiz_error_value"]
    question = next(q for q in bank.questions("ch01", planted) if q.id == "error_value")
    failing = {seed for seed in seeds if watch.problems.get("ch01/quiz_error_value", {}).get(seed)}
    near = {seed for seed in seeds
            if abs(question.values_for(f"{selftest.LEARNER_PREFIX}{seed}", "ch01")["x"] - 8.5) < 0.15}
    assert failing == near and near and failures[0].seed == next(s for s in seeds if s in near)


@pytest.mark.slow
def test_a_planted_ill_conditioned_range_fails_naming_its_seed_and_the_command_reproduces_it(planted):
    done = run_grade("selftest", "--seeds", 60, "--chapters", "ch01", "--no-code", "--quizzes", planted)
    assert done.returncode == 1, done.stdout + done.stderr[-2000:]
    found = re.search(r"^FAIL ch01/quiz_error_value at seed (\d+) \(and (\d+) other seeds\):$", done.stdout,
                      re.MULTILINE)
    assert found, done.stdout
    seed = int(found[1])
    first = done.stdout.split(found[0], 1)[1]
    assert re.search(r"the key is ill-conditioned in [ax]: its relative condition number is 1\d\d \(at most 100\)", first)
    learner = f"{selftest.LEARNER_PREFIX}{seed}"
    question = next(q for q in bank.questions("ch01", planted) if q.id == "error_value")
    assert abs(question.values_for(learner, "ch01")["x"] - 8.5) == pytest.approx(0.1)  # the draws next to a fail
    assert f"(learner {learner}: a = 8.5, x = " in first
    command = re.search(r"reproduce: grade (selftest --seed \d+ --chapters ch01 --quizzes \S+);", first)[1].split()
    assert command[:5] == ["selftest", "--seed", str(seed), "--chapters", "ch01"]
    again = run_grade(*command, "--no-code")
    assert again.returncode == 1 and f"FAIL ch01/quiz_error_value at seed {seed}:" in again.stdout, again.stdout
    assert "ch01/quiz_tangent_value" not in done.stdout  # the banks' own questions hold
    assert done.stdout.rstrip().splitlines()[-1].startswith("1 check or question fail at 60 seeds")


def test_a_check_whose_random_points_repeat_one_point_fails_where_its_mistake_hides():
    """range_bearing_all_quadrants asks for points in all four quadrants; were its points one point drawn eight times
    (each from a fresh generator, as ctx.rng once gave), "atan" would hide at every seed whose point has x > 0."""
    watch = selftest.Watch()
    for seed, apart in ((1, True), (2, False), (3, True)):
        watch.mistake("ch06/range_bearing_all_quadrants", "atan\nhelp", "atan", "known", seed, apart,
                      "ch06/range_bearing")
    failures, _ = watch.failures([1, 2, 3], lambda item, seed: f"grade selftest --seed {seed}")
    assert [(f.item, f.seed) for f in failures] == [("ch06/range_bearing_all_quadrants", 2)]
    assert "the mistake 'atan' is not told apart" in failures[0].problems[0]
    watch.mistake("ch06/range_bearing_worked_example", "atan\nhelp", "atan", "known", 2, True, "ch06/range_bearing")
    failures, notes = watch.failures([1, 2, 3], lambda item, seed: "")
    assert failures == [] and any("another check of ch06/range_bearing does" in note for note in notes)


def test_a_check_draws_one_stream_of_random_inputs():
    from grader.checks import ch06
    from grader.checks.base import Context
    from grader.judging.expected import planning

    context = Context(17, "ch06", "range_bearing_elevation_random_points")
    with planning("ch06", context.check_id, 17):
        points = [tuple(ch06._point_3d(context.rng)) for _ in range(8)]
    assert len(set(points)) == 8
    assert {point[0] > 0 for point in points} == {True, False}  # both sides of the dish: atan is told from atan2


def test_a_range_without_numbers_fails_at_once_instead_of_drawing_forever(tmp_path):
    banks = tmp_path / "quizzes"
    shutil.copytree(bank.QUIZ_DIR, banks, ignore=shutil.ignore_patterns("__pycache__", "*.md"))
    text = (banks / "ch06.yaml").read_text(encoding="utf-8")
    (banks / "ch06.yaml").write_text(text.replace("params: {r: [0.5, 5]}", "params: {r: [0, 0.4]}"), encoding="utf-8")
    watch = selftest.Watch()
    selftest.check_quiz(["ch06"], [1, 2], watch, banks)
    failures, _ = watch.failures([1, 2], lambda item, seed: "")
    assert [(f.item, f.seed) for f in failures] == [("ch06/quiz_bearing_variance", 1)]
    assert "r in [0, 0.4] has no value of size 0.5 or more" in failures[0].problems[0]


@pytest.mark.slow
def test_the_course_holds_at_200_seeds():
    done = run_grade("selftest", "--seeds", 200, timeout=3600)
    assert done.returncode == 0, done.stdout[-5000:] + done.stderr[-2000:]
    summary = done.stdout.rstrip().splitlines()[-1]
    assert summary.startswith("everything holds at 200 seeds"), summary
    checks = int(re.search(r"(\d+) checks judged", summary)[1])
    draws = int(re.search(r"(\d+) quiz draws judged", summary)[1])
    from grader import checks as check_registry
    from grader.chapters import CHAPTERS

    every = sum(len(check_registry.load(c.id).checks) for c in CHAPTERS)
    drawn = sum(bool(q.params) for c in CHAPTERS for q in bank.questions(c.id))
    assert checks == 200 * every and draws == 200 * drawn, summary  # every check at every seed, every draw


@pytest.mark.slow
def test_the_default_selftest_of_the_quiz_holds_and_its_help_says_what_it_checks():
    done = run_grade("selftest", "--no-code")
    assert done.returncode == 0, done.stdout[-3000:]
    assert done.stdout.rstrip().splitlines()[-1].startswith(f"everything holds at {selftest.DEFAULT_SEEDS} seeds")
    shown = run_grade("selftest", "--help").stdout
    assert "well-conditioned" in shown and "grade selftest --seeds 200" in shown
