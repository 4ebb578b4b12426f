"""bank.public_keys: the keys an immediate-feedback handout may ship (none computed by the
references, none of a per-learner question), as plain data that bank.keys reads back and grades with."""

from __future__ import annotations

import json
import shutil

import pytest
import yaml

from grader.chapters import CHAPTERS
from grader.model import Status
from grader.quiz import bank, grade_quiz
from grader.quiz.templates import reference_answers
from tests.support import run_grade

ALL = [c.id for c in CHAPTERS]


@pytest.fixture
def immediate(tmp_path):
    """A copy of the banks with only the public keys, dumped as the release builder would."""
    quiz_dir = tmp_path / "quizzes"
    (quiz_dir / "keys").mkdir(parents=True)
    for chapter in ALL:
        shutil.copy(bank.QUIZ_DIR / f"{chapter}.yaml", quiz_dir)
        (quiz_dir / "keys" / f"{chapter}.yaml").write_text(yaml.safe_dump(bank.public_keys(chapter)))
    return quiz_dir


@pytest.mark.parametrize("chapter", ALL)
def test_public_keys_are_the_stored_keys_and_read_back_unchanged(immediate, chapter):
    every = bank.keys(chapter)
    fixed = {q.id for q in bank.questions(chapter) if not q.params}
    stored = {qid for qid, key in every.items() if key.compute is None and qid in fixed}
    assert stored and stored != set(every)  # each chapter has both kinds
    public = bank.public_keys(chapter)
    assert set(public) == stored
    assert not any("compute" in raw for raw in public.values())
    assert bank.keys(chapter, immediate) == {qid: every[qid] for qid in stored}


@pytest.mark.parametrize("chapter", ["ch02", "ch03", "ch04", "ch06", "ch07"])
def test_a_per_learner_symbolic_key_stays_with_the_instructor(chapter):
    """Written in the question's parameters it is everyone's answer at once: never a practice key."""
    per_learner = [q.id for q in bank.questions(chapter) if q.kind == "symbolic" and q.params]
    keys = bank.keys(chapter)
    assert per_learner and all(keys[qid].compute is None for qid in per_learner)
    assert not set(per_learner) & set(bank.public_keys(chapter))


@pytest.mark.parametrize("chapter", ALL)
def test_public_keys_grade_their_questions_and_the_computed_ones_are_recorded(tmp_path, immediate, chapter):
    folder = tmp_path / "answers"
    folder.mkdir()
    (folder / f"{chapter}.yaml").write_text(reference_answers(chapter, "alice"))
    results, problems = grade_quiz(chapter, folder, "alice", "exercises/answers", quiz_dir=immediate)
    assert not problems
    for result in results:
        if result.function in bank.public_keys(chapter):
            assert result.status == Status.PASS and result.points == result.max_points, result.message
        else:
            assert result.status == Status.RECORDED, result.message


def test_public_keys_are_a_fresh_copy_and_empty_without_keys(tmp_path):
    bank.public_keys("ch06")["dbearing_dx"]["answer"] = "x"
    assert bank.public_keys("ch06")["dbearing_dx"]["answer"] == "-y/(x^2 + y^2)"
    shutil.copy(bank.QUIZ_DIR / "ch06.yaml", tmp_path)
    assert bank.public_keys("ch06", tmp_path) == {}


def test_cli_in_an_immediate_handout_judges_public_keys_and_records_the_rest(tmp_path, immediate):
    answers = tmp_path / "exercises" / "answers"
    answers.mkdir(parents=True)
    (answers / "ch06.yaml").write_text(reference_answers("ch06", "alice"))
    proc = run_grade("quiz", "ch06", "--submission", tmp_path, "--learner", "alice", "--format", "json",
                     quiz_dir=immediate)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    chapter = json.loads(proc.stdout)["chapters"][0]
    statuses = {c["function"]: c["status"] for c in chapter["checks"]}
    assert statuses == {"bearing_near_dish": "pass", "H_at_point": "recorded", "dbearing_dx": "pass",
                        "bearing_variance": "recorded", "H_facts": "pass", "dish_dbearing_dx": "recorded"}
    points = {q.id: q.points for q in bank.questions("ch06")}
    assert chapter["score"] == chapter["max_score"] == points["bearing_near_dish"] + points["dbearing_dx"] + 1
    assert chapter["pending_score"] == points["H_at_point"] + points["bearing_variance"] + points["dish_dbearing_dx"]
