"""Cost of the HTML report: `grade all --html` against `grade all`, both on the reference solutions.

Interleaved repetitions in one run, medians compared. Target: at most 2x.

    python benchmarks/report.py [--repeat 5]
"""

from __future__ import annotations

import argparse
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
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
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
    base = statistics.median(samples["grade all --solutions"])
    for name, values in samples.items():
        print(f"{name:<32} median {statistics.median(values):6.3f} s  min {min(values):6.3f} s")
    ratio = statistics.median(samples["grade all --solutions --html"]) / base
    print(f"\n--html / plain = {ratio:.2f}x (target <= 2x); report size {out.stat().st_size / 1024:.0f} KiB")


if __name__ == "__main__":
    main()
