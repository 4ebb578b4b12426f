"""The batch benchmark's floor (benchmarks/batch.py --learner-side) runs what it says it runs: every learner's calls,
behind the batch's sandbox, read back. A floor that silently ran nothing (a broken boundary, a request the child
could not read) would print a flattering figure; here a right submission must answer every call (a value, or the
exception the contract asks for), and a learner whose function ends the process must not."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from tests.support import BWRAP, build_submission, replace_function

REPO = Path(__file__).resolve().parents[1]

pytestmark = [pytest.mark.slow, pytest.mark.skipif(BWRAP is None and not os.environ.get("CI"),
                                                   reason="bubblewrap (bwrap) is not installed")]


def _floor(folder: Path) -> dict:
    done = subprocess.run([sys.executable, str(REPO / "benchmarks" / "batch.py"), "--learner-side", str(folder),
                           "--jobs", "1"], cwd=REPO, capture_output=True, text=True, encoding="utf-8", timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    return json.loads(done.stdout.strip().splitlines()[-1])


def test_the_floor_runs_every_call_of_every_learner(tmp_path: Path) -> None:
    build_submission(tmp_path / "right" / "a")
    build_submission(tmp_path / "right" / "b")
    figures = _floor(tmp_path / "right")
    assert figures["learners"] == 2
    assert figures["calls"] > 2 * 500  # every chapter's planned calls, per learner
    assert figures["answered"] == figures["calls"]
    assert figures["seconds"] > 0 and figures["cpu"] is not None and figures["cpu"] > 0


def test_the_floor_counts_only_what_came_back(tmp_path: Path) -> None:
    exits = replace_function("ch06_measurement", "H_jacobian",
                             "def H_jacobian(x, y):\n    import os\n    os._exit(3)\n")
    build_submission(tmp_path / "hostile" / "a", {"ch06_measurement": exits})
    figures = _floor(tmp_path / "hostile")
    assert 0 < figures["answered"] < figures["calls"]


def test_the_floor_sends_each_chapters_calls_encoded_once_as_a_batch_worker_does() -> None:
    """A batch worker sends every learner the calls its memo keeps with their JSON text (grader.core.memo.Memo.calls);
    a floor that encoded them again for each learner would count work the batch does not do."""
    from benchmarks.batch import _encoded_once
    from grader.boundary.wire import EncodedCalls
    from grader.chapters import CHAPTERS
    from grader.core.grading import DEFAULT_SEED, _plan

    for chapter in CHAPTERS:
        request = _encoded_once(chapter.id, chapter.module)
        planned = _plan(chapter.id, DEFAULT_SEED, False, frozenset()).calls
        assert (request.chapter, request.module) == (chapter.id, chapter.module)
        assert isinstance(request.calls, EncodedCalls)
        assert json.loads(request.calls.text) == json.loads(json.dumps([c.to_json(i) for i, c in enumerate(planned)]))
