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


def test_a_worker_settles_with_the_batch_collection():
    """After its first learner a worker freezes what it imported and collects as a batch for the rest of its life."""
    code = ("import gc\nfrom grader.course import workers\nworkers._settle_heap()\n"
            "print(gc.get_threshold(), gc.get_freeze_count() > 0)")
    shown = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert shown.strip() == f"{BATCH_COLLECTION} True"
