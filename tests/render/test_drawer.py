"""The HTML report's drawing process (grader.render.drawer): started before grading, it draws the figures
itself, survives the grader's cleanup of orphaned learner processes, and ends when the grader does."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
import time

import pytest

from grader.system import fork_is_safe
from tests.support import REPO

pytestmark = pytest.mark.skipif(not fork_is_safe(), reason="the drawing process is forked (Linux)")

SCRIPT = textwrap.dedent("""
    import os, sys
    from pathlib import Path
    from grader.boundary import spawn
    from grader.render import drawer, figures

    spawn.become_subreaper()
    assert drawer.start()
    process = drawer._STARTED[0][0]
    spawn.kill_orphans()  # what ending a learner's child does: our own drawing process is not an orphan

    from grader.core.grading import judge_chapters
    from tests.support import open_session
    session = open_session(Path(sys.argv[1]), "solutions")
    report = judge_chapters(session, ["ch01", "ch06", "ch08"], with_plots=True)

    def must_not_run(*args, **kwargs):
        raise AssertionError("the figures were drawn here, not by the drawing process")

    drawer._draw_in_two = figures.figures = must_not_run  # in this process only: the drawer forked before
    chapters = [c for c in report.chapters if c.plots]
    drawn = drawer.figures_due(chapters)()
    print(process.is_alive() or process.exitcode == 0, [len(f) for f in drawn],
          all(f.uri.startswith("data:image/svg+xml;base64,") for figures in drawn for f in figures))
""")


def test_the_drawing_process_draws_every_figure_and_outlives_the_cleanup_of_orphans():
    proc = subprocess.run([sys.executable, "-c", SCRIPT, str(REPO)], cwd=REPO, capture_output=True,
                          text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert proc.stdout.split() == ["True", "[1,", "1,", "1]", "True"], proc.stdout + proc.stderr[-2000:]


def test_an_unused_drawing_process_ends_with_the_grader():
    script = textwrap.dedent("""
        from grader.render import drawer
        assert drawer.start()
        print(drawer._STARTED[0][0].pid, flush=True)
    """)
    proc = subprocess.run([sys.executable, "-c", script], cwd=REPO, capture_output=True, text=True, timeout=60)
    assert proc.returncode == 0, proc.stderr[-2000:]
    pid = int(proc.stdout.split()[0])
    deadline = time.monotonic() + 20
    while time.monotonic() < deadline:
        try:
            os.kill(pid, 0)
        except ProcessLookupError:
            return
        time.sleep(0.1)
    pytest.fail(f"the drawing process {pid} outlived the grader that started it")


def test_no_drawing_process_is_started_while_another_thread_runs():
    """The same rule as every fork of drawing processes (grader.system.forkable_now): a fork copies only the calling thread."""
    script = textwrap.dedent("""
        import threading
        from grader.render import drawer
        release = threading.Event()
        threading.Thread(target=release.wait, daemon=True).start()
        assert not drawer.start() and not drawer._STARTED
        release.set()
    """)
    proc = subprocess.run([sys.executable, "-c", script], cwd=REPO, capture_output=True, text=True, timeout=60)
    assert proc.returncode == 0, proc.stderr[-2000:]


def test_the_drawing_processes_get_matplotlib_frozen_out_of_the_collectors_passes():
    """The drawing process imports matplotlib with the collector off and freezes what it made before it forks its
    drawing processes: their collections (on again) never walk matplotlib's objects."""
    script = textwrap.dedent("""
        import gc, types
        from grader.render import drawer, figures
        def said(chapter):  # what a drawing process says instead of drawing
            return [gc.get_freeze_count(), gc.isenabled()]
        figures.figures = said
        assert drawer.start()
        drawn = drawer.figures_due([types.SimpleNamespace(chapter="ch00"), types.SimpleNamespace(chapter="ch01")])()
        assert all(count > 10_000 and enabled for count, enabled in drawn), drawn
    """)
    proc = subprocess.run([sys.executable, "-c", script], cwd=REPO, capture_output=True, text=True, timeout=60)
    assert proc.returncode == 0, proc.stderr[-2000:]


def test_the_drawing_processes_yield_to_the_grading():
    """The drawing process and the two it forks run at a lower priority (nice 10) than the grader, whose grading is
    what the figures wait for."""
    script = textwrap.dedent("""
        import os, types
        from grader.render import drawer, figures
        def said(chapter):
            return [os.getpriority(os.PRIO_PROCESS, 0)]
        figures.figures = said
        assert drawer.start()
        mine = os.getpriority(os.PRIO_PROCESS, 0)
        drawn = drawer.figures_due([types.SimpleNamespace(chapter="ch00"), types.SimpleNamespace(chapter="ch01")])()
        assert all(nice == min(mine + 10, 19) for [nice] in drawn), (mine, drawn)
    """)
    proc = subprocess.run([sys.executable, "-c", script], cwd=REPO, capture_output=True, text=True, timeout=60)
    assert proc.returncode == 0, proc.stderr[-2000:]


def test_a_drawing_process_that_sent_its_figures_is_waited_for_when_the_command_ends_not_before():
    """Its figures come back at once; its own end (its drawing processes shut down first) is waited for by
    drawer.end, which the command calls once the page and the terminal's text are written."""
    script = textwrap.dedent("""
        import os, types
        from grader.render import drawer, figures
        def said(chapter):
            return [chapter.chapter]
        figures.figures = said
        assert drawer.start()
        process = drawer._STARTED[0][0]
        drawn = drawer.figures_due([types.SimpleNamespace(chapter="ch00"), types.SimpleNamespace(chapter="ch05")])()
        assert drawn == [["ch00"], ["ch05"]], drawn
        assert drawer._ENDING == [process]
        drawer.end()
        assert not drawer._ENDING and process.exitcode == 0 and not os.path.exists(f"/proc/{process.pid}")
    """)
    proc = subprocess.run([sys.executable, "-c", script], cwd=REPO, capture_output=True, text=True, timeout=60)
    assert proc.returncode == 0, proc.stderr[-2000:]


def test_the_pages_meanwhile_work_runs_once_the_figures_are_sent_to_be_drawn():
    """html.render sends the figures' data first; the caller's work (the terminal's text) and the rest of the page's
    cleaning happen while they are drawn."""
    script = textwrap.dedent("""
        import sys
        from pathlib import Path
        from grader.render import drawer, html
        assert drawer.start()
        from grader.core.grading import judge_chapters
        from tests.support import open_session
        session = open_session(Path(sys.argv[1]), "solutions")
        report = judge_chapters(session, ["ch06"], with_plots=True)
        sent = []
        page = html.render(report, meanwhile=lambda: sent.append(not drawer._STARTED))
        assert sent == [True] and page.count("data:image/svg+xml;base64,") == 1, sent
        drawer.end()
    """)
    proc = subprocess.run([sys.executable, "-c", script, str(REPO)], cwd=REPO, capture_output=True, text=True,
                          timeout=120)
    assert proc.returncode == 0, proc.stderr[-2000:]


def test_the_learners_child_starts_first_then_the_drawing_process_is_forked_with_numpy_imported(tmp_path):
    """The learner's child starts first (its start is what the learner waits on); then numpy is imported, once
    for the grader and the drawing process it forks (where matplotlib needs it), not again there."""
    script = textwrap.dedent("""
        import sys
        from grader.render import drawer
        assert "numpy" not in sys.modules
        assert drawer.start()
        assert "numpy" in sys.modules
    """)
    proc = subprocess.run([sys.executable, "-c", script], cwd=REPO, capture_output=True, text=True, timeout=60)
    assert proc.returncode == 0, proc.stderr[-2000:]
    environment = {**os.environ, "GRADER_TRACE": repr(time.time()), "GRADER_CACHE_DIR": ""}
    proc = subprocess.run([sys.executable, "-m", "grader", "ch06", "--solutions", "--html", str(tmp_path / "r.html")],
                          cwd=REPO, capture_output=True, text=True, env=environment, timeout=120)
    assert proc.returncode == 0, proc.stderr[-2000:]
    points = [line.split(" ms  ", 1)[1] for line in proc.stderr.splitlines() if line.startswith("trace ")]
    assert points.index("child started") < points.index("drawing process started"), points


@pytest.mark.slow
@pytest.mark.parametrize("extra", [[], ["--seed", "not-a-number"]], ids=["graded", "usage-error"])
def test_the_grade_command_leaves_no_drawing_process_behind(tmp_path, extra):
    """`grade ... --html` forks the drawing process early (grader.faces.launch, once the learner's child has started,
    before click parses the command line): when the command ends, graded (with every figure) or refused as misused, no process of
    it is left, not even for a moment. Forked processes keep the command line, which names the report."""
    from tests.support import processes_with

    out = tmp_path / "report-of-this-test.html"
    said = tmp_path / "said.txt"
    with said.open("wb") as output:  # a file, not a pipe: run() then waits for the command's own process only
        proc = subprocess.run([sys.executable, "-m", "grader", "ch01", "ch08", "--solutions", "--html", str(out),
                               *extra], cwd=tmp_path, stdout=output, stderr=output, timeout=120)
    text = said.read_text(encoding="utf-8")
    if extra:
        assert proc.returncode == 2 and "not-a-number" in text, text[-2000:]
    else:
        assert proc.returncode == 0, text[-2000:]
        assert out.read_text(encoding="utf-8").count("data:image/svg+xml;base64,") == 2  # one plot each
    assert not processes_with(str(out))  # stopped, not left to end by itself


@pytest.mark.slow
def test_a_drawing_process_that_died_is_reaped_and_the_figures_drawn_all_the_same(tmp_path):
    """If the drawing process is gone before the chapters reach it, the grader draws them itself and
    leaves no zombie behind (its /proc entry is gone, not in state Z)."""
    script = textwrap.dedent("""
        import os, signal, sys
        from pathlib import Path
        from grader.render import drawer
        assert drawer.start()
        process = drawer._STARTED[0][0]
        os.kill(process.pid, signal.SIGKILL)
        while Path(f"/proc/{process.pid}/stat").read_text().split()[2] != "Z":
            pass  # dead and unreaped: a zombie until someone waits for it

        from grader.core.grading import judge_chapters
        from tests.support import open_session
        session = open_session(Path(sys.argv[1]), "solutions")
        report = judge_chapters(session, ["ch06", "ch07"], with_plots=True)
        drawn = drawer.figures_due([c for c in report.chapters if c.plots])()
        print(os.path.exists(f"/proc/{process.pid}"), [len(f) for f in drawn],
              all(f.uri.startswith("data:image/svg+xml;base64,") for figures in drawn for f in figures))
    """)
    proc = subprocess.run([sys.executable, "-c", script, str(REPO)], cwd=REPO, capture_output=True, text=True,
                          timeout=120)
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert proc.stdout.split() == ["False", "[1,", "1]", "True"], proc.stdout + proc.stderr[-2000:]


@pytest.mark.slow
def test_figures_due_here_draws_them_in_this_process_alone():
    """`here` (a batch worker's report): every figure drawn by the calling process, neither by a started
    drawing process (which keeps its place, unsent) nor by two processes forked for it."""
    script = textwrap.dedent("""
        import sys
        from pathlib import Path
        from grader.render import drawer

        assert drawer.start()
        from grader.core.grading import judge_chapters
        from tests.support import open_session
        session = open_session(Path(sys.argv[1]), "solutions")
        report = judge_chapters(session, ["ch06", "ch07"], with_plots=True)

        def must_not_run(*args, **kwargs):
            raise AssertionError("the figures were drawn by processes forked for them")

        drawer._draw_in_two = drawer.two_processes = must_not_run
        drawn = drawer.figures_due([c for c in report.chapters if c.plots], here=True)()
        print(len(drawer._STARTED), [len(f) for f in drawn],
              all(f.uri.startswith("data:image/svg+xml;base64,") for figures in drawn for f in figures))
    """)
    proc = subprocess.run([sys.executable, "-c", script, str(REPO)], cwd=REPO, capture_output=True, text=True,
                          timeout=120)
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert proc.stdout.split() == ["1", "[1,", "1]", "True"], proc.stdout + proc.stderr[-2000:]


FIGURES_OF = textwrap.dedent("""
    import hashlib, json, sys, warnings
    warnings.simplefilter("error")  # the 3D toolkit held back during the import says nothing
    how = sys.argv[2]
    if how == "as matplotlib imports itself":
        import matplotlib.figure
    from grader.model import ChapterResult
    from grader.render import figures
    figures.preload()
    chapters = [ChapterResult.from_dict(c) for c in json.loads(open(sys.argv[1], encoding="utf-8").read())]
    digest = hashlib.sha256()
    for chapter in chapters:
        for figure in figures.figures(chapter):
            assert figure.uri, figure.caption
            digest.update(figure.uri.encode() + figure.alt.encode())
    from mpl_toolkits.mplot3d import Axes3D  # still there for whoever wants it
    from matplotlib.lines import Line2D
    Line2D([0], [0]).set(color="red", linewidth=2)  # set() works the same without its generated docstring
    from matplotlib import artist
    assert "linewidth" in artist.kwdoc(Line2D)  # put back once matplotlib.figure has loaded
    print(digest.hexdigest())
""")


def test_the_lighter_import_changes_no_figure(tmp_path):
    """preload skips what matplotlib's import builds for help() and its 3D toolkit: every figure is byte for byte
    what matplotlib imported as is draws."""
    import json

    from grader.core.grading import judge_chapters
    from tests.support import open_session

    session = open_session(REPO, "solutions")
    report = judge_chapters(session, [f"ch{n:02d}" for n in range(10)], with_plots=True)
    chapters = tmp_path / "chapters.json"
    chapters.write_text(json.dumps([c.to_dict() for c in report.chapters if c.plots]), encoding="utf-8")
    digests = {}
    for how in ("as matplotlib imports itself", "lighter"):
        proc = subprocess.run([sys.executable, "-c", FIGURES_OF, str(chapters), how], cwd=REPO, capture_output=True,
                              text=True, timeout=120)
        assert proc.returncode == 0, proc.stderr[-3000:]
        digests[how] = proc.stdout.strip()
    assert len(set(digests.values())) == 1, digests


@pytest.mark.slow
def test_a_batch_draws_the_class_summarys_figures_in_the_drawing_process_it_started(tmp_path):
    """`grade batch` starts the drawing process before grading: the class summary's figures (one per chapter, drawn
    for a class of grader.course.statistics.RELIABLE_LEARNERS or more) are drawn there, so the batch's own process never
    imports matplotlib, which it did at the end before."""
    import shutil

    from grader.course.statistics import RELIABLE_LEARNERS
    from tests.support import build_submission

    first = build_submission(tmp_path / "subs" / "learner00")
    for number in range(1, RELIABLE_LEARNERS):
        shutil.copytree(first, tmp_path / "subs" / f"learner{number:02d}")
    script = textwrap.dedent("""
        import re, sys
        from pathlib import Path
        from grader.course.batch import run_batch

        out = Path(sys.argv[1]) / "out"
        run_batch(Path(sys.argv[1]) / "subs", out, chapters=["ch01", "ch06"], jobs=2, seed=3, html=False)
        page = (out / "summary.html").read_text(encoding="utf-8")
        print("matplotlib" in sys.modules, len(re.findall("data:image/svg[+]xml", page)), "could not be drawn" in page)
    """)
    proc = subprocess.run([sys.executable, "-c", script, str(tmp_path)], cwd=REPO, capture_output=True, text=True,
                          timeout=300)
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert proc.stdout.split() == ["False", "2", "False"], proc.stdout + proc.stderr[-2000:]


def test_a_batch_too_small_for_the_summarys_figures_starts_no_drawing_process(tmp_path):
    """Below grader.course.statistics.RELIABLE_LEARNERS the class summary has no figures: a batch that small (a regrade of a
    few learners) forks no drawing process to import matplotlib for nothing."""
    from tests.support import build_submission

    for learner in ("ann", "bo"):
        build_submission(tmp_path / "subs" / learner)
    script = textwrap.dedent("""
        import sys
        from pathlib import Path
        from grader.course.batch import run_batch
        from grader.render import drawer

        run_batch(Path(sys.argv[1]) / "subs", Path(sys.argv[1]) / "out", chapters=["ch01"], jobs=1, seed=3, html=False)
        print(bool(drawer._STARTED or drawer._ENDING), "matplotlib" in sys.modules)
    """)
    proc = subprocess.run([sys.executable, "-c", script, str(tmp_path)], cwd=REPO, capture_output=True, text=True,
                          timeout=300)
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert proc.stdout.split() == ["False", "False"], proc.stdout + proc.stderr[-2000:]
