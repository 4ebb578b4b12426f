"""Latency of `grade ch06` against `python -c "import numpy"`, and the floors it sits on, timed in the same run.

Every command is timed as a whole process, the commands interleaved round after round (paired runs), each
printed as its median and spread over the rounds and as a ratio to the numpy import's median of the same run.
Target: `grade ch06` (a right submission and the stubs, quiz included, sandbox on) at most 1.5x the numpy import.

What is timed (the grader's caches in a private folder, warmed by one run first, as on a learner's machine
after their first `grade`):
- `grade ch06 --solutions` and `grade ch06` on the stubs, run again with the answers unchanged: the kept
  sandbox starts the child first, and the kept verdicts are reused (grader.core.memo);
- the same with a function changed before every run (a new constant each time): the checks whose calls now answer
  otherwise are judged afresh, by the judge the previous run kept warm (grader.core.warm_judge), so the command
  imports neither numpy nor the checks; and with a syntax error made anew before every run;
- the first run of all, with nothing kept (a fresh cache folder each time): the door decides, the sandbox's
  folders are prepared, every chapter is planned and judged;
- without the sandbox (so nothing is reused either: learner code could write the memo);
- the floors: bubblewrap with the grader's allow-list starting a bare interpreter, and the child's path alone
  (bubblewrap, the child's interpreter, numpy, the chapter and its calls, from a launcher that starts it with a
  ready request and reads its lines to the end).

    python benchmarks/latency.py [--repeat 15] [--trace]
"""

from __future__ import annotations

import argparse
import compileall
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from tests.support import build_submission, replace_function  # noqa: E402

# Starts the sandboxed child behind the kept sandbox with a ready request (argv[1], JSON) and reads its lines to
# the end: the child's path, with nothing of the grader's own work beside it.
_CHILD_PATH = """import json, os, sys
from grader.boundary import kept
from grader.system import read_chunk
with open(sys.argv[1], encoding="utf-8") as handle:
    request = json.load(handle)
prefix, child = kept.start("auto")
child.send(json.dumps(request))
buffer = b""
while b'"done"' not in buffer:
    chunk = read_chunk(child.read_fd, 30)
    if not chunk:
        break
    buffer += chunk
child.stop(0)
os._exit(0 if b'"done"' in buffer else 1)
"""

_CHANGED = """def range_bearing(x, y):
    return np.array([np.hypot(x, y) * {scale!r}, np.arctan2(y, x)])
"""
_SYNTAX_ERROR = """def range_bearing(x, y):
    return np.array([np.hypot(x, y) * {scale!r} np.arctan2(y, x)])
"""


def timed(command: list[str], env: dict) -> float:
    started = time.perf_counter()
    subprocess.run(command, cwd=ROOT, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, check=False)
    return time.perf_counter() - started


def ready_request(root: Path, cache: Path, env: dict) -> Path:
    """The ch06 request `grade` sends (the memo's kept calls, the submission's files), as the child's path gets it."""
    from grader.boundary.session import Limits
    from grader.submission import Submission

    subprocess.run([sys.executable, "-m", "grader", "ch06", "--no-quiz", "--submission", str(root)], cwd=ROOT,
                   env=env, stdout=subprocess.DEVNULL, check=True)
    kept = json.loads((cache / "results" / "ch06.json").read_text(encoding="utf-8"))
    request = {"package": "exercises", "files": Submission(root).prepare().files, "limits": Limits().rlimits(),
               "chapters": [{"chapter": "ch06", "module": "ch06_measurement", "calls": next(iter(kept["plans"].values()))}]}
    path = cache / "request.json"
    path.write_text(json.dumps(request), encoding="utf-8")
    return path


def trace(root: Path, env: dict, runs: int = 5) -> None:
    """Where the time of `grade ch06` goes: the command's own trace points (GRADER_TRACE), median per point."""
    points: dict[str, list[float]] = {}
    for _ in range(runs):
        done = subprocess.run([sys.executable, "-m", "grader", "ch06", "--submission", str(root)], cwd=ROOT,
                              env=dict(env, GRADER_TRACE=repr(time.time())), capture_output=True, text=True,
                              check=False)
        for line in done.stderr.splitlines():
            if line.startswith("trace "):
                at, what = line[6:].split(" ms  ", 1)
                points.setdefault(what, []).append(float(at))
    for what, values in points.items():
        print(f"  {statistics.median(values):6.1f} ms  {what}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=15)
    parser.add_argument("--trace", action="store_true", help="also print where a re-run's time goes")
    args = parser.parse_args()
    for folder in ("grader", "solutions", "exercises"):  # the steady state a learner sees
        compileall.compile_dir(str(ROOT / folder), quiet=1)
    scratch = Path(tempfile.mkdtemp(prefix="latency-"))
    try:
        run(scratch, args)
    finally:
        shutil.rmtree(scratch, ignore_errors=True)


def run(scratch: Path, args) -> None:
    cache = scratch / "cache"
    env = dict(os.environ, GRADER_CACHE_DIR=str(cache))
    right = build_submission(scratch / "right")
    changing = build_submission(scratch / "changing")
    broken = build_submission(scratch / "broken")
    fresh = [0]

    def change_a_function(template: str = _CHANGED, folder: Path = changing) -> None:
        fresh[0] += 1  # a new constant each time: the chapter's answers differ from every kept run
        source = replace_function("ch06_measurement", "range_bearing", template.format(scale=1 + fresh[0] * 1e-9))
        (folder / "exercises" / "ch06_measurement.py").write_text(source.replace("solutions.", "exercises."),
                                                                encoding="utf-8")

    def empty_cache() -> None:
        shutil.rmtree(scratch / "first", ignore_errors=True)

    grade = [sys.executable, "-m", "grader"]
    request = ready_request(right, cache, env)
    prefix = subprocess.run([sys.executable, "-c", "from grader.boundary import kept; print(*kept.wrapper('auto'), "
                             "sep=chr(0))"], cwd=ROOT, env=env, capture_output=True, text=True,
                            check=True).stdout.rstrip("\n").split("\0")  # as `grade` sees it (its sys.path)
    commands: dict[str, tuple[list[str], dict, Callable[[], None] | None]] = {
        "python -c 'import numpy'": ([sys.executable, "-c", "import numpy"], env, None),
        "grade ch06 --solutions": ([*grade, "ch06", "--solutions"], env, None),
        "grade ch06 (stubs)": ([*grade, "ch06"], env, None),
        "  a right submission": ([*grade, "ch06", "--submission", str(right)], env, None),
        "  a function changed": ([*grade, "ch06", "--submission", str(changing)], env, change_a_function),
        "  a syntax error made": ([*grade, "ch06", "--submission", str(broken)], env,
                                  lambda: change_a_function(_SYNTAX_ERROR, broken)),
        "  first run, nothing kept": ([*grade, "ch06", "--solutions"], dict(env, GRADER_CACHE_DIR=str(scratch / "first")),
                                      empty_cache),
        "  without the sandbox": ([*grade, "ch06", "--solutions", "--no-sandbox"], env, None),
        "grade all --solutions": ([*grade, "all", "--solutions"], env, None),
        "floor: bubblewrap alone": ([*prefix, sys.executable, "-I", "-S", "-c", ""], env, None),
        "floor: the child's path": ([sys.executable, "-c", _CHILD_PATH, str(request)], env, None),
    }
    for name, (command, environment, before) in commands.items():  # warm the page cache and the grader's caches
        for _ in range(2):
            if before:
                before()
            timed(command, environment)
        if name.startswith("floor") and subprocess.run(command, cwd=ROOT, env=environment, stdout=subprocess.DEVNULL,
                                                      stderr=subprocess.DEVNULL, check=False).returncode != 0:
            raise SystemExit(f"{name}: {' '.join(command[:6])} ... failed, so it would time nothing")
    samples: dict[str, list[float]] = {name: [] for name in commands}
    for _ in range(args.repeat):
        for name, (command, environment, before) in commands.items():
            if before:
                before()
            samples[name].append(timed(command, environment))
    baseline = statistics.median(samples["python -c 'import numpy'"])
    print(f"{args.repeat} paired runs; each command's median, its spread (lowest to highest) and its median / the "
          "numpy import's")
    print(f"{'command':<30} {'median s':>9} {'spread s':>15} {'x numpy':>8}")
    for name, values in samples.items():
        median = statistics.median(values)
        print(f"{name:<30} {median:9.3f} {min(values):7.3f}-{max(values):.3f} {median / baseline:8.2f}")

    def ratio(name: str) -> float:
        return statistics.median(samples[name]) / baseline

    print(f"\ngrade ch06 / import numpy = {ratio('grade ch06 --solutions'):.2f}x (--solutions), "
          f"{ratio('grade ch06 (stubs)'):.2f}x (stubs), {ratio('  a right submission'):.2f}x (a right submission) "
          f"(target <= 1.5x); with a function changed {ratio('  a function changed'):.2f}x (target <= 1.5x), a "
          f"syntax error {ratio('  a syntax error made'):.2f}x, the first run {ratio('  first run, nothing kept'):.2f}x")
    print(f"floors: bubblewrap alone {ratio('floor: bubblewrap alone'):.2f}x, the child's path "
          f"{ratio('floor: the child' + chr(39) + 's path'):.2f}x; otter-grader's quoted 3.4 s for one notebook "
          f"would be {3.4 / baseline:.0f}x")
    if args.trace:
        print("\nwhere the time of a re-run of `grade ch06` on a right submission goes (medians):")
        trace(right, env)


if __name__ == "__main__":
    main()
