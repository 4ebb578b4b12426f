"""Learner answer files (exercises/answers/chNN.yaml): each answer with the line it is on.

A file that is not valid YAML is read entry by entry (each top-level `id:` line starts one), so a
slip in one answer costs only that answer.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import yaml

from grader.quiz.bank import SAFE_LOADER

_ENTRY = re.compile(r"^([A-Za-z_][\w-]*)\s*:")


@dataclass
class Answer:
    value: object
    line: int


@dataclass
class AnswerFile:
    answers: dict[str, Answer]
    problems: list[str]  # messages naming the file and line


def _entries_of_node(node: yaml.Node, offset: int, shown: str, out: AnswerFile) -> None:
    if not isinstance(node, yaml.MappingNode):
        out.problems.append(f"{shown}, line {node.start_mark.line + 1 + offset}: expected `question_id: answer` lines")
        return
    constructor = yaml.constructor.SafeConstructor()
    for key_node, value_node in node.value:
        line = key_node.start_mark.line + 1 + offset
        key = str(key_node.value)
        try:
            value = constructor.construct_object(value_node, deep=True)
        except yaml.YAMLError as exc:
            out.problems.append(f"{shown}, line {line}, question {key}: {exc}")
            continue
        if key in out.answers:
            out.problems.append(f"{shown}, line {line}, question {key}: answered twice; the later answer counts")
        out.answers[key] = Answer(value, line)


def read(path: Path, shown: str) -> AnswerFile:
    """The answers in `path`; `shown` is how messages name the file."""
    out = AnswerFile({}, [])
    if not path.exists():
        out.problems.append(f"{shown} was not found: copy the template from the lesson and fill it in")
        return out
    text = path.read_text(encoding="utf-8", errors="replace")
    try:
        node = yaml.compose(text, Loader=SAFE_LOADER)
        if node is not None:
            _entries_of_node(node, 0, shown, out)
        return out
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        where = f"line {mark.line + 1}" if mark else "somewhere"
        out.problems.append(f"{shown}, {where}: not valid YAML ({exc.problem}); the other answers are still graded")
    lines = text.splitlines()
    starts = [i for i, line in enumerate(lines) if _ENTRY.match(line)] + [len(lines)]
    for begin, end in zip(starts, starts[1:]):
        block = "\n".join(lines[begin:end])
        try:
            node = yaml.compose(block, Loader=SAFE_LOADER)
        except yaml.MarkedYAMLError:
            key = _ENTRY.match(lines[begin]).group(1)
            out.problems.append(f"{shown}, line {begin + 1}, question {key}: this answer is not valid YAML "
                                "(quote it: key: \"...\")")
            continue
        if node is not None:
            _entries_of_node(node, begin, shown, out)
    return out
