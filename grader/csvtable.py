"""The instructor's CSV files (the roster, overrides.csv) read as spreadsheets save them: UTF-8 with or
without a byte-order mark, ',' or ';' (or a tab) between cells, told from the header outside quoted
cells, columns in any order and case among others. Every row keeps its line number for messages."""

from __future__ import annotations

import csv
import io
import re
from pathlib import Path


class TableError(ValueError):
    """A file that cannot be read as the table it should be (the message names the file and line)."""


def read_table(path: Path, required: tuple[str, ...], text: str | None = None) -> list[tuple[int, dict[str, str]]]:
    """(line, {column: cell}) of every row with something in it; the columns lower-cased and stripped, the
    cells stripped (`text`: the file's text as read before, e.g. as a run of the history kept it). TableError when
    the file cannot be read or its header lacks a `required` column."""
    try:
        text = path.read_bytes().decode("utf-8-sig") if text is None else text.removeprefix("\ufeff")
    except UnicodeDecodeError as exc:
        raise TableError(f"{path}: not UTF-8 text (byte {exc.start}); save it as CSV in UTF-8") from None
    except OSError as exc:
        raise TableError(f"{path}: {exc.strerror}") from None
    header = re.sub(r'"[^"]*"', "", text.splitlines()[0]) if text.strip() else ""  # separators in quotes do not count
    rows = csv.reader(io.StringIO(text, newline=""), delimiter=max(",;\t", key=header.count))
    columns = [column.strip().lower() for column in next(rows, [])]
    missing = [c for c in required if c not in columns]
    if missing:
        raise TableError(f"{path}, line 1: the header must name the columns {' and '.join(required)} "
                         f"(it has: {', '.join(map(repr, columns)) or 'nothing'})")
    table = []
    for row in rows:
        if not any(cell.strip() for cell in row):
            continue
        table.append((rows.line_num, {c: (row[i].strip() if i < len(row) else "") for i, c in enumerate(columns)}))
    return table
