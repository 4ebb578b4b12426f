"""Throughput of `grade batch`: a few hundred generated submissions (right, buggy and hostile mixed),
all chapters and quizzes, isolation on. Prints submissions per second and per-submission cost,
against `grade all --solutions` (one submission through the learner CLI) timed in the same run.

    python benchmarks/batch.py [--count 200] [--jobs N]
"""

from __future__ import annotations

import argparse
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


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--count", type=int, default=200)
    parser.add_argument("--jobs", type=int, default=None)
    args = parser.parse_args()
    work = Path(tempfile.mkdtemp(prefix="grade-batch-bench-"))
    make(work / "submissions", args.count)
    started = time.perf_counter()
    subprocess.run([sys.executable, "-m", "grader", "all", "--solutions"], cwd=ROOT, stdout=subprocess.DEVNULL,
                   check=False)
    single = time.perf_counter() - started
    command = [sys.executable, "-m", "grader", "batch", str(work / "submissions"), "--out", str(work / "out"),
               "--no-html"] + (["--jobs", str(args.jobs)] if args.jobs else [])
    started = time.perf_counter()
    proc = subprocess.run(command, cwd=ROOT, capture_output=True, text=True, check=False)
    elapsed = time.perf_counter() - started
    print(proc.stdout.strip().splitlines()[0] if proc.stdout.strip() else proc.stderr[-500:])
    print(proc.stderr.strip().splitlines()[0] if proc.stderr.strip() else "")
    print(f"{args.count} submissions (all chapters and quizzes) in {elapsed:.1f} s: "
          f"{args.count / elapsed:.1f} submissions/s, {elapsed / args.count * 1000:.0f} ms each (wall, all cores)")
    print(f"one `grade all --solutions` from the CLI: {single:.2f} s; batch per submission / that = "
          f"{elapsed / args.count / single:.2f}; target >= 10 submissions/s")
    shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
