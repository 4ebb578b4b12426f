"""The learner's child that `grade` starts before its heavy imports (grader.launch), held until the command
that graded with it takes it (grader.cli), or stopped."""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from grader.boundary import Session
    from grader.submission import Submission

_held: tuple | None = None  # (submission, its sandbox mode, the Session around the started child)


def hold(submission: Submission, sandbox: str, session: Session) -> None:
    """Keep `session` (its child already starting) for the command about to grade `submission`."""
    global _held
    _held = (submission, sandbox, session)


def take(submission: Submission | None, sandbox: str = "auto") -> Session | None:
    """The held Session if it serves `submission` sandboxed as `sandbox` asks; else None (and the held child,
    if any, is stopped)."""
    global _held
    held, _held = _held, None
    if held is None:
        return None
    submission_held, mode, session = held
    if submission_held == submission and mode == sandbox:
        return session
    session.close()
    return None
