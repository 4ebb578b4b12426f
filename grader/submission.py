"""Find the submission to grade: the reference solutions, a given folder, or the project around cwd."""

from __future__ import annotations

import importlib.util
from dataclasses import dataclass, field
from pathlib import Path
from typing import NamedTuple

MAX_FILES_BYTES = 32 << 20


class Submission(NamedTuple):
    """Where the learner's chapter files are: `root/package/chNN_*.py` or `chNN_*.ipynb`. `kernel` holds
    chapters whose code an IPython kernel ran (`%grade`, grader.faces.magic): (module, ((label, cell source),
    ...)) each, graded instead of that chapter's file."""

    root: Path
    package: str = "exercises"
    kernel: tuple = ()

    def module_file(self, module: str) -> Path:
        return self.root / self.package / f"{module}.py"

    def chapter_file(self, module: str) -> Path:
        """The file a chapter is graded from: its .py, else its notebook, else (missing) its .py."""
        python = self.module_file(module)
        notebook = python.with_suffix(".ipynb")
        return notebook if notebook.is_file() and not python.is_file() else python

    def files(self) -> dict[str, str]:
        """The package's Python files, relative path -> base64: what the child gets in its request."""
        return self.prepare().files

    def prepare(self) -> Prepared:
        """What the child gets (grader.notebook turns notebooks and kernel cells into modules) and how to
        speak of it: the package's .py files and its notebooks as modules (a notebook only where no .py of
        its name is), relative path -> base64, read here (the child never reads the submission's folder).
        Symlinks are not followed; at most MAX_FILES_BYTES."""
        import base64
        import os

        from grader import notebook

        prepared = Prepared()
        package = Path(self.root) / self.package
        texts: dict[str, bytes] = {}
        notebooks: dict[str, Path] = {}
        total = 0
        for folder, subfolders, names in os.walk(package):  # never into a symlinked folder
            subfolders[:] = sorted(n for n in subfolders if not n.startswith("."))  # .ipynb_checkpoints
            for name in sorted(names):
                path = Path(folder) / name
                if not name.endswith((".py", ".ipynb")) or path.is_symlink() or not path.is_file():
                    continue
                relative = path.relative_to(self.root).as_posix()
                if name.endswith(".ipynb"):
                    if Path(name).stem.isidentifier():
                        notebooks[relative[: -len(".ipynb")] + ".py"] = path
                    continue
                texts[relative] = path.read_bytes()
        for relative, path in notebooks.items():
            shown = f"{relative[: -len('.py')]}.ipynb"
            module = Path(relative).stem
            if relative in texts:
                prepared.notes.setdefault(module, []).append(
                    f"both {relative} and {Path(shown).name} exist: graded {relative} (remove or rename the one "
                    "you do not use)")
                continue
            try:
                source = notebook.convert(path.read_bytes(), shown)
            except notebook.NotebookError as exc:
                prepared.problems[module] = f"{shown} could not be read: {exc}"
                prepared.graded[module] = shown  # the chapter's file, though no module came of it
                continue
            texts[relative] = source.text.encode("utf-8")
            prepared.sources[relative] = source
            prepared.graded[module] = shown
        for module, cells in self.kernel:
            for relative, (text, source) in notebook.kernel_module(self.package, module, list(cells)).items():
                texts[relative] = text.encode("utf-8")
                if source is not None:
                    prepared.sources[relative] = source
            prepared.graded[module] = notebook.KERNEL
            prepared.problems.pop(module, None)
        from grader.safe_text import decode_saved_text, encoding_note, not_utf8, not_utf8_note

        for relative, data in list(texts.items()):
            if relative.endswith(".py") and relative not in prepared.sources:
                text, encoding = decode_saved_text(data)
                if encoding:  # Python reads UTF-8 (a byte-order mark it skips; UTF-16 not at all)
                    texts[relative] = text.encode("utf-8")
                    prepared.notes.setdefault(Path(relative).stem, []).append(encoding_note(relative, encoding))
                elif (bad := not_utf8(data)) is not None:  # graded as imported, as it is: `python FILE` refuses it
                    prepared.notes.setdefault(Path(relative).stem, []).append(not_utf8_note(relative, *bad))
        for relative, data in texts.items():
            total += len(data)
            if total > MAX_FILES_BYTES:
                break
            prepared.files[relative] = base64.b64encode(data).decode()
        return prepared


@dataclass
class Prepared:
    """A submission as the child gets it (`files`: relative path -> base64) and what the messages say about
    it: the module line maps of notebooks and kernel cells (`sources`, by the module's relative path), the
    file each chapter module was graded from where it is not its .py (`graded`), notes (both a .py and a
    notebook) and notebooks that could not be read (`problems`), by module name."""

    files: dict[str, str] = field(default_factory=dict)
    sources: dict = field(default_factory=dict)
    graded: dict[str, str] = field(default_factory=dict)
    notes: dict[str, list[str]] = field(default_factory=dict)
    problems: dict[str, str] = field(default_factory=dict)


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
    if any(root.glob("ch0[0-9]_*.py")) or any(root.glob("ch0[0-9]_*.ipynb")):
        return Submission(root.parent, root.name)
    raise SubmissionNotFound(f"{directory} holds neither exercises/ nor chapter files (chNN_*.py, chNN_*.ipynb)")


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
