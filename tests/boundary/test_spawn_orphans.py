"""Finding this process's children, adopted orphans among them (grader.boundary.spawn): the kernel's children lists
and the scan of every process's parent find the same processes."""

from __future__ import annotations

import subprocess
import sys

import pytest

from grader.boundary.spawn import _children


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="/proc")
def test_the_kernels_children_lists_and_the_scan_of_proc_find_the_same_children():
    sleepers = [subprocess.Popen([sys.executable, "-c", "import time; time.sleep(30)"]) for _ in range(3)]
    try:
        listed, scanned = set(_children()), set(_children(scan=True))
        assert {p.pid for p in sleepers} <= listed
        assert listed == scanned
    finally:
        for sleeper in sleepers:
            sleeper.kill()
            sleeper.wait()
