"""The learner's child that `grade` starts first (grader.faces.launch), held until the command that grades with it takes
it (grader.faces.cli), or stopped."""

from __future__ import annotations

TYPE_CHECKING = False  # typing's own costs the launcher 5 ms before the child starts (mypy reads this one too)
if TYPE_CHECKING:
    from grader.boundary import Boundary
    from grader.boundary.session import ChildHandle

_held: tuple | None = None  # (the sandbox mode asked, the command prefix it was started with or None, the child)


def hold(sandbox: str, prefix: list[str] | None, child: ChildHandle) -> None:
    """Keep `child`, started for sandbox mode `sandbox` behind `prefix` (a sandbox's command line; None: none),
    for the command about to grade."""
    global _held
    _held = (sandbox, prefix, child)


def take(sandbox: str, boundary: Boundary | None) -> ChildHandle | None:
    """The held child if it was started as `boundary` starts its children for mode `sandbox`; else None (and the
    held child, if any, is stopped). take("", None) stops it."""
    global _held
    held, _held = _held, None
    if held is None:
        return None
    mode, prefix, child = held
    if boundary is not None and mode == sandbox and prefix == boundary.command_prefix():
        return child
    child.stop(0)
    return None
