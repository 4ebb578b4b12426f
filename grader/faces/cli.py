"""The `grade` command: a thin click layer over the transaction that grades a submission (grader.core.transaction),
the course operations and the renderers. Its commands are those of grader.faces.commands, each imported only when
used or listed: the learner's (grader.faces.learner_commands) and the instructor's (grader.faces.course_commands).

    grade ch06 | grade 6 | grade all       grade code (and quizzes) of chapters
    grade list                             chapters, functions and points
    grade quiz ch06                        only the quiz
    grade classroom all                    GitHub Classroom's per-check results
    grade submit                           pack exercises/ into the archive your course grades
    grade release / batch / regrade / worker / cluster / gradescope / selftest     the instructor's side
"""

from __future__ import annotations

import importlib

import click

from grader.faces.commands import COMMANDS, DEFAULT, OPTIONS
from grader.faces.options import chapter_of_file, encode_what_the_console_can, is_chapter


class _Commands(click.Group):
    """The commands of grader.faces.commands, each imported when asked for. `grade ch06 ...` means `grade run ch06
    ...`: anything that is not a command is a chapter. A word that is neither a chapter nor a command but close to a
    command (`grade lst`) is a usage error that names the command."""

    def list_commands(self, ctx: click.Context) -> list[str]:
        return sorted(COMMANDS)

    def get_command(self, ctx: click.Context, name: str) -> click.Command | None:
        entry = COMMANDS.get(name)
        if entry is None:
            return None
        command = getattr(importlib.import_module(entry.module), entry.function)
        if entry.examples and not command.epilog:
            command.epilog = examples(entry.examples)
        return command

    def parse_args(self, ctx: click.Context, args: list[str]) -> list[str]:
        if args and args[0] not in COMMANDS and args[0] not in OPTIONS:
            if not args[0].startswith("-") and not is_chapter(args[0]):
                chapter = chapter_of_file(args[0])
                if chapter is not None:
                    raise click.UsageError(f"{args[0]!r} is a chapter's file; grade it by its chapter: `grade {chapter}` "
                                           "(`grade list` shows the chapters)", ctx)
                import difflib

                close = difflib.get_close_matches(args[0].lower(), [c for c in COMMANDS if c != DEFAULT], n=1,
                                                  cutoff=0.6)
                if close:
                    raise click.UsageError(f"no command or chapter {args[0]!r}; did you mean `grade {close[0]}`? "
                                           "(`grade --help` lists the commands, `grade list` the chapters)", ctx)
            args = [DEFAULT, *args]
        return super().parse_args(ctx, args)


@click.group(cls=_Commands, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="jacobians-grader", message="%(prog)s, version %(version)s")  # click's own text, without its gettext lookup
def main() -> None:
    """Grade the lesson "Jacobians & Linearization": `grade ch06`, `grade all`, `grade list`."""
    encode_what_the_console_can()


def examples(lines: tuple[str, ...] | list[str]) -> str:
    return "\b\nExamples:\n" + "\n".join(f"  {line}" for line in lines)


main.epilog = examples(["grade ch06", "grade all", "grade list", "grade quiz ch06 --show",
                        "grade batch submissions/ --out graded/"])
