"""grade batch on a Dask cluster (--scheduler, grader.course.cluster): a real `dask scheduler` and `grade worker`
processes on 127.0.0.1; nothing lost and nothing twice when a worker or the coordinator is killed; outputs
equal to a local batch's but for timings and the isolation line per learner; workers that refuse to start;
and a batch without --scheduler that never imports Dask.

Every process of a cluster test runs the grader from one copy of its files taken when the module starts
(`code`): the grader's version is a hash of those files, and coordinator and workers must agree on it, as
they do when the instructor's wheel is installed on every machine, while the tree under test may change."""

from __future__ import annotations

import csv
import json
import os
import re
import shutil
import signal
import socket
import sqlite3
import subprocess
import sys
import time
import zipfile
from pathlib import Path

import pytest

from tests.support import FakeBwrap, build_submission, hostile_module, replace_function

REPO = Path(__file__).resolve().parents[2]
CHAPTERS = "ch03,ch05,ch06,ch07"
COUNT = 60
VERSION_KEY = ["jacobians-grader", "coordinator-version"]  # grader.course.cluster.VERSION_KEY, as the scheduler keeps it

distributed = pytest.importorskip("distributed", reason="Dask is not installed here (the [cluster] extra; CI "
                                                        "installs it with the test extras)")

BUGS = [
    ("ch06_measurement", replace_function("ch06_measurement", "H_jacobian",
                                          "def H_jacobian(x, y):\n    r2 = x * x + y * y\n    r = np.sqrt(r2)\n"
                                          "    return np.array([[x / r, y / r], [y / r2, x / r2]])\n")),
    ("ch03_jacobian", replace_function("ch03_jacobian", "polar_to_cartesian_jacobian",
                                       "def polar_to_cartesian_jacobian(r, theta):\n    return np.array([[np.cos(theta), "
                                       "np.sin(theta)], [-r * np.sin(theta), r * np.cos(theta)]])\n")),
    ("ch06_measurement", hostile_module()),
    ("ch05_finite_differences", replace_function("ch05_finite_differences", "best_step",
                                                 "def best_step(f, fprime, x, hs):\n    import os\n    os._exit(3)\n")),
    ("ch07_dynamics", replace_function("ch07_dynamics", "propagate_covariance",
                                       "def propagate_covariance(P, F, Q=None):\n    return 'P'\n")),
]


def make_submissions(folder: Path, count: int) -> Path:
    """`count` learners: right ones and each of BUGS in turn (wrong, hostile, exiting, of the wrong type), every
    third zipped."""
    folder.mkdir(parents=True)
    for i in range(count):
        kind = i % (len(BUGS) + 1)
        replacements = {} if kind == 0 else dict([BUGS[kind - 1]])
        root = build_submission(folder.parent / f"{folder.name}-built" / f"learner{i:03d}", replacements)
        if i % 3 == 2:
            with zipfile.ZipFile(folder / f"learner{i:03d}.zip", "w") as archive:
                for path in sorted((root / "exercises").glob("*.py")):
                    archive.write(path, f"exercises/{path.name}")
        else:
            shutil.copytree(root, folder / root.name)
    return folder


def free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


def make_certs(folder: Path, env: dict) -> Path:
    """The cluster's certificates made by `grade cluster certs`, in `folder`."""
    done = grade(env, "cluster", "certs", folder, cwd=folder.parent)
    assert done.returncode == 0, done.stderr
    return folder


class Cluster:
    """A real Dask scheduler (`grade cluster scheduler`: TLS only) on 127.0.0.1 (a free port) and workers joining it,
    each started in a process group of its own, its output in FOLDER/<name>.log; stop() ends each group (a
    worker's sandboxes die with it). `certs`: the course's certificates (`grade cluster certs`)."""

    def __init__(self, folder: Path, env: dict) -> None:
        self.folder, self.env = folder, env
        self.certs = make_certs(folder / "certs", env)
        self.port = free_port()
        self.address = f"tls://127.0.0.1:{self.port}"
        self.processes: dict[str, subprocess.Popen] = {}
        self.start("scheduler", [sys.executable, "-m", "grader", "cluster", "scheduler", "--certs", str(self.certs),
                                 "--host", "127.0.0.1", "--port", str(self.port), "--no-dashboard"])
        deadline = time.monotonic() + 60
        while True:
            try:
                socket.create_connection(("127.0.0.1", self.port), timeout=1).close()
                break
            except OSError:
                assert time.monotonic() < deadline, self.log("scheduler")
                time.sleep(0.2)

    def start(self, name: str, command: list[str], env: dict | None = None) -> subprocess.Popen:
        with (self.folder / f"{name}.log").open("wb") as log:
            process = subprocess.Popen(command, cwd=self.folder, env=env or self.env, stdout=log,
                                       stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL, start_new_session=True)
        self.processes[name] = process
        return process

    def worker(self, name: str, env: dict | None = None, plain: bool = False) -> subprocess.Popen:
        """`grade worker` (or, `plain`, a `dask worker` without the grader's preload) of one process."""
        options = ["--no-dashboard", "--local-directory", str(self.folder / name)]
        if plain:
            command = ["-m", "distributed.cli.dask_worker", self.address, "--nthreads", "1", "--nworkers", "1",
                       "--tls-ca-file", str(self.certs / "ca.pem"), "--tls-cert", str(self.certs / "worker.pem"),
                       "--tls-key", str(self.certs / "worker.pem")]
        else:
            command = ["-m", "grader", "worker", self.address, "--certs", str(self.certs), "--nworkers", "1"]
        return self.start(name, [sys.executable, *command, *options], env)

    def client(self):
        """A client holding the coordinator's certificate."""
        from grader.course import credentials

        return distributed.Client(self.address, security=credentials.security(self.certs, "coordinator"),
                                  set_as_default=False)

    def wait_for_workers(self, count: int) -> None:
        with self.client() as client:
            client.wait_for_workers(count, timeout=120)

    def log(self, name: str) -> str:
        return (self.folder / f"{name}.log").read_text(encoding="utf-8", errors="replace")[-3000:]

    def stop(self, name: str) -> None:
        process = self.processes.pop(name)
        for sent in (signal.SIGTERM, signal.SIGKILL):
            try:
                os.killpg(process.pid, sent)
            except ProcessLookupError:
                break
            try:
                process.wait(timeout=15)
                break
            except subprocess.TimeoutExpired:
                continue
        process.wait(timeout=15)

    def stop_all(self) -> None:
        for name in [n for n in self.processes if n != "scheduler"] + ["scheduler"]:
            if name in self.processes:
                self.stop(name)


@pytest.fixture(scope="module")
def place(tmp_path_factory):
    """The module's folder: a copy of the grader's files (code/) and the environment running them."""
    folder = tmp_path_factory.mktemp("cluster")
    ignore = shutil.ignore_patterns("__pycache__")
    for name in ("grader", "solutions", "quizzes"):
        shutil.copytree(REPO / name, folder / "code" / name, ignore=ignore)
    env = dict(os.environ, PYTHONPATH=str(folder / "code"))
    for name in ("DASK_SCHEDULER_ADDRESS", "GRADER_SANDBOX"):
        env.pop(name, None)
    return folder, env


@pytest.fixture(scope="module")
def cluster(place):
    folder, env = place
    running = Cluster(folder, env)
    try:
        for name in ("worker-a", "worker-b"):
            running.worker(name)
        running.wait_for_workers(2)
        yield running
    finally:
        running.stop_all()


@pytest.fixture(scope="module")
def graded_here(place):
    """COUNT mixed submissions and their local batch (this machine's pool): (submissions, its OUT)."""
    folder, env = place
    submissions = make_submissions(folder / "submissions", COUNT)
    done = grade(env, "batch", submissions, "--out", folder / "local", "--chapters", CHAPTERS, cwd=folder)
    assert done.returncode == 0, done.stderr[-3000:]
    return submissions, folder / "local"


def grade(env: dict, *args, cwd: Path) -> subprocess.CompletedProcess:
    """`grade ARGS` run in `cwd` (`python -m` puts it first on the path: never the tree under test's root where a
    copy of the grader is to run)."""
    return subprocess.run([sys.executable, "-m", "grader", *map(str, args)], env=env, cwd=cwd, capture_output=True,
                          text=True, encoding="utf-8", timeout=1200, check=False)


def start_grade(env: dict, folder: Path, *args) -> subprocess.Popen:
    with (folder / "coordinator.log").open("wb") as log:
        return subprocess.Popen([sys.executable, "-m", "grader", *map(str, args)], env=env, cwd=folder, stdout=log,
                                stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL, start_new_session=True)


def reports(out: Path) -> dict[str, Path]:
    return {path.parent.name: path for path in out.glob("*/report.json")}


def wait_for_reports(out: Path, count: int, process: subprocess.Popen) -> None:
    deadline = time.monotonic() + 600
    while len(reports(out)) < count:
        assert process.poll() is None, "the batch ended before it was stopped"
        assert time.monotonic() < deadline
        time.sleep(0.1)


def comparable(path: Path) -> str:
    """A learner's file as text, the number of its sandboxed folder put aside: a fork server's child gets its files
    in /tmp/grade-run-N, N counting the children that server forked before, so what learner code prints about its
    own files (a warning's file and line) names an N that depends on which worker graded whom, in a local batch
    as much as on a cluster."""
    return re.sub(r"/tmp/grade-run-[0-9]+/", "/tmp/grade-run-N/", path.read_text(encoding="utf-8"))


def without_timing(text: str) -> str:
    """report.json's text without its seconds and the isolation line of a learner graded on a cluster."""
    text = re.sub(r'"seconds": [0-9.e-]+', '"seconds": 0', text)
    return re.sub(r', "isolation": \{"line": "(?:[^"\\]|\\.)*", "worker": "[^"]*"\}', "", text)


def assert_same_outputs(local: Path, out: Path, isolation: str) -> None:
    """`out` holds what the local batch wrote, byte for byte but for timings and each learner's isolation line."""
    assert (out / "gradebook.csv").read_bytes() == (local / "gradebook.csv").read_bytes()
    assert (out / "summary.json").read_bytes() == (local / "summary.json").read_bytes()
    assert (out / "changes.csv").read_bytes() == (local / "changes.csv").read_bytes()
    assert sorted(reports(out)) == sorted(reports(local))
    for learner in reports(local):
        assert without_timing(comparable(out / learner / "report.json")) == without_timing(
            comparable(local / learner / "report.json")), learner
        here, there = (json.loads((folder / learner / "report.json").read_text(encoding="utf-8")) for folder in
                       (local, out))
        assert list(there["batch"]) == list(here["batch"]) + ["isolation"]
        assert there["batch"]["isolation"]["line"] == isolation
        assert re.fullmatch(r"tls://127\.0\.0\.1:[0-9]+", there["batch"]["isolation"]["worker"])
        assert comparable(out / learner / "report.html") == comparable(local / learner / "report.html")
        results = [json.loads(comparable(folder / learner / "results.json")) for folder in (out, local)]
        for data in results:
            data.pop("execution_time")
        assert results[0] == results[1]


def history(out: Path) -> list[tuple[str, str, int]]:
    """(learner, status, how many rows) of the last run in OUT/gradebook.db."""
    with sqlite3.connect(out / "gradebook.db") as db:
        return db.execute("SELECT learner, status, count(*) FROM results WHERE run = (SELECT max(id) FROM runs) "
                          "GROUP BY learner ORDER BY learner").fetchall()


def gradebook_learners(out: Path) -> list[str]:
    with (out / "gradebook.csv").open(newline="", encoding="utf-8") as handle:
        return [row["learner"] for row in csv.DictReader(handle)]


# ------------------------------------------------------------------------------------ on a real cluster

@pytest.mark.slow
def test_a_worker_killed_mid_task_loses_nobody_and_the_outputs_are_a_local_batchs(place, cluster, graded_here):
    """60 mixed learners graded through --scheduler on two `grade worker` processes; the process of one, while it
    grades a learner, is killed with SIGKILL (its nanny starts it again): every learner is graded exactly once,
    and the gradebook, reports and summary are the local batch's."""
    folder, env = place
    submissions, local = graded_here
    out = folder / "on-the-cluster"
    coordinator = start_grade(env, folder, "batch", submissions, "--out", out, "--chapters", CHAPTERS,
                              "--scheduler", cluster.address, "--certs", cluster.certs)

    def grading(dask_worker) -> tuple[int, list[str]]:
        return os.getpid(), [str(task.key) for task in dask_worker.state.executing]

    try:
        wait_for_reports(out, COUNT // 4, coordinator)
        with cluster.client() as client:
            before = client.run(grading)
            while True:
                found = [(address, pid) for address, (pid, keys) in client.run(grading).items()
                         if any(key.startswith("grade-") for key in keys)]
                if found:
                    break
                assert coordinator.poll() is None, "the batch ended before a worker could be killed"
                time.sleep(0.05)
            killed, pid = found[0]
            os.kill(pid, signal.SIGKILL)
            graded_at_kill = len(reports(out))
            assert coordinator.wait(timeout=1200) == 0, (folder / "coordinator.log").read_text(encoding="utf-8")
            cluster.wait_for_workers(2)
            after = client.run(grading)
    finally:
        if coordinator.poll() is None:
            os.killpg(coordinator.pid, signal.SIGKILL)
    said = (folder / "coordinator.log").read_text(encoding="utf-8")
    assert graded_at_kill < COUNT
    assert f"{COUNT} submissions: {COUNT} graded;" in said
    assert killed not in after and len(after) == 2  # the nanny started a new worker process
    assert pid not in {process for process, _ in after.values()} and killed in before
    learners = sorted(path.name for path in submissions.iterdir())
    learners = sorted(name.removesuffix(".zip") for name in learners)
    assert history(out) == [(learner, "graded", 1) for learner in learners]
    assert sorted(gradebook_learners(out)) == learners
    isolation = json.loads((local / "summary.json").read_text(encoding="utf-8"))["isolation"]
    assert_same_outputs(local, out, isolation)
    jsonschema = pytest.importorskip("jsonschema")
    from referencing import Registry, Resource

    from grader.render import lms

    registry = Registry().with_resources((lms.schema(n)["$id"], Resource.from_contents(lms.schema(n)))
                                         for n in lms.SCHEMAS)
    validator = jsonschema.Draft202012Validator(lms.schema("batch-report"), registry=registry)
    for path in reports(out).values():
        validator.validate(json.loads(path.read_text(encoding="utf-8")))


@pytest.mark.slow
def test_a_killed_coordinator_resumes_grading_only_what_is_missing(place, cluster, graded_here):
    """The coordinator killed with SIGKILL mid-batch: run again, it grades only the learners without a finished
    report (the others are unchanged, their files untouched), and the outputs are the local batch's."""
    folder, env = place
    submissions, local = graded_here
    out = folder / "resumed"
    coordinator = start_grade(env, folder, "batch", submissions, "--out", out, "--chapters", CHAPTERS,
                              "--scheduler", cluster.address, "--certs", cluster.certs)
    try:
        wait_for_reports(out, COUNT // 3, coordinator)
    finally:
        os.killpg(coordinator.pid, signal.SIGKILL)
        coordinator.wait(timeout=30)
    finished = {learner: path.stat().st_mtime_ns for learner, path in reports(out).items()
                if "hash" in json.loads(path.read_text(encoding="utf-8"))["batch"]}
    assert COUNT // 3 <= len(finished) < COUNT
    done = grade(env, "batch", submissions, "--out", out, "--chapters", CHAPTERS, "--scheduler", cluster.address,
                 "--certs", cluster.certs, cwd=folder)
    assert done.returncode == 0, done.stderr[-3000:]
    assert (f"{COUNT} submissions: {COUNT - len(finished)} graded, {len(finished)} unchanged; "
            f"graded {COUNT - len(finished)} in") in done.stdout
    assert {learner: reports(out)[learner].stat().st_mtime_ns for learner in finished} == finished
    assert [row[1:] for row in history(out)] == [("graded", 1)] * COUNT
    isolation = json.loads((local / "summary.json").read_text(encoding="utf-8"))["isolation"]
    assert_same_outputs(local, out, isolation)


@pytest.mark.slow
@pytest.mark.parametrize("first_failure", [1, 2], ids=["at-the-start-check", "while-grading"])
def test_a_worker_whose_sandbox_cannot_start_never_grades_and_its_learners_are_graded_elsewhere(place, cluster,
                                                                                             graded_here,
                                                                                             first_failure):
    """A `dask worker` (without the grader's start checks) whose bubblewrap fails joins the cluster: where it fails
    the coordinator's start check, no learner is sent to it; where it fails only once grading began, the learner it
    failed is graded on another worker and it is sent no other. Either way the coordinator says it cannot grade and
    no report names it."""
    folder, env = place
    here = folder / f"broken-from-call-{first_failure}"
    broken = FakeBwrap(here / "bwrap", failing=range(first_failure, 10000))
    cluster.worker("broken", env={**env, "PATH": broken.env["PATH"]}, plain=True)
    try:
        cluster.wait_for_workers(3)
        with cluster.client() as client:
            addresses = client.run(lambda dask_worker: os.environ["PATH"])
        broken_address = next(a for a, path in addresses.items() if path.startswith(str(here)))
        submissions = make_submissions(here / "few", 8)
        out = here / "out"
        done = grade(env, "batch", submissions, "--out", out, "--chapters", "ch06", "--no-html",
                     "--scheduler", cluster.address, "--certs", cluster.certs, cwd=folder)
    finally:
        cluster.stop("broken")
    assert done.returncode == 0, done.stderr[-3000:]
    assert "8 submissions: 8 graded;" in done.stdout
    if first_failure == 1:
        assert (f"a worker that cannot grade (the learners sent to it are graded by another): {broken_address}: "
                "learner code cannot run on") in done.stderr
        assert broken.calls == 1  # its start check only
    else:
        assert f"learner code cannot run on worker {broken_address}: " in done.stderr
        assert "its learners are graded on other workers" in done.stderr
        assert broken.calls > 1
    for path in reports(out).values():
        data = json.loads(path.read_text(encoding="utf-8"))
        assert data["infrastructure"] is None and data["batch"]["isolation"]["worker"] != broken_address


@pytest.mark.slow
def test_a_worker_refuses_to_start_beside_a_coordinator_of_another_grader_version(place, cluster):
    """`grade worker` and `dask worker --preload grader.course.cluster` refuse to join while the running coordinator
    (its version published on the scheduler) grades with another grader, and say which versions differ."""
    folder, env = place
    with cluster.client() as client:
        client.set_metadata(VERSION_KEY, "0.1.0+g000000000000")
        try:
            done = grade(env, "worker", cluster.address, "--certs", cluster.certs, "--nworkers", "1", "--no-dashboard",
                         cwd=folder)
            preloaded = subprocess.run([sys.executable, "-m", "distributed.cli.dask_worker", cluster.address,
                                        "--preload", "grader.course.cluster", "--nthreads", "1", "--no-dashboard",
                                        "--tls-ca-file", str(cluster.certs / "ca.pem"), "--tls-cert",
                                        str(cluster.certs / "worker.pem"), "--tls-key", str(cluster.certs / "worker.pem"),
                                        "--local-directory", str(folder / "refused")],
                                       env={**env, "DASK_DISTRIBUTED__COMM__REQUIRE_ENCRYPTION": "True"}, cwd=folder,
                                       capture_output=True, text=True, timeout=300, check=False)
        finally:
            client.set_metadata(VERSION_KEY, None)
    assert done.returncode == 2, done.stderr
    assert "grade worker: not started: this worker's grader is 0.1.0+g" in done.stderr
    assert "the coordinator's is 0.1.0+g000000000000" in done.stderr
    assert "install the instructor's wheel of 0.1.0+g000000000000 here" in done.stderr
    assert preloaded.returncode != 0
    assert "grade worker: not started: this worker's grader is" in preloaded.stderr


@pytest.mark.slow
def test_a_worker_whose_barrier_cannot_stand_refuses_to_start(place, tmp_path):
    """`grade worker` on a machine where bubblewrap fails, and learner code cannot run as an unprivileged user of its
    own either (the grader's files here are root's only), refuses before it joins anything, saying why."""
    folder, env = place
    broken = FakeBwrap(tmp_path / "bwrap", failing=range(1, 1000))
    certs = make_certs(tmp_path / "certs", env)
    done = grade({**env, "PATH": broken.env["PATH"]}, "worker", f"tls://127.0.0.1:{free_port()}", "--certs", certs,
                 cwd=folder)
    assert done.returncode == 2
    assert "grade worker: not started: learner code cannot run on" in done.stderr
    assert "behind a barrier" in done.stderr and "bubblewrap" in done.stderr and "grader-learner" in done.stderr


@pytest.mark.slow
def test_the_instructors_checkout_and_its_wheel_are_one_grader_version(place, tmp_path):
    """Workers run the instructor's wheel, the coordinator often the project itself: both are one grader version
    (the banks inside the installed grader count as they do beside it), so neither refuses the other."""
    folder, env = place
    project = tmp_path / "project"
    shutil.copytree(folder / "code", project)
    for name in ("pyproject.toml", "README.md"):
        shutil.copy(REPO / name, project / name)
    built = subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--quiet", "--disable-pip-version-check",
                            "-w", str(tmp_path / "wheel"), str(project)], capture_output=True, text=True, check=False)
    if built.returncode != 0:  # offline: the build backend as installed here
        built = subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "--quiet",
                                "-w", str(tmp_path / "wheel"), str(project)], capture_output=True, text=True, check=False)
    assert built.returncode == 0, built.stderr[-2000:]
    installed = subprocess.run([sys.executable, "-m", "pip", "install", "--no-deps", "--quiet", "--target",
                                str(tmp_path / "installed"), *map(str, (tmp_path / "wheel").glob("*.whl"))],
                               capture_output=True, text=True, check=False)
    assert installed.returncode == 0, installed.stderr[-2000:]
    assert (tmp_path / "installed" / "grader" / "quizzes").is_dir() and not (project / "grader" / "quizzes").exists()

    def version(where: Path) -> list[str]:
        shown = subprocess.run([sys.executable, "-c", ("from grader import provenance; "
                                                       "print(provenance.grader_version(), provenance.GRADER_DIR)")],
                               env={**env, "PYTHONPATH": str(where)}, cwd=tmp_path, capture_output=True, text=True,
                               check=True)
        return shown.stdout.split()

    (wheel, wheel_dir), (checkout, checkout_dir) = version(tmp_path / "installed"), version(project)
    assert (wheel_dir, checkout_dir) == (str(tmp_path / "installed" / "grader"), str(project / "grader"))
    assert wheel == checkout


# ------------------------------------------------------------------------------------ closed to anyone else

TAKEOVER = """def H_jacobian(x, y):
    import socket
    said = []
    try:
        import distributed
        with distributed.Client({address!r}, timeout=5, set_as_default=False) as client:
            client.set_metadata({key!r}, "0.1.0+gtaken")
            client.run(lambda: open({marker!r}, "w").write("taken"))
        said.append("distributed: connected")
    except BaseException as exc:
        said.append(f"distributed: {{type(exc).__name__}}")
    try:
        socket.create_connection(("127.0.0.1", {port}), timeout=5).close()
        said.append("socket: connected")
    except OSError as exc:
        said.append(f"socket: {{type(exc).__name__}}")
    print("takeover: " + "; ".join(said))
    x, y = float(x), float(y)
    r2 = x * x + y * y
    if r2 == 0:
        raise ValueError("H is undefined at r = 0")
    r = np.sqrt(r2)
    return np.array([[x / r, y / r], [-y / r2, x / r2]])
"""


ATTEMPTS = """
import json, sys
import distributed
from distributed.security import Security

address, certs, other, marker = sys.argv[1:5]
attempts = {
    "no certificate": (address, None),
    "Dask's temporary certificate": (address, Security.temporary()),
    "another authority's certificate": (address, Security(require_encryption=True, tls_ca_file=certs + "/ca.pem",
                                                          tls_client_cert=other + "/coordinator.pem",
                                                          tls_client_key=other + "/coordinator.pem")),
    "plain tcp": (address.replace("tls://", "tcp://"), None),
}
said = {}
for name, (where, security) in attempts.items():
    try:
        with distributed.Client(where, security=security, timeout=10, set_as_default=False) as client:
            client.run(lambda: open(marker, "w").write("ran"))
            said[name] = "connected"
    except Exception as exc:
        said[name] = f"{type(exc).__name__}: {exc}"
print(json.dumps(said), flush=True)
"""


@pytest.mark.slow
def test_only_holders_of_the_courses_certificates_reach_the_cluster(place, cluster, tmp_path):
    """The scheduler refuses, from another process, a client without a certificate, one whose certificate another
    authority signed (even holding the course's ca.pem), one with Dask's temporary certificate and a plain tcp://
    connection to its port: none of them runs anything on a worker. The coordinator's certificate does."""
    from grader.course import credentials

    folder, env = place
    marker = tmp_path / "ran-on-a-worker"
    other = make_certs(tmp_path / "other-course", env)
    done = subprocess.run([sys.executable, "-c", ATTEMPTS, cluster.address, str(cluster.certs), str(other),
                           str(marker)], env=env, cwd=tmp_path, capture_output=True, text=True, timeout=300, check=False)
    assert done.returncode == 0, done.stderr[-3000:]
    refused = json.loads(done.stdout.splitlines()[-1])
    assert len(refused) == 4 and "connected" not in refused.values(), refused
    assert not marker.exists()
    assert "TLS" in refused["Dask's temporary certificate"] and "TLS" in refused["another authority's certificate"]
    assert "unknown ca" in cluster.log("scheduler").lower()
    with distributed.Client(cluster.address, security=credentials.security(cluster.certs, "coordinator"),
                            set_as_default=False) as client:
        assert set(client.run(os.getpid).values()) and client.scheduler.address == cluster.address


@pytest.mark.slow
def test_learner_code_on_a_worker_cannot_reach_the_scheduler(place, cluster, tmp_path):
    """A learner given the scheduler's address tries, from inside the function being graded, what took a plain Dask
    cluster over (a Client that rewrites the published version and runs a function on every worker): it gets
    nowhere, and the classmates graded beside it get their own grades."""
    folder, env = place
    marker = tmp_path / "taken-over"
    hostile = TAKEOVER.format(address=cluster.address, key=VERSION_KEY, marker=str(marker), port=cluster.port)
    submissions = tmp_path / "submissions"
    build_submission(submissions / "mallory", {"ch06_measurement": replace_function("ch06_measurement", "H_jacobian",
                                                                                    hostile)})
    build_submission(submissions / "ann")
    build_submission(submissions / "bob", dict(BUGS[:1]))
    out = tmp_path / "out"
    done = grade(env, "batch", submissions, "--out", out, "--chapters", "ch06", "--no-html", "--scheduler",
                 cluster.address, "--certs", cluster.certs, cwd=folder)
    assert done.returncode == 0, done.stderr[-3000:]
    said = json.loads((out / "mallory" / "report.json").read_text(encoding="utf-8"))["batch"]["learner_output"]
    assert "takeover: distributed: " in said and "distributed: connected" not in said
    assert "socket: connected" not in said
    assert not marker.exists()
    with cluster.client() as client:
        assert client.get_metadata(VERSION_KEY, default=None) in (None, "")
    with (out / "gradebook.csv").open(newline="", encoding="utf-8") as handle:
        code = {row["learner"]: float(row["ch06_code"]) for row in csv.DictReader(handle)}
    assert code["mallory"] == code["ann"] > code["bob"]


def test_a_cluster_without_tls_is_refused_unless_the_instructor_opens_it(tmp_path):
    """`grade batch --scheduler tcp://...` and `grade worker tcp://...` refuse, naming the option that opens the cluster
    to its network; with it they go on (and meet no scheduler); a tls:// address needs the certificates; a worker
    never starts without a barrier (--no-sandbox)."""
    submissions = tmp_path / "submissions"
    build_submission(submissions / "ann")
    address = f"tcp://127.0.0.1:{free_port()}"
    env = {**os.environ, "DASK_DISTRIBUTED__COMM__TIMEOUTS__CONNECT": "1s"}
    env.pop("DASK_SCHEDULER_ADDRESS", None)
    batch = ["batch", submissions, "--out", tmp_path / "out", "--chapters", "ch00", "--scheduler"]
    for done in (grade(env, *batch, address, cwd=tmp_path), grade(env, "worker", address, cwd=tmp_path)):
        assert done.returncode == 2, done.stderr
        assert f"{address} is a cluster without TLS: anyone who reaches its port" in done.stderr
        assert "--insecure-open-cluster" in done.stderr and "grade cluster certs" in done.stderr
    opened = grade(env, *batch, address, "--insecure-open-cluster", cwd=tmp_path)
    assert opened.returncode == 2 and f"no Dask scheduler answers at {address}" in opened.stderr
    secure = address.replace("tcp://", "tls://")
    for done in (grade(env, *batch, secure, cwd=tmp_path), grade(env, "worker", secure, cwd=tmp_path)):
        assert done.returncode == 2 and "needs the course's certificates: pass --certs DIR" in done.stderr
    assert not (tmp_path / "out").exists()
    unsandboxed = grade(env, "worker", secure, "--no-sandbox", cwd=tmp_path)
    assert unsandboxed.returncode == 2
    assert "a worker never runs learner code without a barrier" in unsandboxed.stderr


@pytest.mark.slow
def test_a_dask_worker_whose_connections_are_not_encrypted_refuses_to_start(place, tmp_path):
    """`dask worker --preload grader.course.cluster` without the course's certificates and Dask's require-encryption
    ends at once, saying how to start it."""
    folder, env = place
    port = free_port()
    with (tmp_path / "scheduler.log").open("wb") as log:
        scheduler = subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_scheduler", "--host", "127.0.0.1",
                                      "--port", str(port), "--no-dashboard"], env=env, cwd=tmp_path, stdout=log,
                                     stderr=subprocess.STDOUT, start_new_session=True)
    try:
        done = subprocess.run([sys.executable, "-m", "distributed.cli.dask_worker", f"tcp://127.0.0.1:{port}",
                               "--preload", "grader.course.cluster", "--nthreads", "1", "--no-dashboard",
                               "--local-directory", str(tmp_path)], env=env, cwd=folder, capture_output=True,
                              text=True, timeout=300, check=False)
    finally:
        os.killpg(scheduler.pid, signal.SIGKILL)
        scheduler.wait(timeout=30)
    assert done.returncode != 0
    assert "grade worker: not started: this worker's connections are not encrypted" in done.stderr


# ------------------------------------------------------------------------------------ the coordinator alone

def test_the_course_file_names_the_scheduler(tmp_path):
    """`scheduler:` in the course file is the cluster grade batch grades on; anything but an address is refused
    with the file and line."""
    from grader import course_config

    good = tmp_path / "course_config.yaml"
    good.write_text("course: c\nseed: 5\nscheduler: tls://scheduler.example.org:8786\n", encoding="utf-8")
    assert course_config._from_yaml(good).scheduler == "tls://scheduler.example.org:8786"
    assert course_config._from_yaml(good).scheduler_certs is None
    good.write_text("course: c\nseed: 5\nscheduler:\n  address: tls://scheduler.example.org:8786\n  certs: certs\n",
                    encoding="utf-8")
    both = course_config._from_yaml(good)
    assert (both.scheduler, both.scheduler_certs) == ("tls://scheduler.example.org:8786", str(tmp_path / "certs"))
    bad = tmp_path / "bad.yaml"
    for wrong in ("8786", "{address: tls://h:8786, cert: certs}", "{certs: certs}"):
        bad.write_text(f"course: c\nseed: 5\nscheduler: {wrong}\n", encoding="utf-8")
        with pytest.raises(course_config.CourseError, match=r"bad.yaml, line 3: scheduler is the address"):
            course_config._from_yaml(bad)


@pytest.mark.slow
@pytest.mark.parametrize("where", ["--scheduler", "DASK_SCHEDULER_ADDRESS", "course file"])
def test_the_scheduler_is_taken_from_the_option_the_environment_or_the_course_file(tmp_path, where):
    """Where no scheduler answers at the address --scheduler, else DASK_SCHEDULER_ADDRESS, else the course file
    names, nobody is graded and the message names the address; --jobs beside a scheduler is a usage error."""
    submissions = tmp_path / "submissions"
    build_submission(submissions / "ann")
    address = f"tls://127.0.0.1:{free_port()}"
    env = {**os.environ, "DASK_DISTRIBUTED__COMM__TIMEOUTS__CONNECT": "1s"}
    make_certs(tmp_path / "certs", env)
    course = tmp_path / "course.yaml"
    course.write_text("course: c\nseed: 5\n" + (f"scheduler: {{address: '{address}', certs: certs}}\n"
                                                 if where == "course file" else ""), encoding="utf-8")
    env.pop("DASK_SCHEDULER_ADDRESS", None)
    if where == "DASK_SCHEDULER_ADDRESS":
        env[where] = address
    args = ["batch", submissions, "--out", tmp_path / "out", "--course", course, "--chapters", "ch00"]
    args += ["--scheduler", address] if where == "--scheduler" else []
    args += ["--certs", tmp_path / "certs"] if where != "course file" else []
    done = grade(env, *args, cwd=tmp_path)
    assert done.returncode == 2
    assert f"no learner was graded: no Dask scheduler answers at {address}" in done.stderr
    assert not (tmp_path / "out").exists()
    jobs = grade(env, *args, "--jobs", "2", cwd=tmp_path)
    assert jobs.returncode == 2 and "--jobs sizes this machine's pool" in jobs.stderr
    assert "--scheduler local" in jobs.stderr


@pytest.mark.slow
def test_a_batch_without_a_scheduler_never_imports_dask_and_a_result_arriving_twice_is_recorded_once(tmp_path):
    """The local pool is the default and imports no Dask (`python -X importtime`); and run_batch records a learner
    whose result arrives twice (a task run again) once: the same outputs as a batch where each arrived once."""
    from grader.course import batch
    from grader.course_config import current

    submissions = tmp_path / "submissions"
    build_submission(submissions / "ann")
    build_submission(submissions / "bob", dict(BUGS[:1]))
    env = {**os.environ, "DASK_SCHEDULER_ADDRESS": ""}
    done = subprocess.run([sys.executable, "-X", "importtime", "-m", "grader", "batch", submissions, "--out",
                           tmp_path / "local", "--chapters", "ch06", "--no-html", "--jobs", "1"], env=env,
                          capture_output=True, text=True, timeout=600, check=False)
    assert done.returncode == 0, done.stderr[-3000:]
    imported = [line.rsplit("|", 1)[-1].strip() for line in done.stderr.splitlines() if line.startswith("import time:")]
    assert "grader.course.batch" in imported and not [name for name in imported if name.split(".")[0] in ("dask",
                                                                                                     "distributed")]

    class Twice(batch.LocalPool):
        def grade(self, *args):
            for graded in super().grade(*args):
                yield graded
                yield graded

    the_course = current()
    for name, pool in (("once", batch.LocalPool(1)), ("twice", Twice(1))):
        result = batch.run_batch(submissions, tmp_path / name, chapters=["ch06"], seed=the_course.grading_seed,
                                 html=False, course=the_course, hidden=the_course.hidden, pool=pool)
        assert result.statuses == {"ann": "graded", "bob": "graded"}
    assert history(tmp_path / "twice") == [("ann", "graded", 1), ("bob", "graded", 1)]
    assert gradebook_learners(tmp_path / "twice") == ["ann", "bob"]
    for name in ("gradebook.csv", "summary.json"):
        assert (tmp_path / "twice" / name).read_bytes() == (tmp_path / "once" / name).read_bytes()


def test_a_task_is_keyed_by_the_learner_its_content_hash_and_the_grader_version():
    """The same grading asked twice (a coordinator run again while the first one's task still runs) is one task;
    another learner, other files or another grader is another, and so is a try on another worker."""
    from grader.course.cluster import task_key
    from grader.course.workers import Staged

    def staged(learner: str, digest: str) -> Staged:
        return Staged(learner, "unused", digest, [], "", None, None, (), "f" * 64)

    key = task_key(staged("ann", "a" * 64), "0.1.0+g1")
    assert key == task_key(staged("ann", "a" * 64), "0.1.0+g1")
    others = {task_key(staged("bob", "a" * 64), "0.1.0+g1"), task_key(staged("ann", "b" * 64), "0.1.0+g1"),
              task_key(staged("ann", "a" * 64), "0.1.0+g2"), task_key(staged("ann", "a" * 64), "0.1.0+g1", attempt=2)}
    assert len(others) == 4 and key not in others
