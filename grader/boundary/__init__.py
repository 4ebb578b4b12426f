"""The learner's boundary: the only way learner code runs, in a child process, never in the grader's.

The one entry, for every face of the grader (`grade chNN`, --watch, batch, the notebook's grading process,
Gradescope, GitHub Classroom):

    boundary = choose(sandbox="auto", resident=False, probe=False)   # decided once, from what the system offers
    session = boundary.open_session(submission, limits)              # a child per session, sandboxed as chosen
    boundary.isolation                                               # the line saying what holds for learner code
    open_session(submission)                                         # the one-off form, for a single command

Inside: door (the decision), session (the parent's side of the protocol), spawn and forkserver (the
launchers), sandbox (bubblewrap), and the child's side (child, confine), with wire, what crosses between
them. Checks import only wire's types. The child imports this package too, so nothing is imported here
until asked for.
"""

from __future__ import annotations

TYPE_CHECKING = False  # not typing's: its import costs the launcher 5 ms before the child starts (mypy reads this)
if TYPE_CHECKING:
    from grader.boundary.door import (
        SANDBOX_MODES,
        Boundary,
        SandboxMode,
        BoundaryUnavailable,
        Launch,
        answer_places,
        choose,
        first_child,
        open_session,
        without_a_sandbox,
    )
    from grader.boundary.session import ChapterRequest, ChapterRun, Limits, Session

__all__ = ["SANDBOX_MODES", "Boundary", "BoundaryUnavailable", "ChapterRequest", "ChapterRun", "Launch", "Limits",
           "SandboxMode", "Session", "answer_places", "bubblewrap_possible", "choose", "first_child",
           "how_to_get_a_barrier", "open_session", "without_a_sandbox"]
_IN_SESSION = ("ChapterRequest", "ChapterRun", "Limits", "Session")  # the others are in door


def __getattr__(name: str):
    if name not in __all__:
        raise AttributeError(f"module 'grader.boundary' has no attribute {name!r}")
    import importlib

    module = "session" if name in _IN_SESSION else "door"
    return getattr(importlib.import_module(f"grader.boundary.{module}"), name)
