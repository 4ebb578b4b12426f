"""GitHub Classroom: the workflow `grade release` writes into the handout for the learners' template
repository, and the sandbox choice of `grade classroom`.

The workflow installs the handout's wheel on GitHub's runner, runs `grade classroom all`, which writes
every judged check with its own points in the format GitHub Classroom's autograding-grading-reporter
reads (grader.render.lms.classroom_data; base64 in the step output `result`), and hands that to the
reporter, which adds the points up for Classroom. It grades what the handout can: the public checks at
the public seed; recorded quiz answers and hidden checks are graded when the instructor grades the
submissions (`grade batch`).

Bubblewrap needs unprivileged user namespaces, which Ubuntu 24.04 (GitHub's ubuntu-latest) restricts
through AppArmor: the workflow lifts the restriction with sysctl (the runner is a throw-away VM and the
job has sudo). Where bubblewrap still cannot start, `grade classroom` grades without it (--sandbox
auto, the default) and its isolation line, on stderr and in the results' message, says so; with
--sandbox required it grades nothing and exits 2 instead.
"""

from __future__ import annotations

import base64
from pathlib import Path

WORKFLOW = Path(".github") / "workflows" / "classroom.yml"
PYTHON_VERSION = "3.12"

_TEMPLATE = """\
# GitHub Classroom autograding for the lesson "Jacobians & Linearization", written by `grade release`.
# Use the handout as the assignment's template repository as it is: this file, the grader wheel at the
# top, exercises/ beside it. On every push the grader runs the public checks (at the public seed) and
# reports each check's own points to GitHub Classroom through its autograding reporter. Recorded quiz
# answers and hidden checks are not graded here: grade the submissions with `grade batch` for those.
name: Autograding Tests
"on":
  - push
  - repository_dispatch
  - workflow_dispatch
permissions:
  checks: write
  actions: read
  contents: read
jobs:
  run-autograding-tests:
    runs-on: ubuntu-latest
    if: github.actor != 'github-classroom[bot]'
    timeout-minutes: 20
    steps:
      - name: Checkout code
        uses: actions/checkout@v5
      - name: Set up Python
        uses: actions/setup-python@v6
        with:
          python-version: "{python}"
      - name: Install the grader and its sandbox
        run: |
          sudo apt-get update -q && sudo apt-get install -y -q --no-install-recommends bubblewrap \\
            || echo "bubblewrap could not be installed: grading runs without the sandbox"
          # bubblewrap needs unprivileged user namespaces; Ubuntu 24.04 restricts them (AppArmor)
          sudo sysctl -w kernel.apparmor_restrict_unprivileged_userns=0 || true
          python -m pip install --quiet --disable-pip-version-check "./{wheel}"
      - name: Grade
        id: grader
        run: grade classroom {chapters} --github-output "$GITHUB_OUTPUT"
      - name: Autograding Reporter
        uses: classroom-resources/autograding-grading-reporter@v1
        env:
          GRADER_RESULTS: "${{{{ steps.grader.outputs.result }}}}"
        with:
          runners: grader
"""


def workflow(wheel: str, chapters: str = "all", python: str = PYTHON_VERSION) -> str:
    """The workflow file's text for a handout whose grader is the wheel file `wheel`."""
    return _TEMPLATE.format(wheel=wheel, chapters=chapters, python=python)


def write_template(out: Path, wheel: str, chapters: str = "all") -> Path:
    """Write the workflow into the handout folder `out`; its path."""
    path = out / WORKFLOW
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(workflow(wheel, chapters), encoding="utf-8")
    return path


def github_output_line(results_json: str) -> str:
    """The line a step appends to $GITHUB_OUTPUT so that `steps.<id>.outputs.result` is the results, base64."""
    return "result=" + base64.b64encode(results_json.encode("utf-8")).decode("ascii") + "\n"


def sandbox_for(mode: str):
    """(the grader.core.transaction.Door to grade behind, the isolation line, why there is no sandbox or ""), after
    starting one interpreter the way grading will (grader.boundary.choose with probe); BoundaryUnavailable where
    `mode` is "required" and the sandbox does not start."""
    from grader.core.transaction import Door

    door = Door(mode, probe=True)
    chosen = door.boundary
    if chosen.sandboxed:
        return door, chosen.isolation, ""
    if chosen.turned_off:
        return door, "isolation: no sandbox (turned off): learner code runs as you, with resource limits only", \
            "turned off"
    return door, (f"isolation: no sandbox: bubblewrap cannot run here ({chosen.why_not}); learner code runs as you, "
                  "with resource limits only (on GitHub's runners: allow user namespaces, "
                  "`sudo sysctl -w kernel.apparmor_restrict_unprivileged_userns=0`, as the release's workflow "
                  "does)"), chosen.why_not
