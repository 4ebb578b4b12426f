"""Chapter quizzes: grade a learner's answer file against the question bank and its keys, and
record (format-checked, graded on submission) the answers whose key is not here.

Quiz results are CheckResult(kind="quiz") in the same ChapterResult as the code checks. No learner
code runs here: answers are data, read from YAML and parsed behind a whitelist (symbolic.py).
`add_quiz_results` is the one entry point of `grade chNN`; `quiz_report` that of `grade quiz`;
`templates.show_text` that of `grade quiz --show`.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

from grader.chapters import BY_ID
from grader.ids import id_problem
from grader.model import NOT_ANSWERED, ChapterResult, CheckResult, Report, Status
from grader.quiz import bank
from grader.quiz.answers import LOADER, MAX_BYTES, TOO_LARGE, read
from grader.quiz.symbolic import AnswerError
from grader.safe_text import decode_saved_text

DEFAULT_LEARNER = "anonymous"


def answers_dir(root: Path, package: str) -> Path:
    return Path(root) / package / "answers"


def _configured_learner(config: Path, shown: str) -> tuple[str | None, str]:
    """(the id in learner.yaml or None, why it names no usable id: "" where it names nobody), the file
    named as `shown` and, where one is to blame, its line."""
    import yaml

    if not config.exists():
        return None, ""
    if config.stat().st_size > MAX_BYTES:
        return None, f"{shown} is too large"
    try:
        node = yaml.compose(decode_saved_text(config.read_bytes())[0], Loader=LOADER)
    except (yaml.YAMLError, RecursionError) as exc:
        mark = getattr(exc, "problem_mark", None)
        return None, f"{shown} is not valid YAML{f' (line {mark.line + 1})' if mark else ''}"
    if node is None:
        return None, ""
    if not isinstance(node, yaml.MappingNode):
        return None, f"{shown} should hold one line `learner: your-id`"
    for key, value in node.value:
        if not (isinstance(key, yaml.ScalarNode) and key.value == "learner"):
            continue
        where = f"{shown}, line {value.start_mark.line + 1}"
        if not isinstance(value, yaml.ScalarNode):
            kind = "a list" if isinstance(value, yaml.SequenceNode) else "a mapping"
            return None, f"{where}: `learner:` holds {kind}, not one id; write `learner: your-id`"
        who = value.value.strip()
        if not who:
            return None, ""
        problem = id_problem(who)
        if problem:
            return None, f"{where}: the learner id {who!r} {problem}"
        return who, ""
    return None, ""


def learner_in_file(answers_folder: Path, package: str = "exercises") -> tuple[str | None, str]:
    """(the id <package>/answers/learner.yaml names, or None; why it names no usable id, with the file and line, or
    "" where it names nobody): the one reading of learner.yaml, for every command that takes the id from it."""
    return _configured_learner(answers_folder / "learner.yaml", f"{package}/answers/learner.yaml")


def learner_id(answers_folder: Path, given: str | None, package: str = "exercises",
               given_from: str = "--learner") -> tuple[str, str]:
    """(learner id, where it came from): the id `given` (from `given_from`: --learner, or a batch's roster, a
    submission's name, Gradescope's metadata), else <package>/answers/learner.yaml, else 'anonymous'."""
    if given is not None and given.strip():
        return given.strip(), given_from
    who, note = learner_in_file(answers_folder, package)
    if who is not None:
        return who, f"{package}/answers/learner.yaml"
    return DEFAULT_LEARNER, f"default; {note}" if note else "default"


def _short(text: str, width: int = 100) -> str:
    text = " ".join(text.split())
    return text if len(text) <= width else text[:width - 3] + "..."


RECORDED_MESSAGE = "recorded; graded when you submit"


OUT_OF_TIME = "not judged: the time for this learner ran out before this question's turn"


def _time_is_up(deadline: float | None) -> bool:
    return deadline is not None and time.monotonic() >= deadline


def grade_quiz(chapter: str, answers_folder: Path, learner: str, shown_folder: str,
               quiz_dir: Path | None = None, deadline: float | None = None,
               only: frozenset[str] | None = None, notes: list[str] | None = None) -> tuple[list[CheckResult], list[str]]:
    """The quiz results of one chapter, and chapter-level problems (file, line, question).

    A question whose key is here is judged. One whose key is not (no keys file, not in it, or
    computed by references that are not installed) has its answer read and format-checked
    without sympy and is RECORDED when well-formed: graded on submission, not in max_score.
    Whatever an answer holds, it costs only its own question: an answer that cannot be read or
    judged fails with file, line and why; one not judged by `deadline` (time.monotonic()) is SKIP
    with OUT_OF_TIME; one that sympy could not decide in time fails with judge.UNDECIDED. `only` (question
    ids) grades those questions alone."""
    from grader.quiz.judge import (
        answer_terms,
        fmt_value,
        judge,
        read_answer,
        right_answer,
        shown_key,
    )

    questions = bank.questions(chapter, quiz_dir)
    keys = bank.keys(chapter, quiz_dir) or {}
    shown = f"{shown_folder}/{chapter}.yaml"
    answers = read(answers_folder / f"{chapter}.yaml", shown)
    problems = list(answers.problems)
    if notes is not None:  # what costs nothing, e.g. the file's encoding (not UTF-8, read all the same)
        notes.extend(answers.notes)
    known = {q.id for q in questions}
    for qid, answer in answers.answers.items():
        if qid not in known:
            problems.append(f"{shown}, line {answer.line}: unknown question id {qid!r} "
                            f"(the questions are {', '.join(sorted(known))})")
    problems.extend(message for qid, message in answers.unreadable.items() if qid not in known)
    results = []
    for question in questions:
        if only is not None and question.id not in only:
            continue
        values = question.values_for(learner, chapter)
        lettering = question.lettering(learner, chapter)
        result = CheckResult(id=f"quiz_{question.id}", function=question.id,
                             description=_short(question.text_for(values)), status=Status.FAIL,
                             points=0.0, max_points=question.points, kind="quiz")
        results.append(result)
        answer = answers.answers.get(question.id)
        if question.id in answers.unreadable:
            result.message = answers.unreadable[question.id]
            continue
        if answer is None or answer.value is None or answer.text.strip() == "":
            result.message = NOT_ANSWERED
            continue
        result.got = answer.text
        where = f"{shown}, line {answer.line}, question {question.id}"
        key = keys.get(question.id)
        try:
            try:
                right_value = None if key is None else key.value_for(chapter, values)
            except bank.KeyUnavailable:
                key = None
            if key is None:  # read and format-checked only: quick, whatever the time
                read_answer(question, answer.value, lettering, answer.text)
                result.status, result.message = Status.RECORDED, RECORDED_MESSAGE
                continue
            if _time_is_up(deadline):
                result.status, result.message = Status.SKIP, OUT_OF_TIME
                continue
            verdict = judge(question, key, answer.value, right_value,
                            bank.variant_seed("points", chapter, question.id), lettering, deadline,
                            values=values, text=answer.text)
        except AnswerError as exc:
            result.message = f"{where}: {exc}"
            continue
        except OverflowError:
            result.message = f"{where}: {TOO_LARGE}"
            continue
        except Exception as exc:  # noqa: BLE001  one answer never costs more than its question
            result.status = Status.ERROR
            result.message = f"{where}: could not be judged ({type(exc).__name__}); please tell your instructor"
            continue
        if verdict.out_of_time:
            result.status, result.message = Status.SKIP, OUT_OF_TIME
            continue
        result.points = question.points * verdict.fraction
        result.status = Status.PASS if verdict.right else Status.FAIL
        result.message = verdict.feedback
        result.mistake = verdict.mistake
        result.answer = answer_terms(question, answer.value, lettering, answer.text, values)
        if verdict.right:  # the key appears in the output only once the learner has it
            result.expected = fmt_value(shown_key(question, right_answer(question, key, right_value, values),
                                                  lettering))
    return results, problems


def add_quiz_results(report: Report, root: Path, package: str, learner: str | None = None,
                     deadline: float | None = None, learner_from: str = "--learner") -> str:
    """Append each chapter's quiz results to `report` and record whose variants were graded (`learner`, from
    `learner_from`, else learner.yaml's).
    Reads YAML only: no learner code runs, and sympy runs (in a separate process) only for an answer
    that needs it. Questions not judged by `deadline` (a time.monotonic() value: what is left of the
    learner's time) say that the time ran out. Nothing in an answer file raises out of here: the
    report's code results always stay."""
    folder = answers_dir(root, package)
    who, source = learner_id(folder, learner, package, learner_from)
    report.learner = f"{who} (from {source})"
    report.learner_id, report.learner_unset = who, source.startswith("default")
    for chapter in report.chapters:
        try:
            results, problems = grade_quiz(chapter.chapter, folder, who, f"{package}/answers", deadline=deadline,
                                           notes=chapter.notes)
        except bank.BankError as exc:
            chapter.problems.append(f"quiz not graded: {exc}")
            continue
        except FileNotFoundError:
            continue  # a chapter without a quiz
        except Exception as exc:  # noqa: BLE001  the quiz never takes the code results with it
            chapter.problems.append(f"quiz not graded: {type(exc).__name__}: {exc}")
            continue
        chapter.checks.extend(results)
        chapter.problems.extend(problems)
    return report.learner


def quiz_report(chapters: list[str], root: Path, package: str, label: str, learner: str | None) -> tuple[Report, str]:
    """A report of quizzes only (`grade quiz`)."""
    report = Report(label, [ChapterResult(c, BY_ID[c].title) for c in chapters])
    who = add_quiz_results(report, root, package, learner)
    return report, who


@dataclass(frozen=True)
class ClassQuestion:
    """A quiz question as every learner has it, for the class summary (grader.render.summary.Tally)."""

    template: str  # its prompt, each per-learner number shown as its range
    options: dict  # canonical option -> its text (choice questions)
    right: frozenset  # the canonical options that are right, where the key is here


def class_questions(chapters: list[str]) -> dict[tuple[str, str], ClassQuestion]:
    """Every quiz question of `chapters` as the class summary shows it, by (chapter, question id); a chapter
    whose bank cannot be read is left out (its checks show their own descriptions)."""
    found = {}
    for chapter in chapters:
        try:
            questions = bank.questions(chapter)
            keys = bank.keys(chapter) or {}
        except (OSError, ValueError, bank.BankError):
            continue
        for question in questions:
            text = question.prompt
            for name, (low, high) in question.params.items():
                text = text.replace("{" + name + "}", f"<{name}: {low:g} to {high:g}, per learner>")
            answer = getattr(keys.get(question.id), "answer", None)
            right = ({x.strip() for x in answer.split(",") if x.strip()} if isinstance(answer, str)
                     else {str(x) for x in answer} if isinstance(answer, list) else set())
            found[(chapter, question.id)] = ClassQuestion(" ".join(text.split()), dict(question.options or {}),
                                                          frozenset(right))
    return found
