"""What running a course costs on top of grading: a batch of generated submissions (right, buggy and
hostile mixed, all chapters and quizzes) graded once, then rebuilt with nothing new (the history, the
overrides, changes.csv and every export from it), then rebuilt with --similarity (copydetect over every
pair). Prints the seconds of each and the size of OUT/gradebook.db after them.

    python benchmarks/course_admin.py [--count 300] [--jobs N]
"""

from __future__ import annotations

import argparse
import os
import sqlite3
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from benchmarks.batch import make, run_batch  # noqa: E402


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--count", type=int, default=300)
    parser.add_argument("--jobs", type=int, default=None)
    args = parser.parse_args()
    env = dict(os.environ)
    with tempfile.TemporaryDirectory(prefix="course-admin-") as temporary:
        submissions, out = Path(temporary) / "submissions", Path(temporary) / "out"
        make(submissions, args.count)
        timings = {}
        for name, extra in (("grade batch (all graded)", ("--no-html",)),
                            ("rebuild, nothing new", ("--no-html",)),
                            ("rebuild with --similarity", ("--no-html", "--similarity"))):
            wall, _, said = run_batch(submissions, out, args.jobs, env, extra)
            timings[name] = wall
            print(f"{name:<28} {wall:7.1f} s   {said.splitlines()[0] if said else ''}")
        size = (out / "gradebook.db").stat().st_size
        with sqlite3.connect(out / "gradebook.db") as db:
            rows = db.execute("SELECT count(*) FROM results").fetchone()[0]
        print(f"similarity costs {timings['rebuild with --similarity'] - timings['rebuild, nothing new']:.1f} s for "
              f"{args.count} learners ({args.count * (args.count - 1) // 2} pairs)")
        print(f"gradebook.db: {size / 1024:.0f} KiB after 3 runs ({rows} result rows, "
              f"{size / max(rows, 1):.0f} bytes per learner and run)")


if __name__ == "__main__":
    main()
