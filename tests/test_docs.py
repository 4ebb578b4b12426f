"""The documentation: the README is the entry point (under 200 lines, every link it gives leads somewhere), the site
in docs/ builds with MkDocs with warnings as errors (its command reference made from the commands themselves, every
JSON schema of grader/schemas/ shown on it), no page tells how the project was written (sessions, commit hashes,
before-and-after narrative), which a reader cannot act on, and no shell example drifts from the commands: every
`grade ...` line of a console or shell block is parsed by the real click command, and the blocks marked
`<!-- run -->` (or `<!-- run: exit N -->`) right above them are run."""

from __future__ import annotations

import copy
import html
import json
import os
import re
import shlex
import shutil
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest

from tests.support import REPO

PAGES = [REPO / "README.md", REPO / "benchmarks" / "README.md", *sorted((REPO / "docs" / "pages").rglob("*.md"))]
HISTORY = re.compile(r"\b(first|second|third|fourth|fifth|sixth|seventh|eighth|ninth|tenth|this|that|last|next) "
                     r"session\b|\bcommit [0-9a-f]{7}|\b[0-9a-f]{7}\b(?= \(|,| beside| in a worktree)", re.IGNORECASE)


def test_the_readme_is_the_entry_point():
    text = (REPO / "README.md").read_text(encoding="utf-8")
    assert len(text.splitlines()) < 200
    for target in re.findall(r"\]\(([^)#]+)\)", text):
        if not target.startswith("http"):
            assert (REPO / target).exists(), target


@pytest.mark.parametrize("page", PAGES, ids=lambda p: str(p.relative_to(REPO)))
def test_no_page_tells_how_the_project_was_written(page):
    found = [line for line in page.read_text(encoding="utf-8").splitlines() if HISTORY.search(line)]
    assert found == []


def test_a_history_sentence_is_caught():
    assert HISTORY.search("2026-11-26 (fourth session), against c58d2ff beside it")
    assert not HISTORY.search("a grading session opens behind the door; the child's session ends")


@pytest.fixture(scope="module")
def site(tmp_path_factory) -> Path:
    """The site, built once with `mkdocs build --strict` (a warning fails the build)."""
    pytest.importorskip("mkdocs")
    pytest.importorskip("mkdocs_click")
    out = tmp_path_factory.mktemp("docs") / "site"
    done = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "-f", str(REPO / "docs" / "mkdocs.yml"),
                           "-d", str(out)], capture_output=True, text=True, encoding="utf-8")
    assert done.returncode == 0, done.stderr[-3000:]
    return out


def test_the_site_builds_without_warnings_and_lists_every_command(site):
    reference = (site / "cli" / "index.html").read_text(encoding="utf-8")
    from grader.faces.commands import COMMANDS, DEFAULT

    for name in COMMANDS:
        if name != DEFAULT:  # `grade ch06` is `grade run ch06`: the default's options are under `grade`
            assert f'id="grade-{name}"' in reference, name
    assert reference.count('id="grade') > len(COMMANDS)


SCHEMAS = sorted((REPO / "grader" / "schemas").glob("*.json"))


def json_blocks(page: Path) -> list[object]:
    """Every ```json block of a built page, as data (a block that is no JSON, such as an example with `...`, left out)."""
    found = []
    for text in re.findall(r'<code class="language-json">(.*?)</code>', page.read_text(encoding="utf-8"), re.DOTALL):
        try:
            found.append(json.loads(html.unescape(text)))
        except ValueError:
            continue
    return found


@pytest.mark.parametrize("schema", SCHEMAS, ids=lambda p: p.name)
def test_every_json_schema_is_on_the_site_as_shipped(site, schema):
    shown = [block for page in sorted(site.rglob("*.html")) for block in json_blocks(page)]
    assert json.loads(schema.read_text(encoding="utf-8")) in shown, f"{schema.name} is not on the site"


def test_there_are_schemas_to_show():
    assert {p.name for p in SCHEMAS} >= {"report.schema.json", "summary.schema.json"}


# ------------------------------------------------------------------------------ shell examples against the commands

SHELLS = {"console", "bash", "sh", "shell"}
FENCE = re.compile(r"^(?P<indent>\s*)(?P<fence>`{3,}|~{3,})\s*(?P<language>[\w+-]*)")
RUN = re.compile(r"^<!-- run(?:: exit (?P<status>\d+))? -->$")
SEPARATORS = {"&&", "||", ";", "|", "&"}


@dataclass(frozen=True)
class Example:
    """One `grade ...` command of a shell block: where it is, its arguments after `grade`, and the exit status it
    must end with where its block is marked to run (None: not run)."""

    page: Path
    line: int
    args: tuple[str, ...]
    run: int | None

    @property
    def where(self) -> str:
        return f"{self.page.relative_to(REPO)}:{self.line}"


def shell_blocks(page: Path) -> list[tuple[str, list[tuple[int, str]], int | None]]:
    """Every fenced block of a page: its language, its lines (with their numbers) and the exit status of its
    `<!-- run -->` marker (on the last non-blank line above the fence; None without one)."""
    blocks, lines = [], page.read_text(encoding="utf-8").splitlines()
    i = 0
    while i < len(lines):
        opening = FENCE.match(lines[i])
        if not opening:
            i += 1
            continue
        above = next((lines[j].strip() for j in range(i - 1, -1, -1) if lines[j].strip()), "")
        marker = RUN.match(above)
        fence, body, i = opening["fence"], [], i + 1
        while i < len(lines) and not re.fullmatch(rf"\s*{re.escape(fence[0])}{{{len(fence)},}}\s*", lines[i]):
            body.append((i + 1, lines[i]))
            i += 1
        blocks.append((opening["language"].lower(), body, int(marker["status"] or 0) if marker else None))
        i += 1
    return blocks


def commands_of(language: str, body: list[tuple[int, str]]) -> list[tuple[int, str]]:
    """The command lines of a shell block (a console block's `$ ` lines), continuation lines joined."""
    out: list[tuple[int, str]] = []
    pending: tuple[int, str] | None = None
    for number, line in body:
        if pending is None:
            if language == "console":
                if not line.startswith("$ "):
                    continue
                line = line[2:]
            pending = (number, "")
        text = pending[1] + line
        if text.endswith("\\"):
            pending = (pending[0], text[:-1] + " ")
            continue
        out.append((pending[0], text))
        pending = None
    return out


def grade_commands(line: str) -> list[tuple[str, ...]]:
    """The `grade ...` commands of one shell line (also after `&&`, `;` or `|`), as shlex splits them."""
    lexer = shlex.shlex(line, posix=True, punctuation_chars=True)
    lexer.whitespace_split = True
    found, current = [], []
    for token in [*lexer, ";"]:
        if token in SEPARATORS:
            if current[:1] == ["grade"]:
                found.append(tuple(current[1:]))
            current = []
        else:
            current.append(token)
    return found


def examples() -> list[Example]:
    found = []
    for page in [REPO / "README.md", *sorted((REPO / "docs" / "pages").rglob("*.md"))]:
        for language, body, run in shell_blocks(page):
            if language in SHELLS:
                found += [Example(page, number, args, run) for number, line in commands_of(language, body)
                          for args in grade_commands(line)]
    return found


EXAMPLES = examples()


def resolve(args: tuple[str, ...]) -> None:
    """Parse `grade ARGS` with the real click commands, group by group down to the command it names (`grade ch06`
    is `grade run ch06`), as `grade` would before running anything; then the chapters and functions it names, as
    the command reads them. A click error (an unknown command or option, a wrong value) propagates; `--help` and
    `--version` end the parse as they end the command."""
    import click

    from grader.faces.cli import main
    from grader.faces.options import chapters_and_functions, chapters_from, chapters_option

    try:
        ctx = main.make_context("grade", list(args), resilient_parsing=False)
        while isinstance(ctx.command, click.Group):
            protected = ctx._protected_args if hasattr(ctx, "_protected_args") else ctx.protected_args  # click < 8.2
            rest = [*protected, *ctx.args]
            if not rest:
                return
            name, command, rest = ctx.command.resolve_command(ctx, rest)
            ctx = command.make_context(name, rest, parent=ctx, resilient_parsing=False)
    except click.exceptions.Exit as stop:
        assert stop.exit_code == 0
        return
    chapters, chapter_list = ctx.params.get("chapters"), ctx.params.get("chapter_list")
    if chapters and ctx.command.name == "run":
        chapters_and_functions(chapters)
    elif chapters:
        chapters_from(chapters)
    if isinstance(chapter_list, str):
        chapters_option(chapter_list)


@pytest.fixture
def placeholders(monkeypatch, tmp_path):
    """Paths in examples are placeholders (OUT, SUBMISSIONS/, my-course.yaml): a path option need not exist, in a
    folder where none does; everything else about a value (an integer, a choice, a chapter) is checked."""
    import click

    convert = click.Path.convert

    def any_path(self, value, param, ctx):
        relaxed = copy.copy(self)
        relaxed.exists = False
        return convert(relaxed, value, param, ctx)

    monkeypatch.setattr(click.Path, "convert", any_path)
    monkeypatch.chdir(tmp_path)


def test_every_run_marker_is_well_formed_and_above_a_shell_block():
    misplaced = []
    for page in [REPO / "README.md", *sorted((REPO / "docs" / "pages").rglob("*.md"))]:
        lines = page.read_text(encoding="utf-8").splitlines()
        for number, line in enumerate(lines, 1):
            if "<!-- run" in line:
                below = next((text for text in lines[number:] if text.strip()), "")
                fence = FENCE.match(below)
                if not RUN.match(line.strip()) or not fence or fence["language"].lower() not in SHELLS:
                    misplaced.append(f"{page.relative_to(REPO)}:{number}")
    assert misplaced == []


def test_the_docs_have_shell_examples_and_some_run():
    pages = {e.page.relative_to(REPO).as_posix() for e in EXAMPLES}
    assert len(EXAMPLES) >= 40 and {"README.md", "docs/pages/authors.md", "docs/pages/instructors/batch.md"} <= pages
    assert len([e for e in EXAMPLES if e.run is not None]) >= 5


@pytest.mark.parametrize("example", EXAMPLES, ids=lambda e: f"{e.where} grade {' '.join(e.args)}"[:120])
def test_every_shell_example_parses_as_the_command_it_names(example, placeholders):
    import click

    try:
        resolve(example.args)
    except click.ClickException as exc:
        pytest.fail(f"{example.where}: `grade {shlex.join(example.args)}`: {exc.format_message()}")


@pytest.mark.parametrize("line", [
    "grade lst",  # no such command (close to one)
    "grade nonsense",  # neither a command nor a chapter
    "grade ch06 --colour",  # no such option
    "grade batch SUBMISSIONS --out OUT --jobs N",  # not an integer
    "grade batch SUBMISSIONS --out OUT --lms blackboard",  # not a choice
    "grade batch SUBMISSIONS --out OUT --chapters ch5x",  # no such chapter
    "grade cluster certz DIR",  # no such command of a group
    "grade ch06 H_jacobain",  # no such function
    "grade release OUT [--course FILE] [--force]",  # a synopsis, not a command
    "grade gradescope autograder.zip --sandbox auto",  # not one of this option's choices
])
def test_a_wrong_example_is_caught(line, placeholders):
    import click

    (args,) = grade_commands(line)
    with pytest.raises(click.ClickException):
        resolve(args)


def test_the_examples_are_found_where_the_docs_put_them(tmp_path):
    page = tmp_path / "page.md"
    page.write_text("text\n\n<!-- run: exit 1 -->\n```console\n$ grade ch06 \\\n  --seed 7\noutput\n$ echo && grade list\n"
                    "```\n\n```sh\npip install . && grade all  # every chapter\n```\n\n```python\ngrade = 1\n```\n",
                    encoding="utf-8")
    blocks = shell_blocks(page)
    assert [(language, run) for language, _, run in blocks] == [("console", 1), ("sh", None), ("python", None)]
    assert [(n, grade_commands(line)) for n, line in commands_of("console", blocks[0][1])] == [
        (5, [("ch06", "--seed", "7")]), (8, [("list",)])]
    assert [grade_commands(line) for _, line in commands_of("sh", blocks[1][1])] == [[("all",)]]


RUNNABLE = [e for e in EXAMPLES if e.run is not None]


@pytest.mark.parametrize("example", RUNNABLE, ids=lambda e: f"{e.where} grade {' '.join(e.args)}"[:120])
def test_the_examples_marked_to_run_run_as_the_docs_say(example, tmp_path):
    """In a fresh folder holding a copy of the project's exercises/ (the untouched stubs), with the user's cache
    turned off; `grade` is `python -m grader`."""
    shutil.copytree(REPO / "exercises", tmp_path / "exercises", ignore=shutil.ignore_patterns("__pycache__"))
    env = {**os.environ, "GRADER_CACHE_DIR": "",
           "PYTHONPATH": os.pathsep.join(filter(None, [str(REPO), os.environ.get("PYTHONPATH")]))}
    done = subprocess.run([sys.executable, "-m", "grader", *example.args], cwd=tmp_path, env=env, timeout=120,
                          capture_output=True, text=True, encoding="utf-8", errors="replace")
    assert done.returncode == example.run, (f"{example.where}: `grade {shlex.join(example.args)}` exited "
                                            f"{done.returncode}, not {example.run}\n{done.stdout[-2000:]}\n"
                                            f"{done.stderr[-2000:]}")

