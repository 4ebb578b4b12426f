"""The documentation: the README is the entry point (under 200 lines, every link it gives leads somewhere), the site
in docs/ builds with MkDocs with warnings as errors (its command reference made from the commands themselves), and no
page tells how the project was written (sessions, commit hashes, before-and-after narrative), which a reader cannot
act on."""

from __future__ import annotations

import re
import subprocess
import sys

import pytest

from tests.support import REPO

PAGES = [REPO / "README.md", REPO / "benchmarks" / "README.md", *sorted((REPO / "docs" / "pages").glob("*.md"))]
HISTORY = re.compile(r"\b(first|second|third|fourth|fifth|sixth|seventh|eighth|ninth|tenth|this|that|last|next) "
                     r"session\b|\bcommit [0-9a-f]{7}|\b[0-9a-f]{7}\b(?= \(|,| beside| in a worktree)", re.IGNORECASE)


def test_the_readme_is_the_entry_point():
    text = (REPO / "README.md").read_text(encoding="utf-8")
    assert len(text.splitlines()) < 200
    for target in re.findall(r"\]\(([^)#]+)\)", text):
        if not target.startswith("http"):
            assert (REPO / target).exists(), target


@pytest.mark.parametrize("page", PAGES, ids=lambda p: str(p.relative_to(REPO)))
def test_no_page_tells_how_the_project_was_written(page):
    found = [line for line in page.read_text(encoding="utf-8").splitlines() if HISTORY.search(line)]
    assert found == []


def test_a_history_sentence_is_caught():
    assert HISTORY.search("2026-11-26 (fourth session), against c58d2ff beside it")
    assert not HISTORY.search("a grading session opens behind the door; the child's session ends")


def test_the_site_builds_without_warnings_and_lists_every_command(tmp_path):
    pytest.importorskip("mkdocs")
    pytest.importorskip("mkdocs_click")
    done = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "-f", str(REPO / "docs" / "mkdocs.yml"),
                           "-d", str(tmp_path / "site")], capture_output=True, text=True, encoding="utf-8")
    assert done.returncode == 0, done.stderr[-3000:]
    reference = (tmp_path / "site" / "cli" / "index.html").read_text(encoding="utf-8")
    from grader.faces.commands import COMMANDS, DEFAULT

    for name in COMMANDS:
        if name != DEFAULT:  # `grade ch06` is `grade run ch06`: the default's options are under `grade`
            assert f'id="grade-{name}"' in reference, name
    assert reference.count('id="grade') > len(COMMANDS)
