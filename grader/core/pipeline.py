"""One pipeline builds a report: `grade chNN`, `grade batch`, the release's checks and LMS runners all
call `build_report`, so a submission gets the same verdicts wherever it is graded.

Code checks run in the session's child (grader.core.grading), then the quiz answers are judged (no learner
code: YAML only), then what the course hides is accounted for: on the instructor's side hidden
checks run like any other; in a handout they are not there, and each chapter says how many checks
and points are graded on submission instead. A course that turns the exact-derivative checks off
(`exact_derivatives: false`) has them nowhere: not run, not in any score.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import TYPE_CHECKING

from grader import course_config as courses
from grader.model import Report

if TYPE_CHECKING:
    from grader.boundary import Session
    from grader.core.memo import Memo


@dataclass(frozen=True)
class Request:
    """What to grade, and how."""

    chapters: tuple[str, ...]
    seed: int
    learner: str | None = None  # whose per-learner quiz numbers (None: learner.yaml, else 'anonymous')
    learner_from: str = "--learner"  # where `learner` came from, for the report (a batch: its roster, a name...)
    quiz: bool = True
    plots: bool = False  # gather the HTML report's plot data in the same round trip
    label: str | None = None  # how the report names the submission (default: its folder)
    functions: tuple[str, ...] = ()  # grade only these functions' checks (and no quiz); () grades them all
    other_ids: tuple[str, ...] = ()  # ids whose quiz numbers a learner may have used by mistake (e.g. a manifest's)


def instructor_course(config: str | None = None) -> courses.Course:
    """The course every command that grades on the instructor's side reads (batch, Gradescope, release): the
    course file (grader.course_config.current), its hidden check ids checked against the checks there are.
    CourseError, with the file and line, for an id that names no check (and the one it may mean)."""
    import difflib

    from grader import checks as check_registry
    from grader.chapters import BY_ID

    course = courses.current(config)
    known = [f"{chapter}/{c.id}" for chapter in BY_ID for c in check_registry.load(chapter).checks]
    unknown = [f"{name}{f': did you mean {close[0]}?' if (close := difflib.get_close_matches(name, known, n=1)) else ''}"
               for name in sorted(course.hidden) if name not in known]
    if unknown:
        raise courses.CourseError(f"{course.where('hidden')}: hidden names checks that do not exist: "
                                  f"{'; '.join(unknown)} (`grade list --checks` shows the ids)")
    return course


def hidden_ids(course: courses.Course, chapters: tuple[str, ...]) -> frozenset[str]:
    """The "chNN/check_id" of checks this grader must not run: in a handout, those it does not have."""
    if not course.in_handout:
        return frozenset()
    hidden = course.handout.get("hidden", {})
    return frozenset(f"{c}/{i}" for c in chapters for i in hidden.get(c, {}).get("ids", []))


def switched_off(course: courses.Course, chapters: tuple[str, ...]) -> frozenset[str]:
    """The "chNN/check_id" of checks the course leaves out: the exact-derivative checks, where it turns them off."""
    if course.exact_derivatives:
        return frozenset()
    from grader import checks as check_registry

    return frozenset().union(*(check_registry.load(c).exact_derivative_ids for c in chapters))


def other_functions(request: Request) -> tuple[frozenset[str], dict[str, str]]:
    """With `request.functions`, the "chNN/check_id" of every check of another function, and per chapter a
    note saying what was left out; nothing without."""
    if not request.functions:
        return frozenset(), {}
    from grader import checks as check_registry
    from grader.render import plural

    left: set[str] = set()
    notes = {}
    for chapter in request.chapters:
        checks = check_registry.load(chapter).checks
        others = [c for c in checks if c.function not in request.functions]
        left |= {f"{chapter}/{c.id}" for c in others}
        graded = ", ".join(dict.fromkeys(c.function for c in checks if c.function in request.functions))
        names = ", ".join(dict.fromkeys(c.function for c in others))
        notes[chapter] = (f"graded {graded} only; left out {plural(len(others), 'check')} "
                          f"({plural(sum(c.points for c in others), 'point')}) of {names}" if others else
                          f"graded {graded}") + f", and the quiz: `grade {chapter}` grades the whole chapter"
    return frozenset(left), notes


def build_report(session: Session, request: Request, course: courses.Course | None = None,
                 memo: Memo | None = None) -> Report:
    """Grade `request.chapters` of the session's submission into one Report (closes the session), as `course`
    has it (default: a handout's own course; on the instructor's side every check runs). With `memo`
    (grader.core.memo: `grade` on one submission, walled off), verdicts made from exactly the same answers are reused."""
    from grader.core.grading import judge_chapters

    course = course or courses.here()
    others, notes = other_functions(request)
    hidden = hidden_ids(course, request.chapters)
    if request.functions:
        request = dataclasses.replace(request, quiz=False)
    quizzes: list[Report] = []
    if request.quiz:  # judged while the child runs the code's calls (no learner code: YAML only)
        def quiz_meanwhile() -> None:
            try:
                quizzes.append(kept_quiz_report(session, request, course, memo))
            except Exception:  # noqa: BLE001  judged again below, where what it raises is the report's to meet
                pass

        session.meanwhile.append(quiz_meanwhile)
    version: list[str] = []
    session.meanwhile.append(lambda: _version_ready(memo, version))
    report = judge_chapters(session, list(request.chapters), seed=request.seed, with_plots=request.plots,
                   submission_label=request.label,
                   exclude=hidden | switched_off(course, request.chapters) | others, memo=memo)
    for chapter in report.chapters:
        chapter.hidden_checks, chapter.hidden_points = course.hidden_in(chapter.chapter)
        if chapter.chapter in notes:  # one function: only its hidden checks are left for the submission
            from grader import checks as check_registry

            mine = [c for c in check_registry.load(chapter.chapter).checks
                    if f"{chapter.chapter}/{c.id}" in hidden and f"{chapter.chapter}/{c.id}" not in others]
            chapter.hidden_checks, chapter.hidden_points = len(mine), sum(c.points for c in mine)
            chapter.notes.append(notes[chapter.chapter])
    learner_id = request.learner
    if request.quiz:
        quiz = quizzes.pop() if quizzes else kept_quiz_report(session, request, course, memo)
        learner_id = quiz.learner_id
        report.learner, report.learner_unset = quiz.learner, quiz.learner_unset
        report.flags += quiz.flags
        judged = {c.chapter: c for c in quiz.chapters}
        for chapter in report.chapters:
            chapter.checks.extend(judged[chapter.chapter].checks)
            chapter.problems.extend(judged[chapter.chapter].problems)
            chapter.notes.extend(judged[chapter.chapter].notes)
    from grader import provenance

    provenance.stamp(report, course, learner_id, version=version[0] if version else None)
    return report


def _version_ready(memo: Memo | None, version: list[str]) -> None:
    """Work out the grader's version for the report's stamp now, into `version` (from the memo where it holds
    one): on the instructor's side a hash of the grader's files."""
    from grader import provenance

    try:
        version.append(memo.version() if memo is not None else provenance.grader_version())
    except Exception:  # noqa: BLE001  worked out again when the report is stamped, which meets what it raises
        pass


def _answers(folder) -> list | None:
    """Every file of a learner's answers folder, by name, with its bytes' hash (None where it cannot be read)."""
    import hashlib
    import os

    found = []
    try:
        for where, folders, files in os.walk(folder):
            folders.sort()
            for name in sorted(files):
                path = os.path.join(where, name)
                with open(path, "rb") as handle:
                    found.append([os.path.relpath(path, folder), hashlib.sha256(handle.read()).hexdigest()])
    except OSError:
        return None
    return found


def kept_quiz_report(session: Session, request: Request, course: courses.Course, memo: Memo | None) -> Report:
    """quiz_report, or with one learner's `memo` the quiz judged from exactly the same answer files before."""
    if memo is None or not memo.one_learner:
        return quiz_report(session, request, course, list(request.chapters))
    from grader.core.memo import key_of

    submission = session.submission
    answers = _answers(submission.root / submission.package / "answers")
    key = None if answers is None else key_of(list(request.chapters), request.learner, list(request.other_ids),
                                              request.label, str(submission.root), submission.package, answers)
    kept = memo.verdict("quiz", key)
    if kept is not None:
        try:
            return Report.from_kept(kept)
        except (KeyError, TypeError, ValueError):
            pass
    report = quiz_report(session, request, course, list(request.chapters))
    from grader.quiz import OUT_OF_TIME
    from grader.quiz.judge import UNDECIDED

    if not any(c.message.startswith(OUT_OF_TIME) or UNDECIDED in c.message for ch in report.chapters
               for c in ch.checks):  # what time decided is judged again
        memo.keep_verdict("quiz", key, report.to_kept())
    return report


def quiz_report(session: Session, request: Request, course: courses.Course, chapters: list[str]) -> Report:
    """The quiz of `chapters` alone, as a Report (its `learner_id`: whose numbers were graded): answers judged
    with what is left of the learner's time budget, answers worked out with another id's numbers explained,
    practice quizzes marked."""
    from grader.model import ChapterResult
    from grader.quiz import DEFAULT_LEARNER, add_quiz_results, answers_dir, other_ids
    from grader.quiz import learner_id as quiz_learner

    submission = session.submission
    report = Report(request.label or str(submission.root), [ChapterResult(c, "") for c in chapters])
    add_quiz_results(report, submission.root, submission.package, request.learner, deadline=session.learner_end,
                     learner_from=request.learner_from)
    folder = answers_dir(submission.root, submission.package)
    report.learner_id = quiz_learner(folder, request.learner)[0]
    report.flags += other_ids.explain(report, folder, f"{submission.package}/answers", report.learner_id,
                                      [*request.other_ids, quiz_learner(folder, None)[0], DEFAULT_LEARNER])
    for chapter in report.chapters:
        if course.practice(chapter.chapter):
            practice(chapter)
    return report


def practice(chapter) -> None:
    """A practice quiz (immediate feedback: its keys are in the handout, so it can be answered by trying every
    option): its answers are judged for the learner's sake and never counted, here or on submission."""
    for check in chapter.checks:
        if check.kind == "quiz":
            check.practice, check.points, check.max_points = True, 0.0, 0.0
