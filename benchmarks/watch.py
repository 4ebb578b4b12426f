"""Save-to-output time of `grade ch06 --watch`: a right and a one-bug H_jacobian saved in turn, each time
from the save to the end of the updated output, against one cold `grade ch06` on the same files timed in
the same run. Target: 100 ms from save to output.

    python benchmarks/watch.py [--saves 12]
"""

from __future__ import annotations

import argparse
import queue
import re
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from tests.support import build_submission  # noqa: E402

RIGHT_H = "    return np.array([[x / r, y / r], [-y / r2, x / r2]])"
WRONG_H = "    return np.array([[x / r, y / r], [y / r2, x / r2]])"
DONE = "watching for saves"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--saves", type=int, default=12)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as folder:
        root = build_submission(Path(folder) / "learner")
        chapter = root / "exercises" / "ch06_measurement.py"
        right = chapter.read_text(encoding="utf-8")
        if RIGHT_H not in right:
            raise SystemExit("the reference H_jacobian changed: update RIGHT_H")
        cold = []
        for _ in range(3):
            started = time.perf_counter()
            subprocess.run([sys.executable, "-m", "grader", "ch06", "--no-quiz", "--submission", str(root)],
                           cwd=ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, check=False)
            cold.append(time.perf_counter() - started)
        process = subprocess.Popen([sys.executable, "-m", "grader", "ch06", "--watch", "--no-quiz", "--submission",
                                    str(root)], cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                                   text=True, encoding="utf-8")
        lines: queue.Queue = queue.Queue()
        threading.Thread(target=lambda: [lines.put((time.perf_counter(), line)) for line in process.stdout],
                         daemon=True).start()

        def until_done(timeout: float = 30.0) -> tuple[float, list[str]]:
            seen, end = [], time.monotonic() + timeout
            while time.monotonic() < end:
                try:
                    when, line = lines.get(timeout=0.5)
                except queue.Empty:
                    continue
                seen.append(line)
                if DONE in line:
                    return when, seen
            raise SystemExit("the watch printed no update in time:\n" + "".join(seen[-20:]))

        try:
            until_done(60)
            after_save, own = [], []
            for i in range(args.saves):
                time.sleep(0.3)  # saves a learner would make, not a burst
                text = right.replace(RIGHT_H, WRONG_H) if i % 2 == 0 else right
                saved = time.perf_counter()
                chapter.write_text(text, encoding="utf-8")
                when, seen = until_done()
                after_save.append(when - saved)
                own += [int(m.group(1)) for line in seen if (m := re.search(r"graded ch06 in (\d+) ms", line))]
        finally:
            process.terminate()
            process.wait(timeout=10)
    median = statistics.median(after_save)
    print(f"cold grade ch06 --no-quiz:              median {statistics.median(cold) * 1000:6.0f} ms")
    print(f"--watch, save to updated output:        median {median * 1000:6.0f} ms  max {max(after_save) * 1000:.0f} ms"
          f"  ({len(after_save)} saves; the files are polled every 50 ms)")
    if own:
        print(f"--watch, its own 'graded in' figure:    median {statistics.median(own):6.0f} ms")
    print(f"\nsave to output = {median * 1000:.0f} ms = {median / 0.1:.2f}x the 100 ms target; "
          f"{median / statistics.median(cold):.2f}x a cold grade ch06")


if __name__ == "__main__":
    main()
