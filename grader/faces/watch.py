"""`grade ch06 --watch`: stay running and grade a chapter again each time its file is saved.

A resident door (grader.core.transaction.Door with resident=True: where the system allows, a fork server, a
sandboxed interpreter with numpy and the child side already imported) starts a fresh, confined child per
run (grader.core.transaction.grade_submission), and this process keeps the checks and the references imported, so a save costs only the run itself. The files are polled (a stat of a dozen
files every 50 ms: portable, no watcher library). After each run it prints the chapter's report and
what changed since the last run of that chapter: checks newly passing, newly failing. A syntax error
or an endless loop in the saved file is reported like any run and the watch goes on; Ctrl-C ends it.
"""

from __future__ import annotations

import re
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

from grader.boundary import Limits
from grader.chapters import BY_ID
from grader.core.pipeline import Request
from grader.core.transaction import Door, grade_submission
from grader.model import Report, Status
from grader.submission import Submission

POLL_SECONDS = 0.05


def _stamp(path: Path) -> tuple[int, int] | None:
    try:
        info = path.stat()
    except OSError:
        return None
    return info.st_mtime_ns, info.st_size


@dataclass
class Watcher:
    """Grades `chapters` of `submission` again whenever one of their files changes."""

    submission: Submission
    chapters: list[str]
    request: Request
    door: Door  # where each run's child comes from (resident)
    limits: Limits = field(default_factory=Limits)
    last: dict[str, dict[str, Status]] = field(default_factory=dict)  # chapter -> check id -> status

    def files(self) -> dict[Path, str]:
        """Every file that can change a watched chapter's grade, and the chapter it belongs to."""
        package = Path(self.submission.root) / self.submission.package
        found = {}
        for chapter in self.chapters:
            found[package / f"{BY_ID[chapter].module}.py"] = chapter
            found[package / f"{BY_ID[chapter].module}.ipynb"] = chapter  # a chapter kept as a notebook
            found[package / "answers" / f"{chapter}.yaml"] = chapter
        found[package / "answers" / "learner.yaml"] = "*"
        return found

    def snapshot(self) -> dict[Path, tuple[int, int] | None]:
        return {path: _stamp(path) for path in self.files()}

    def affected(self, changed: list[Path]) -> list[str]:
        """The chapters to grade again: those whose files changed, and watched chapters that import one."""
        files = self.files()
        direct = {files[p] for p in changed}
        if "*" in direct:
            return list(self.chapters)
        modules = [BY_ID[c].module for c in direct]
        for chapter in self.chapters:
            try:
                text = self.submission.chapter_file(BY_ID[chapter].module).read_text(encoding="utf-8", errors="replace")
            except OSError:
                continue
            if any(re.search(rf"\b{m}\b", text) for m in modules):
                direct.add(chapter)
        return [c for c in self.chapters if c in direct]

    def grade(self, chapters: list[str]) -> tuple[Report, float]:
        started = time.perf_counter()
        request = Request(tuple(chapters), self.request.seed, learner=self.request.learner, quiz=self.request.quiz,
                          functions=self.request.functions)
        report = grade_submission(self.submission, request, self.door, limits=self.limits).report
        return report, time.perf_counter() - started

    def changes(self, report: Report) -> list[str]:
        """What passes now that did not, and what fails now that passed, since the last run of each chapter."""
        lines = []
        for chapter in report.chapters:
            now = {c.id: c.status for c in chapter.checks}
            before = self.last.get(chapter.chapter)
            self.last[chapter.chapter] = now
            if before is None:
                continue
            better = [i for i, s in now.items() if s == Status.PASS and before.get(i) not in (None, Status.PASS)]
            worse = [i for i, s in now.items() if s != Status.PASS and before.get(i) == Status.PASS]
            if better:
                lines.append(f"{chapter.chapter}: newly passing: {', '.join(better)}")
            if worse:
                lines.append(f"{chapter.chapter}: newly failing: {', '.join(worse)}")
            if not better and not worse:
                lines.append(f"{chapter.chapter}: no check changed")
        return lines


def run(watcher: Watcher, show: Callable[[Report, list[str], float, list[str]], None],
        should_stop: Callable[[], bool] = lambda: False) -> None:
    """Grade everything once, then again on every change, until `should_stop` says so (or Ctrl-C)."""
    seen = watcher.snapshot()
    report, seconds = watcher.grade(watcher.chapters)
    show(report, watcher.changes(report), seconds, [])
    try:
        while not should_stop():
            time.sleep(POLL_SECONDS)
            now = watcher.snapshot()
            changed = [p for p in now if now[p] != seen.get(p)]
            if not changed:
                continue
            seen = now
            chapters = watcher.affected(changed)
            if chapters:
                report, seconds = watcher.grade(chapters)
                show(report, watcher.changes(report), seconds, [str(p.name) for p in changed])
    except KeyboardInterrupt:
        pass
