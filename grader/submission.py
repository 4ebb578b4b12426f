"""Find the submission to grade: the reference solutions, a given folder, or the project around cwd."""

from __future__ import annotations

import importlib.util
from pathlib import Path
from typing import NamedTuple


class Submission(NamedTuple):
    """Where the learner's chapter files are: `root/package/chNN_*.py`."""

    root: Path
    package: str = "exercises"

    def module_file(self, module: str) -> Path:
        return self.root / self.package / f"{module}.py"


class SubmissionNotFound(LookupError):
    """No chapter files where the learner pointed (the message says where we looked)."""


def solutions_submission() -> Submission:
    spec = importlib.util.find_spec("solutions")
    if spec is None or not spec.submodule_search_locations:
        raise SubmissionNotFound("the reference solutions are not installed")
    package_dir = Path(list(spec.submodule_search_locations)[0])
    return Submission(package_dir.parent, package_dir.name)


def folder_submission(directory: str | Path) -> Submission:
    """A folder holding exercises/, or a folder of chapter files (imported under its own name)."""
    root = Path(directory).resolve()
    if (root / "exercises").is_dir():
        return Submission(root, "exercises")
    if any(root.glob("ch0[0-9]_*.py")):
        return Submission(root.parent, root.name)
    raise SubmissionNotFound(f"{directory} holds neither exercises/ nor chapter files (chNN_*.py)")


def project_submission(start: Path | None = None) -> Submission:
    here = (start or Path.cwd()).resolve()
    for candidate in (here, *here.parents):
        if (candidate / "exercises").is_dir():
            return Submission(candidate, "exercises")
    raise SubmissionNotFound("no exercises/ folder here or above; run inside the lesson project "
                             "or pass --submission DIR")


def locate(directory: str | None, use_solutions: bool) -> Submission:
    if use_solutions:
        return solutions_submission()
    if directory is not None:
        return folder_submission(directory)
    return project_submission()
