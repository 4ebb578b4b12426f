"""`grade review OUT` as an instructor uses it: the real command serving a real batch's folder on 127.0.0.1, asked
over HTTP (the token, the CSRF token, escaping, files outside OUT, read-only, two saves at once), and in Debian's
Chromium driven by Playwright (filter to a named mistake, open a learner, record an override, read it back in
gradebook.db, the Canvas file and the learner's report; axe-core's WCAG 2.1 AA rules on both pages)."""

from __future__ import annotations

import html
import http.client
import json
import os
import re
import shutil
import sqlite3
import subprocess
import sys
import threading
import urllib.parse
from pathlib import Path

import pytest

from tests.support import REPO, chapter_submission, replace_function, run_grade

pytest.importorskip("starlette")
pytest.importorskip("uvicorn")

HOSTILE = "<img src=x onerror=alert(1)>"
TRANSPOSED = "def H_jacobian(x, y):\n    r2 = x * x + y * y\n    r = np.sqrt(r2)\n" \
             "    return np.array([[x / r, -y / r2], [y / r, x / r2]])\n"


@pytest.fixture(scope="module")
def graded(tmp_path_factory) -> Path:
    """A batch of ch06 with --lms canvas: right learners, two who transposed H (a named mistake), and one whose id
    is markup and whose code holds a script."""
    folder = tmp_path_factory.mktemp("review")
    submissions = folder / "submissions"
    transposed = replace_function("ch06_measurement", "H_jacobian", TRANSPOSED).replace("solutions.", "exercises.")
    hostile = transposed.replace("def H_jacobian", "# </pre><script>alert('code')</script>\ndef H_jacobian", 1)
    for learner, text in (("ann", None), ("bo", transposed), ("cy", transposed), ("di", None), (HOSTILE, hostile)):
        chapter_submission(submissions / learner, learner, "ch06_measurement", text)
    out = folder / "out"
    done = run_grade("batch", submissions, "--out", out, "--chapters", "ch06", "--lms", "canvas", "--similarity")
    assert (out / "gradebook.db").is_file(), done.stdout + done.stderr
    return out


class Server:
    """`grade review OUT --no-browser` running; its address from what it printed."""

    def __init__(self, out: Path, *extra: str) -> None:
        self.process = subprocess.Popen([sys.executable, "-m", "grader", "review", str(out), "--no-browser", *extra],
                                        cwd=REPO, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                                        encoding="utf-8")
        line = self.process.stdout.readline()
        found = re.search(r"http://127\.0\.0\.1:(\d+)/\?token=(\S+)", line)
        if not found:
            self.process.kill()
            _, error = self.process.communicate(timeout=10)
            raise AssertionError(line + error)
        self.url, self.port, self.token = found.group(0), int(found.group(1)), found.group(2)

    def request(self, method: str, path: str, body: dict | None = None, cookie: bool = True,
                headers: dict | None = None) -> tuple[int, dict, str]:
        connection = http.client.HTTPConnection("127.0.0.1", self.port, timeout=60)
        sent = {"Cookie": f"grade_review={self.token}"} if cookie else {}
        data = None
        if body is not None:
            data = urllib.parse.urlencode(body)
            sent["Content-Type"] = "application/x-www-form-urlencoded"
        sent.update(headers or {})
        try:
            connection.request(method, path, data, sent)
            response = connection.getresponse()
            return response.status, dict(response.getheaders()), response.read().decode("utf-8")
        finally:
            connection.close()

    def stop(self) -> None:
        self.process.terminate()
        self.process.communicate(timeout=10)  # and its pipes closed


@pytest.fixture
def server(graded, tmp_path):
    out = tmp_path / "out"
    shutil.copytree(graded, out)
    running = Server(out)
    yield running, out
    running.stop()


def _form(page: str) -> dict:
    return {"csrf": re.search(r'name="csrf" value="([^"]+)"', page).group(1),
            "seen_run": re.search(r'name="seen_run" value="(\d+)"', page).group(1)}


def _learner_path(learner: str) -> str:
    return "/learner/" + urllib.parse.quote(learner, safe="")


def test_it_listens_on_127_0_0_1_and_asks_for_the_token(server):
    running, _ = server
    status, _, body = running.request("GET", "/", cookie=False)
    assert status == 403 and "token" in body
    status, _, _ = running.request("GET", "/", cookie=False, headers={"Cookie": "grade_review=" + "x" * 43})
    assert status == 403
    status, headers, _ = running.request("GET", f"/?token={running.token}", cookie=False)
    assert status == 303 and "HttpOnly" in headers["set-cookie"] and "SameSite=strict" in headers["set-cookie"]
    status, headers, page = running.request("GET", "/")
    assert status == 200 and "script-src 'nonce-" in headers["content-security-policy"]
    assert "bo" in page and "ch06/H_jacobian: transpose" in page


def test_learner_text_is_shown_as_text(server):
    running, _ = server
    _, _, page = running.request("GET", "/")
    assert HOSTILE not in page and "&lt;img src=x onerror=alert(1)&gt;" in page
    status, _, page = running.request("GET", _learner_path(HOSTILE))
    assert status == 200
    assert "<script>alert('code')</script>" not in page and "&lt;script&gt;alert('code')&lt;/script&gt;" in page
    assert HOSTILE not in page
    assert len(re.findall(r"<script\b", page)) == 0  # a learner's page needs no script at all


def test_a_wrong_or_missing_csrf_token_and_a_read_only_review_record_nothing(server, graded, tmp_path):
    running, out = server
    _, _, page = running.request("GET", _learner_path("bo"))
    form = {**_form(page), "target": "ch06", "points": "2", "reason": "regrade request", "who": "bo"}
    for wrong in ({**form, "csrf": "x" * len(form["csrf"])}, {k: v for k, v in form.items() if k != "csrf"}):
        status, _, _ = running.request("POST", _learner_path("bo") + "/override", wrong)
        assert status == 403
    status, _, _ = running.request("POST", _learner_path("bo") + "/override", form,
                                   headers={"Origin": "http://evil.example"})
    assert status == 403
    assert not (out / "overrides.csv").exists()
    with sqlite3.connect(out / "gradebook.db") as db:
        assert db.execute("SELECT count(*) FROM runs").fetchone()[0] == 1
    other = tmp_path / "read-only"
    shutil.copytree(graded, other)
    reader = Server(other, "--read-only")
    try:
        _, _, page = reader.request("GET", _learner_path("bo"))
        assert "<form" not in page
        status, _, _ = reader.request("POST", _learner_path("bo") + "/override", form)
        assert status == 403 and not (other / "overrides.csv").exists()
    finally:
        reader.stop()


def test_a_similar_pair_is_shown_side_by_side_with_the_shared_lines_marked(server):
    running, out = server
    pairs = json.loads((out / "summary.json").read_text(encoding="utf-8"))["similar"]
    first, second = pairs[0]["learners"]  # the most alike: two learners who handed in the same file
    _, _, page = running.request("GET", _learner_path(first))
    assert f"{first} and {second}" in page
    side = page[page.index("Similar submissions"):]
    assert side.count('class="shared"') > 10
    assert f'<pre aria-label="{first}">' in side and f'<pre aria-label="{second}">' in side
    _, _, page = running.request("GET", "/")
    row = next(r for r in page.split("<tr ") if f'data-learner="{first}"' in r)
    assert "similar" in row.split('data-flags="', 1)[1].split('"', 1)[0] and second in row


def test_nothing_outside_out_is_served(server):
    running, out = server
    assert running.request("GET", "/out/bo/report.html")[0] == 200
    for path in ("/out/../gradebook.db", "/out/gradebook.db", "/out/%2e%2e/%2e%2e/etc/passwd", "/out/.staging/bo/x",
                 "/out/..%2F..%2Fetc%2Fpasswd"):
        assert running.request("GET", path)[0] in (403, 404), path


def test_an_override_is_recorded_through_the_history_and_every_output_shows_it(server):
    running, out = server
    _, _, page = running.request("GET", _learner_path("bo"))
    form = {**_form(page), "target": "ch06", "points": "2.5", "reason": "regrade request: rows were unclear",
            "who": "bo the TA"}
    status, headers, _ = running.request("POST", _learner_path("bo") + "/override", form)
    assert status == 303
    _check_recorded(out, "bo", 2.5, "regrade request: rows were unclear")
    _, _, page = running.request("GET", _learner_path("bo"))
    assert "regrade request: rows were unclear" in page and "Undo" in page
    undo = {**_form(page), "target": "ch06", "points": "-2.5", "reason": "undo: regrade request", "who": "bo the TA"}
    assert running.request("POST", _learner_path("bo") + "/override", undo)[0] == 303
    with sqlite3.connect(out / "gradebook.db") as db:
        assert db.execute("SELECT count(*) FROM runs").fetchone()[0] == 3  # undo is another entry
        rows = db.execute("SELECT points, reason FROM overrides WHERE run = 3 AND learner = 'bo'").fetchall()
    assert sorted(rows) == [(-2.5, "undo: regrade request"), (2.5, "regrade request: rows were unclear")]


def _check_recorded(out: Path, learner: str, points: float, reason: str) -> None:
    with sqlite3.connect(out / "gradebook.db") as db:
        run, why = db.execute("SELECT id, reason FROM runs ORDER BY id DESC").fetchone()
        score, adjustments = db.execute("SELECT score, adjustments FROM results WHERE run = ? AND learner = ?",
                                        (run, learner)).fetchone()
        before = db.execute("SELECT score FROM results WHERE run = 1 AND learner = ?", (learner,)).fetchone()[0]
    assert run >= 2 and reason in why
    assert score == pytest.approx(before + points)
    assert any(a["reason"] == reason for a in json.loads(adjustments))
    canvas = next(out.glob("*canvas*.csv")).read_text(encoding="utf-8")
    assert f"{score:g}" in next(line for line in canvas.splitlines() if learner in line)
    report = json.loads((out / learner / "report.json").read_text(encoding="utf-8"))
    assert report["score"] == pytest.approx(score)
    assert reason in json.dumps(report)


def test_two_saves_of_one_page_at_once_keep_one_and_refuse_the_stale_one(server):
    running, out = server
    _, _, page = running.request("GET", _learner_path("cy"))
    form = _form(page)
    results = []

    def save(points: str) -> None:
        results.append(running.request("POST", _learner_path("cy") + "/override",
                                       {**form, "target": "total", "points": points, "reason": f"tab {points}",
                                        "who": "bo"}))

    threads = [threading.Thread(target=save, args=(p,)) for p in ("1", "2")]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    statuses = sorted(status for status, _, _ in results)
    assert statuses == [303, 409]
    refused = next(body for status, _, body in results if status == 409)
    assert "was recorded after run 1" in refused
    assert len((out / "overrides.csv").read_text(encoding="utf-8").strip().splitlines()) == 2  # header and one row


CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")


@pytest.mark.slow
@pytest.mark.skipif(CHROMIUM is None and not os.environ.get("CI"), reason="Debian's chromium is not installed")
def test_in_a_browser_filter_open_and_record_an_override_and_the_pages_pass_axe(server):
    from tests.render.test_html_accessibility import CHROMIUM_FLAGS, _axe_script, _sync_api

    running, out = server
    script = _axe_script()
    with _sync_api().sync_playwright() as playwright:
        browser = playwright.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_FLAGS)
        try:
            page = browser.new_context(bypass_csp=True, viewport={"width": 1280, "height": 900}).new_page()
            page.goto(running.url)
            assert page.title().startswith("Review")
            page.select_option("#mistake", "ch06/H_jacobian: transpose")
            visible = page.locator("#learners tbody tr:visible td:first-child").all_inner_texts()
            assert sorted(visible) == sorted(["bo", "cy", HOSTILE])
            page.select_option("#mistake", "")
            page.select_option("#chapter", "ch06")  # failing any check of ch06, as each row's checks say
            failing = re.findall(r'data-learner="([^"]*)" data-flags="[^"]*" data-checks="([^"]*)"', page.content())
            expected = sorted(html.unescape(name) for name, checks in failing if "ch06/" in checks)
            assert sorted(page.locator("#learners tbody tr:visible td:first-child").all_inner_texts()) == expected
            page.select_option("#chapter", "")
            page.select_option("#flag", "similar")  # the pair summary.json lists, and no one else
            pair = json.loads((out / "summary.json").read_text(encoding="utf-8"))["similar"][0]["learners"]
            assert sorted(page.locator("#learners tbody tr:visible td:first-child").all_inner_texts()) == sorted(pair)
            page.select_option("#flag", "")
            page.select_option("#mistake", "ch06/H_jacobian: transpose")
            assert page.evaluate("typeof window.pwned") == "undefined"
            page.select_option("#mistake", "")
            page.get_by_role("button", name="total", exact=True).click()  # sorted by total, lowest first
            totals = [float(t) for t in page.locator("#learners tbody tr td:nth-child(3)").all_inner_texts()]
            assert totals == sorted(totals) and len(totals) == 5
            assert page.locator("th[aria-sort=ascending]").inner_text() == "total"
            page.evaluate("document.activeElement.blur()")
            page.keyboard.press("j")  # the first learner's link, then the next
            first = page.evaluate("document.activeElement.textContent")
            page.keyboard.press("j")
            assert page.evaluate("document.activeElement.textContent") != first
            page.keyboard.press("k")
            assert page.evaluate("document.activeElement.textContent") == first
            page.select_option("#mistake", "ch06/H_jacobian: transpose")
            violations = _axe(page, script)
            assert violations == [], violations
            page.get_by_role("link", name="bo", exact=True).click()
            page.wait_for_url("**/learner/bo")
            assert page.locator(".blame").count() >= 1 and "transpose" in page.locator(".blame").first.inner_text()
            violations = _axe(page, script)
            assert violations == [], violations
            page.select_option("#target", "ch06")
            page.fill("#points", "1.5")
            page.fill("#reason", "accommodation: a sign convention from another course")
            page.get_by_role("button", name="Record override").click()
            page.wait_for_url("**/learner/bo?saved=1")
            assert "Recorded" in page.locator("[role=status]").inner_text()
        finally:
            browser.close()
    _check_recorded(out, "bo", 1.5, "accommodation: a sign convention from another course")


def _axe(page, script: str) -> list[str]:
    page.evaluate(script)
    found = page.evaluate("() => axe.run(document, {runOnly: {type: 'tag', values: ['wcag2a', 'wcag2aa', "
                          "'wcag21a', 'wcag21aa']}, resultTypes: ['violations']})")
    return [f"{v['id']}: {v['nodes'][0]['html'][:160]}" for v in found["violations"]]


def test_an_overrides_file_edited_by_hand_since_the_last_run_is_not_written_over(server):
    running, out = server
    (out / "overrides.csv").write_text("learner,target,points,factor,reason,who\nann,total,1,,by hand,bo\n",
                                       encoding="utf-8")
    _, _, page = running.request("GET", _learner_path("bo"))
    status, _, body = running.request("POST", _learner_path("bo") + "/override",
                                      {**_form(page), "target": "total", "points": "1", "reason": "r", "who": "bo"})
    assert status == 409 and "overrides.csv changed since run 1 read it" in body
    assert "bo,total" not in (out / "overrides.csv").read_text(encoding="utf-8")
