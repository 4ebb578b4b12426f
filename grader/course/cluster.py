"""`grade batch --scheduler`: the batch on a Dask cluster, the coordinator staging and writing, workers grading.

The coordinator (grader.course.batch.run_batch with a ClusterPool) stages each submission into OUT/.staging as the
local pool does and decides which are due (one whose files, grader, seed and settings hash as at its last
grading is not graded again, so a coordinator killed mid-batch resumes with what is missing). Each due
learner's staged files travel in a task keyed by the learner, its content hash and the grader's version. A
worker grades it through the local pool's path (grader.course.workers.grade_staged: the one transaction, bubblewrap, a
resident fork server and every per-learner limit, on the worker's machine) and sends back plain data: the
texts of the learner's files, with the worker's isolation line in its report.json. The coordinator alone
writes into OUT, records the history and builds the class outputs (run_batch), so the outputs are those of a
local batch but for timings and that line.

Nothing lost, nothing twice: a worker process that dies mid-task has its tasks rescheduled by Dask; a result
that arrives twice is recorded once (run_batch); a worker on which learner code cannot run (its sandbox does
not start, or it holds another grader version) answers so for that task, never with a grade, and the task
is tried on another worker.

The cluster is closed to anyone without the course's certificates: scheduler, workers and coordinator connect
over mutual TLS only (grader.course.credentials), so nobody else on the network reaches the scheduler, runs
anything on a worker or hands in a result; a plain `tcp://` cluster is used only where the instructor passes
--insecure-open-cluster, whose name says what it is.

The workers: `grade worker SCHEDULER --certs DIR` (or `dask worker SCHEDULER --preload grader.course.cluster
--nthreads 1` with Dask's TLS options) checks on start that its connections are encrypted, that learner code
starts here behind a barrier (bubblewrap, or as root the dropped uid: never without one, whatever the
coordinator asks) and that this grader is the version of the coordinator using the scheduler (published on it
by each coordinator while it runs), and refuses otherwise. The references and keys a worker grades with are
those of the instructor's wheel installed with it: the version check proves they are the coordinator's.

Dask (the [cluster] extra: dask[distributed]) is imported here only, and this module only with --scheduler.
"""

from __future__ import annotations

import os
import socket
import sys
import tempfile
import threading
import time
from collections.abc import Callable, Iterator, Mapping
from pathlib import Path

from grader.course import workers
from grader.course.staging import StagingError

VERSION_KEY = ["jacobians-grader", "coordinator-version"]  # scheduler metadata: the running coordinator's grader
TRIES = 3  # workers a learner is tried on, where learner code cannot run on one
INSTALL_HINT = "pip install 'jacobians-grader[cluster]' (Dask's distributed scheduler)"
WORKER_SANDBOX = "barrier"  # how learner code runs on every worker (grader.boundary.SandboxMode), whatever is asked
# `grade worker --insecure-open-cluster`: its processes accept a cluster without TLS (their own start check)
OPEN_CLUSTER = "GRADER_INSECURE_OPEN_CLUSTER"
OPEN_OPTION = "--insecure-open-cluster"
SECURE_SCHEMES = ("tls", "wss", "gateway")  # Dask's encrypted comms; Dask Gateway's, TLS through its proxy


def open_cluster_refused(address: str, open_cluster: bool) -> str:
    """Why `address` is refused ("" where it is not): a scheduler reached without TLS accepts anyone who reaches
    its port, unless the instructor says the cluster is open (OPEN_OPTION)."""
    scheme = address.split("://", 1)[0] if "://" in address else "tcp"
    if scheme in SECURE_SCHEMES or open_cluster:
        return ""
    return (f"{address} is a cluster without TLS: anyone who reaches its port could run code on every worker, read "
            "the references and the course seed there and rewrite any grade. Make the course's certificates "
            "(`grade cluster certs DIR`), start the scheduler with them (`grade cluster scheduler --certs DIR`) and "
            f"use its tls:// address with --certs DIR; or pass {OPEN_OPTION} where nobody else reaches that network")


class ClusterError(workers.InfrastructureError):
    """The cluster cannot grade (no scheduler answers, no worker joins, or none can run learner code): nobody is
    graded; the message says why and what to do."""


class WorkerRefused(RuntimeError):
    """This machine cannot be a grading worker (learner code does not start behind the sandbox, or its grader is
    not the coordinator's version): the message says why."""


def distributed_module():
    """dask.distributed, or ClusterError saying how to install it."""
    try:
        import distributed
    except ImportError:
        raise ClusterError(f"grading on a cluster needs Dask: {INSTALL_HINT}") from None
    return distributed


def grader_version() -> str:
    """The version of this grader: the hash of its checks, references and keys on the instructor's side."""
    from grader import provenance

    return provenance.grader_version()


# ------------------------------------------------------------------------------------ the worker's side

_lock = threading.Lock()  # one learner at a time per worker process: its resident fork server serves one session
_started: dict[str, str] = {}  # sandbox mode -> this process's isolation line, proved when it started
_start_method: list[str] = []  # multiprocessing's start method as Dask left it in this process, once put back


def _as_a_local_worker() -> None:
    """Let this worker process choose its launcher as a local pool's worker does. Dask's nanny spawned it, so
    multiprocessing's start method reads "spawn" here, which grader.system.fork_is_safe takes for a system where
    a process holding numpy must not fork (macOS): learner code would start in a fresh interpreter per learner
    instead of from the resident fork server. The platform's own default is put back (still "spawn" on macOS)."""
    import multiprocessing

    if not _start_method:
        _start_method.append(multiprocessing.get_start_method(allow_none=True) or "default")
        multiprocessing.set_start_method(None, force=True)


def sandbox_check() -> str:
    """The isolation line of learner code on this worker (behind WORKER_SANDBOX), after one child interpreter
    started the way tasks will start theirs; WorkerRefused with the reason where it does not."""
    _as_a_local_worker()
    if WORKER_SANDBOX not in _started:
        try:
            _started[WORKER_SANDBOX] = workers.probe(WORKER_SANDBOX, tuple(_credentials))
        except workers.InfrastructureError as exc:
            raise WorkerRefused(f"learner code cannot run on {socket.gethostname()} behind a barrier: {exc}. Install "
                                "bubblewrap (`bwrap --version` must work, with user namespaces), or run the worker as "
                                "root with a user grader-learner of its own (learner code then runs as that user): a "
                                "worker never runs learner code without one") from None
    return _started[WORKER_SANDBOX]


def version_check(published: str | None) -> None:
    """WorkerRefused where a coordinator's grader version is published and is not this grader's."""
    mine = grader_version()
    if published and published != mine:
        raise WorkerRefused(f"this worker's grader is {mine}, the coordinator's is {published}: install the "
                            f"instructor's wheel of {published} here (the same checks, references and keys), then "
                            "start the worker again (a coordinator publishes its version on the scheduler while it "
                            "runs; one that was killed leaves it there until the next one connects)")


def encryption_check(security) -> None:
    """WorkerRefused where this worker's connections are not all encrypted with the course's certificates (Dask's
    require-encryption and a worker certificate), unless it was started for an open cluster (OPEN_CLUSTER)."""
    if os.environ.get(OPEN_CLUSTER) == "1":
        return
    if not (security.require_encryption and security.tls_ca_file and security.tls_worker_cert):
        raise WorkerRefused("this worker's connections are not encrypted (no TLS certificate, or Dask's "
                            "distributed.comm.require-encryption off): start it with `grade worker tls://SCHEDULER:8786 "
                            "--certs DIR` (`grade cluster certs DIR` makes the certificates), or with Dask's TLS "
                            f"options and DASK_DISTRIBUTED__COMM__REQUIRE_ENCRYPTION=True; {OPEN_OPTION} runs it "
                            "without, where nobody else reaches the cluster's network")


_credentials: list[str] = []  # this worker's certificate and key files: learner code must not read them


async def dask_setup(worker) -> None:
    """`dask worker --preload grader.course.cluster`: refuse to start where the worker's connections are not
    encrypted, where learner code cannot run here behind a barrier or where a running coordinator grades with
    another grader version. Dask only logs an exception of a preload and starts the worker all the same, so this
    process ends (status 2), having said why; its nanny then fails to start and `dask worker` ends too. Files this
    worker writes (Dask's spilled task data: learners' files) are its user's only."""
    os.umask(0o077)
    try:
        encryption_check(worker.security)
        _credentials[:] = sorted({str(path) for path in (worker.security.tls_worker_cert, worker.security.tls_worker_key)
                                  if path and "\n" not in str(path)})
        sandbox_check()
        try:
            published = await worker.scheduler.get_metadata(keys=VERSION_KEY, default=None)
        except Exception:  # noqa: BLE001  no scheduler yet: the coordinator checks every worker when it connects
            published = None
        version_check(published)
    except WorkerRefused as exc:
        print(f"grade worker: not started: {exc}", file=sys.stderr, flush=True)
        os._exit(2)


def worker_facts(dask_worker=None) -> dict:
    """What the coordinator checks of each worker when it connects (run there by Client.run): its grader version,
    and its isolation line or why learner code cannot run there."""
    facts = {"version": grader_version(), "host": socket.gethostname(), "pid": os.getpid()}
    try:
        facts["isolation"] = sandbox_check()
    except WorkerRefused as exc:
        facts["problem"] = str(exc)
    return facts


def grade_task(staged: workers.Staged, files: Mapping[str, bytes], grading: workers.Grading, version: str) -> dict:
    """One learner graded on this worker, from its staged `files` (relative path -> bytes), copied into a private
    folder of this machine, behind WORKER_SANDBOX whatever `grading` asks; returns plain data:
    {"graded": grader.course.workers.Outcome, "worker": its address}, or {"refused": why, "worker": ...} where this
    worker holds another grader `version` or learner code cannot run here (an infrastructure failure, never a
    grade: the coordinator tries another worker)."""
    import dataclasses

    from distributed import get_worker

    worker = get_worker().address
    mine = grader_version()
    if mine != version:
        return {"refused": f"worker {worker} holds grader {mine}, not the coordinator's {version}", "worker": worker}
    grading = dataclasses.replace(grading, sandbox=WORKER_SANDBOX)
    with _lock:
        _as_a_local_worker()
        try:
            line = workers.worker_isolation(WORKER_SANDBOX, tuple(_credentials))
        except workers.InfrastructureError as exc:
            return {"refused": f"learner code cannot run on worker {worker}: {exc}", "worker": worker}
        with tempfile.TemporaryDirectory(prefix="grade-task-") as scratch:
            package = Path(scratch) / "exercises"
            for relative, data in files.items():
                parts = Path(relative).parts
                if Path(relative).is_absolute() or ".." in parts or not parts:
                    continue  # staging never names such a file
                path = package.joinpath(*parts)
                path.parent.mkdir(parents=True, exist_ok=True)
                path.write_bytes(data)
            try:
                graded = workers.grade_staged(staged, grading, root=Path(scratch),
                                              extra={"isolation": {"line": line, "worker": worker}},
                                              secrets=tuple(_credentials))
            except (OSError, workers.InfrastructureError) as exc:  # no child process starts here at all
                return {"refused": f"learner code cannot run on worker {worker}: {exc}", "worker": worker}
    return {"graded": graded, "worker": worker}


def task_key(staged: workers.Staged, version: str, attempt: int = 1) -> str:
    """The task's key: the learner, its content hash and the grader version (two coordinators asking for one
    grading at once share one task), and the try where learner code could not run on the worker of the last."""
    import hashlib

    digest = hashlib.sha256(f"{staged.learner}\0{staged.digest}\0{version}".encode("utf-8", "surrogatepass"))
    return f"grade-{digest.hexdigest()[:32]}" + (f"-try{attempt}" if attempt > 1 else "")


def worker_command(scheduler: str, nworkers: int | None = None, dask_options: tuple[str, ...] = (),
                   certs: Path | None = None) -> list[str]:
    """The `dask worker` command `grade worker` becomes: worker processes of one thread each (a learner at a
    time, behind the process's resident barrier), each checking itself on start (the preload, dask_setup), with
    the worker's certificate from `certs` (grader.course.credentials) and no dashboard."""
    from grader.course import credentials

    tls = credentials.dask_options(certs, "worker") if certs is not None else []
    return [sys.executable, "-m", "distributed.cli.dask_worker", scheduler, "--preload", "grader.course.cluster",
            "--nthreads", "1", "--nworkers", str(nworkers or os.cpu_count() or 1), "--no-dashboard", *tls,
            *dask_options]


def worker_environment(certs: Path | None, open_cluster: bool) -> dict[str, str]:
    """What `grade worker` adds to its worker processes' environment: Dask's require-encryption where the cluster
    has certificates, or OPEN_CLUSTER where the instructor opened it."""
    from grader.course import credentials

    if certs is not None:
        return credentials.require_encryption_environment()
    return {OPEN_CLUSTER: "1"} if open_cluster else {}


def prepare_worker(scheduler: str, certs: Path | None = None, open_cluster: bool = False) -> str:
    """The checks `grade worker` makes before it joins `scheduler`: Dask installed, the connection encrypted with the
    course's certificates in `certs` (unless `open_cluster`), learner code starting here behind a barrier, and
    this grader the version of a coordinator running there. Returns the isolation line; WorkerRefused with the
    reason otherwise."""
    from grader.course import credentials

    try:
        distributed = distributed_module()
    except ClusterError as exc:
        raise WorkerRefused(str(exc)) from None
    refused = open_cluster_refused(scheduler, open_cluster)
    if refused:
        raise WorkerRefused(refused)
    if certs is None and not open_cluster:
        raise WorkerRefused(f"{scheduler} needs the course's certificates: pass --certs DIR (`grade cluster certs DIR` "
                            "makes them; this machine needs ca.pem and worker.pem)")
    try:
        security = credentials.security(certs, "worker", client="worker") if certs is not None else None
    except credentials.CredentialsError as exc:
        raise WorkerRefused(str(exc)) from None
    if security is not None:
        _credentials[:] = [str(credentials.role_file(Path(certs).expanduser(), "worker"))]
    line = sandbox_check()
    try:
        with distributed.Client(scheduler, security=security, set_as_default=False) as client:  # Dask's timeout
            published = client.get_metadata(VERSION_KEY, default=None)
    except Exception as exc:  # noqa: BLE001  refused, unreachable or misconfigured: Dask's own words say which
        raise WorkerRefused(f"no Dask scheduler answers at {scheduler} ({exc}); start it (`grade cluster scheduler "
                            "--certs DIR`) or correct the address") from None
    version_check(published)
    return line


def become(command: list[str], environment: Mapping[str, str] = {}) -> None:  # noqa: B006
    """Replace this process with `command` (its signals, its exit status), `environment` added to its own; where
    that is not possible, run it. Files it writes are its user's only."""
    env = {**os.environ, **environment}
    if hasattr(os, "umask"):
        os.umask(0o077)
    if hasattr(os, "execve"):
        os.execve(command[0], command, env)
    import subprocess

    sys.exit(subprocess.call(command, env=env))


# ------------------------------------------------------------------------------------ the coordinator's side

class ClusterPool:
    """The pool run_batch grades through on a Dask cluster (see grader.course.workers.LocalPool): connected to the
    scheduler at `scheduler` with `security` (a distributed.Security with the coordinator's certificate:
    grader.course.credentials.security), or through `client`, a distributed.Client made elsewhere (e.g. by Dask
    Gateway). A connection without TLS is refused unless `open_cluster`. `say` is given what the instructor should
    read as it happens (a worker that cannot grade)."""

    def __init__(self, scheduler: str | None = None, *, client=None, security=None, open_cluster: bool = False,
                 say: Callable[[str], None] | None = None, wait_for_workers: float = 60.0) -> None:
        if scheduler is None and client is None:
            raise ValueError("a scheduler address or a client")
        self.scheduler = scheduler
        self.client = client
        self.security = security
        self.open_cluster = open_cluster
        self.say = say or (lambda line: None)
        self.wait_for_workers = wait_for_workers
        self.version = grader_version()
        self.good: list[str] = []  # the workers that checked out when the batch started
        self.unable: set[str] = set()  # the workers that cannot grade: never sent a learner
        self._own_client = client is None

    def _connect(self):
        distributed = distributed_module()
        if self.client is None:
            refused = open_cluster_refused(self.scheduler, self.open_cluster)
            if refused:
                raise ClusterError(refused)
            security = self.security
            if security is None and not self.open_cluster:
                security = distributed.Security()  # Dask's own TLS settings, where its configuration has them
                if not (security.tls_ca_file and security.tls_client_cert):
                    raise ClusterError(f"{self.scheduler} needs the course's certificates: pass --certs DIR (`grade "
                                       "cluster certs DIR` makes them; the coordinator needs ca.pem and "
                                       "coordinator.pem), or set Dask's distributed.comm.tls options")
            try:
                self.client = distributed.Client(self.scheduler, security=security, set_as_default=False)
            except Exception as exc:  # noqa: BLE001  refused, unreachable or misconfigured: Dask's own words say which
                raise ClusterError(f"no Dask scheduler answers at {self.scheduler} ({exc}); start it (`grade cluster "
                                   "scheduler --certs DIR`, dask-jobqueue, dask-kubernetes or Dask Gateway) or correct "
                                   "--scheduler and --certs") from None
        else:
            refused = open_cluster_refused(self.client.scheduler.address, self.open_cluster)
            if refused:
                raise ClusterError(refused)
        return self.client

    @property
    def where(self) -> str:
        """The scheduler's address, for messages."""
        return self.scheduler or self.client.scheduler.address

    def isolation(self, sandbox: str) -> str:
        """Connect, publish this coordinator's grader version for the workers that join later, wait for a worker,
        and check every worker: its grader version must be this one and learner code must start there behind a
        barrier. Returns the workers' isolation line; ClusterError where no worker can grade, or where the batch
        asks (`sandbox` "off") to grade without a barrier (a cluster never does)."""
        if sandbox == "off":
            raise ClusterError("a cluster grades learner code only behind a barrier (bubblewrap on each worker, or as "
                               "root an unprivileged user of its own): drop --no-sandbox")
        client = self._connect()
        try:
            return self._check_workers(client)
        except BaseException:
            self.close()
            raise

    def _check_workers(self, client) -> str:
        client.set_metadata(VERSION_KEY, self.version)
        try:
            client.wait_for_workers(1, timeout=self.wait_for_workers)
        except TimeoutError:
            raise ClusterError(f"no worker joined the scheduler at {self.where} within {self.wait_for_workers:g} s; "
                               f"start workers with `grade worker {self.where}`") from None
        facts = client.run(worker_facts, on_error="return")
        lines: dict[str, list[str]] = {}
        refused = []
        for address, fact in sorted(facts.items()):
            if isinstance(fact, BaseException) or fact["version"] != self.version or "problem" in fact:
                self.unable.add(address)
            if isinstance(fact, BaseException):
                refused.append(f"{address}: did not answer ({type(fact).__name__}: {fact})")
            elif fact["version"] != self.version:
                refused.append(f"{address} ({fact['host']}): holds grader {fact['version']}, not this coordinator's "
                               f"{self.version}; install the instructor's wheel there")
            elif "problem" in fact:
                refused.append(f"{address}: {fact['problem']}")
            else:
                lines.setdefault(fact["isolation"], []).append(address)
        self.good = sorted(address for addresses in lines.values() for address in addresses)
        if not self.good:
            raise ClusterError(f"no worker of the scheduler at {self.where} can grade: " + "; ".join(refused))
        for why in refused:
            self.say(f"a worker that cannot grade (the learners sent to it are graded by another): {why}")
        if len(lines) == 1:
            return next(iter(lines))
        return "; ".join(f"on {', '.join(addresses)}: {line}" for line, addresses in sorted(lines.items()))

    def grade(self, entries: list, out: Path, grading: workers.Grading, overrides: Mapping[str, tuple],
              previous: Mapping[str, str] = {}, force: bool = False) -> Iterator[workers.Outcome]:  # noqa: B006
        """Stage each learner here, send the due ones to the workers (a bounded number in flight, so that memory
        does not grow with the class) and yield each learner's outcome as it completes."""
        try:
            yield from self._grade(entries, out, grading, overrides, previous, force)
        finally:
            self.close()

    def _grade(self, entries: list, out: Path, grading: workers.Grading, overrides: Mapping[str, tuple],
               previous: Mapping[str, str], force: bool) -> Iterator[workers.Outcome]:
        distributed = distributed_module()
        client = self.client or self._connect()
        flying: dict = {}  # future -> (staged, its files, attempt, the workers it could not run on)
        completed = distributed.as_completed(loop=client.loop)
        waiting = iter(entries)
        told: set[str] = set()  # the workers said to have failed a learner
        limit, counted = 8, 0.0

        def in_flight() -> int:
            """Tasks to keep sent: four per worker thread now (workers join and leave: an adaptive cluster)."""
            nonlocal limit, counted
            if time.monotonic() - counted > 2:
                limit, counted = max(8, 4 * sum(client.nthreads().values())), time.monotonic()
            return limit

        def send(staged: workers.Staged, files: dict, attempt: int, avoid: tuple[str, ...]) -> bool:
            """Send `staged` to a worker that is neither unable to grade nor in `avoid` (a strict restriction: an
            idle worker that cannot grade would otherwise take it back); False where no such worker is left."""
            others = None
            if self.unable or avoid:
                others = [w for w in client.scheduler_info(n_workers=-1)["workers"]
                          if w not in self.unable and w not in avoid]
                if not others:
                    return False
            future = client.submit(grade_task, staged, files, grading, self.version, key=task_key(staged, self.version,
                                                                                                   attempt),
                                   workers=others, allow_other_workers=False)
            flying[future] = (staged, files, attempt, avoid)
            completed.add(future)
            return True

        def unsent(staged: workers.Staged, attempt: int, why: str) -> workers.Outcome:
            tried = f", on {attempt} worker{'s' * (attempt != 1)}," if attempt else ""
            return workers.Outcome(staged.learner, "error", f"not graded{tried} for a reason outside the learner's "
                                   f"code: {why}; the next run grades it again", staged, infrastructure=why)

        no_worker = "no worker that can grade is left on the cluster"

        try:
            while True:
                while len(flying) < in_flight():
                    entry = next(waiting, None)
                    if entry is None:
                        break
                    staged = entry if isinstance(entry, workers.Staged) else workers.stage_one(
                        entry, out, grading, tuple(overrides.get(entry.learner, ())), previous.get(entry.learner), force)
                    if isinstance(staged, workers.Outcome):
                        yield staged
                        continue
                    try:
                        files = staged.files()
                    except StagingError as exc:  # its record gone meanwhile: this learner alone is not graded
                        yield workers.Outcome(staged.learner, "error", f"{exc}; the next run grades it again", staged)
                        continue
                    if not send(staged, files, 1, ()):
                        yield unsent(staged, 0, no_worker)
                if not flying:
                    return
                future = next(completed)
                staged, files, attempt, avoid = flying.pop(future)
                try:
                    outcome = future.result()
                except Exception as exc:  # noqa: BLE001  a lost task is that learner's error, never the batch's
                    yield workers.Outcome(staged.learner, "error", f"not graded on the cluster ({type(exc).__name__}: "
                                                                 f"{exc}); the next run grades it again", staged)
                    continue
                finally:
                    future.release()
                graded = outcome.get("graded")
                why = outcome.get("refused") or (graded.infrastructure if graded else "")
                if why and outcome["worker"] not in told:
                    told.add(outcome["worker"])
                    self.say(f"{why}; its learners are graded on other workers")
                if outcome.get("refused"):
                    self.unable.add(outcome["worker"])
                if why and attempt < TRIES:
                    if send(staged, files, attempt + 1, (*avoid, outcome["worker"])):
                        continue
                    why = f"{why}; {no_worker}"
                yield graded if graded is not None else unsent(staged, attempt, why)
        finally:
            for future in flying:
                future.release()

    def close(self) -> None:
        """Withdraw this coordinator's version from the scheduler and disconnect (a client made elsewhere stays)."""
        if self.client is None:
            return
        try:
            self.client.set_metadata(VERSION_KEY, None)
        except Exception:  # noqa: BLE001,S110  the scheduler may be gone already; nothing is left to withdraw
            pass
        if self._own_client:
            self.client.close()
            self.client = None

