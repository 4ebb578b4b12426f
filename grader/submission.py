"""Find the submission to grade: the reference solutions, a given folder, or the project around cwd."""

from __future__ import annotations

import importlib.util
from pathlib import Path
from typing import NamedTuple


MAX_FILES_BYTES = 32 << 20


class Submission(NamedTuple):
    """Where the learner's chapter files are: `root/package/chNN_*.py`."""

    root: Path
    package: str = "exercises"

    def module_file(self, module: str) -> Path:
        return self.root / self.package / f"{module}.py"

    def files(self) -> dict[str, str]:
        """The package's Python files, relative path -> base64: what the child gets in its request (it
        never reads the submission's folder itself). Symlinks are not followed; at most MAX_FILES_BYTES."""
        import base64
        import os

        package = Path(self.root) / self.package
        files, total = {}, 0
        for folder, subfolders, names in os.walk(package):  # never into a symlinked folder
            subfolders.sort()
            for name in sorted(names):
                path = Path(folder) / name
                if not name.endswith(".py") or path.is_symlink() or not path.is_file():
                    continue
                data = path.read_bytes()
                total += len(data)
                if total > MAX_FILES_BYTES:
                    return files
                files[path.relative_to(self.root).as_posix()] = base64.b64encode(data).decode()
        return files


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
