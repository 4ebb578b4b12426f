"""Emulated systems for tests: run the grader on Linux as Windows or macOS would run it.

No Windows or macOS machine is here, so each route is emulated by taking away, before grader is
imported, what that system's Python lacks (and by making what it has behave as it does there):
- WINDOWS: no fork, process groups, pread, uids, pass_fds/preexec_fn/start_new_session, SIGKILL and
  the other POSIX signals, poll/epoll, Unix sockets, nor the resource/fcntl/pwd/grp/termios modules;
  select() takes sockets only (pipes raise WinError 10038); Popen.kill terminates the one process
  (subprocess keeps its own POSIX internals, e.g. waitpid with WNOHANG, which stand in for Windows').
  Every Python the grader starts with `-c` gets the same treatment (the child, sympy's worker).
- MACOS: multiprocessing starts by "spawn" (fork after numpy is unsafe there) and bubblewrap does
  not exist.
"""

from __future__ import annotations

import sys

WINDOWS = r'''
import os, select, selectors, shutil, signal, socket, stat, subprocess, sys
_kill = os.kill
for _name in ("fork", "forkpty", "killpg", "getpgid", "getpgrp", "setsid", "setpgid", "pread", "pwrite", "geteuid",
              "getuid", "getegid", "getgid", "setuid", "setgid", "getgroups", "sched_getaffinity", "register_at_fork",
              "O_TMPFILE", "pidfd_open", "wait3", "wait4", "getloadavg", "nice"):
    if hasattr(os, _name):
        delattr(os, _name)
for _name in ("SIGKILL", "SIGXFSZ", "SIGSTOP", "SIGALRM", "SIGCHLD", "SIGHUP", "SIGUSR1", "SIGUSR2", "SIGPIPE",
              "SIGQUIT", "setitimer", "getitimer", "alarm", "pthread_kill", "pthread_sigmask", "siginterrupt"):
    if hasattr(signal, _name):
        delattr(signal, _name)
for _name in ("poll", "epoll", "devpoll", "kqueue"):
    if hasattr(select, _name):
        delattr(select, _name)
for _name in ("AF_UNIX", "send_fds", "recv_fds"):
    if hasattr(socket, _name):
        delattr(socket, _name)
for _module in ("resource", "fcntl", "pwd", "grp", "termios", "pty", "tty"):
    sys.modules[_module] = None
_select = select.select
def _sockets_only(r, w, x, *timeout):
    for _f in [*r, *w, *x]:
        if not stat.S_ISSOCK(os.fstat(_f if isinstance(_f, int) else _f.fileno()).st_mode):
            raise OSError(10038, "An operation was attempted on something that is not a socket")
    return _select(r, w, x, *timeout)
select.select = _sockets_only
selectors.SelectSelector._select = staticmethod(_sockets_only)
selectors.DefaultSelector = selectors.SelectSelector
_popen_init = subprocess.Popen.__init__
def _windows_popen(self, args, *more, **options):
    for _key, _unset in (("pass_fds", ()), ("preexec_fn", None), ("start_new_session", False),
                         ("process_group", None), ("user", None), ("group", None), ("umask", -1)):
        if options.get(_key, _unset) not in (_unset, None):
            raise ValueError(f"{_key} is not supported on Windows platforms")
    if isinstance(args, list) and "-c" in args and args[0] == sys.executable:
        _at = args.index("-c") + 1
        args = [*args[:_at], f"EMULATION = {EMULATION!r}\nexec(EMULATION)\n" + args[_at], *args[_at + 1:]]
    _popen_init(self, args, *more, **options)
def _terminate(self, sig=None):
    if self.returncode is None:
        try:
            _kill(self.pid, 9)
        except ProcessLookupError:
            pass
subprocess.Popen.__init__ = _windows_popen
subprocess.Popen.send_signal = _terminate
subprocess.Popen.terminate = subprocess.Popen.kill = _terminate
'''

MACOS = r'''
import multiprocessing, shutil
multiprocessing.set_start_method("spawn", force=True)
_which = shutil.which
shutil.which = lambda name, *a, **k: None if name in ("bwrap", "setpriv") else _which(name, *a, **k)
'''

ROUTES = {"linux": None, "windows": WINDOWS, "macos": MACOS}


def grade_command(route: str, *arguments: str) -> list[str]:
    """A command line running `grade ARGUMENTS...` as it runs on `route` ("linux", "windows", "macos")."""
    emulation = ROUTES[route]
    if emulation is None:
        return [sys.executable, "-m", "grader", *arguments]
    boot = (f"EMULATION = {emulation!r}\nexec(EMULATION)\nimport sys\nsys.argv[0] = 'grade'\n"
            "from grader.cli import main\nmain()\n")
    return [sys.executable, "-c", boot, *arguments]
