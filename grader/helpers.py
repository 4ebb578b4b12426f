"""The grader's own helper processes (never learner code): sympy's worker for the quiz's symbolic answers
(grader.quiz.symbolic) and the notebook's grading process (grader.faces.magic). Learner code starts only through
grader.boundary."""

from __future__ import annotations

import os
import subprocess

from grader.system import child_environment, process_groups


def start_helper(command: list[str]) -> subprocess.Popen:
    """A helper interpreter of the grader's own talking over stdin and stdout, in a process group of its own
    where the system has them, so that stop_helper ends all it started."""
    groups = process_groups()
    return subprocess.Popen(command, stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL,
                            bufsize=0, env=child_environment(), start_new_session=groups,
                            creationflags=0 if groups else getattr(subprocess, "CREATE_NEW_PROCESS_GROUP", 0))


def stop_helper(process: subprocess.Popen) -> None:
    """Kill a start_helper process (with its process group where there is one) and close its pipes."""
    try:
        if process_groups():
            os.killpg(process.pid, 9)
        else:
            process.kill()
    except (ProcessLookupError, PermissionError, OSError):
        pass
    process.wait()
    for stream in (process.stdin, process.stdout):
        try:
            stream.close()
        except OSError:
            pass
