"""Chapter quizzes: grade a learner's answer file against the question bank and its keys.

Quiz results are CheckResult(kind="quiz") in the same ChapterResult as the code checks. No learner
code runs here: answers are data, read from YAML and parsed behind a whitelist (symbolic.py).
"""

from __future__ import annotations

import zlib
from pathlib import Path

from grader.chapters import BY_ID
from grader.model import ChapterResult, CheckResult, Report, Status
from grader.quiz import bank
from grader.quiz.answers import read
from grader.quiz.symbolic import AnswerError

DEFAULT_LEARNER = "anonymous"


def answers_dir(root: Path, package: str) -> Path:
    return Path(root) / package / "answers"


def learner_id(answers_folder: Path, given: str | None) -> tuple[str, str]:
    """(learner id, where it came from): --learner, else answers/learner.yaml, else 'anonymous'."""
    if given:
        return given, "--learner"
    config = answers_folder / "learner.yaml"
    if config.exists():
        import yaml

        try:
            data = yaml.safe_load(config.read_text(encoding="utf-8")) or {}
            if isinstance(data, dict) and str(data.get("learner") or "").strip():
                return str(data["learner"]).strip(), f"{config.parent.name}/learner.yaml"
        except yaml.YAMLError:
            pass
    return DEFAULT_LEARNER, "default"


def grade_quiz(chapter: str, answers_folder: Path, learner: str, shown_folder: str,
               quiz_dir: Path = bank.QUIZ_DIR) -> tuple[list[CheckResult], list[str]]:
    """The quiz results of one chapter, and chapter-level problems (file, line, question)."""
    from grader.quiz.judge import fmt_value, judge

    questions = bank.questions(chapter, quiz_dir)
    keys = bank.keys(chapter, quiz_dir)
    shown = f"{shown_folder}/{chapter}.yaml"
    answers = read(answers_folder / f"{chapter}.yaml", shown)
    problems = list(answers.problems)
    known = {q.id for q in questions}
    for qid, answer in answers.answers.items():
        if qid not in known:
            problems.append(f"{shown}, line {answer.line}: unknown question id {qid!r} "
                            f"(the questions are {', '.join(sorted(known))})")
    module = BY_ID[chapter].module
    results = []
    for question in questions:
        values = question.values_for(learner, chapter)
        description = " ".join(question.text_for(values).split())
        if len(description) > 100:
            description = description[:97] + "..."
        result = CheckResult(id=f"quiz_{question.id}", function=question.id, description=description,
                             status=Status.FAIL, points=0.0, max_points=question.points, kind="quiz")
        answer = answers.answers.get(question.id)
        if answer is None or answer.value is None or str(answer.value).strip() == "":
            result.message = "not answered yet"
        elif keys is None or question.id not in keys:
            result.status, result.message = Status.SKIP, "the answer key is not installed here; your answer is kept"
            result.got = answer.value
        else:
            key = keys[question.id]
            result.got = answer.value if isinstance(answer.value, (int, float, str, list)) else str(answer.value)
            seed = zlib.crc32(f"{chapter}/{question.id}".encode())
            try:
                right_value = key.value_for(module, values)
                verdict = judge(question, key, answer.value, right_value, seed)
            except AnswerError as exc:
                result.message = f"{shown}, line {answer.line}, question {question.id}: {exc}"
            else:
                result.points = question.points * verdict.fraction
                result.status = Status.PASS if verdict.right else Status.FAIL
                result.message = verdict.feedback
                if verdict.right:
                    result.expected = fmt_value(right_value)
        results.append(result)
    return results, problems


def add_quiz_results(report: Report, root: Path, package: str, learner: str | None = None) -> str:
    """Append each chapter's quiz results to `report` and record whose variants were graded."""
    folder = answers_dir(root, package)
    who, source = learner_id(folder, learner)
    report.learner = f"{who} (from {source})"
    for chapter in report.chapters:
        try:
            results, problems = grade_quiz(chapter.chapter, folder, who, f"{package}/answers")
        except bank.BankError as exc:
            chapter.problems.append(f"quiz not graded: {exc}")
            continue
        except FileNotFoundError:
            continue  # a chapter without a quiz
        chapter.checks.extend(results)
        chapter.problems.extend(problems)
    return report.learner


def quiz_report(chapters: list[str], root: Path, package: str, label: str, learner: str | None) -> tuple[Report, str]:
    """A report of quizzes only (`grade quiz`)."""
    report = Report(label, [ChapterResult(c, BY_ID[c].title) for c in chapters])
    who = add_quiz_results(report, root, package, learner)
    return report, who
