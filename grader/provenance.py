"""What made a result: the grader's version, the handout, the course, the seed and the learner id.

Every report carries them (grader.model.Report: grader, handout, course, seed, learner_id) and every
renderer shows them, so a score at home can be matched with the official one check by check (each
check has its stable id, `chNN/check_id`).

The grader's version is the package's version with a local label that changes whenever anything it
grades with changes: in a handout, the handout's own version (`grade release` hashes everything in
it); on the instructor's side a hash of the grader's code, the references and the question banks and
keys, so a grader fix reads as a new version (and `grade batch` grades everyone again).
"""

from __future__ import annotations

import functools
import hashlib
from pathlib import Path

GRADER_DIR = Path(__file__).resolve().parent


def base_version() -> str:
    """The grader's version without a local label ("0.1.0")."""
    from grader import __version__

    return __version__


def verdict_sources() -> list[Path]:
    """The folders whose files decide verdicts: the grader, the references, the question banks and keys."""
    import importlib.util

    folders = [GRADER_DIR]
    try:
        spec = importlib.util.find_spec("solutions")
    except (ImportError, ValueError):
        spec = None
    if spec is not None and spec.submodule_search_locations:
        folders.append(Path(list(spec.submodule_search_locations)[0]))
    for quizzes in (GRADER_DIR / "quizzes", GRADER_DIR.parent / "quizzes"):
        if quizzes.is_dir() and quizzes not in folders:
            folders.append(quizzes)
            break
    return folders


@functools.lru_cache(maxsize=1)
def code_digest() -> str:
    """A hash of every file that decides a verdict (Python sources, YAML banks and keys, recorded data). Each file
    counts once, by its path in its own source folder: the banks inside an installed grader (grader/quizzes) hash
    as beside it in the project, so the instructor's checkout and its wheel (a cluster's workers) agree."""
    digest = hashlib.sha256()
    folders = verdict_sources()
    for folder in folders:
        inner = [other for other in folders if other != folder and other.is_relative_to(folder)]
        for path in sorted(folder.rglob("*")):
            if (path.suffix in (".py", ".yaml", ".json") and path.is_file() and "__pycache__" not in path.parts
                    and not any(path.is_relative_to(other) for other in inner)):
                digest.update(path.relative_to(folder).as_posix().encode() + b"\0" + path.read_bytes() + b"\0")
    return digest.hexdigest()


@functools.lru_cache(maxsize=1)
def grader_version() -> str:
    """This grader's version: a handout's own ("0.1.0+handout.3f2a..."), else the package's version with
    the hash of what it grades with ("0.1.0+g1a2b3c4d5e6f")."""
    from grader import course_config

    if course_config.in_handout():
        try:
            return str(course_config.current().handout["version"])
        except (course_config.CourseError, KeyError, TypeError):
            pass
    return f"{base_version()}+g{code_digest()[:12]}"


def handout_id(the_course=None) -> str | None:
    """The handout this result is tied to: in a handout its own version; on the instructor's side the
    course's current handout (course.yaml `handout:`), or None."""
    from grader import course_config as courses

    the_course = the_course or (courses.current() if courses.in_handout() else None)
    if the_course is None:
        return None
    if the_course.in_handout:
        return str(the_course.handout.get("version") or "") or None
    return the_course.current_handout


def stamp(report, the_course=None, learner_id: str | None = None, version: str | None = None) -> None:
    """Fill in `report`'s provenance: grader version (`version`, else worked out here), handout id, course id and
    learner id."""
    report.grader = version or grader_version()
    report.handout = handout_id(the_course)
    report.course = the_course.id if the_course is not None else None
    if learner_id is not None:
        report.learner_id = learner_id


def shown_seed(report, learner_sees: bool = False) -> str:
    """The seed as an output shows it: where the learner sees it, a seed other than the public one is not shown (it
    is the instructor's secret, or drawn from it)."""
    from grader.course_config import PUBLIC_SEED

    if report.seed is None:
        return "none"
    if learner_sees and report.seed != PUBLIC_SEED:
        return "not shown (the course's, or drawn from it)"
    return str(report.seed)


def footer(report, learner_sees: bool = False) -> str:
    """The one line every text output ends with: what graded this, at which seed (shown_seed), for whom."""
    parts = [f"grader {report.grader or 'unknown'}", f"handout {report.handout or 'none'}"]
    if report.course:
        parts.append(f"course {report.course}")
    parts.append(f"seed {shown_seed(report, learner_sees)}")
    parts.append(f"learner {report.learner_id or 'not set'}")
    return "Graded by " + ", ".join(parts) + "."
