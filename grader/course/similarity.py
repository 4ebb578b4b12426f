"""Which submissions are most alike: pairs of learners ranked for a person to look at (it accuses no one).

The engine is copydetect (the winnowing of Schleimer, Wilkerson and Aiken's MOSS paper, on code
tokenized by Pygments with every name replaced by one letter and strings by another, so renaming
variables or reformatting changes nothing): each learner's chapter files are fingerprinted per
top-level function and whole. What everyone shares counts for nothing:
- the public stubs (signatures, docstrings, the lines handed out) are copydetect's boilerplate;
- a fingerprint that more than half the class has (a three-line H_jacobian written the one way it can
  be written) is discounted as well, since it tells nothing about any pair.
A pair's score is the share of their remaining fingerprints they have in common, summed over the
functions both wrote, so that each function weighs by its size: a long function shared counts for much,
a short one little. The whole files' share is given beside it. Only pairs that share a distinctive
fingerprint are scored (an inverted index, as MOSS does); the top pairs come with the lines they share,
found by copydetect's comparison.

Needs the `similarity` extra (`pip install "jacobians-grader[similarity]"`, i.e. copydetect).
"""

from __future__ import annotations

import ast
import functools
import io
from collections import Counter, defaultdict
from dataclasses import dataclass, field
from pathlib import Path

NOISE = 25  # copydetect's defaults: matches shorter than this many filtered characters are noise ...
GUARANTEE = 30  # ... and any match this long is found
COMMON_SHARE = 0.5  # a fingerprint more than this share of the class has is discounted
TOP = 20


class SimilarityUnavailable(RuntimeError):
    """copydetect is not installed."""


@dataclass
class Pair:
    first: str
    second: str
    score: float  # share of their distinctive fingerprints in common, functions weighed by size, 0..1
    files_score: float  # the same for their whole files
    functions: list[str] = field(default_factory=list)  # the functions most alike, most first
    shared: list[str] = field(default_factory=list)  # blocks of lines they share (the first learner's text)

    def to_dict(self) -> dict:
        return {"learners": [self.first, self.second], "score": round(self.score, 4),
                "files_score": round(self.files_score, 4), "functions": self.functions, "shared": self.shared}


def _engine():
    try:
        import matplotlib

        matplotlib.use("Agg")  # copydetect's report module imports pyplot
        from copydetect.detector import CodeFingerprint, compare_files
    except ImportError as exc:
        raise SimilarityUnavailable(f"--similarity needs copydetect ({exc}): pip install "
                                    "'jacobians-grader[similarity]'") from None
    return CodeFingerprint, compare_files


def function_lines(source: str) -> dict[str, tuple[int, int]]:
    """Each top-level function of a file: its first and last line, by name (parsed, never run; a file that does not
    parse: nothing)."""
    try:
        tree = ast.parse(source)
    except (SyntaxError, ValueError, RecursionError, MemoryError):  # a file nested too deep is just not split
        return {}
    return {node.name: (node.lineno, node.end_lineno or node.lineno) for node in tree.body
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef))}


def _functions(source: str) -> dict[str, str]:
    """Each top-level function's source, by name (a file that does not parse: nothing)."""
    lines = source.splitlines()
    return {name: "\n".join(lines[first - 1:last]) for name, (first, last) in function_lines(source).items()}


def _fingerprinter(boilerplate):
    """A function text -> copydetect fingerprint, each distinct text tokenized once (a function written the
    same way by many learners, an untouched stub file)."""
    CodeFingerprint, _ = _engine()

    @functools.lru_cache(maxsize=None)
    def fingerprint(text: str):
        return CodeFingerprint("code.py", NOISE, GUARANTEE - NOISE + 1, boilerplate=boilerplate,
                               fp=io.StringIO(text), language="python")

    return fingerprint


def _stub_hashes(stubs: Path | None) -> list:
    """Every k-gram hash of the public stubs (copydetect's boilerplate: window 1 keeps them all)."""
    import numpy as np

    CodeFingerprint, _ = _engine()
    hashes: set = set()
    for path in sorted(stubs.glob("ch0*.py")) if stubs else []:
        hashes |= CodeFingerprint(str(path), NOISE, 1, fp=io.StringIO(path.read_text(encoding="utf-8")),
                                  language="python").hashes
    return np.array(sorted(hashes))


def _without(fingerprint, common: set) -> None:
    """Drop the class-wide fingerprints from one fingerprint (copydetect's own boilerplate removal, later)."""
    from copydetect.utils import get_token_coverage

    fingerprint.hashes = fingerprint.hashes - common
    fingerprint.hash_idx = {h: i for h, i in fingerprint.hash_idx.items() if h not in common}
    fingerprint.token_coverage = get_token_coverage(fingerprint.hash_idx, fingerprint.k,
                                                    len(fingerprint.filtered_code))


def _shared(one, two) -> tuple[int, int]:
    """(fingerprints two parts share, the fingerprints of the smaller): a long part weighs more than a short one."""
    return len(one.hashes & two.hashes), min(len(one.hashes), len(two.hashes))


def _shared_lines(fingerprint, slices, limit: int = 3) -> list[str]:
    """The lines of `fingerprint`'s code that the slices (copydetect's, in its raw text) cover."""
    text = fingerprint.raw_code
    blocks = []
    for start, end in zip(*slices):
        first = text.rfind("\n", 0, int(start)) + 1
        last = text.find("\n", int(end))
        blocks.append(text[first:last if last >= 0 else len(text)].strip("\n"))
        if len(blocks) == limit:
            break
    return blocks


def _sources(files: dict[str, bytes]) -> dict[str, str]:
    """A learner's chapters as code, by module, from their staged files (grader.course.staging.kept_files): each
    chNN_*.py, and each notebook without a .py of its name by its code cells in order (what is graded of it). A
    notebook that cannot be read gives nothing."""
    from grader.notebook import NotebookError, code_cells

    top = sorted(name for name in files if "/" not in name and name.startswith("ch0"))
    found = {name[:-len(".py")]: files[name].decode("utf-8", "replace") for name in top if name.endswith(".py")}
    for name in top:
        if name.endswith(".ipynb") and name[:-len(".ipynb")] not in found:
            try:
                found[name[:-len(".ipynb")]] = "\n\n".join(source for _, source in code_cells(files[name]))
            except NotebookError:
                continue
    return found


def rank(staging: Path, learners: list[str], stubs: Path | None = None, top: int = TOP) -> tuple[list[Pair], list[str]]:
    """The `top` pairs of `learners` whose staged code (their chNN_*.py as the batch kept them in `staging`, or the
    code cells of a chapter kept as a notebook) is most alike, and a sentence for each file that could not be
    compared (a hostile one: too deeply nested, too large to tokenize), which is left out, the others compared."""
    from grader.course.staging import kept_files

    _, compare_files = _engine()
    if stubs is None:
        try:
            from grader.course.release import ReleaseError, _project_exercises

            stubs = _project_exercises()
        except ReleaseError:
            stubs = None
    fingerprint = _fingerprinter(_stub_hashes(stubs))
    prints: dict[str, dict[str, object]] = {}  # learner -> "chNN_module.function" (and "chNN_module" whole) -> fp
    left_out: list[str] = []
    for learner in learners:
        mine: dict[str, object] = {}
        for module, source in _sources(kept_files(staging, learner) or {}).items():
            try:
                parts = {module: fingerprint(source), **{f"{module}.{name}": fingerprint(text)
                                                          for name, text in _functions(source).items()}}
            except (RecursionError, MemoryError, ValueError, IndexError) as exc:
                left_out.append(f"--similarity left out {learner}'s {module} (it could not be compared: "
                                f"{type(exc).__name__})")
                continue
            mine.update(parts)
        prints[learner] = mine
    holders: Counter = Counter()
    for mine in prints.values():
        holders.update(set().union(*(fp.hashes for part, fp in mine.items() if "." in part)) if mine else set())
    common = {h for h, n in holders.items() if n > max(2, COMMON_SHARE * len(prints))}
    candidates: set[tuple[str, str]] = set()
    by_hash: dict = defaultdict(set)
    filtered: set[int] = set()
    for learner, mine in prints.items():
        for fp in mine.values():
            if id(fp) not in filtered:  # one fingerprint may serve many learners
                _without(fp, common)
                filtered.add(id(fp))
            for h in fp.hashes:
                by_hash[h].add(learner)
    for owners in by_hash.values():
        if 1 < len(owners) <= max(2, COMMON_SHARE * len(prints)):
            candidates.update((a, b) for a in owners for b in owners if a < b)
    pairs = []
    for a, b in candidates:  # ranked by shared fingerprints (as MOSS ranks), lines by copydetect for the top
        both = set(prints[a]) & set(prints[b])
        functions = [(_shared(prints[a][part], prints[b][part]), part) for part in sorted(both) if "." in part]
        files = [_shared(prints[a][part], prints[b][part]) for part in both if "." not in part]
        possible = sum(size for (_, size), _ in functions)
        if not possible:
            continue
        files_possible = sum(size for _, size in files)
        pairs.append(Pair(a, b, sum(shared for (shared, _), _ in functions) / possible,
                          sum(shared for shared, _ in files) / files_possible if files_possible else 0.0,
                          [part for (shared, _), part in sorted(functions, key=lambda f: (-f[0][0], f[1])) if shared]))
    pairs.sort(key=lambda p: (-p.score, -p.files_score, p.first, p.second))
    for pair in pairs[:top]:
        for part in pair.functions[:3]:
            _, _, (slices, _) = compare_files(prints[pair.first][part], prints[pair.second][part])
            pair.shared += _shared_lines(prints[pair.first][part], slices, limit=1)
    return pairs[:top], left_out
