"""Latency of `grade ch06` on the reference solutions against `python -c "import numpy"`.

Both are timed in the same run, interleaved, with several repetitions; medians are compared.
Target: grade ch06 at most 1.5x the numpy import. For scale (quoted, not measured here):
otter-grader's `otter run` takes about 3.4 s for one submission with five H/J checks on this kind
of machine, nbgrader about 3.9 s.

    python benchmarks/latency.py [--repeat 15]
"""

from __future__ import annotations

import argparse
import compileall
import statistics
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def timed(command: list[str]) -> float:
    started = time.perf_counter()
    subprocess.run(command, cwd=ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, check=False)
    return time.perf_counter() - started


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=15)
    args = parser.parse_args()
    for folder in ("grader", "solutions", "exercises"):  # the steady state a learner sees
        compileall.compile_dir(str(ROOT / folder), quiet=1)
    commands = {
        "python -c 'import numpy'": [sys.executable, "-c", "import numpy"],
        "grade ch06 --solutions": [sys.executable, "-m", "grader", "ch06", "--solutions"],
        "  code only (--no-quiz)": [sys.executable, "-m", "grader", "ch06", "--solutions", "--no-quiz"],
        "  code only, no sandbox": [sys.executable, "-m", "grader", "ch06", "--solutions", "--no-quiz",
                                    "--no-sandbox"],
        "grade ch06 (stubs)": [sys.executable, "-m", "grader", "ch06"],
        "grade all --solutions": [sys.executable, "-m", "grader", "all", "--solutions"],
    }
    for command in commands.values():  # warm the page cache
        timed(command)
    samples: dict[str, list[float]] = {name: [] for name in commands}
    for _ in range(args.repeat):
        for name, command in commands.items():
            samples[name].append(timed(command))
    baseline = statistics.median(samples["python -c 'import numpy'"])
    print(f"{'command':<28} {'median s':>9} {'min s':>7} {'x numpy':>8}")
    for name, values in samples.items():
        median = statistics.median(values)
        print(f"{name:<28} {median:9.3f} {min(values):7.3f} {median / baseline:8.2f}")
    ratio = statistics.median(samples["grade ch06 --solutions"]) / baseline
    code = statistics.median(samples["  code only (--no-quiz)"]) / baseline
    print(f"\ngrade ch06 / import numpy = {ratio:.2f}x with the quiz, {code:.2f}x code only (target <= 1.5x); "
          f"otter-grader's quoted 3.4 s would be {3.4 / baseline:.0f}x")


if __name__ == "__main__":
    main()
