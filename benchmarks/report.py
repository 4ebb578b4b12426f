"""Cost of the HTML report: `grade all --html` against `grade all`, both on the reference solutions.

Interleaved repetitions in one run (each `--html` run right after its plain one, so both meet the same
machine: on shared cores its speed drifts by a quarter within minutes); the figure is the median of
those paired ratios, with the ratio of the two medians beside it. The grader's files are compiled
first, as a learner's install has them. Target: at most 2x.

    python benchmarks/report.py [--repeat 9]
"""

from __future__ import annotations

import argparse
import compileall
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def timed(command: list[str]) -> float:
    started = time.perf_counter()
    subprocess.run(command, cwd=ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, check=False)
    return time.perf_counter() - started


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=9)
    args = parser.parse_args()
    for folder in ("grader", "solutions", "exercises"):  # the steady state a learner sees
        compileall.compile_dir(str(ROOT / folder), quiet=1)
    out = Path(tempfile.mkdtemp()) / "report.html"
    commands = {
        "grade all --solutions": [sys.executable, "-m", "grader", "all", "--solutions"],
        "grade all --solutions --html": [sys.executable, "-m", "grader", "all", "--solutions", "--html", str(out)],
    }
    for command in commands.values():
        timed(command)
    samples: dict[str, list[float]] = {name: [] for name in commands}
    for _ in range(args.repeat):
        for name, command in commands.items():
            samples[name].append(timed(command))
    plain, html = samples["grade all --solutions"], samples["grade all --solutions --html"]
    for name, values in samples.items():
        print(f"{name:<32} median {statistics.median(values):6.3f} s  min {min(values):6.3f} s")
    paired = statistics.median(h / p for h, p in zip(html, plain))
    print(f"\n--html / plain = {paired:.2f}x, the median of {len(plain)} paired runs (ratio of the medians "
          f"{statistics.median(html) / statistics.median(plain):.2f}x; target <= 2x); report size "
          f"{out.stat().st_size / 1024:.0f} KiB")


if __name__ == "__main__":
    main()
