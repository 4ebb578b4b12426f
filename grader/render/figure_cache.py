"""The HTML report's figures kept from the last run, one entry per chapter, reused while that chapter's
plot data is unchanged.

A learner re-runs `grade all --html` after each edit, and most chapters then return what they returned
before; drawing them again (matplotlib's import and about 27 ms a figure) is most of the report's cost.
An entry's key covers the chapter's plot data, the drawing code (grader/render/figures.py) and the installed
matplotlib; each chapter keeps only its last entry, so the cache holds one file per chapter at most.
Anything missing, unreadable or malformed is a miss: the cache never breaks a report, and an entry can
only ever give SVG data URIs and text (the page escapes the text)."""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import re
from pathlib import Path

from grader.system import cache_folder

_FIELDS = {"uri": str, "alt": str, "caption": str, "width": int, "height": int, "gave": str}
_SVG_URI = re.compile(r"data:image/svg\+xml;base64,[A-Za-z0-9+/]*={0,2}")
_CHAPTER_ID = re.compile(r"[a-z0-9_]{1,40}")


def default_folder() -> Path | None:
    """GRADER_CACHE_DIR/figures (None if it is empty), else jacobians-grader/figures in the user's cache folder of
    the platform (grader.system.cache_folder)."""
    folder = cache_folder("figures")
    return None if folder is None else Path(folder)


def default() -> FigureCache | None:
    """The cache in default_folder(), or None where there is none."""
    folder = default_folder()
    return None if folder is None else FigureCache(folder)


def _plain(value):
    if hasattr(value, "tolist"):  # numpy arrays and scalars
        return value.tolist()
    raise TypeError(f"{type(value).__name__} is not plot data")


def _drawing_version() -> str:
    """What the figures' look depends on besides their data: the drawing code and the installed matplotlib
    (found, not imported)."""
    import importlib.util

    from grader.render import figures

    digest = hashlib.sha256(Path(figures.__file__).read_bytes())
    spec = importlib.util.find_spec("matplotlib")
    if spec is not None and spec.origin:
        stat = os.stat(spec.origin)
        digest.update(f"{spec.origin}:{stat.st_mtime_ns}:{stat.st_size}".encode())
    return digest.hexdigest()


class FigureCache:
    """The figures of each chapter's last drawing, kept in `folder` as <chapter>.json."""

    def __init__(self, folder: Path) -> None:
        self.folder = folder
        self._version: str | None = None

    def key(self, chapter_id: str, plots: dict) -> str | None:
        """The key of one chapter's figures; None where its data cannot be keyed (then it is not cached)."""
        if not _CHAPTER_ID.fullmatch(chapter_id):
            return None
        if self._version is None:
            try:
                self._version = _drawing_version()
            except OSError:
                return None
        try:
            text = json.dumps([self._version, chapter_id, plots], sort_keys=True, default=_plain)
        except (TypeError, ValueError):
            return None
        return hashlib.sha256(text.encode("utf-8")).hexdigest()

    def load(self, chapter_id: str, plots: dict) -> list[dict] | None:
        """The kept figures (each a dict of _FIELDS) if they were drawn from exactly this data, else None."""
        key = self.key(chapter_id, plots)
        if key is None:
            return None
        try:
            entry = json.loads((self.folder / f"{chapter_id}.json").read_text(encoding="utf-8"))
        except (OSError, ValueError):
            return None
        if not isinstance(entry, dict) or entry.get("key") != key or not isinstance(entry.get("figures"), list):
            return None
        figures = entry["figures"]
        for figure in figures:
            if not (isinstance(figure, dict) and set(figure) == set(_FIELDS)
                    and all(type(figure[name]) is kind for name, kind in _FIELDS.items())
                    and _SVG_URI.fullmatch(figure["uri"])):
                return None
        return figures

    def store(self, chapter_id: str, plots: dict, figures: list[dict]) -> None:
        """Keep one chapter's figures, replacing its earlier entry; figures that could not be drawn
        (no image) are not kept, as the next run may draw them. Failing to write is not an error."""
        key = self.key(chapter_id, plots)
        if key is None or not figures or not all(_SVG_URI.fullmatch(str(f.get("uri"))) for f in figures):
            return
        path = self.folder / f"{chapter_id}.json"
        temporary = path.with_name(f".{chapter_id}.{os.getpid()}.tmp")
        try:
            self.folder.mkdir(parents=True, exist_ok=True)
            temporary.write_text(json.dumps({"key": key, "figures": figures}), encoding="utf-8")
            os.replace(temporary, path)
        except OSError:
            with contextlib.suppress(OSError):
                temporary.unlink(missing_ok=True)
