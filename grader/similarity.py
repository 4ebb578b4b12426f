"""Which submissions are most alike: pairs of learners ranked for a person to look at (it accuses no one).

The engine is copydetect (the winnowing of Schleimer, Wilkerson and Aiken's MOSS paper, on code
tokenized by Pygments with every name replaced by one letter and strings by another, so renaming
variables or reformatting changes nothing): each learner's chapter files are fingerprinted per
top-level function and whole. What everyone shares counts for nothing:
- the public stubs (signatures, docstrings, the lines handed out) are copydetect's boilerplate;
- a fingerprint that more than half the class has (a three-line H_jacobian written the one way it can
  be written) is discounted as well, since it tells nothing about any pair.
A pair's score is the share of their remaining code they have in common, summed over the functions both
wrote and weighed by each function's size: a long function shared counts for much, a short one little.
The whole files' share is given beside it. The top pairs come with the lines they share.

Needs the `similarity` extra (`pip install "jacobians-grader[similarity]"`, i.e. copydetect).
"""

from __future__ import annotations

import ast
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
    score: float  # size-weighted share of their distinctive code in common, 0..1
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


def _functions(source: str) -> dict[str, str]:
    """Each top-level function's source, by name (a file that does not parse: nothing)."""
    try:
        tree = ast.parse(source)
    except (SyntaxError, ValueError):
        return {}
    return {node.name: ast.get_source_segment(source, node) or "" for node in tree.body
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef))}


def _fingerprint(text: str, boilerplate):
    CodeFingerprint, _ = _engine()
    return CodeFingerprint("code.py", NOISE, GUARANTEE - NOISE + 1, boilerplate=boilerplate, fp=io.StringIO(text))


def _stub_hashes(stubs: Path | None) -> list:
    """Every k-gram hash of the public stubs (copydetect's boilerplate: window 1 keeps them all)."""
    import numpy as np

    CodeFingerprint, _ = _engine()
    hashes: set = set()
    for path in sorted(stubs.glob("ch0*.py")) if stubs else []:
        hashes |= CodeFingerprint(str(path), NOISE, 1, fp=io.StringIO(path.read_text(encoding="utf-8"))).hashes
    return np.array(sorted(hashes))


def _without(fingerprint, common: set) -> None:
    """Drop the class-wide fingerprints from one fingerprint (copydetect's own boilerplate removal, later)."""
    from copydetect.utils import get_token_coverage

    fingerprint.hashes = fingerprint.hashes - common
    fingerprint.hash_idx = {h: i for h, i in fingerprint.hash_idx.items() if h not in common}
    fingerprint.token_coverage = get_token_coverage(fingerprint.hash_idx, fingerprint.k,
                                                    len(fingerprint.filtered_code))


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


def rank(staging: Path, learners: list[str], stubs: Path | None = None, top: int = TOP) -> list[Pair]:
    """The `top` pairs of `learners` whose staged code (staging/<folder>/exercises/chNN_*.py) is most alike."""
    from grader.batch import folder_name

    _, compare_files = _engine()
    if stubs is None:
        try:
            from grader.release import ReleaseError, _project_exercises

            stubs = _project_exercises()
        except ReleaseError:
            stubs = None
    boilerplate = _stub_hashes(stubs)
    prints: dict[str, dict[str, object]] = {}  # learner -> "chNN_module.function" (and "chNN_module" whole) -> fp
    for learner in learners:
        package = staging / folder_name(learner) / "exercises"
        mine: dict[str, object] = {}
        for path in sorted(package.glob("ch0*.py")):
            source = path.read_text(encoding="utf-8", errors="replace")
            mine[path.stem] = _fingerprint(source, boilerplate)
            for name, text in _functions(source).items():
                mine[f"{path.stem}.{name}"] = _fingerprint(text, boilerplate)
        prints[learner] = mine
    holders: Counter = Counter()
    for mine in prints.values():
        holders.update(set().union(*(fp.hashes for part, fp in mine.items() if "." in part)) if mine else set())
    common = {h for h, n in holders.items() if n > max(2, COMMON_SHARE * len(prints))}
    candidates: dict[tuple[str, str], int] = Counter()
    by_hash: dict = defaultdict(set)
    for learner, mine in prints.items():
        for fp in mine.values():
            _without(fp, common)
            for h in fp.hashes:
                by_hash[h].add(learner)
    for owners in by_hash.values():
        if 1 < len(owners) <= max(2, COMMON_SHARE * len(prints)):
            for a in owners:
                for b in owners:
                    if a < b:
                        candidates[(a, b)] += 1
    pairs = []
    for a, b in candidates:
        shared_tokens = possible = 0.0
        alike = []
        for part in sorted(set(prints[a]) & set(prints[b])):
            if "." not in part:
                continue
            one, two = prints[a][part], prints[b][part]
            size = min(one.token_coverage, two.token_coverage)
            if size <= 0:
                continue
            overlap, (share_one, share_two), _ = compare_files(one, two)
            shared_tokens += size * (share_one + share_two) / 2
            possible += size
            if overlap:
                alike.append(((share_one + share_two) / 2 * size, part))
        if not possible:
            continue
        files = [(prints[a][m], prints[b][m]) for m in set(prints[a]) & set(prints[b]) if "." not in m]
        file_shares = [compare_files(x, y)[1] for x, y in files if x.token_coverage and y.token_coverage]
        files_score = sum((s1 + s2) / 2 for s1, s2 in file_shares) / len(file_shares) if file_shares else 0.0
        pairs.append(Pair(a, b, shared_tokens / possible, files_score, [p for _, p in sorted(alike, reverse=True)]))
    pairs.sort(key=lambda p: (-p.score, -p.files_score, p.first, p.second))
    for pair in pairs[:top]:
        for part in pair.functions[:3]:
            _, _, (slices, _) = compare_files(prints[pair.first][part], prints[pair.second][part])
            pair.shared += _shared_lines(prints[pair.first][part], slices, limit=1)
    return pairs[:top]
