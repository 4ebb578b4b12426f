"""Latency of `grade ch06` on the reference solutions against `python -c "import numpy"`.

Both are timed in the same run, interleaved, with several repetitions; medians are compared.
Target: grade ch06 at most 1.5x the numpy import. For scale (quoted, not measured here):
otter-grader's `otter run` takes about 3.4 s for one submission with five H/J checks on this kind
of machine, nbgrader about 3.9 s.

Beside them it times the floor of the grader's own process: a bare interpreter importing exactly the
modules `grade ch06 --solutions` has imported when it ends (recorded from one run) and ending as the
command does, so the figure can be read against what importing numpy, click, pyyaml and the grader
alone costs.

    python benchmarks/latency.py [--repeat 15]
"""

from __future__ import annotations

import argparse
import compileall
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
from grader.system import SINGLE_THREADED_BLAS  # noqa: E402


def timed(command: list[str]) -> float:
    started = time.perf_counter()
    subprocess.run(command, cwd=ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, check=False)
    return time.perf_counter() - started


# Runs `grade ch06 --solutions` in this interpreter and writes the names of the modules it imported, as it ends.
_RECORD_MODULES = """import json, os, sys
leave, where = os._exit, sys.argv[1]
def record(code):
    with open(where, "w", encoding="utf-8") as out:
        json.dump(sorted(sys.modules), out)
    leave(code)
os._exit = record
sys.argv = ["grade", "ch06", "--solutions"]
from grader.launch import main
main()
"""


def imports_of_grade() -> list[str]:
    """A command importing what `grade ch06 --solutions` imports (its own grading process), and nothing else."""
    with tempfile.TemporaryDirectory() as scratch:
        names = os.path.join(scratch, "modules.json")
        subprocess.run([sys.executable, "-c", _RECORD_MODULES, names], cwd=ROOT, stdout=subprocess.DEVNULL,
                       check=True)
        with open(names, encoding="utf-8") as handle:
            modules = [m for m in json.load(handle) if m != "__main__"]
    # as grader.launch does: BLAS told to run single-threaded before numpy's import, and no teardown at the end;
    # Cython's own entries in sys.modules (cython_runtime, _cython_3_x) are not modules one can import
    body = (f"import importlib, os\nos.environ.update({SINGLE_THREADED_BLAS!r})\nfor name in {modules!r}:\n"
            "    try:\n        importlib.import_module(name)\n    except ModuleNotFoundError:\n        pass\n"
            "os._exit(0)\n")
    return [sys.executable, "-c", body]


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
        "its imports alone": imports_of_grade(),
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
    floor = statistics.median(samples["its imports alone"]) / baseline
    print(f"\ngrade ch06 / import numpy = {ratio:.2f}x with the quiz, {code:.2f}x code only (target <= 1.5x); "
          f"otter-grader's quoted 3.4 s would be {3.4 / baseline:.0f}x")
    print(f"importing what grade ch06 imports, and nothing else, is {floor:.2f}x: the rest of the command "
          f"(starting the child, planning, the quiz, judging, output) adds {ratio - floor:.2f}x")


if __name__ == "__main__":
    main()
