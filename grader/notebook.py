"""Jupyter notebooks as chapter modules, on the grading side (the contract: a chapter may be kept as
chNN_*.ipynb, nbformat 4).

A notebook's code cells, in order, are the module; IPython magics (`%...`, a `%%...` cell), shell
lines (`!...`) and help lines (`name?`) are left out, as nbconvert's script export leaves them to
IPython. Each left-out line becomes `pass` (or an empty line) so every other line keeps its place:
`ModuleSource.where` turns a line of the module back into "cell N, line M". The same conversion
serves the cells an IPython kernel ran (`%grade`, grader.faces.magic), labelled "In [N]".

Only json, re and tokenize here (the first two loaded when needed): this runs in the parent on every `grade chNN` that meets a notebook,
and the child never sees a notebook, only the module made from it.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

_DOTTED_NAME = re.compile(r"[A-Za-z_][\w.]*")
_TARGETS = re.compile(r"[\w.,\s\[\]()]+")


def is_escaped(line: str) -> bool:
    """Whether IPython reads `line`, where it starts a logical line, as one of its own commands: a magic (%), a
    shell line (!), help (?name, name?), the auto-call escapes (/ , ;), or a magic or shell line assigned
    (`files = !ls`, `t = %timeit -o f()`). In time linear in the line's length (learner text: no regular
    expression here may backtrack)."""
    text = line.lstrip()
    if not text:
        return False
    if text[0] in "%!?/,;":
        return True
    stripped = text.rstrip()
    name = stripped.rstrip("?")
    if 1 <= len(stripped) - len(name) <= 2 and _DOTTED_NAME.fullmatch(name):
        return True
    targets, equals, value = line.partition("=")
    return bool(equals) and value.lstrip()[:1] in ("%", "!") and _TARGETS.fullmatch(targets) is not None


class NotebookError(ValueError):
    """A file that is not a notebook of nbformat 4 (the message says what is wrong with it)."""


@dataclass(frozen=True)
class Segment:
    """One cell in the module: its first line there, its number of lines and its label ("cell 4")."""

    start: int
    length: int
    label: str


@dataclass(frozen=True)
class ModuleSource:
    """A module made of cells: its text, what to call its file in messages, and where each cell lies."""

    text: str
    shown: str
    segments: tuple[Segment, ...]

    def where(self, line: int) -> str:
        """"cell 4, line 2" for a line of the module (1-based); "line N" outside every cell."""
        for segment in self.segments:
            if segment.start <= line < segment.start + segment.length:
                return f"{segment.label}, line {line - segment.start + 1}"
        return f"line {line}"


def code_cells(data: bytes) -> list[tuple[int, str]]:
    """(cell number, counting every cell from 1; its source) of each code cell of a notebook file.
    NotebookError when the bytes are not a notebook of nbformat 4."""
    import json

    try:
        notebook = json.loads(data.decode("utf-8-sig"))
    except UnicodeDecodeError as exc:
        raise NotebookError(f"not a Jupyter notebook: not UTF-8 text (byte {exc.start})") from None
    except (ValueError, RecursionError) as exc:
        raise NotebookError(f"not a Jupyter notebook: not valid JSON ({str(exc)[:200]})") from None
    if not isinstance(notebook, dict) or not isinstance(notebook.get("cells"), list):
        raise NotebookError("not a Jupyter notebook: it has no list of cells")
    if notebook.get("nbformat") != 4:
        raise NotebookError(f"a notebook of nbformat {notebook.get('nbformat')!r}; the grader reads nbformat 4 "
                            "(open it in Jupyter and save it again)")
    cells = []
    for number, cell in enumerate(notebook["cells"], 1):
        if not isinstance(cell, dict) or cell.get("cell_type") != "code":
            continue
        source = cell.get("source", "")
        if isinstance(source, list):
            source = "".join(part for part in source if isinstance(part, str))
        cells.append((number, source if isinstance(source, str) else ""))
    return cells


def python_lines(code: str) -> list[str]:
    """A cell's lines with IPython's own lines left out: a `%%` cell magic empties the cell; a magic,
    shell or help line that starts a logical line (not one inside a string or brackets) becomes `pass`
    at its indentation, and the lines it continues with a backslash become empty."""
    lines = code.splitlines()
    first = next((line for line in lines if line.strip()), "")
    if first.lstrip().startswith("%%"):
        return ["" for _ in lines]
    candidates = {i for i, line in enumerate(lines) if is_escaped(line)}
    for _ in range(8):  # dropping a line can change what the lines after it are; settle it
        replaced = _replace(lines, candidates)
        starts = _logical_starts(replaced)
        if starts is None:  # a dropped line held a bracket (`  % 2)`): the cell as written tells
            starts = _logical_starts(lines)
        if starts is None:  # Python the tokenizer cannot read: keep the plain line rule
            break
        kept = {i for i in candidates if i in starts}
        if kept == candidates:
            break
        candidates = kept
    return _replace(lines, candidates, final=True)


def _replace(lines: list[str], dropped: set[int], final: bool = False) -> list[str]:
    """`lines` with the `dropped` ones as `pass` (a `final` top-level one as an empty line, which keeps a
    later `from __future__` first)."""
    out = list(lines)
    for i in sorted(dropped):
        indent = re.match(r"\s*", lines[i]).group(0)
        out[i] = "" if final and not indent else f"{indent}pass"
        j = i
        while lines[j].rstrip().endswith("\\") and j + 1 < len(lines):  # the command goes on
            j += 1
            out[j] = ""
    return out


def _logical_starts(lines: list[str]) -> set[int] | None:
    """The (0-based) lines on which a logical line of Python starts; None if they cannot be tokenized."""
    import io
    import tokenize

    text = "\n".join(lines) + "\n"
    starts: set[int] = set()
    expect = True
    skip = (tokenize.NL, tokenize.COMMENT, tokenize.INDENT, tokenize.DEDENT, tokenize.ENDMARKER, tokenize.ENCODING)
    try:
        for token in tokenize.generate_tokens(io.StringIO(text).readline):
            if token.type == tokenize.NEWLINE:
                expect = True
            elif token.type not in skip:
                if expect:
                    starts.add(token.start[0] - 1)
                expect = False
    except (tokenize.TokenError, SyntaxError):
        return None
    return starts


_FUTURE = re.compile(r"^from __future__ import [\w ,]+$")


def module_from_cells(cells: list[tuple[str, str]], shown: str) -> ModuleSource:
    """One module from (label, source) cells, in order: each cell's lines (IPython's own left out), then
    an empty line. A `from __future__` import, which a kernel takes in any cell, moves to a first line
    of its own (its place becomes an empty line)."""
    text: list[str] = []
    futures: list[str] = []
    segments = []
    for label, code in cells:
        lines = python_lines(code)
        for i, line in enumerate(lines):
            if _FUTURE.match(line.strip()) and not line[:1].isspace():
                futures.append(line.strip())
                lines[i] = ""
        segments.append(Segment(len(text) + 1, len(lines), label))
        text.extend(lines)
        text.append("")
    if futures:
        text.insert(0, "; ".join(dict.fromkeys(futures)))
        segments = [Segment(s.start + 1, s.length, s.label) for s in segments]
    return ModuleSource("\n".join(text) + "\n" if text else "", shown, tuple(segments))


def convert(data: bytes, shown: str) -> ModuleSource:
    """A notebook file's bytes as a module (NotebookError if they are not a notebook); `shown` names
    the notebook in messages."""
    return module_from_cells([(f"cell {n}", code) for n, code in code_cells(data)], shown)


def without_outputs(data: bytes) -> bytes:
    """A notebook file without its cells' outputs (images can make it large; grading reads only sources);
    bytes that are not a notebook come back as they are, to be reported when it is graded."""
    import json

    try:
        notebook = json.loads(data.decode("utf-8-sig"))
        for cell in notebook["cells"]:
            if isinstance(cell, dict) and "outputs" in cell:
                cell["outputs"] = []
        return json.dumps(notebook, ensure_ascii=False, indent=1).encode("utf-8")
    except (ValueError, KeyError, TypeError, AttributeError, RecursionError, UnicodeDecodeError):
        return data


_FRAME = re.compile(r'^(\s*File ")([^"]+)(", line )(\d+)', re.M)
_FRAME_NAME = re.compile(r'^\s*File "([^"]+)", line (\d+), in (.+)$', re.M)


def relocate(error: dict | None, sources: dict[str, ModuleSource]) -> None:
    """Say where in the learner's files an error description from the child (grader.boundary.wire.clean_error)
    happened. Where the outermost traceback frame is the top level of a module (the chapter's file being imported)
    and the error happened elsewhere (a function it calls, a module it imports), error["statement"] says where
    that top-level statement is and error["inside"] where the error happened ("boom, line 5"; "boom, cell 2,
    line 3"): the line to fix may be either. Modules made from cells (`sources`, by the module's file) are named
    by their notebook and "cell N, line M" there, in every traceback frame too, and error["where"] says where the
    innermost frame of the learner's files is; any other file by itself and "line N". In place."""
    if not error:
        return
    trace = error.get("traceback") or ""
    frames = [(m.group(1), int(m.group(2)), m.group(3).strip()) for m in _FRAME_NAME.finditer(trace)]
    if len(frames) > 1 and frames[0][2] == "<module>" and frames[0][:2] != frames[-1][:2]:
        (outer_file, outer_line, _), (file, line, name) = frames[0], frames[-1]
        error["statement"] = _place(outer_file, outer_line, sources)
        at = _place(file, line, sources, within=outer_file)
        error["inside"] = at if name == "<module>" else f"{name}, {at}"
    if not sources:
        return
    innermost = None
    for match in _FRAME.finditer(trace):
        innermost = match
    if innermost is not None and innermost.group(2) in sources:
        error["where"] = _place(innermost.group(2), int(innermost.group(4)), sources)

    def frame(match: re.Match) -> str:
        source = sources.get(match.group(2))
        if source is None:
            return match.group(0)
        return f"{match.group(1)}{source.shown}\", {source.where(int(match.group(4)))}"

    error["traceback"] = _FRAME.sub(frame, trace)


def _place(file: str, line: int, sources: dict[str, ModuleSource], within: str = "") -> str:
    """"exercises/ch06_measurement.py, line 5", or for a module made from cells "exercises/ch06_measurement.ipynb,
    cell 2, line 3"; without the file where it is `within`."""
    source = sources.get(file)
    at = source.where(line) if source is not None else f"line {line}"
    return at if file == within else f"{source.shown if source is not None else file}, {at}"


KERNEL = "the code this notebook's kernel ran"

_RUNNER = '''"""The code an IPython kernel ran, as %grade sent it: each cell runs in order, as in the kernel, an
exception ending only its own cell (what it says goes to the output -v shows)."""


def _run_cells(names):
    import os
    import traceback

    folder = os.path.join(os.path.dirname(os.path.abspath(__file__)), {folder!r})
    for name in names:
        path = os.path.join(folder, name)
        with open(path, encoding="utf-8") as handle:
            code = compile(handle.read(), path, "exec", dont_inherit=True)
        try:
            exec(code, globals())
        except BaseException:
            traceback.print_exc()


_run_cells({names!r})
del _run_cells
'''


def kernel_module(package: str, module: str, cells: list[tuple[str, str]]) -> dict[str, tuple[str, ModuleSource | None]]:
    """The files that make `module` of the cells a kernel ran ((label, source), in order): one file per
    cell that compiles (one that does not never ran) and a module that runs them in order, each in a try,
    as the kernel did. Relative path -> (text, the cell's line map; None for the module itself)."""
    folder = f"_kernel/{module}"
    files: dict[str, tuple[str, ModuleSource | None]] = {}
    names = []
    for index, (label, code) in enumerate(cells, 1):
        text = "\n".join(python_lines(code)) + "\n"
        try:
            compile(text, label, "exec", dont_inherit=True)
        except (SyntaxError, ValueError, RecursionError, MemoryError):  # it failed before running in the kernel too
            continue
        name = f"cell_{index:04d}.py"
        names.append(name)
        relative = f"{package}/{folder}/{name}"
        files[relative] = (text, ModuleSource(text, KERNEL, (Segment(1, text.count("\n"), label),)))
    files[f"{package}/{module}.py"] = (_RUNNER.format(folder=folder, names=names), None)
    return files
