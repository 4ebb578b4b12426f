"""A judge kept warm between one learner's runs of `grade`: the checks a changed function needs judged without
numpy's import in the command's own process.

A learner edits a function and runs `grade ch06` again. The chapter's other checks keep their verdicts
(grader.core.memo), but the changed function's checks are judged afresh, and judging needs numpy and the checks:
imported, they cost the command more than the learner's child it waits on. So a one-off `grade` that judged in
its own process (numpy and the checks imported) forks, as it ends, a copy of itself that waits on a Unix socket in
the user's cache folder for the next command's checks (`linger`); the next command sends it the checks to plan,
the kept calls and what the child answered, and gets their verdicts back (`judge`), as plain data (JSON lines).

The judge runs the grader's code only: a copy of the grader made after grading, given plain data. What keeps
anyone else from it is the user: the socket is the user's own (0600, in the user's cache folder) and each end checks
that the other runs as the same user. Like the memo's, a judge is used only where learner code cannot reach this
user's files (the sandbox or a dropped uid), so it is exactly as safe as the user's cache folder. The two ends also
tell each other their grader's stamp (grader.core.memo: its files, the interpreter, numpy), which keeps a judge of
another grader or of older files from answering (it is no proof of anything: any process of the user could say
it). A judge ends after IDLE_SECONDS in which no command greeted it, when its socket is removed or taken by a
newer judge, or when a command of another grader greets it. Where none answers, or it fails, the command judges
in its own process: the judge decides speed, never a verdict. It is kept where forking a process that has numpy
loaded is safe (grader.system.forkable_now) and a socket's peer can be known; GRADER_WARM_JUDGE=off turns it off.
"""

from __future__ import annotations

import json
import os
import sys
import time

TYPE_CHECKING = False  # typing's own import is not needed here (mypy reads this one too)
if TYPE_CHECKING:
    import socket

    from grader.model import ChapterResult, CheckResult

SETTING = "GRADER_WARM_JUDGE"
IDLE_SECONDS = 600.0  # a judge no command greeted for this long ends
CHECK_SECONDS = 2.0  # how often a waiting judge looks whether its socket is still its own
HELLO_SECONDS = 0.5  # the most a command waits for a judge's greeting (one busy with another command gives none)
ANSWER_SECONDS = 30.0  # the most a command waits for one answer before it judges itself
QUESTION_SECONDS = 300.0  # the most a judge waits for a greeted command's next question (its child may run long)

_client: list = []  # this command's connection to a judge: [[socket, reader]], or [None] once none answered
_served = False  # a judge answered this command (then it is still warm: nothing to fork)
_wanted: list[str] = []  # the grader stamp of this command's memo: a judge of it may be kept warm (`linger`)


def wanted(stamp: str) -> None:
    """Say that this command grades one learner with the memo of grader `stamp` (walled off from learner code): a
    judge of that grader may answer it, and be kept warm as it ends."""
    if not _wanted:
        _wanted.append(stamp)


def _socket_path() -> str | None:
    from grader.system import cache_folder

    folder = cache_folder("launch")
    return None if folder is None else os.path.join(folder, "judge")


def enabled() -> bool:
    """Whether a warm judge may be used and kept here: not turned off, and Unix sockets whose peer is known."""
    if os.environ.get(SETTING, "on") == "off":
        return False
    import socket

    return hasattr(socket, "AF_UNIX") and hasattr(socket, "SO_PEERCRED")


def _peer_uid(connection: socket.socket) -> int:
    import socket
    import struct

    credentials = connection.getsockopt(socket.SOL_SOCKET, socket.SO_PEERCRED, struct.calcsize("3i"))
    return struct.unpack("3i", credentials)[1]


def _send(connection: socket.socket, message: dict) -> None:
    connection.sendall((json.dumps(message) + "\n").encode("utf-8"))


def _connection(stamp: str) -> list | None:
    """This command's connection to the warm judge of grader `stamp` ([socket, reader]), or None."""
    if _client:
        return _client[0]
    _client.append(None)
    path = _socket_path()
    if not enabled() or path is None or not os.path.exists(path):
        return None
    import socket

    connection = None
    try:
        connection = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        connection.settimeout(HELLO_SECONDS)
        connection.connect(path)
        if _peer_uid(connection) != os.getuid():
            raise OSError("the judge's socket is another user's")
        reader = connection.makefile("rb")
        _send(connection, {"stamp": stamp})
        hello = json.loads(reader.readline() or b"null")
        if not isinstance(hello, dict) or hello.get("stamp") != stamp:
            raise OSError("a judge of another grader")
        connection.settimeout(ANSWER_SECONDS)
    except (OSError, ValueError):
        if connection is not None:
            connection.close()
        return None
    _client[0] = [connection, reader]
    return _client[0]


def release() -> None:
    """Let this command's connection go (the judge answers one command at a time): a process that grades again, as
    --watch does, asks afresh."""
    held = _client[0] if _client else None
    _client.clear()
    if held is not None:
        held[0].close()


def available(stamp: str) -> bool:
    """Whether a warm judge of grader `stamp` answers this command (connected now, for the questions to come)."""
    return _connection(stamp) is not None


def _ask(stamp: str, question: dict) -> dict | None:
    """The warm judge's answer to `question`; None where none answers (the connection is then let go: a judge that
    answered nothing readable is not asked again by this command)."""
    global _served
    held = _connection(stamp)
    if held is None:
        return None
    connection, reader = held
    try:
        _send(connection, question)
        reply = json.loads(reader.readline() or b"null")
    except (OSError, ValueError, TypeError):
        reply = None
    if not isinstance(reply, dict):
        _client[0] = None
        connection.close()
        return None
    _served = True
    return reply


def judge(stamp: str, chapter_id: str, seed: int, exclude: frozenset[str], slots: dict[str, list[int]],
          calls: dict[int, dict], results: dict, module_file: str) -> tuple[list[CheckResult], dict] | None:
    """grader.core.planning.judge_checks, answered by the warm judge of grader `stamp`: (the CheckResults of exactly
    the checks of `slots`, in their order; the helpers each check's calls entered), or None where no judge answers
    or it cannot say (then the command judges)."""
    reply = _ask(stamp, {"judge": [chapter_id, seed, sorted(exclude), slots, {str(i): c for i, c in calls.items()},
                                   {str(i): None if r is None else r.to_plain() for i, r in results.items()},
                                   module_file]})
    if reply is None or not isinstance(reply.get("checks"), list):
        return None
    from grader.model import ChapterResult

    try:
        checks = ChapterResult.from_dict({"chapter": chapter_id, "checks": reply["checks"]}).checks
        entered = {str(c): [str(h) for h in helpers] for c, helpers in dict(reply["entered"]).items()}
    except (KeyError, TypeError, ValueError):
        return None
    return (checks, entered) if [c.id for c in checks] == list(slots) else None


def judge_not_imported(stamp: str, chapter_id: str, exclude: frozenset[str], import_error: dict,
                       module_file: str) -> ChapterResult | None:
    """grader.core.planning.judge_not_imported, answered by the warm judge of grader `stamp`: the ChapterResult of a
    chapter file that could not be imported, or None where no judge answers (then the command judges)."""
    reply = _ask(stamp, {"not_imported": [chapter_id, sorted(exclude), import_error, module_file]})
    if reply is None or not isinstance(reply.get("chapter"), dict):
        return None
    from grader.model import ChapterResult

    try:
        chapter = ChapterResult.from_dict(reply["chapter"])
    except (KeyError, TypeError, ValueError):
        return None
    return chapter if chapter.chapter == chapter_id else None


def linger() -> None:
    """As a one-off command that judged in its own process ends: fork the warm judge of its grader (`wanted`), unless
    one answered this command, or judging was not imported here, or forking is not safe here now. Call it with
    everything written and flushed."""
    if not _wanted or _served or not enabled() or "grader.core.planning" not in sys.modules:
        return
    stamp = _wanted[0]
    from grader.system import forkable_now

    path = _socket_path()
    if path is None or not forkable_now():
        return
    import socket

    temporary = f"{path}.{os.getpid()}"
    mask = os.umask(0o077)
    listener = None
    try:
        os.makedirs(os.path.dirname(path), exist_ok=True)
        if os.path.lexists(temporary):  # left by a process of this pid that ended before it was put in place
            os.unlink(temporary)
        listener = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        listener.bind(temporary)
        pid = os.fork()
    except OSError:
        if listener is not None:
            listener.close()
            _unlink(temporary)
        return
    finally:
        os.umask(mask)
    if pid == 0:
        try:
            _serve(listener, stamp, temporary, path)
        finally:
            os._exit(0)
    listener.close()


def _unlink(path: str) -> None:
    try:
        os.unlink(path)
    except OSError:
        pass


def _serve(listener: socket.socket, stamp: str, temporary: str, path: str) -> None:
    """The judge: a session of its own (no terminal's signals, no pipe of the command's kept open, no folder of its
    held), listening on `temporary` moved to `path`, answering one command at a time until it is idle too long or
    its socket is no longer its own."""
    from grader.system import keep_only

    os.setsid()
    keep_only(listener.fileno())
    os.chdir("/")
    import gc

    gc.freeze()  # what the command made stays out of the collector's passes
    try:
        listener.listen(4)  # here, so that a command's peer credentials are the judge's
        info = os.stat(temporary)
        mine = (info.st_dev, info.st_ino)  # a rename keeps them: what `path` is while it is this judge's
        os.replace(temporary, path)  # a judge before this one finds its socket taken and ends
    except OSError:
        _unlink(temporary)
        return
    listener.settimeout(CHECK_SECONDS)
    idle_until = time.monotonic() + IDLE_SECONDS
    while time.monotonic() < idle_until:
        try:
            connection, _ = listener.accept()
        except TimeoutError:
            try:
                info = os.stat(path)
            except OSError:
                return
            if (info.st_dev, info.st_ino) != mine:
                return
            continue
        except OSError:
            break
        with connection:
            greeted = _answer(connection, stamp)
        if greeted is False:
            break
        if greeted:
            idle_until = time.monotonic() + IDLE_SECONDS
    try:
        info = os.stat(path)
        if (info.st_dev, info.st_ino) == mine:  # still this judge's: nobody will answer on it
            _unlink(path)
    except OSError:
        pass


def _answer(connection: socket.socket, stamp: str) -> bool | None:
    """Answer one command's questions until it closes: True where a command of this grader greeted it, False where
    one of another grader did (this judge is then stale and ends), None where nobody greeted it."""
    from grader.boundary.wire import Returned
    from grader.core.planning import judge_checks, judge_not_imported
    from grader.model import ChapterResult

    greeted = None
    try:
        connection.settimeout(ANSWER_SECONDS)
        if _peer_uid(connection) != os.getuid():
            return None
        reader = connection.makefile("rb")
        hello = json.loads(reader.readline() or b"null")
        if not isinstance(hello, dict):
            return None
        _send(connection, {"stamp": stamp})
        if hello.get("stamp") != stamp:
            return False
        greeted = True
        connection.settimeout(QUESTION_SECONDS)
        for line in reader:
            reply: dict = {}
            try:
                question = json.loads(line)
                if "not_imported" in question:
                    chapter_id, exclude, import_error, module_file = question["not_imported"]
                    reply = {"chapter": judge_not_imported(chapter_id, frozenset(exclude), import_error,
                                                           module_file).to_kept()}
                else:
                    chapter_id, seed, exclude, slots, calls, answered, module_file = question["judge"]
                    results = {int(i): None if r is None else Returned.from_plain(r) for i, r in answered.items()}
                    judged = judge_checks(chapter_id, seed, frozenset(exclude), slots,
                                          {int(i): c for i, c in calls.items()}, results, module_file)
                    if judged is not None:
                        reply = {"checks": ChapterResult(chapter_id, "", list(judged[0])).to_kept()["checks"],
                                 "entered": judged[1]}
            except Exception:  # noqa: BLE001  the command judges itself, and meets what it raises
                reply = {}
            _send(connection, reply)
    except (OSError, ValueError, TypeError):
        pass
    return greeted
