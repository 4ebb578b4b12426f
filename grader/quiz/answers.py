"""Learner answer files (exercises/answers/chNN.yaml): each answer with the line it is on.

The file is composed into YAML nodes (their marks give line numbers) and each answer is checked
before it is turned into data: no anchors/aliases (an alias bomb would expand exponentially), at
most MAX_DEPTH levels of brackets and MAX_ITEMS values. A file that is not valid YAML is read
entry by entry (each top-level `id:` line starts one), so a slip in one answer costs only that
answer.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from itertools import pairwise
from pathlib import Path

import yaml

from grader.safe_text import (
    decode_saved_text,
    encoding_note,
    first_not_utf8,
    not_utf8_note,
)

# libyaml's composer recurses in C and crashes the process on deeply nested input, while the pure-Python
# one stops with a RecursionError. So libyaml (15 times faster) composes only a text that cannot nest
# deeper than C_DEPTH_BOUND: every level of nesting needs one of NESTING's characters or a line. Any
# text that libyaml refuses is composed again by the pure-Python loader, whose messages are the ones shown.
LOADER = yaml.SafeLoader
FAST_LOADER = getattr(yaml, "CSafeLoader", None)
NESTING = "[{-?:"
C_DEPTH_BOUND = 1000
MAX_BYTES = 64_000
MAX_DEPTH = 3  # an answer, a list, a list of lists (a matrix)
MAX_ITEMS = 100
_ENTRY = re.compile(r"^([A-Za-z_][\w-]*)\s*:")
_START = re.compile(r"^([A-Za-z_][\w-]*)")  # an entry's first line: a question id, with its ':' or without
MAX_INT_BITS = 1000  # about 301 decimal digits: the integers a float can hold, with room to spare
TOO_LARGE = "the number is too large"
NOT_UTF8_READ = ("it was read with each such byte as an unknown character, so an answer that holds one is not what "
                 "you wrote")


@dataclass
class Answer:
    value: object
    line: int
    text: str = ""  # the answer as written (the source of a list, the value of a scalar)


@dataclass
class AnswerFile:
    answers: dict[str, Answer]
    problems: list[str]  # about the file as a whole, naming the file and line
    unreadable: dict[str, str] = field(default_factory=dict)  # question id -> why (file, line, question)
    notes: list[str] = field(default_factory=list)  # what the learner should know that costs nothing (its encoding)


def _shape_problem(node: yaml.Node) -> str | None:
    """Why this answer node is not plain data of a sensible size, or None."""
    seen: set[int] = set()
    stack = [(node, 1)]
    count = 0
    while stack:
        current, depth = stack.pop()
        if id(current) in seen:
            return "anchors and aliases (& and *) are not used in answers; quote an answer that starts with *"
        seen.add(id(current))
        count += 1
        if count > MAX_ITEMS:
            return f"more than {MAX_ITEMS} values in one answer"
        if depth > MAX_DEPTH:
            return f"brackets nested more than {MAX_DEPTH - 1} deep"
        if isinstance(current, yaml.SequenceNode):
            stack.extend((child, depth + 1) for child in current.value)
        elif isinstance(current, yaml.MappingNode):
            return "a mapping (key: value) is not an answer; quote the answer if it contains ': '"
    return None


def _construct(constructor: yaml.constructor.SafeConstructor, node: yaml.Node) -> tuple[object, str | None]:
    """(the answer as data, None) or (None, why it cannot be read). An integer too large for a float
    (310 digits or more; Python refuses to even read 4301 or more) is refused here, before anything
    converts it: it would raise OverflowError or ValueError where the answer is judged."""
    try:
        value = constructor.construct_object(node, deep=True)
    except (yaml.YAMLError, RecursionError) as exc:
        return None, str(exc).splitlines()[0] if str(exc) else type(exc).__name__
    except ValueError as exc:  # the digits limit of int(), or a date such as 2001-13-01
        if "digits" in str(exc):
            return None, TOO_LARGE
        return None, f"cannot read this value ({str(exc).splitlines()[0][:100] if str(exc) else type(exc).__name__})"
    except (OverflowError, TypeError, ArithmeticError) as exc:
        return None, f"cannot read this value ({type(exc).__name__})"
    if _too_large(value):
        return None, TOO_LARGE
    return value, None


def _too_large(value: object) -> bool:
    """Whether `value` holds an integer beyond the range of a float (checked without converting it)."""
    if isinstance(value, bool):
        return False
    if isinstance(value, int):
        return value.bit_length() > MAX_INT_BITS
    if isinstance(value, (list, tuple)):
        return any(_too_large(item) for item in value)
    return False


def _entries_of_node(node: yaml.Node, offset: int, source: str, shown: str, out: AnswerFile) -> None:
    if not isinstance(node, yaml.MappingNode):
        out.problems.append(f"{shown}, line {node.start_mark.line + 1 + offset}: expected `question_id: answer` lines")
        return
    constructor = yaml.constructor.SafeConstructor()
    for key_node, value_node in node.value:
        line = key_node.start_mark.line + 1 + offset
        key = str(key_node.value)
        if not isinstance(key_node, yaml.ScalarNode):
            out.problems.append(f"{shown}, line {line}: expected `question_id: answer` lines")
            continue
        problem = _shape_problem(value_node)
        if problem is None:
            value, problem = _construct(constructor, value_node)
        if problem is not None:
            out.unreadable[key] = f"{shown}, line {line}, question {key}: {problem}"
            out.answers.pop(key, None)
            continue
        if isinstance(value_node, yaml.ScalarNode):
            text = "" if value is None else str(value)
        else:
            text = source[value_node.start_mark.index:value_node.end_mark.index].strip()
        if key in out.answers:
            out.problems.append(f"{shown}, line {line}, question {key}: answered twice; the later answer counts")
        out.answers[key] = Answer(value, line, text)
        out.unreadable.pop(key, None)


def _why_not_yaml(line: str, key: str) -> str:
    """Why the entry starting at `line` is not valid YAML, in the learner's terms."""
    value = line.split(":", 1)[1].strip()
    if value == "-" or value.startswith(("- ", "-\t")):  # `id: - 0.5`: a list where no list may start
        quoted = value.replace("\\", "\\\\").replace('"', '\\"')
        return f"YAML reads an answer that starts with '- ' as a list: put it in quotes, e.g. {key}: \"{quoted}\""
    return "this answer is not valid YAML (quote it: key: \"...\")"


def compose(text: str) -> yaml.Node | None:
    """`text` composed into YAML nodes (marks give lines and character offsets); yaml.YAMLError or
    RecursionError as the pure-Python loader raises them."""
    if FAST_LOADER is not None and sum(map(text.count, NESTING)) + text.count("\n") < C_DEPTH_BOUND:
        try:
            return yaml.compose(text, Loader=FAST_LOADER)
        except yaml.YAMLError:
            pass  # composed again below, for the pure-Python loader's message
    return yaml.compose(text, Loader=LOADER)


def read(path: Path, shown: str) -> AnswerFile:
    """The answers in `path`; `shown` is how messages name the file."""
    out = AnswerFile({}, [])
    if not path.exists():
        out.problems.append(f"{shown} was not found: copy the template from the lesson and fill it in")
        return out
    size = path.stat().st_size
    if size > MAX_BYTES:
        out.problems.append(f"{shown} is {size} bytes; answer files are read up to {MAX_BYTES} bytes")
        return out
    data = path.read_bytes()
    key = (shown, data, FAST_LOADER)  # what is read depends on the bytes, how the file is named and who composes it
    kept = _READ.get(key)
    if kept is None:
        if len(_READ) >= _READ_MAX:
            _READ.clear()  # as grader.quiz.judge keeps its verdicts: memory stays flat
        kept = _READ[key] = _parsed(data, shown)
    return AnswerFile(dict(kept.answers), list(kept.problems), dict(kept.unreadable), list(kept.notes))


_READ: dict[tuple, AnswerFile] = {}  # (how the file is named, its bytes, the loader) -> what reading them gave
_READ_MAX = 256  # a worker's learners' files repeat (the quiz is read again for other ids: grader.quiz.other_ids)


def _parsed(data: bytes, shown: str) -> AnswerFile:
    """The answers in an answer file's bytes (read)."""
    out = AnswerFile({}, [])
    text, encoding = decode_saved_text(data)
    if encoding:
        out.notes.append(encoding_note(shown, encoding))
    elif (bad := first_not_utf8(data)) is not None:  # read all the same, each such byte as an unknown character
        out.notes.append(not_utf8_note(shown, *bad, NOT_UTF8_READ))
    try:
        node = compose(text)
        if node is not None:
            _entries_of_node(node, 0, text, shown, out)
        return out
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        whole = f"{shown}, line {mark.line + 1}: not valid YAML ({exc.problem})" if mark else f"{shown}: not valid YAML"
    except (yaml.YAMLError, RecursionError):
        whole = f"{shown}: not valid YAML"
    out.answers.clear()
    out.unreadable.clear()
    # Read entry by entry: an entry starts with a question id at the start of a line, with its ':' or without
    # (a missing colon costs that answer alone, said at its own line, not the answer above it).
    lines = text.splitlines()
    starts = [i for i, line in enumerate(lines) if _START.match(line)] + [len(lines)]
    for begin, end in pairwise(starts):
        block = "\n".join(lines[begin:end])
        key = _START.match(lines[begin]).group(1)
        if not _ENTRY.match(lines[begin]):
            rest = lines[begin][len(key):].strip()
            out.unreadable[key] = (f"{shown}, line {begin + 1}, question {key}: no ':' after the question id; write "
                                   f"`{key}: {rest}`" if rest else f"{shown}, line {begin + 1}: {key!r} without ':' "
                                   "and an answer")
            out.answers.pop(key, None)
            continue
        try:
            node = compose(block)
        except (yaml.YAMLError, RecursionError):
            out.unreadable[key] = f"{shown}, line {begin + 1}, question {key}: {_why_not_yaml(lines[begin], key)}"
            out.answers.pop(key, None)
            continue
        if node is not None:
            _entries_of_node(node, begin, block, shown, out)
    if not out.unreadable:  # no entry of its own is wrong: say what the whole file's reading said
        out.problems.append(f"{whole}; the answers were read one by one")
    return out
