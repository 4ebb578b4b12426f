"""Cost of the HTML report: `grade all --html` against `grade all`, both on the reference solutions.

Three cases of the report, as a learner meets them (grader.render.figure_cache, grader.core.memo):
- first run: nothing kept, every figure drawn (GRADER_CACHE_DIR empty: no cache);
- one chapter changed: every chapter's figures kept from the last run but ch06's, which is drawn;
- nothing changed: every figure and verdict reused from the last run, nothing drawn.
Each against `grade all` with nothing kept, and the re-runs also against `grade all` run again with what it keeps.

Interleaved repetitions in one run (each `--html` run right after its plain one, so both meet the same
machine: on shared cores its speed drifts by a quarter within minutes); each figure is the median of those
paired ratios, with the ratio of the two medians beside it. The grader's files are compiled first, as a
learner's install has them. Targets: at most 2x (first run), 1.5x (re-runs).

    python benchmarks/report.py [--repeat 9]
"""

from __future__ import annotations

import argparse
import compileall
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def timed(command: list[str], cache: str) -> float:
    environment = {**os.environ, "GRADER_CACHE_DIR": cache}
    started = time.perf_counter()
    subprocess.run(command, cwd=ROOT, env=environment, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                   check=True)
    return time.perf_counter() - started


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=9)
    args = parser.parse_args()
    for folder in ("grader", "solutions", "exercises"):  # the steady state a learner sees
        compileall.compile_dir(str(ROOT / folder), quiet=1)
    scratch = Path(tempfile.mkdtemp())
    out, kept = scratch / "report.html", scratch / "cache"
    plain = [sys.executable, "-m", "grader", "all", "--solutions"]
    html = [*plain, "--html", str(out)]
    cases = {  # name: (command, GRADER_CACHE_DIR, what to do before each run)
        "grade all --solutions": (plain, "", None),
        "grade all --solutions, re-run": (plain, str(kept), None),
        "--html, first run": (html, "", None),
        "--html, one chapter changed": (html, str(kept), lambda: (kept / "figures" / "ch06.json").unlink()),
        "--html, nothing changed": (html, str(kept), None),
    }
    timed(html, str(kept))  # keeps every chapter's figures
    samples: dict[str, list[float]] = {name: [] for name in cases}
    for _ in range(args.repeat):
        for name, (command, cache, before) in cases.items():
            if before:
                before()
            samples[name].append(timed(command, cache))
    for name, values in samples.items():
        print(f"{name:<32} median {statistics.median(values):6.3f} s  spread {min(values):6.3f} to {max(values):6.3f} s")
    print()
    base, warm = samples["grade all --solutions"], samples["grade all --solutions, re-run"]
    for name, values in list(samples.items())[2:]:
        paired = statistics.median(h / p for h, p in zip(values, base))
        target = "2x" if "first" in name else "1.5x"
        again = "" if "first" in name else (f"; against `grade all` run again with what it keeps (its verdicts, its "
                                            f"sandbox), {statistics.median(h / p for h, p in zip(values, warm)):.2f}x")
        print(f"{name:<32} {paired:.2f}x grade all, the median of {len(base)} paired runs (ratio of the medians "
              f"{statistics.median(values) / statistics.median(base):.2f}x; target <= {target}){again}")
    print(f"report size {out.stat().st_size / 1024:.0f} KiB")

if __name__ == "__main__":
    main()
