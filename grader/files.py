"""Writing a file so that no reader ever sees half of it: through a temporary file beside it, then one rename."""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path
from typing import TextIO


def write_atomically(path: Path | str, text: str) -> None:
    """Write `text` (UTF-8, its line ends the system's as a text file writes them) to `path` through a temporary
    file beside it: encoded at once and written as bytes (a batch writes three such files per learner)."""
    path = Path(path)
    data = (text if os.linesep == "\n" else text.replace("\n", os.linesep)).encode("utf-8")
    temporary = _beside(path)
    with open(temporary, "wb") as handle:
        handle.write(data)
    os.replace(temporary, path)


def write_atomically_from(path: Path, write: Callable[[TextIO], object], replace: bool = True) -> Path:
    """As write_atomically, `write` writing the text into the file it is given (piece by piece: a large class's
    outputs are never whole in memory); with replace=False the written file is left beside `path` (returned) for
    the caller to os.replace."""
    temporary = _beside(path)
    with temporary.open("w", encoding="utf-8") as handle:
        write(handle)
    if replace:
        os.replace(temporary, path)
    return temporary


def _beside(path: Path) -> Path:
    """The temporary file `path` is written through: hidden, beside it, this process's own."""
    return path.with_name(f".{path.name}.{os.getpid()}.tmp")
