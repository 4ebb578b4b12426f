"""Learner-controlled text made safe for each medium it reaches.

Learner ids, file and zip entry names, exception names and messages, what learner code printed and
quiz answers as written all end up in grader outputs. Each medium has its own hazards:

- every UTF-8 output (JSON, HTML, CSV, XML, a terminal): lone surrogates ("\\udcff", from bytes that
  were not UTF-8) cannot be encoded at all; they become U+FFFD.
- XML (junit.xml): characters XML 1.0 forbids (most C0 controls, U+FFFE, U+FFFF) make the file
  unreadable; they become U+FFFD.
- HTML: escaping is the renderer's (jinja2's autoescape, html.escape); control characters become
  U+FFFD.
- CSV (the gradebook): a cell starting with = + - @, a tab or a carriage return is a formula to a
  spreadsheet; it gets a leading single quote (OWASP's advice). Nothing else changes, so ids stay as
  given. Line breaks and other control characters inside a cell become spaces and U+FFFD.
- a terminal: escape sequences (colours, clearing the screen, moving the cursor, window titles) are
  removed; other control characters (a carriage return that would overwrite a line, a backspace,
  bidirectional overrides that reorder what is shown) become '?'. Newlines and tabs stay unless the
  text must stay on one line.

`clean_report` applies one of these to every string of a grader.model.Report (a copy), so a renderer
can make a report safe in one place.
"""

from __future__ import annotations

import dataclasses
import json
import re
from collections.abc import Callable, Mapping
from enum import Enum

_SURROGATES = re.compile("[\ud800-\udfff]")
# Characters XML 1.0 does not allow (besides the surrogates)
_NOT_XML = re.compile("[\x00-\x08\x0b\x0c\x0e-\x1f\ud800-\udfff\ufffe\uffff]")
# C0 and C1 controls but tab and newline (and carriage return, handled apart), DEL
_CONTROL = re.compile("[\x00-\x08\x0b\x0c\x0e-\x1f\x7f-\x9f]")
# Bidirectional embeddings, overrides and isolates, and the line and paragraph separators
_BIDI = re.compile("[\u200e\u200f\u202a-\u202e\u2066-\u2069\u2028\u2029]")
# Terminal escape sequences: CSI (colours, cursor, clear), OSC (titles, links), DCS/SOS/PM/APC
# strings, the 8-bit CSI, and the short two-character escapes
_ESCAPE_SEQUENCE = re.compile(
    r"\x1b\[[0-?]*[ -/]*[@-~]?"
    r"|\x1b\][^\x07\x1b\x9c]*(?:\x07|\x1b\\|\x9c)?"
    r"|\x1b[PX^_][^\x1b\x9c]*(?:\x1b\\|\x9c)?"
    r"|\x9b[0-?]*[ -/]*[@-~]?"
    r"|\x1b[ -/]*[0-~]?")
FORMULA_START = ("=", "+", "-", "@", "\t", "\r")


def unicode_clean(text: str) -> str:
    """`text` that encodes as UTF-8: lone surrogates become U+FFFD."""
    return _SURROGATES.sub("\ufffd", text)


def for_xml(text: str) -> str:
    """`text` with every character XML 1.0 forbids replaced by U+FFFD (escaping is ElementTree's)."""
    return _NOT_XML.sub("\ufffd", text)


def for_html(text: str) -> str:
    """`text` for an HTML page before escaping: no lone surrogates, no control characters but tab and
    line breaks."""
    return _CONTROL.sub("\ufffd", unicode_clean(text))


def for_csv(text: str) -> str:
    """A spreadsheet cell: one line, no formula (a leading = + - @ tab or CR gets a single quote)."""
    if text.startswith(FORMULA_START):
        text = "'" + text
    text = re.sub(r"\r\n|[\r\n\t]", " ", text)
    return _CONTROL.sub("\ufffd", unicode_clean(text))


def for_terminal(text: str, one_line: bool = False) -> str:
    """`text` that cannot move the cursor, change colours, clear the screen, set a title or overwrite
    a line: escape sequences removed, other controls (and bidirectional overrides) shown as '?'.
    With `one_line`, line breaks and tabs become spaces."""
    text = _ESCAPE_SEQUENCE.sub("", text).replace("\r\n", "\n")
    if one_line:
        text = re.sub(r"[\n\t]+", " ", text)
    text = _CONTROL.sub("?", text.replace("\r", "?"))
    return _BIDI.sub("?", _SURROGATES.sub("?", text))


def for_json(value: object) -> object:
    """Plain JSON data (dicts, lists, strings, numbers) whose strings all encode as UTF-8; JSON's
    own escaping takes care of control characters. Data that already does is returned as it is (one
    encoding in C tells, instead of a walk through every string)."""
    try:
        text = json.dumps(value, ensure_ascii=False)
    except (TypeError, ValueError):  # not JSON data: its strings cleaned all the same
        return clean_value(value, unicode_clean)
    return clean_value(value, unicode_clean) if _SURROGATES.search(text) else value


def json_text(value: object, indent: int | None = None) -> str:
    """`json.dumps(for_json(value), allow_nan=False, indent=indent)`, encoded once where, as almost always, every
    string is ASCII: that text is the same with or without ensure_ascii. NaN and what is not JSON data raise as
    json.dumps does."""
    text = unicode_json(value) if indent is None else json.dumps(value, ensure_ascii=False, allow_nan=False,
                                                                 indent=indent)
    if ascii_as_escaped(text):
        return text
    if _SURROGATES.search(text):
        value = clean_value(value, unicode_clean)
    return json.dumps(value, allow_nan=False, indent=indent)


def ascii_as_escaped(text: str) -> bool:
    """JSON text written with ensure_ascii=False that ensure_ascii=True would write the same: ASCII, and no DEL
    (which only ensure_ascii escapes)."""
    return text.isascii() and "\x7f" not in text


# What for_terminal would change, as it shows in JSON text written with ensure_ascii=False: C0 controls
# (escaped by JSON as \u00XX, \r, \b, \f), C1 controls and DEL, bidirectional marks and separators. A
# backslash the text itself holds shows as \\ and may match too: that only sends the data the slow way.
_TERMINAL_UNSAFE_JSON = re.compile(r"\\u00|\\[rbf]|[\x7f-\x9f\u200e\u200f\u202a-\u202e\u2066-\u2069\u2028\u2029]")
# The same in ASCII JSON text without DEL, found by plain substring searches
_TERMINAL_UNSAFE_ASCII_JSON = ("\\u00", "\\r", "\\b", "\\f")


def json_for_terminal(data: object, texts: Mapping[int, str] | None = None, path: tuple[str, ...] = ()) -> str:
    """JSON text (ASCII, no NaN) of plain data with every string made safe by for_terminal. Data with
    nothing to clean, as almost all is (one encoding in C tells), is written as it is: no walk. `texts` and
    `path`: as json_spliced's, the texts of some of its dicts (made by unicode_json)."""
    text = json_spliced(data, texts, unicode_json, path) if texts else unicode_json(data)
    if ascii_as_escaped(text):
        if not any(unsafe in text for unsafe in _TERMINAL_UNSAFE_ASCII_JSON):
            return text
    elif not _SURROGATES.search(text) and not _TERMINAL_UNSAFE_JSON.search(text):
        return json.dumps(data, allow_nan=False)
    return json.dumps(clean_value(data, for_terminal), allow_nan=False)  # for_terminal leaves no lone surrogate


# json.dumps(value, ensure_ascii=False, allow_nan=False), its encoder made once: the first try of json_text and of
# json_for_terminal (strings as they are, no NaN)
unicode_json = json.JSONEncoder(ensure_ascii=False, allow_nan=False).encode


def json_spliced(data: dict, texts: Mapping[int, str], dumps: Callable[[object], str], path: tuple[str, ...]) -> str:
    """`dumps(data)` (json.dumps with its default separators and no indent), where each dict reached along `path`
    (("chapters", "checks"): every data["chapters"][i]["checks"][j]) whose id is in `texts` is written as that text,
    which is what `dumps` gives of it (made once for a check reused learner after learner, grader.model.made_text).
    JSON is written part by part: the whole is the same text. Data of another shape is given to `dumps` whole."""

    def dict_text(value: object, path: tuple[str, ...]) -> str:
        if type(value) is not dict or not all(type(key) is str for key in value):  # json.dumps writes other keys
            return dumps(value)                                                      # as strings: left to it
        return "{" + ", ".join(f"{dumps(key)}: {list_text(item, path[1:]) if key == path[0] else dumps(item)}"
                               for key, item in value.items()) + "}"

    def list_text(value: object, rest: tuple[str, ...]) -> str:
        if type(value) is not list:
            return dumps(value)
        if rest:
            return "[" + ", ".join(dict_text(item, rest) for item in value) + "]"
        parts, start = [], 0  # the items with no text given are written a run at a time
        for i, item in enumerate(value):
            text = texts.get(id(item))
            if text is not None:
                if start < i:
                    parts.append(dumps(value[start:i])[1:-1])
                parts.append(text)
                start = i + 1
        if start < len(value):
            parts.append(dumps(value[start:])[1:-1])
        return "[" + ", ".join(parts) + "]"

    return dict_text(data, path) if path else dumps(data)


_PLAIN = frozenset({int, float, bool, type(None)})
# ASCII control characters but tab and newline: an ASCII string without them is one that unicode_clean, for_html,
# for_xml and for_terminal all leave as it is
_ASCII_CONTROL = re.compile("[\x00-\x08\x0b-\x1f\x7f]")
# How clean_value walks a value, by its type: kept as it is, a string, items (a list or tuple), a dict, or a
# dataclass (the names of the fields its __init__ sets)
_KEEP, _TEXT, _ITEMS, _MAPPING = "keep", "text", "items", "mapping"
_walk_of: dict[type, str | tuple[str, ...]] = {}


def _how_to_walk(kind: type) -> str | tuple[str, ...]:
    if kind in _PLAIN or issubclass(kind, Enum):
        how: str | tuple[str, ...] = _KEEP
    elif issubclass(kind, str):
        how = _TEXT
    elif kind is list or kind is tuple:
        how = _ITEMS
    elif issubclass(kind, dict):
        how = _MAPPING
    elif dataclasses.is_dataclass(kind):
        how = tuple(f.name for f in dataclasses.fields(kind) if f.init) or _KEEP
    else:
        how = _KEEP  # numbers of other types, arrays, anything else
    _walk_of[kind] = how
    return how


def clean_value(value: object, clean: Callable[[str], str],
                known_clean: Mapping[type, Callable[[object], bool]] | None = None) -> object:
    """`value` with `clean` applied to every string inside it: dict keys and values, list and tuple
    items and the fields of dataclasses. What changes is copied, never changed in place; what needs no
    cleaning (almost everything) is the same object, shared: the renderers that call this only read it.
    Enums, numbers and arrays are left as they are. `known_clean`: for a dataclass, a function that may know that
    one of its instances needs no cleaning (True: it is left as it is, unwalked)."""
    keeps_plain_ascii = clean in _KEEP_PLAIN_ASCII
    unsafe = _ASCII_CONTROL.search
    known = known_clean or {}

    def walk(value: object) -> object:
        kind = type(value)
        how = _walk_of.get(kind) or _how_to_walk(kind)
        if how is _KEEP:
            return value
        if how is _TEXT:
            if keeps_plain_ascii and value.isascii() and not unsafe(value):
                return value
            cleaned = clean(value)
            return value if cleaned == value else cleaned
        # below, a number or a string that needs no cleaning (most items) is passed over without a call
        if how is _ITEMS:
            for i, item in enumerate(value):
                kind = type(item)
                if kind in _PLAIN or kind is str and keeps_plain_ascii and item.isascii() and not unsafe(item):
                    continue
                if walk(item) is not item:  # the first that changes: copy
                    return type(value)([*value[:i], *map(walk, value[i:])])
            return value
        if how is _MAPPING:
            for i, (key, item) in enumerate(value.items()):
                if walk(key) is not key or walk(item) is not item:
                    pairs = list(value.items())
                    return dict(pairs[:i] + [(walk(k), walk(v)) for k, v in pairs[i:]])
            return value
        if kind in known and known[kind](value):
            return value
        changes = {}
        for name in how:
            item = getattr(value, name)
            kind = type(item)
            if kind in _PLAIN or kind is str and keeps_plain_ascii and item.isascii() and not unsafe(item):
                continue
            cleaned = walk(item)
            if cleaned is not item:
                changes[name] = cleaned
        return dataclasses.replace(value, **changes) if changes else value

    return walk(value)


_KEEP_PLAIN_ASCII = frozenset({unicode_clean, for_html, for_xml, for_terminal})


def clean_report(report, clean: Callable[[str], str],
                 known_clean: Mapping[type, Callable[[object], bool]] | None = None):
    """A copy of a grader.model.Report with `clean` applied to every string in it (messages, problems,
    what learner code printed, quiz answers as written, the learner's id ...); `known_clean` as clean_value's."""
    return clean_value(report, clean, known_clean)


def decode_saved_text(data: bytes) -> tuple[str, str]:
    """A learner's saved text file as text, and what encoding it was in where that was not plain UTF-8 ("" for
    UTF-8): UTF-8 with a byte-order mark, and UTF-16 (Windows Notepad's "Unicode", with its byte-order mark, or
    without one where every other byte is a NUL) are read as such. Bytes that are none of these become U+FFFD."""
    import codecs

    if data.startswith(codecs.BOM_UTF8):
        return data[len(codecs.BOM_UTF8):].decode("utf-8", "replace"), "UTF-8 with a byte-order mark"
    if data.startswith((codecs.BOM_UTF16_LE, codecs.BOM_UTF16_BE)):
        return data.decode("utf-16", "replace"), "UTF-16 (Windows Notepad's \"Unicode\")"
    if len(data) >= 4 and data.count(0) * 3 >= len(data):  # UTF-16 without its mark: a NUL beside each ASCII byte
        little = data[1::2].count(0) >= data[0::2].count(0)
        return data.decode("utf-16-le" if little else "utf-16-be", "replace"), "UTF-16 (without a byte-order mark)"
    return data.decode("utf-8", "replace"), ""


def first_not_utf8(data: bytes) -> tuple[int, int] | None:
    """(line, byte) of the first byte of `data` that is not UTF-8; None where all of it is."""
    try:
        data.decode("utf-8")
        return None
    except UnicodeDecodeError as exc:
        return data.count(b"\n", 0, exc.start) + 1, data[exc.start]


def not_utf8(data: bytes) -> tuple[int, int] | None:
    """(line, byte) of the first byte that is not UTF-8 in a Python file that declares no other encoding (PEP 263),
    which `python FILE` refuses ("Non-UTF-8 code starting with ..."); None for a file it reads. (An import takes such
    bytes in a comment and refuses them in a string.)"""
    bad = first_not_utf8(data)
    if bad is None:
        return None
    import io
    import tokenize

    try:
        declared, _ = tokenize.detect_encoding(io.BytesIO(data).readline)
    except SyntaxError:  # a byte that is not UTF-8 in the first two lines, which declare nothing
        declared = "utf-8"
    if declared not in ("utf-8", "utf-8-sig"):
        return None  # Python reads it as it declares (or says why not itself)
    return bad


PYTHON_REFUSES = "`python` refuses such a file"


def not_utf8_note(shown: str, line: int, byte: int, consequence: str = PYTHON_REFUSES) -> str:
    """The sentence a learner reads about a file with a byte that is not UTF-8 on `line` (the first such): what that
    does (`consequence`: for a Python file, that `python` refuses it) and how to fix it."""
    try:
        seen = bytes([byte]).decode("cp1252")
        guess = f', "{seen}" in Windows-1252' if seen.isprintable() and not seen.isspace() else ""
    except UnicodeDecodeError:
        guess = ""
    return (f"{shown}, line {line} is not UTF-8 (byte 0x{byte:02X}{guess}): {consequence}; save it as "
            "UTF-8 (in Notepad: Save as, Encoding: UTF-8)")


def encoding_note(shown: str, encoding: str) -> str:
    """The sentence a learner reads about a file saved in `encoding` instead of UTF-8."""
    return (f"{shown} is saved as {encoding}: it was read as such; save it as UTF-8 (in Notepad: Save as, Encoding: "
            "UTF-8) so that every tool reads it")
