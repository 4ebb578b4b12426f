"""The `grade` command's table: each command, where it is defined, whether it grades one submission at once, and
its examples. Read by the launcher (grader.faces.launch), which imports nothing of click and starts the learner's
child before anything else for a command that grades at once, and by the click layer (grader.faces.cli), which
imports a command's module only when the command is used or listed."""

from __future__ import annotations


class Command:
    """One command: the module and function of its click command, whether it grades one submission right away (the
    launcher then starts the learner's child first), and its examples. (No typing or dataclasses here: the launcher
    imports this module before the child starts.)"""

    __slots__ = ("module", "function", "grades_at_once", "examples")

    def __init__(self, module: str, function: str, grades_at_once: bool, examples: tuple[str, ...] = ()) -> None:
        self.module, self.function, self.grades_at_once, self.examples = module, function, grades_at_once, examples


LEARNER = "grader.faces.learner_commands"
COURSE = "grader.faces.course_commands"
COMMANDS = {
    "run": Command(LEARNER, "run_command", True, (
        "grade ch06                      grade chapter 6 (code and quiz)",
        "grade ch06 H_jacobian           only that function's checks",
        "grade all --html report.html    every chapter, and a report with plots",
        "grade 6 --format json -v        machine-readable; -v adds tracebacks")),
    "list": Command(LEARNER, "list_command", False, (
        "grade list", "grade list --checks            also every check's id and points")),
    "quiz": Command(LEARNER, "quiz_command", False, (
        "grade quiz ch06", "grade quiz ch06 --show          the questions with your numbers and letters")),
    "submit": Command(LEARNER, "submit_command", False, (
        "grade submit                     pack exercises/ into <your id>.zip, checked and graded",
        "grade submit --learner ada.lovelace --out ~/handin.zip")),
    "classroom": Command(LEARNER, "classroom_command", False, (  # it proves its sandbox first
        "grade classroom all --github-output \"$GITHUB_OUTPUT\"   in a GitHub Actions step",
        "grade classroom ch06 --output results.json")),
    "release": Command(COURSE, "release_command", False, (
        "grade release handout/", "grade release handout/ --course my-course.yaml --force",
        "grade release handout/ --notebooks   stubs as notebooks (Jupyter, Colab)")),
    "batch": Command(COURSE, "batch_command", False, (
        "grade batch submissions/ --out graded/",
        "grade batch submissions/ --out graded/ --roster roster.csv --chapters ch05,ch06 --lms canvas",
        "grade batch submissions/ --out graded/ --overrides overrides.csv --handout handout/ --similarity",
        "grade batch submissions/ --out graded/ --scheduler tls://scheduler:8786 --certs ~/grading-certs   on a Dask "
        "cluster")),
    "worker": Command(COURSE, "worker_command", False, (
        "grade worker tls://scheduler:8786 --certs ~/grading-certs",
        "grade worker tls://scheduler:8786 --certs ~/grading-certs --nworkers 8 --memory-limit 16GB")),
    "cluster": Command(COURSE, "cluster_group", False, (
        "grade cluster certs ~/grading-certs            the course's certificate authority and one certificate per role",
        "grade cluster scheduler --certs ~/grading-certs   the scheduler, TLS only")),
    "gradescope": Command(COURSE, "gradescope_command", False, (
        "grade gradescope autograder.zip", "grade gradescope autograder.zip --learner-id sid --chapters ch06,ch07")),
    "regrade": Command(COURSE, "regrade_command", False, (
        "grade regrade graded/                     whose grade today's grader would change, and why",
        "grade regrade graded/ --apply --reason \"bearing_variance: 3 significant digits, as its hint says\"",
        "grade regrade graded/ --course course.yaml   with an edited course file (the differences are listed)")),
    "review": Command(COURSE, "review_command", False, (
        "grade review graded/                      the class and each learner in the browser; overrides recorded",
        "grade review graded/ --read-only --no-browser   for a TA: read, record nothing")),
    "selftest": Command(COURSE, "selftest_command", False, (
        "grade selftest                            25 seeds, every chapter (CI runs it)",
        "grade selftest --seeds 200 --chapters ch06",
        "grade selftest --seed 17 --chapters ch06 --quizzes my-quizzes/   one failure again")),
}
DEFAULT = "run"  # `grade ch06` is `grade run ch06`
OPTIONS = ("--help", "-h", "--version")  # the group's own options


def grades_at_once(args: list[str]) -> bool:
    """Whether the command line `args` (without the program's name) names a command that grades at once (no command
    named: `grade ch06`, the default), and does not only ask for help."""
    if not args or any(a in ("--help", "-h") for a in args) or args[0] == "--version":
        return False
    command = COMMANDS.get(args[0])
    return COMMANDS[DEFAULT].grades_at_once if command is None else command.grades_at_once
