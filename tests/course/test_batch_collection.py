"""The garbage collector in a batch: fewer young passes in the coordinator and the workers, and the coordinator's
collector as it was once the batch is done."""

from __future__ import annotations

import gc
import subprocess
import sys

from grader.course.batch import run_batch
from grader.course.workers import BATCH_COLLECTION, collecting_as_a_batch
from tests.support import build_submission


def test_the_coordinator_collects_as_a_batch_while_it_grades_and_as_before_after(tmp_path):
    folder = tmp_path / "submissions"
    build_submission(folder / "alice")
    during = []
    before = gc.get_threshold()
    gc.set_threshold(700, 10, 10)
    try:
        run_batch(folder, tmp_path / "out", chapters=["ch03"], jobs=1, seed=4, html=False,
                  progress=lambda *_: during.append(gc.get_threshold()))
        assert during == [BATCH_COLLECTION]
        assert gc.get_threshold() == (700, 10, 10)
    finally:
        gc.set_threshold(*before)


def test_the_collector_is_put_back_when_the_batch_raises():
    before = gc.get_threshold()
    try:
        with collecting_as_a_batch():
            assert gc.get_threshold() == BATCH_COLLECTION
            raise KeyError("a broken batch")
    except KeyError:
        pass
    assert gc.get_threshold() == before


def test_a_local_workers_collector_is_the_batchs_and_a_cluster_workers_its_own(tmp_path):
    """A local pool's worker collects as the batch does from its first learner on; grading a staged learner as a
    cluster's worker does (grade_staged) leaves that process's collector as it was."""
    build_submission(tmp_path / "alice")
    code = ("import gc, sys\nfrom pathlib import Path\nfrom grader.course import workers\n"
            "from grader.course.staging import discover\nfrom grader.course_config import current\n"
            "gc.set_threshold(700, 10, 10)\n"
            "grading = workers.Grading(('ch03',), 4, False, False, {}, 'required', frozenset(), current(None))\n"
            "entry = discover(Path(sys.argv[1]))[0]\n"
            "staged = workers.stage_one(entry, Path(sys.argv[2]), grading)\n"
            "workers.grade_staged(staged, grading)\nprint(gc.get_threshold())\n"
            "workers._grade_one(entry, sys.argv[2], grading, (), None, True)\nprint(gc.get_threshold())\n")
    (tmp_path / "out").mkdir()
    shown = subprocess.run([sys.executable, "-c", code, str(tmp_path), str(tmp_path / "out")], capture_output=True,
                           text=True, check=True).stdout.split("\n")
    assert shown[:2] == [str((700, 10, 10)), str(BATCH_COLLECTION)]
