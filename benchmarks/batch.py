"""Throughput of `grade batch`: a few hundred generated submissions (right, buggy and hostile mixed),
all chapters and quizzes, isolation on, every output written (HTML reports included). Prints submissions per second and the cost per submission
(wall and CPU), against two baselines timed in the same run: one `grade all --solutions` from the
CLI, and the same batch with a fresh sandboxed interpreter per learner instead of the fork server
(GRADER_FORK_SERVER=off).

    python benchmarks/batch.py [--count 300] [--jobs N] [--baseline-count 100]
"""

from __future__ import annotations

import argparse
import os
import random
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from tests.conftest import build_submission, replace_function  # noqa: E402

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


def make(folder: Path, count: int) -> None:
    draw = random.Random(1)
    answers = ROOT / "solutions" / "answers"
    for i in range(count):
        kind = ("right", "buggy", "hostile")[i % 3]
        replacements = {}
        if kind != "right":
            module, function, source = draw.choice(BUGGY if kind == "buggy" else HOSTILE)
            replacements[module] = replace_function(module, function, source)
        root = build_submission(folder / f"{kind}{i:04d}", replacements)
        shutil.copytree(answers, root / "exercises" / "answers")


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


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--count", type=int, default=300)
    parser.add_argument("--baseline-count", type=int, default=100)
    parser.add_argument("--jobs", type=int, default=None)
    args = parser.parse_args()
    work = Path(tempfile.mkdtemp(prefix="grade-batch-bench-"))
    make(work / "submissions", args.count)
    make(work / "baseline", args.baseline_count)
    singles = []
    for _ in range(3):
        started = time.perf_counter()
        subprocess.run([sys.executable, "-m", "grader", "all", "--solutions"], cwd=ROOT, stdout=subprocess.DEVNULL,
                       stderr=subprocess.DEVNULL, check=False)
        singles.append(time.perf_counter() - started)
    single = sorted(singles)[1]
    env = dict(os.environ)
    wall, cpu, output = run_batch(work / "submissions", work / "out", args.jobs, env)
    base_wall, base_cpu, _ = run_batch(work / "baseline", work / "out-baseline", args.jobs,
                                       dict(env, GRADER_FORK_SERVER="off"))
    print(output)
    per, base_per = wall / args.count, base_wall / args.baseline_count
    cpu_text = lambda total, n: "" if total is None else f", {total / n * 1000:.0f} ms CPU"  # noqa: E731
    print(f"fork server: {args.count} submissions (all chapters and quizzes) in {wall:.1f} s: "
          f"{args.count / wall:.1f} submissions/s, {per * 1000:.0f} ms wall each{cpu_text(cpu, args.count)}")
    print(f"fresh sandboxed interpreter per learner: {args.baseline_count} in {base_wall:.1f} s: "
          f"{args.baseline_count / base_wall:.1f} submissions/s, {base_per * 1000:.0f} ms wall each"
          f"{cpu_text(base_cpu, args.baseline_count)}; fork server speed-up {base_per / per:.2f}x")
    print(f"one `grade all --solutions` from the CLI: {single:.2f} s; batch per submission / that = {per / single:.2f}; "
          f"target >= 10 submissions/s")
    shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
