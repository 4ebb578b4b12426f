"""WCAG 2.1 AA for the HTML report: axe-core, run in a real headless chromium (Debian's), finds no
violation in the report file of the untouched stubs, of a right and of a partly right submission, nor
in the fragment a notebook shows inline (in a light and in a dark notebook page).

axe-core comes from the `axe-playwright-python` wheel (the test extra), which ships axe.min.js; the
browser is driven by playwright, as in tests/render/test_html.py.
"""

from __future__ import annotations

import os
import shutil
from html.parser import HTMLParser
from pathlib import Path

import pytest

from grader.chapters import CHAPTERS
from tests.support import (
    grade_json,
    run_grade,
    unbarred,
)

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
CHROMIUM_FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                  "--disable-background-networking", "--disable-component-update", "--disable-sync"]

pytestmark = [pytest.mark.slow,  # a real browser and axe-core; the report's HTML is checked fast in test_outputs_safety
              pytest.mark.skipif(CHROMIUM is None and not os.environ.get("CI"),
                                 reason="Debian's chromium is not installed (apt-get install chromium)")]


def _axe_script() -> str:
    """axe.min.js as the axe-playwright-python wheel ships it (CI must have it: no skip there)."""
    if os.environ.get("CI"):
        import axe_playwright_python
    else:
        axe_playwright_python = pytest.importorskip("axe_playwright_python")
    return (Path(axe_playwright_python.__file__).parent / "axe.min.js").read_text(encoding="utf-8")


def _sync_api():
    if os.environ.get("CI"):
        return __import__("playwright.sync_api", fromlist=["sync_playwright"])
    return pytest.importorskip("playwright.sync_api")


def axe(html: Path, context: str | None = None) -> dict:
    """axe-core's results for the page at `html` (every rule axe runs by default: WCAG 2.0/2.1 A and
    AA, and its best practices), in headless chromium; `context` limits the run to a CSS selector."""
    assert CHROMIUM, "CI must have chromium (.ci/run installs it)"
    script = _axe_script()
    with _sync_api().sync_playwright() as playwright:
        browser = playwright.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_FLAGS)
        try:
            page = browser.new_page(viewport={"width": 1100, "height": 900})
            page.goto(html.resolve().as_uri(), wait_until="load")
            page.evaluate(script)
            assert page.evaluate("typeof axe") == "object", "axe-core did not load (the page's CSP?)"
            return page.evaluate("([context]) => axe.run(context || document, {resultTypes: ['violations']})",
                                 [context])
        finally:
            browser.close()


def summary(results: dict) -> str:
    """One line per violation: rule, impact, how many elements, and the first element's snippet."""
    return "\n".join(f"{v['id']} ({v['impact']}): {len(v['nodes'])} element(s), e.g. "
                     f"{v['nodes'][0]['html'][:160]} -- {v['nodes'][0].get('failureSummary', '')[:300]}"
                     for v in results["violations"])


def _replace(source: str, function: str, new_source: str) -> str:
    """`source` with its top-level function `function` replaced by `new_source`."""
    import re

    pattern = re.compile(rf"^def {function}\(.*?(?=^\S)", re.S | re.M)
    changed, count = pattern.subn(lambda _: new_source + "\n\n", source + "\n#end\n", count=1)
    assert count == 1, f"{function} not found"
    return changed


def partly_right(root: Path, repo_root: Path) -> Path:
    """A submission with every kind of verdict: right chapters, a wrong matrix (ch06), a function not
    written (ch07), a check not judged because of another function (ch03), wrong curves (ch05, ch00),
    a chapter that does not import (ch08), learner text with markup (ch09), and quiz answers partly
    wrong and partly missing."""
    from tests.support import build_submission, replace_function

    sources = {
        "ch06_measurement": replace_function(
            "ch06_measurement", "H_jacobian",
            "def H_jacobian(x, y):\n    r2 = x * x + y * y\n    r = np.sqrt(r2)\n"
            "    return np.array([[x / r, y / r], [y / r2, x / r2]])\n"),
        "ch03_jacobian": _replace(replace_function(
            "ch03_jacobian", "polar_to_cartesian_jacobian",
            "def polar_to_cartesian_jacobian(r, theta):\n"
            "    return np.array([[np.cos(theta), -r * np.sin(theta)], [np.sin(theta), np.cos(theta)]])\n"),
            "area_scale", "def area_scale(r, theta):\n    return float(r)\n"),
        "ch07_dynamics": replace_function(
            "ch07_dynamics", "F_jacobian", "def F_jacobian(state, v, omega, dt):\n    raise NotImplementedError\n"),
        "ch05_finite_differences": replace_function(
            "ch05_finite_differences", "central_difference",
            "def central_difference(f, x, h):\n    return (f(x + h) - f(x)) / h\n"),
        "ch00_range_sensor": replace_function(
            "ch00_range_sensor", "mean_shift",
            "def mean_shift(mean, sigma, n, seed):\n    return sigma / 10\n"),
        "ch08_lab": "import numpy as np\n\ndef measure_samples(samples, ref_bearing)\n    return samples\n",
        "ch09_choose_your_tool": replace_function(
            "ch09_choose_your_tool", "classify_critical_point",
            "def classify_critical_point(hessian):\n    return '<b>saddle</b> & $x$'\n"),
    }
    build_submission(root, sources)
    answers = root / "exercises" / "answers"
    answers.mkdir()
    for source in sorted((repo_root / "solutions" / "answers").glob("*.yaml")):
        if source.name != "ch02.yaml":  # ch02's quiz left unanswered
            (answers / source.name).write_text(source.read_text(encoding="utf-8"), encoding="utf-8")
    ch06 = answers / "ch06.yaml"
    ch06.write_text(ch06.read_text(encoding="utf-8").replace('bearing_near_dish: "a"', 'bearing_near_dish: "b"'),
                    encoding="utf-8")
    return root


@pytest.fixture(scope="module")
def reports(repo_root, tmp_path_factory) -> dict[str, tuple[Path, dict]]:
    """The `--html` reports of the untouched stubs, the reference solutions and a partly right submission."""
    folder = tmp_path_factory.mktemp("a11y")
    submission = partly_right(folder / "partly", repo_root)
    out = {}
    for name, args in (("stubs", ["all"]), ("solutions", ["all", "--solutions"]),
                       ("partly", ["all", "--submission", str(submission)])):
        path = folder / f"{name}.html"
        out[name] = (path, grade_json(*args, html=path, cwd=repo_root))
    return out


def test_partly_right_has_every_verdict(reports):
    statuses = {c["status"] for ch in reports["partly"][1]["chapters"] for c in ch["checks"]}
    assert {"pass", "fail", "error", "skip"} <= statuses, statuses


@pytest.mark.parametrize("name", ["stubs", "solutions", "partly"])
def test_report_file_has_no_axe_violation(reports, name):
    path, _ = reports[name]
    results = axe(path)
    assert not results["violations"], f"{name}: axe-core found\n{summary(results)}"


def test_class_summary_has_no_axe_violation(repo_root, tmp_path):
    """The instructor's summary.html of a batch (right and partly right learners, named mistakes, chosen
    options, the similarity table) meets WCAG 2.1 AA too."""
    from tests.support import build_submission

    submissions = tmp_path / "submissions"
    build_submission(submissions / "ann")
    build_submission(submissions / "bo")
    partly_right(submissions / "cy", repo_root)
    done = run_grade("batch", submissions, "--out", tmp_path / "out", "--no-html", "--similarity", cwd=repo_root)
    assert done.returncode in (0, 1), done.stderr[-2000:]
    page = tmp_path / "out" / "summary.html"
    assert "cy" in page.read_text(encoding="utf-8")
    results = axe(page)
    assert not results["violations"], f"summary.html: axe-core found\n{summary(results)}"


def test_axe_finds_the_old_low_contrast_green(reports, tmp_path):
    """The harness is not blind: the pass green the report had (#16a34a, 3.3:1 on white) is found."""
    path, data = reports["partly"]
    text = path.read_text(encoding="utf-8")
    low = text.replace("</head>", "<style>#report .pass .status{color:#16a34a}</style></head>", 1)
    (tmp_path / "low.html").write_text(low, encoding="utf-8")
    results = axe(tmp_path / "low.html")
    found = {v["id"]: len(v["nodes"]) for v in results["violations"]}
    passes = sum(c["status"] == "pass" for ch in data["chapters"] for c in ch["checks"])
    assert found.get("color-contrast", 0) >= passes > 0, summary(results)


class _Parts(HTMLParser):
    """The images (their attributes), the checks' status words and the matrix cells of a report."""

    def __init__(self) -> None:
        super().__init__()
        self.images: list[dict] = []
        self.statuses: list[tuple[str, str]] = []  # (the check's class, the status span's text)
        self.wrong_cells: list[str] = []
        self._check = ""
        self._in: list[str] = []  # what text goes to: "status" or "wrong"
        self._depth: list[int] = []

    def handle_starttag(self, tag, attrs):
        attrs = dict(attrs)
        classes = (attrs.get("class") or "").split()
        if tag == "img":
            self.images.append(attrs)
        if tag == "div" and "check" in classes:
            self._check = classes[-1]
        for name, store in (("status", self.statuses), ("wrong", self.wrong_cells)):
            if name in classes:
                store.append((self._check, "") if name == "status" else "")
                self._in.append(name)
                self._depth.append(0)
                return
        if self._depth:
            self._depth[-1] += 1

    def handle_endtag(self, tag):
        if self._depth:
            if self._depth[-1] == 0:
                self._depth.pop()
                self._in.pop()
            else:
                self._depth[-1] -= 1

    def handle_data(self, data):
        if self._in and self._in[-1] == "status":
            check, said = self.statuses[-1]
            self.statuses[-1] = (check, said + data)
        elif self._in and self._in[-1] == "wrong":
            self.wrong_cells[-1] += data


def _parts(text: str) -> _Parts:
    parser = _Parts()
    parser.feed(text)
    return parser


def _shown_statuses(chapter: dict) -> tuple[list[str], set[str]]:
    """The verdicts a chapter's report shows, in its order (code, then quiz), and the functions not written yet:
    each of those is one line, as grader.model.not_written folds it (all its code checks say it raises
    NotImplementedError); every other check has its own."""
    code = [c for c in chapter["checks"] if c["kind"] == "code"]
    unwritten = {f for f in {c["function"] for c in code}
                 if all(f"{f} is not implemented yet" in c["message"] for c in code if c["function"] == f)}
    shown, folded = [], set()
    for kind in ("code", "quiz"):
        for c in (c for c in chapter["checks"] if c["kind"] == kind):
            if kind == "code" and c["function"] in unwritten:
                if c["function"] not in folded:
                    shown.append("fail")
                    folded.add(c["function"])
            else:
                shown.append(c["status"])
    return shown, unwritten


@pytest.mark.parametrize("name", ["stubs", "solutions", "partly"])
def test_verdicts_are_words_not_only_colours(reports, name):
    path, data = reports[name]
    parts = _parts(path.read_text(encoding="utf-8"))
    shown = [_shown_statuses(ch) for ch in data["chapters"]]
    statuses = [status for chapter, _ in shown for status in chapter]
    assert len(parts.statuses) == len(statuses)
    for function in (f for _, unwritten in shown for f in unwritten):
        assert f"{function}: not implemented yet (" in path.read_text(encoding="utf-8"), function
    marks = {"pass": "\u2713", "fail": "\u2717", "error": "!", "skip": "\u2013", "recorded": "\u2022"}
    for (css_class, said), status in zip(parts.statuses, statuses):
        assert css_class == status and said == f"{marks[status]} {status}", (css_class, said)
    text = path.read_text(encoding="utf-8")
    verdict = text[text.index('<p id="verdict">'):].split("</p>", 1)[0]
    assert "above" not in verdict  # no instruction by where things are on the screen (WCAG 1.3.3)
    assert ("\u2717 fail" in verdict) == (name != "solutions")


def test_differing_matrix_entries_are_said_in_words(reports):
    cells = _parts(reports["partly"][0].read_text(encoding="utf-8")).wrong_cells
    assert cells and all(cell.endswith(" \u2717 (differs)") for cell in cells), cells[:5]


def _alts(path: Path) -> dict[str, str]:
    """The plots' alt texts by chapter (a chapter's several plots' joined by ' | ')."""
    alts: dict[str, list[str]] = {}
    for image in _parts(path.read_text(encoding="utf-8")).images:
        alts.setdefault(image["alt"].split(" ", 1)[0], []).append(image["alt"])
    return {chapter: " | ".join(texts) for chapter, texts in alts.items()}


def test_plots_say_in_numbers_what_the_learners_functions_gave(reports):
    import numpy as np

    alts = _alts(reports["partly"][0])
    for chapter in ("ch00", "ch01", "ch02", "ch03", "ch04", "ch05", "ch06", "ch07", "ch09"):
        assert "In numbers: your " in alts[chapter], alts[chapter]
    # mean_shift returns sigma / 10 here
    assert "your mean_shift gave 0.025 at sigma = 0.25; 0.1 at sigma = 1; 0.15 at sigma = 1.5 (reference: " \
        in alts["ch00"]
    c, s = np.cos(0.8), np.sin(0.8)  # this J has cos theta where r cos theta belongs
    assert f"your polar_to_cartesian_jacobian(2, 0.8) gave [[{c:.4g}, {-2 * s:.4g}], [{s:.4g}, {c:.4g}]] " \
           f"(reference: [[{c:.4g}, {-2 * s:.4g}], [{s:.4g}, {2 * c:.4g}]])" in alts["ch03"]
    assert "your classify_critical_point gave <b>saddle</b> & $x$ (reference: saddle)" in alts["ch09"]
    assert "<b>saddle" not in reports["partly"][0].read_text(encoding="utf-8"), "learner text must stay escaped"
    stubs = _alts(reports["stubs"][0])
    assert "your mean_shift gave nothing usable at sigma = 0.25;" in stubs["ch00"]
    right = _alts(reports["solutions"][0])
    assert "your pipeline_jacobian(1.5, 0.9) gave [[" in right["ch04"]
    assert set(right) == {c.id for c in CHAPTERS}


# A notebook front end's page, written for this test: rules with the selectors (and so the
# specificity) that notebook front ends give the HTML of an output (tables, pre, links, headings), in
# a light and a dark theme. The fragment must look the same, and pass axe, in both.
NOTEBOOK_THEMES = {
    "light": {"bg": "#ffffff", "fg": "#000000", "row": "#f5f5f5", "link": "#0d47a1"},
    "dark": {"bg": "#111111", "fg": "#ffffff", "row": "#424242", "link": "#90caf9"},
}
NOTEBOOK_CSS = """
body{margin:0;background:%(bg)s;color:%(fg)s;font:13px sans-serif}
.nb-output{color:%(fg)s;padding:4px 20px 4px 8px;text-align:right}
.nb-output a:link,.nb-output a:visited{color:%(link)s;text-decoration:none}
.nb-theme .nb-output pre,.nb-theme .nb-output code{background-color:%(bg)s;color:%(fg)s;border:0;padding:0;margin:0}
.nb-output table{color:%(fg)s;border:none;margin-left:auto;margin-right:auto;table-layout:fixed}
.nb-output td,.nb-output th,.nb-output tr{text-align:right;padding:.5em;border:none;vertical-align:middle}
.nb-output tbody tr:nth-child(odd){background:%(bg)s}
.nb-output tbody tr:nth-child(even){background:%(row)s}
.nb-output h1,.nb-output h2,.nb-output h3,.nb-output h4{color:%(fg)s;margin:1em 0 .5em}
.nb-output p{margin:0 0 1em}
.nb-output img{max-width:100%%;height:auto}
"""
HOST_CELL = ('<div class="nb-output"><p id="host-p">The notebook\'s own text.</p><pre id="host-pre">x = 1</pre>'
             '<table id="host-table"><caption>host</caption><thead><tr><th scope="col">a</th></tr></thead>'
             '<tbody><tr><td>1</td></tr><tr><td>2</td></tr></tbody></table></div>')


def notebook_page(path: Path, fragments: list[str], theme: str) -> Path:
    """An HTML page as a notebook shows outputs: a title, one cell of its own, then each fragment in
    an output area."""
    outputs = "".join(f'<div class="nb-output">{f}</div>' for f in fragments)
    path.write_text(f'<!DOCTYPE html><html lang="en"><head><meta charset="utf-8"><title>ch06.ipynb</title>'
                    f"<style>{NOTEBOOK_CSS % NOTEBOOK_THEMES[theme]}</style></head><body class=\"nb-theme\">"
                    f"<main><h1>ch06.ipynb</h1>{HOST_CELL}{outputs}</main></body></html>", encoding="utf-8")
    return path


@pytest.fixture(scope="module")
def in_process(repo_root, reports) -> dict:
    """Report objects with their plot data (what `%grade` would render), graded in this process's
    child like the CLI: the stubs, the reference solutions and the partly right submission."""
    from grader.chapters import CHAPTERS as chapters
    from grader.core.grading import DEFAULT_SEED
    from grader.core.pipeline import Request, build_report
    from grader.submission import Submission, solutions_submission

    partly = reports["partly"][0].parent / "partly"
    request = Request(tuple(c.id for c in chapters), DEFAULT_SEED, plots=True)
    unsandboxed = unbarred()
    return {name: build_report(unsandboxed.open_session(submission), request)
            for name, submission in (("stubs", Submission(repo_root, "exercises")),
                                     ("solutions", solutions_submission()),
                                     ("partly", Submission(partly, "exercises")))}


def test_fragment_is_a_scoped_part_of_a_page(in_process):
    import re

    from grader.render.html import render_fragment

    text = render_fragment(in_process["partly"], id_prefix="g1-")
    assert not re.search(r"<!DOCTYPE|<html|<head|<body|<main|<script", text, re.I)
    style = re.fullmatch(r"\s*<style>(.*?)</style>\s*(<div .*</div>)\s*", text, re.S)
    assert style, text[:300]
    selectors = [s.strip() for rule in style.group(1).split("}") if "{" in rule for s in rule.split("{")[0].split(",")]
    assert selectors and all(s.startswith("#g1-report") for s in selectors), \
        [s for s in selectors if not s.startswith("#g1-report")]
    assert style.group(2).startswith('<div class="jl-report fragment" id="g1-report" lang="en">')
    ids = re.findall(r'\bid="([^"]*)"', text)
    assert ids and all(i.startswith("g1-") for i in ids) and len(ids) == len(set(ids))
    assert {h[1:] for h in re.findall(r'href="([^"]*)"', text)} <= set(ids)
    assert "<b>saddle" not in text and "&lt;b&gt;saddle&lt;/b&gt;" in text  # learner text escaped
    assert "<h2 " in text and "<h1" not in text  # below the notebook's own title
    assert render_fragment(in_process["partly"], heading_level=1).count("<h1 ") == 1
    other = render_fragment(in_process["partly"])
    assert re.search(r'id="(grade-[0-9a-f]+-)report"', other)  # a fresh prefix per call
    assert re.search(r'id="(grade-[0-9a-f]+-)report"', other).group(1) != \
        re.search(r'id="(grade-[0-9a-f]+-)report"', render_fragment(in_process["partly"])).group(1)
    with pytest.raises(ValueError):
        render_fragment(in_process["partly"], id_prefix='x" onload="')


_STYLES = """(ids) => Object.fromEntries(ids.map(id => { const s = getComputedStyle(document.querySelector(id));
    return [id, [s.color, s.backgroundColor, s.textAlign, s.fontFamily, s.padding]]; }))"""


@pytest.mark.parametrize("theme", ["light", "dark"])
def test_fragments_in_a_notebook_have_no_axe_violation(in_process, tmp_path, theme):
    from grader.render.html import render_fragment

    fragments = [render_fragment(in_process[name]) for name in ("stubs", "solutions", "partly")]
    page = notebook_page(tmp_path / f"notebook-{theme}.html", fragments, theme)
    bare = notebook_page(tmp_path / f"bare-{theme}.html", [], theme)
    results = axe(page)
    assert not results["violations"], f"{theme} notebook: axe-core found\n{summary(results)}"

    sync_api = _sync_api()
    with sync_api.sync_playwright() as playwright:
        browser = playwright.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_FLAGS)
        try:
            tab = browser.new_page(viewport={"width": 1100, "height": 900})
            tab.goto(bare.resolve().as_uri())
            host = ["#host-p", "#host-pre", "#host-table td", "#host-table"]
            before = tab.evaluate(_STYLES, host)
            tab.goto(page.resolve().as_uri())
            after = tab.evaluate(_STYLES, host)
            ours = tab.evaluate(_STYLES, [".jl-report", ".jl-report pre", ".jl-report a", ".jl-report tbody td"])
            widths = tab.eval_on_selector_all(".jl-report img", "i => i.map(e => e.complete ? e.naturalWidth : 0)")
            tab.screenshot(path=str(tmp_path / f"notebook-{theme}.png"), full_page=False)
        finally:
            browser.close()
    assert before == after, "the fragment's style must not reach the notebook's own output"
    # the fragment's own colours win over the notebook's, also in a dark theme
    assert ours[".jl-report"][:2] == ["rgb(31, 41, 55)", "rgb(255, 255, 255)"]
    assert ours[".jl-report pre"][:2] == ["rgb(31, 41, 55)", "rgb(243, 244, 246)"]
    assert ours[".jl-report a"][0] == "rgb(29, 78, 216)"
    assert ours[".jl-report tbody td"][:3] == ["rgb(31, 41, 55)", "rgb(255, 255, 255)", "left"]
    assert len(widths) >= 3 * len(CHAPTERS) - 1 and all(w > 0 for w in widths)


def _contrast(colour) -> float:
    """WCAG contrast ratio of a matplotlib colour against white."""
    from matplotlib.colors import to_rgb

    def linear(c: float) -> float:
        return c / 12.92 if c <= 0.03928 else ((c + 0.055) / 1.055) ** 2.4

    r, g, b = (linear(c) for c in to_rgb(colour))
    return 1.05 / (0.2126 * r + 0.7152 * g + 0.0722 * b + 0.05)


@pytest.mark.parametrize("name", ["stubs", "solutions", "partly"])
def test_plots_keep_series_apart_without_colour(in_process, name):
    """In every plot, the series in a legend differ by marker or line style, not by colour alone, and
    every line, marker and contour has 3:1 against white (WCAG 1.4.11)."""
    from grader.render.figures import draw

    drawn = 0
    for chapter in in_process[name].chapters:
        for data in chapter.plots.values():
            fig, _ = draw(chapter.chapter, data)
            for ax in fig.axes:
                lines = [line for line in ax.get_lines() if not line.get_label().startswith("_")]
                styles = [(line.get_linestyle(), line.get_marker()) for line in lines]
                assert len(set(styles)) == len(styles), (chapter.chapter, ax.get_title(),
                                                         [(line.get_label(), *s) for line, s in zip(lines, styles)])
                colours = [line.get_color() for line in ax.get_lines()]
                colours += [c for col in ax.collections for c in col.get_edgecolor()]
                colours += [c for col in ax.collections if col.get_array() is None for c in col.get_facecolor()
                            if c[3] > 0 and type(col).__name__ == "Quiver"]
                assert all(_contrast(c) >= 3 for c in colours), (chapter.chapter, ax.get_title(),
                                                                sorted({round(_contrast(c), 2) for c in colours}))
            drawn += 1
    assert drawn >= len(CHAPTERS) - (1 if name == "partly" else 0)
