"""Throughput of `grade batch`: a few hundred generated submissions (right, buggy and hostile mixed),
all chapters and quizzes, isolation on, every output written (HTML reports included). Prints submissions per second and the cost per submission
(wall and CPU), against two baselines timed in the same run: one `grade all --solutions` from the
CLI, and the same batch with a fresh sandboxed interpreter per learner instead of the fork server
(GRADER_FORK_SERVER=off).

    python benchmarks/batch.py [--count 300] [--jobs N] [--baseline-count 100]

--rss grades 250, 500 and 1000 generated submissions instead (--rss-counts) and prints, against the count,
the peak resident memory of the batch's own process and of its process tree (workers, fork servers,
learner children: /proc polled), and the ratio of each at the largest count to at the smallest (flat: near
1). --discovery times grader.course.staging.discover on 2,500, 5,000 and 10,000 empty folders (and with a roster
giving them all one id) and prints the cost per folder at 10,000 against at 2,500 (linear: near 1) and
the seconds at 10,000 against the 3.4 s the issue measured. --scheduler grades the --count submissions through
`grade batch --scheduler` on a scheduler started here (`grade cluster scheduler`: TLS, on 127.0.0.1) with one, then
two `grade worker` processes of one worker each, each run right after the local pool's, and prints both in
submissions per second (needs the [cluster] extra). --repeat N runs each N times: medians.

The floor, timed in the same rounds: the learner side alone, as `grade batch` would run it (the same number of
worker processes, each with its own sandboxed fork server; every learner's calls run in a forked child and read
back, line by line, into results) with nothing else of the grader's: no judging, no quiz, no report written.
With --repeat N the batch, its floor and `grade all --solutions` run in N interleaved rounds, and each figure
is printed as the median and spread of its per-round ratios; so is the batch against its floor of the same round
(what the grader's own work adds to the learner side, on a machine whose speed drifts between rounds).
"""

from __future__ import annotations

import argparse
import json
import os
import random
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from grader.system import SINGLE_THREADED_BLAS  # noqa: E402
from tests.support import build_submission, replace_function  # noqa: E402

BUGGY = [
    ("ch06_measurement", "H_jacobian", "def H_jacobian(x, y):\n    r2 = x * x + y * y\n    r = np.sqrt(r2)\n"
                                       "    return np.array([[x / r, y / r], [y / r2, x / r2]])\n"),
    ("ch03_jacobian", "polar_to_cartesian_jacobian", "def polar_to_cartesian_jacobian(r, theta):\n"
                                                     "    return np.array([[np.cos(theta), np.sin(theta)], [-r * np.sin(theta), r * np.cos(theta)]])\n"),
    ("ch07_dynamics", "propagate_covariance", "def propagate_covariance(P, F, Q=None):\n"
                                              "    return np.asarray(F).T @ np.asarray(P) @ np.asarray(F)\n"),
]
HOSTILE = [
    ("ch06_measurement", "H_jacobian", "def H_jacobian(x, y):\n    import sys\n    sys.exit(1)\n"),
    ("ch06_measurement", "H_jacobian", "def H_jacobian(x, y):\n    return 'H'\n"),
    ("ch02_gradient", "example_gradient", "def example_gradient(x, y):\n    return np.array([np.nan, np.nan])\n"),
    ("ch05_finite_differences", "best_step", "def best_step(f, fprime, x, hs):\n    import os\n    os._exit(3)\n"),
]


# Right answers as learners write them (issue 14): loops over samples in plain Python, math per element,
# sympy at every call. Each replaces the reference's function of that name in a "styled" submission.
STYLED = [
    ("ch00_range_sensor", "mean_shift", """def mean_shift(mean, sigma, n, seed):
    import math
    rng = np.random.default_rng(seed)
    total = 0.0
    for _ in range(int(n)):
        dx, dy = rng.standard_normal(2)
        total += math.hypot(mean[0] + sigma * dx, mean[1] + sigma * dy)
    return total / int(n) - math.hypot(mean[0], mean[1])
"""),
    ("ch08_lab", "measure_samples", """def measure_samples(samples, ref_bearing):
    import math
    rows = []
    for x, y in samples:
        bearing = math.atan2(y, x)
        bearing += 2 * math.pi * round((ref_bearing - bearing) / (2 * math.pi))
        rows.append([math.hypot(x, y), bearing])
    return np.array(rows)
"""),
    ("ch02_gradient", "example_gradient", """def example_gradient(x, y):
    import sympy
    X, Y = sympy.symbols("x y")
    f = X ** 2 + X * Y
    return np.array([float(sympy.diff(f, v).subs({X: x, Y: y})) for v in (X, Y)])
"""),
    ("ch06_measurement", "H_jacobian", """def H_jacobian(x, y):
    import math
    r2 = x * x + y * y
    if r2 == 0:
        raise ValueError("H is undefined at r = 0")
    r = math.sqrt(r2)
    return np.array([[x / r, y / r], [-y / r2, x / r2]])
"""),
]


def own_answers(answers: Path, learner: str) -> None:
    """The right quiz answers for `learner`'s own numbers and option letters, and learner.yaml naming them."""
    from grader.chapters import CHAPTERS
    from grader.course.submit import write_learner_yaml
    from grader.quiz.templates import reference_answers

    for chapter in CHAPTERS:
        (answers / f"{chapter.id}.yaml").write_text(reference_answers(chapter.id, learner), encoding="utf-8")
    write_learner_yaml(answers, learner)


def make(folder: Path, count: int, styles: bool = False) -> None:
    """`count` submissions: right, buggy and hostile in turn; with `styles`, right ones in the learners' styles
    (STYLED) as a fourth kind, and every third submission zipped. Four in five answer the quiz with their own
    numbers; every fifth with the reference's, as a learner whose learner.yaml names someone else."""
    draw = random.Random(1)
    answers = ROOT / "solutions" / "answers"
    kinds = ("right", "styled", "buggy", "hostile") if styles else ("right", "buggy", "hostile")
    for i in range(count):
        kind = kinds[i % len(kinds)]
        replacements: dict[str, str] = {}
        if kind == "styled":
            for module, function, source in STYLED:
                replacements[module] = replace_function(module, function, source)  # one function per module
        elif kind != "right":
            module, function, source = draw.choice(BUGGY if kind == "buggy" else HOSTILE)
            replacements[module] = replace_function(module, function, source)
        root = build_submission(folder / f"{kind}{i:04d}", replacements)
        shutil.copytree(answers, root / "exercises" / "answers")
        if i % 5 != 4:  # most learners answer their own quiz; every fifth with the reference's numbers (flagged)
            own_answers(root / "exercises" / "answers", root.name)
        if styles and i % 3 == 2:
            shutil.make_archive(str(root), "zip", root)
            shutil.rmtree(root)


def busy_cpu_seconds() -> float | None:
    """CPU time spent by the whole machine (all cores, not idle) so far; None off Linux."""
    try:
        with open("/proc/stat") as handle:
            fields = [int(v) for v in handle.readline().split()[1:]]
    except OSError:
        return None
    return (sum(fields) - fields[3] - fields[4]) / os.sysconf("SC_CLK_TCK")


def run_batch(submissions: Path, out: Path, jobs: int | None, env: dict,
              extra: tuple[str, ...] = ()) -> tuple[float, float | None, str]:
    """(wall seconds, busy CPU seconds, first output lines) of one `grade batch` run (`extra`: more options)."""
    command = [sys.executable, "-m", "grader", "batch", str(submissions), "--out", str(out), *extra]  # HTML too
    command += ["--jobs", str(jobs)] if jobs else []
    cpu_before, started = busy_cpu_seconds(), time.perf_counter()
    proc = subprocess.run(command, cwd=ROOT, capture_output=True, text=True, check=False, env=env)
    wall, cpu_after = time.perf_counter() - started, busy_cpu_seconds()
    cpu = None if cpu_before is None or cpu_after is None else cpu_after - cpu_before
    lines = (proc.stdout.strip().splitlines()[:1] + proc.stderr.strip().splitlines()[:1]) or [proc.stderr[-500:]]
    return wall, cpu, "\n".join(lines)


def _learner_side(submissions: str, jobs: int) -> None:
    """The floor (run as its own process, `--learner-side`): every submission's calls run behind the batch's
    boundary, in `jobs` worker processes, and read back. Prints, as JSON, the seconds and the machine's busy CPU
    seconds this took (staging and planning, done first, left out), the learners, the calls asked and the calls
    answered (a value returned, or an exception raised as the learner's function did)."""
    import multiprocessing

    from grader.chapters import CHAPTERS
    from grader.core.transaction import Door
    from grader.course import staging

    scratch = Path(tempfile.mkdtemp(prefix="grade-floor-"))
    try:
        roots = [str(staging.stage(entry, scratch)) for entry in staging.discover(Path(submissions))]
        _PLANNED.extend(_encoded_once(chapter.id, chapter.module) for chapter in CHAPTERS)
        Door("required", probe=True).isolation  # as the batch proves its sandbox before any learner
        cpu_before, started = busy_cpu_seconds(), time.perf_counter()
        with multiprocessing.get_context("fork").Pool(jobs) as pool:
            answered = sum(pool.imap_unordered(_run_learner, roots))
        seconds, cpu_after = time.perf_counter() - started, busy_cpu_seconds()
    finally:
        shutil.rmtree(scratch, ignore_errors=True)
    cpu = None if cpu_before is None or cpu_after is None else cpu_after - cpu_before
    calls = len(roots) * sum(len(request.calls) for request in _PLANNED)
    print(json.dumps({"seconds": seconds, "cpu": cpu, "learners": len(roots), "calls": calls, "answered": answered}))


_PLANNED: list = []  # the chapters' requests, planned once before the pool forks


def _encoded_once(chapter: str, module: str):
    """A chapter's request as a batch worker sends it to all its learners: the calls planned once at the default
    seed and kept with their JSON text (grader.core.memo.Memo.calls), so no learner's request encodes them again."""
    from grader.boundary.session import ChapterRequest
    from grader.core.grading import DEFAULT_SEED, _plan
    from grader.core.memo import Memo

    memo = Memo(None, "the floor")
    memo.keep_calls(chapter, "planned", _plan(chapter, DEFAULT_SEED, False, frozenset()).calls)
    return ChapterRequest(chapter, module, memo.calls(chapter, "planned"))


_WORKER: dict = {}


def _run_learner(root: str) -> int:
    """One learner's calls, run in a child of this worker's fork server: how many it answered."""
    from grader.boundary import Limits
    from grader.boundary.wire import RAISED, VALUE
    from grader.core.transaction import Door
    from grader.submission import Submission

    if "boundary" not in _WORKER:
        _WORKER["boundary"] = Door("required", resident=True).boundary
    runs = _WORKER["boundary"].open_session(Submission(Path(root), "exercises"), Limits()).run(_PLANNED)
    return sum(result.kind in (VALUE, RAISED) for run in runs.values() for result in run.results)


def run_learner_side(submissions: Path, jobs: int | None, env: dict) -> dict:
    """The floor for `submissions` (see _learner_side), from a process of its own."""
    command = [sys.executable, str(Path(__file__).resolve()), "--learner-side", str(submissions),
               "--jobs", str(jobs or os.cpu_count() or 1)]
    # one BLAS thread, set before numpy loads, as `grade` sets it (grader.faces.launch): idle OpenBLAS threads would spin
    proc = subprocess.run(command, cwd=ROOT, capture_output=True, text=True, check=False,
                          env=dict(env, **SINGLE_THREADED_BLAS))
    if proc.returncode != 0:
        raise SystemExit(f"the learner side alone failed: {proc.stderr[-800:]}")
    return json.loads(proc.stdout.strip().splitlines()[-1])


# ------------------------------------------------------------------------------------ memory against the count

def _children() -> dict[int, list[int]]:
    """Every process's children, by parent pid, from /proc."""
    children: dict[int, list[int]] = {}
    for entry in os.scandir("/proc"):
        if not entry.name.isdigit():
            continue
        try:
            with open(f"/proc/{entry.name}/stat", "rb") as handle:
                parent = int(handle.read().rsplit(b")", 1)[1].split()[1])
        except (OSError, ValueError, IndexError):
            continue
        children.setdefault(parent, []).append(int(entry.name))
    return children


def _memory(pid: int) -> tuple[int, int]:
    """(resident now, resident at its peak) of a process in kB; (0, 0) once it is gone."""
    values = {}
    try:
        with open(f"/proc/{pid}/status") as handle:
            for line in handle:
                if line.startswith(("VmRSS:", "VmHWM:")):
                    values[line[:5]] = int(line.split()[1])
    except (OSError, ValueError):
        return 0, 0
    return values.get("VmRSS", 0), values.get("VmHWM", 0)


def run_batch_memory(submissions: Path, out: Path, jobs: int | None, every: float = 0.1) -> dict:
    """One `grade batch` run (isolation on, HTML reports written) with its memory polled from /proc: the peak
    of its own process (VmHWM), the largest peak of any other process in its tree, the tree's peak total
    (every process's resident memory summed, at one poll: shared pages counted in each), and the largest
    process's peak as the kernel reports it for reaped children (ru_maxrss of RUSAGE_CHILDREN, through a
    wrapper process of its own, so that earlier runs do not count)."""
    import json

    command = [sys.executable, "-m", "grader", "batch", str(submissions), "--out", str(out)]
    command += ["--jobs", str(jobs)] if jobs else []
    wrapper = ("import json, resource, subprocess, sys\n"
               "done = subprocess.run(sys.argv[1:], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)\n"
               "print(json.dumps([done.returncode, done.stderr[-300:],"
               " resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss]))\n")
    started = time.perf_counter()
    proc = subprocess.Popen([sys.executable, "-c", wrapper, *command], cwd=ROOT, stdout=subprocess.PIPE, text=True)
    main_peak = other_peak = tree_peak = 0
    batch: int | None = None
    while proc.poll() is None:
        children = _children()
        if batch is None:
            batch = next(iter(children.get(proc.pid, [])), None)
        if batch is not None:
            pending, total = [batch], 0
            while pending:
                pid = pending.pop()
                pending.extend(children.get(pid, []))
                now, peak = _memory(pid)
                total += now
                if pid == batch:
                    main_peak = max(main_peak, peak)
                else:
                    other_peak = max(other_peak, peak)
            tree_peak = max(tree_peak, total)
        time.sleep(every)
    code, errors, maxrss = json.loads(proc.stdout.read())
    return {"seconds": time.perf_counter() - started, "main": main_peak, "other": other_peak, "tree": tree_peak,
            "maxrss": maxrss, "code": code, "errors": errors}


def memory_figures(work: Path, counts: list[int], jobs: int | None, repeat: int) -> None:
    """Peak RSS against the number of submissions (medians of `repeat` runs), and the ratio at the largest
    count to at the smallest."""
    make(work / "all", max(counts))
    names = sorted(path.name for path in (work / "all").iterdir())
    rows = {}
    for count in counts:
        folder = work / f"submissions-{count}"
        for name in names[:count]:  # the same learners, a prefix of the largest set (hard links: quick)
            shutil.copytree(work / "all" / name, folder / name, copy_function=os.link)
        runs = []
        for _ in range(repeat):
            shutil.rmtree(work / "out", ignore_errors=True)
            runs.append(run_batch_memory(folder, work / "out", jobs))
            if runs[-1]["code"] not in (0, 1):
                print(f"grade batch failed (exit {runs[-1]['code']}): {runs[-1]['errors']}")
        rows[count] = {key: statistics.median(r[key] for r in runs) for key in ("seconds", "main", "other", "tree",
                                                                                "maxrss")}
        row = rows[count]
        print(f"{count:5d} submissions: {row['seconds']:6.1f} s; peak RSS: batch process {row['main'] / 1024:6.1f} MB, "
              f"largest other process {row['other'] / 1024:6.1f} MB, whole tree {row['tree'] / 1024:7.1f} MB "
              f"(ru_maxrss of the largest process {row['maxrss'] / 1024:.1f} MB)", flush=True)
    low, high = rows[min(counts)], rows[max(counts)]

    def ratio(key: str) -> float:
        return high[key] / low[key] if low[key] else float("nan")

    print(f"peak RSS at {max(counts)} / at {min(counts)} submissions ({repeat} run{'s' * (repeat > 1)} each, medians): "
          f"batch process {ratio('main'):.2f}, whole tree {ratio('tree'):.2f}, largest process {ratio('maxrss'):.2f}; "
          "target: flat (near 1)")


# ------------------------------------------------------------------------------------ discovery against the count

DISCOVERY_BASELINE = 3.4  # seconds for 10,000 empty folders, as issue 14 measured them


def discovery_figures(work: Path, counts: list[int], repeat: int) -> None:
    """grader.course.staging.discover on empty folders (by name, and with a roster giving every one the same id, which
    makes each id unique in turn): seconds per count (medians), the cost per folder at the largest count
    against at the smallest, and the largest against the issue's baseline."""
    from grader.course.staging import discover

    for label, with_roster in (("by folder name", False), ("one id for all, from a roster", True)):
        seconds = {}
        for count in counts:
            folder = work / f"empty-{count}"
            if not folder.exists():
                for i in range(count):
                    (folder / f"learner{i:05d}").mkdir(parents=True)
            roster = None
            if with_roster:
                roster = work / f"roster-{count}.csv"
                roster.write_text("submission,learner\n" + "".join(f"learner{i:05d},alice\n" for i in range(count)))
            times = []
            for _ in range(repeat):
                started = time.perf_counter()
                found = discover(folder, roster)
                times.append(time.perf_counter() - started)
            assert len(found) == count
            seconds[count] = statistics.median(times)
        low, high = min(counts), max(counts)
        per = (seconds[high] / high) / (seconds[low] / low)
        print(f"discover(), {label}: " + ", ".join(f"{n} folders {seconds[n]:.3f} s" for n in counts)
              + f"; per folder at {high} / at {low}: {per:.2f} (linear: near 1)")
        if not with_roster and high == 10000:
            print(f"discover() on 10000 empty folders: {seconds[high]:.3f} s against {DISCOVERY_BASELINE} s in the issue: "
                  f"{seconds[high] / DISCOVERY_BASELINE:.3f}x ({DISCOVERY_BASELINE / seconds[high]:.0f} times faster)")


# ------------------------------------------------------------------------------------ on a Dask cluster, here

def _free_port() -> int:
    import socket

    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


def _start(command: list[str], log: Path) -> subprocess.Popen:
    """`command` in a process group of its own (stopped with all it starts by _stop), its output in `log`."""
    with log.open("wb") as handle:
        return subprocess.Popen(command, cwd=ROOT, stdout=handle, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL,
                                start_new_session=True)


def _stop(process: subprocess.Popen) -> None:
    import signal

    try:
        os.killpg(process.pid, signal.SIGTERM)
        process.wait(timeout=20)
    except subprocess.TimeoutExpired:
        os.killpg(process.pid, signal.SIGKILL)
        process.wait()
    except ProcessLookupError:
        process.wait()


def cluster_figures(work: Path, count: int, styles: bool, repeat: int) -> None:
    """The same submissions graded through --scheduler with 1, then 2 workers (each a `grade worker --nworkers 1`
    process: one learner at a time) on a scheduler started here, each run right after a run of the local pool
    (all cores), this machine's speed drifting: submissions per second of each (medians of `repeat` pairs, each
    run into a fresh output folder) and the median of the pairs' ratios."""
    from distributed import Client

    from grader.course import credentials

    make(work / "submissions", count, styles)
    env = dict(os.environ)
    env.pop("DASK_SCHEDULER_ADDRESS", None)
    runs = iter(range(1_000_000))

    def wall_of(extra: tuple[str, ...]) -> float:
        wall, _cpu, output = run_batch(work / "submissions", work / f"out-{next(runs)}", None, env, extra)
        if f"{count} graded" not in output:
            raise SystemExit(f"grade batch {' '.join(extra)} did not grade every submission:\n{output}")
        return wall

    certs = work / "certs"
    credentials.make(certs, force=True)
    address = f"tls://127.0.0.1:{_free_port()}"
    started = [_start([sys.executable, "-m", "grader", "cluster", "scheduler", "--certs", str(certs), "--host",
                       "127.0.0.1", "--port", address.rsplit(":", 1)[1], "--no-dashboard"], work / "scheduler.log")]
    try:
        for workers in (1, 2):
            started.append(_start([sys.executable, "-m", "grader", "worker", address, "--certs", str(certs),
                                   "--nworkers", "1", "--no-dashboard", "--local-directory",
                                   str(work / f"worker-{workers}")], work / f"worker-{workers}.log"))
            with Client(address, timeout=60, security=credentials.security(certs, "coordinator"),
                        set_as_default=False) as client:
                client.wait_for_workers(workers, timeout=300)
            pairs = [(wall_of(()), wall_of(("--scheduler", address, "--certs", str(certs)))) for _ in range(repeat)]
            local, dask = (statistics.median(walls) for walls in zip(*pairs))
            ratio = statistics.median(here / there for here, there in pairs)
            print(f"Dask, {workers} worker{'s' * (workers > 1)} on this machine: {count} submissions in {dask:.1f} s, "
                  f"{count / dask:.1f} submissions/s; the local pool ({os.cpu_count()} processes) beside it: "
                  f"{local:.1f} s, {count / local:.1f} submissions/s; Dask / local {ratio:.2f}x "
                  f"({repeat} pair{'s' * (repeat > 1)})", flush=True)
    finally:
        for process in reversed(started):
            _stop(process)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--count", type=int, default=300)
    parser.add_argument("--baseline-count", type=int, default=100)
    parser.add_argument("--jobs", type=int, default=None)
    parser.add_argument("--rss", action="store_true", help="peak resident memory against the number of submissions")
    parser.add_argument("--rss-counts", default="250,500,1000")
    parser.add_argument("--discovery", action="store_true", help="discover() on 2,500 to 10,000 empty folders")
    parser.add_argument("--discovery-counts", default="2500,5000,10000")
    parser.add_argument("--styles", action="store_true",
                        help="a realistic mix: right answers also in learners' styles (plain-Python loops, math, sympy), a "
                             "third zipped")
    parser.add_argument("--repeat", type=int, default=None, help="runs per figure (medians); --rss 1, --discovery 7")
    parser.add_argument("--scheduler", action="store_true",
                        help="throughput through grade batch --scheduler with 1 and 2 local Dask workers, beside the "
                             "local pool")
    parser.add_argument("--learner-side", metavar="FOLDER", help=argparse.SUPPRESS)  # the floor's own process
    args = parser.parse_args()
    if args.learner_side:
        _learner_side(args.learner_side, args.jobs or os.cpu_count() or 1)
        return
    if args.scheduler:
        work = Path(tempfile.mkdtemp(prefix="grade-batch-bench-"))
        try:
            cluster_figures(work, args.count, args.styles, args.repeat or 1)
        finally:
            shutil.rmtree(work, ignore_errors=True)
        return
    if args.rss or args.discovery:
        work = Path(tempfile.mkdtemp(prefix="grade-batch-bench-"))
        try:
            if args.discovery:
                discovery_figures(work, [int(n) for n in args.discovery_counts.split(",")], args.repeat or 7)
            if args.rss:
                memory_figures(work, [int(n) for n in args.rss_counts.split(",")], args.jobs, args.repeat or 1)
        finally:
            shutil.rmtree(work, ignore_errors=True)
        return
    work = Path(tempfile.mkdtemp(prefix="grade-batch-bench-"))
    make(work / "submissions", args.count, args.styles)
    make(work / "baseline", args.baseline_count, args.styles)
    env = dict(os.environ)
    rounds = args.repeat or 1
    singles: list[float] = []
    walls: list[float] = []
    cpus: list[float] = []
    floors: list[float] = []
    floor_cpus: list[float] = []
    ratios: list[float] = []
    floor_ratios: list[float] = []
    over_floor: list[float] = []  # the batch against its floor in the same round: what the grader's own work adds

    def grade_all(times: int) -> list[float]:
        """`grade all --solutions` judged afresh (nothing kept: as a batch judges each learner's code)."""
        seconds = []
        for _ in range(times):
            started = time.perf_counter()
            subprocess.run([sys.executable, "-m", "grader", "all", "--solutions"], cwd=ROOT, stdout=subprocess.DEVNULL,
                           stderr=subprocess.DEVNULL, check=False, env=dict(env, GRADER_CACHE_DIR=""))
            seconds.append(time.perf_counter() - started)
        singles.extend(seconds)
        return seconds

    output = ""
    for _ in range(rounds):  # one round: grade all, the batch, its floor, grade all (3 of each grade all for one round)
        beside = grade_all(3 if rounds == 1 else 1)
        wall, cpu, output = run_batch(work / "submissions", work / "out", args.jobs, env)
        shutil.rmtree(work / "out", ignore_errors=True)  # the next round grades everyone again
        floor_figures = run_learner_side(work / "submissions", args.jobs, env)
        floor = floor_figures["seconds"]
        if floor_figures["cpu"] is not None:
            floor_cpus.append(floor_figures["cpu"] / args.count)
        beside += grade_all(3 if rounds == 1 else 1)  # as many after as before: the machine's drift shows
        single = statistics.median(beside)
        walls.append(wall / args.count)
        floors.append(floor / args.count)
        ratios.append(wall / args.count / single)
        floor_ratios.append(floor / args.count / single)
        over_floor.append(wall / floor)
        if cpu is not None:
            cpus.append(cpu / args.count)
    base_wall, base_cpu, _ = run_batch(work / "baseline", work / "out-baseline", args.jobs,
                                       dict(env, GRADER_FORK_SERVER="off"))
    print(output)

    def spread(values: list[float], scale: float = 1.0, digits: int = 0) -> str:
        middle = f"{statistics.median(values) * scale:.{digits}f}"
        if len(values) == 1:
            return middle
        low, high = min(values) * scale, max(values) * scale
        return f"{middle} (median of {len(values)} rounds; {low:.{digits}f} to {high:.{digits}f})"

    per = statistics.median(walls)
    base_per = base_wall / args.baseline_count
    cpu_text = f", {spread(cpus, 1000)} ms CPU" if cpus else ""
    print(f"fork server: {args.count} submissions (all chapters and quizzes): {1 / per:.1f} submissions/s, "
          f"{spread(walls, 1000)} ms wall each{cpu_text}")
    floor_cpu_text = f", {spread(floor_cpus, 1000)} ms CPU" if floor_cpus else ""
    print(f"the floor, the learner side alone (calls run and read back; no judging, quiz or outputs): "
          f"{spread(floors, 1000)} ms wall each{floor_cpu_text}")
    base_cpu_text = "" if base_cpu is None else f", {base_cpu / args.baseline_count * 1000:.0f} ms CPU"
    print(f"fresh sandboxed interpreter per learner: {args.baseline_count} in {base_wall:.1f} s: "
          f"{args.baseline_count / base_wall:.1f} submissions/s, {base_per * 1000:.0f} ms wall each"
          f"{base_cpu_text}; fork server speed-up {base_per / per:.2f}x")
    print(f"one `grade all --solutions` from the CLI, judged afresh: median {statistics.median(singles):.2f} s "
          f"({min(singles):.2f} to {max(singles):.2f}, {len(singles)} runs, half before the batch, half after)")
    print(f"batch per submission / that `grade all`: {spread(ratios, digits=3)} (target <= 0.18); "
          f"its floor / that `grade all`: {spread(floor_ratios, digits=3)}")
    print(f"batch per submission / its floor's, each round's own: {spread(over_floor, digits=2)} (target <= 1.5: "
          "what the grader's own work adds, judging, the quiz and the outputs, at most half the learner side)")
    shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
