"""The HTML report: self-contained, complete, and rendered by a real browser (Debian's chromium)."""

from __future__ import annotations

import os
import re
import shutil
from html.parser import HTMLParser

import pytest

from grader.chapters import CHAPTERS
from tests.support import grade_json

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
CHROMIUM_FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                  "--disable-background-networking", "--disable-component-update", "--disable-sync"]


@pytest.fixture(scope="module")
def reports(repo_root, tmp_path_factory) -> dict:
    """Reports of the reference solutions and of the untouched stubs, with their JSON."""
    folder = tmp_path_factory.mktemp("reports")
    out = {}
    for name, args in (("solutions", ["all", "--solutions"]), ("stubs", ["all", "--submission", str(repo_root)])):
        path = folder / f"{name}.html"
        out[name] = (path, grade_json(*args, html=path, cwd=repo_root))
    return out


class _Images(HTMLParser):
    def __init__(self) -> None:
        super().__init__()
        self.images, self.links, self.sections = [], [], []

    def handle_starttag(self, tag, attrs):
        attrs = dict(attrs)
        if tag == "img":
            self.images.append(attrs)
        if tag in ("a", "link", "script", "iframe"):
            self.links.append(attrs.get("href") or attrs.get("src") or "")
        if tag == "section" and attrs.get("class") == "chapter":
            self.sections.append(attrs.get("id"))


@pytest.mark.slow
@pytest.mark.parametrize("name", ["solutions", "stubs"])
def test_report_is_self_contained_and_complete(reports, name):
    path, data = reports[name]
    text = path.read_text(encoding="utf-8")
    parser = _Images()
    parser.feed(text)
    assert parser.sections == [c.id for c in CHAPTERS]
    assert len(parser.images) >= len(CHAPTERS)
    for image in parser.images:
        assert image["src"].startswith("data:image/svg+xml;base64,")
        assert image.get("alt"), "every image needs alt text"
    assert not re.search(r"""(src|href)=["']?(https?:)?//""", text), "no external resources"
    assert all(link.startswith("#") for link in parser.links)
    assert "<script" not in text
    assert f"{data['score']:g} / {data['max_score']:g}" in text


@pytest.mark.slow
def test_stub_report_shows_reference_plots_and_says_so(reports):
    text = reports["stubs"][0].read_text(encoding="utf-8")
    assert text.count("gave no usable value") >= len(CHAPTERS)
    assert "not implemented yet" in text


def test_wrong_matrix_entries_are_marked(repo_root, tmp_path):
    from tests.support import build_submission, replace_function

    source = replace_function("ch06_measurement", "H_jacobian",
                              "def H_jacobian(x, y):\n    r2 = x * x + y * y\n    r = np.sqrt(r2)\n"
                              "    return np.array([[x / r, y / r], [y / r2, x / r2]])\n")
    root = build_submission(tmp_path / "sub", {"ch06_measurement": source})
    out = tmp_path / "r.html"
    grade_json("ch06", "--submission", root, html=out, cwd=repo_root)
    text = out.read_text(encoding="utf-8")
    # marked by a cross and (for screen readers) a word as well as by colour
    assert '<td class="wrong">0.16<span aria-hidden="true"> \u2717</span><span class="sr-only"> (differs)</span></td>' in text
    assert "\u2717 marks each entry where got differs from expected." in text
    assert "H[1,0] = d bearing/d x: got 0.16, expected -0.16" in text


def _matrices(text: str) -> dict[str, list[list[str]]]:
    """The first expected and got matrices in `text`, each entry as the page writes it (its marks left out)."""
    found = {}
    for caption, body in re.findall(r'<table class="matrix"><caption>(\w+)</caption>(.*?)</table>', text):
        rows = [[re.sub(r"<span.*", "", cell) for cell in re.findall(r"<td[^>]*>(.*?)</td>", row)]
                for row in re.findall(r"<tr>(.*?)</tr>", body)]
        found.setdefault(caption, rows)
    return found


def test_a_matrix_writes_each_entry_as_the_checks_message_does(repo_root, tmp_path):
    """An expected entry that rounding left at 6.5e-18 (sigma^2 H H^T off its diagonal) reads "0" in the message,
    below a tenth of the tolerance: the matrices beside it write it so too, not 6.54248e-18."""
    from tests.support import build_submission, replace_function

    source = replace_function("ch06_measurement", "measurement_covariance",
                              "def measurement_covariance(x, y, sigma):\n    H = H_jacobian(x, y)\n"
                              "    return float(sigma) ** 2 * (H @ H.T) + 0.5\n")
    root = build_submission(tmp_path / "sub", {"ch06_measurement": source})
    out = tmp_path / "r.html"
    data = grade_json("ch06", "--submission", root, html=out, cwd=repo_root)
    message = next(c["message"] for c in data["chapters"][0]["checks"] if c["id"] == "covariance_random_points")
    told = re.findall(r"R\[(\d),(\d)\] \([^)]*\): got (\S+), expected (\S+)", message)
    assert ("0", "1", "0.5", "0") in told, message
    matrices = _matrices(out.read_text(encoding="utf-8").split("&middot; ch06/covariance_random_points</span>")[1])
    for i, j, got, expected in told:
        assert matrices["got"][int(i)][int(j)] == got and matrices["expected"][int(i)][int(j)] == expected, matrices
    assert not any("e-" in entry for rows in matrices.values() for row in rows for entry in row), matrices


def test_learner_text_in_a_figure_is_cleaned_as_on_the_rest_of_the_page(repo_root, tmp_path):
    """The figures' data are cleaned (grader.safe_text.for_html) before they are sent to be drawn, apart from the
    rest of the report: a control character the learner returned shows as U+FFFD in the figure, as in the text."""
    import base64

    from tests.support import build_submission, replace_function

    source = replace_function("ch09_choose_your_tool", "classify_critical_point",
                              "def classify_critical_point(hessian) -> str:\n    return 'saddle\\x1b[31m\\x07'\n")
    root = build_submission(tmp_path / "sub", {"ch09_choose_your_tool": source})
    out = tmp_path / "r.html"
    grade_json("ch09", "--submission", root, html=out, cwd=repo_root)
    text = out.read_text(encoding="utf-8")
    svgs = [base64.b64decode(uri).decode("utf-8") for uri in re.findall(r'src="data:image/svg\+xml;base64,([^"]+)"',
                                                                          text)]
    assert svgs and any("saddle\ufffd[31m\ufffd" in svg for svg in svgs), [svg[-3000:] for svg in svgs]
    assert not any(ch in svg for svg in svgs for ch in "\x1b\x07")
    assert "saddle\ufffd[31m\ufffd" in text and "\x1b" not in text


@pytest.mark.slow
@pytest.mark.skipif(CHROMIUM is None and not os.environ.get("CI"),
                    reason="Debian's chromium is not installed (apt-get install chromium)")
@pytest.mark.parametrize("name", ["solutions", "stubs"])
def test_report_in_a_real_browser(reports, name, tmp_path):
    assert CHROMIUM, "CI must have chromium (.ci/run installs it)"
    sync_api = pytest.importorskip("playwright.sync_api") if not os.environ.get("CI") else \
        __import__("playwright.sync_api", fromlist=["sync_playwright"])
    path, data = reports[name]
    url = path.resolve().as_uri()
    requests, console_errors = [], []
    with sync_api.sync_playwright() as playwright:
        # launch() gives the browser a fresh, empty profile of its own
        browser = playwright.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_FLAGS)
        try:
            page = browser.new_page(viewport={"width": 1100, "height": 900})
            page.on("request", lambda request: requests.append(request.url))
            page.on("console", lambda message: console_errors.append(message.text) if message.type == "error" else None)
            page.on("pageerror", lambda error: console_errors.append(str(error)))
            page.goto(url, wait_until="load")
            widths = page.eval_on_selector_all("img", "images => images.map(i => i.complete ? i.naturalWidth : 0)")
            sections = page.eval_on_selector_all("section.chapter", "s => s.map(e => e.id)")
            total = page.inner_text("#total")
            cells = {c.id: page.inner_text(f'[data-total="{c.id}"]') for c in CHAPTERS}
            shot = tmp_path / f"report-{name}.png"
            page.screenshot(path=str(shot), full_page=True)
        finally:
            browser.close()
    print(f"screenshot: {shot}")
    assert shot.stat().st_size > 10_000
    assert len(widths) >= len(CHAPTERS) and all(w > 0 for w in widths), widths
    assert sections == [c.id for c in CHAPTERS]
    assert not console_errors, console_errors
    assert all(u == url or u.startswith("data:") for u in requests), requests
    assert total == f"{data['score']:g} / {data['max_score']:g}"
    for chapter in data["chapters"]:
        assert cells[chapter["chapter"]] == f"{chapter['score']:g} / {chapter['max_score']:g}"


# ----------------------------------------------------------------------- the templates as shipped compiled

def _small_report():
    from grader.model import ChapterResult, CheckResult, Report, Status

    check = CheckResult("c", "H_jacobian", "shape & values <b>", Status.FAIL, 0, 2, message="got <script>", expected=[[1.0, 0.0]],
                        got=[[1.0, 2.0]], details={"wrong": [[0, 1]]})
    passed = CheckResult("d", "H_jacobian", "another", Status.PASS, 1, 1)
    return Report("subs/ana", [ChapterResult("ch06", "t", [check, passed], ["a note"])], learner_output="printed")


def test_the_shipped_compiled_templates_are_those_of_the_templates_text():
    """grader/render/compiled holds each template as jinja2 compiles it now: after a template's text changes,
    `python -m grader.render.html` writes them again (until then every report compiles its template afresh)."""
    import importlib

    import jinja2

    from grader.render import html, precompiled

    for kind, source in html._SOURCES.items():
        module = importlib.import_module(f"grader.render.compiled.{kind}")
        if module.JINJA2 != jinja2.__version__:  # another jinja2: its own compiling is used, never this module
            assert module.DIGEST != precompiled.digest(source)
            continue
        shipped = (precompiled.FOLDER / f"{kind}.py").read_text(encoding="utf-8")
        assert shipped == precompiled.module_text(kind, source), "run `python -m grader.render.html`"


def test_a_report_reads_the_same_from_the_shipped_template_and_from_one_compiled_here(monkeypatch):
    import jinja2

    from grader.render import html, precompiled
    from grader.render.compiled import page as shipped_page

    if shipped_page.JINJA2 != jinja2.__version__:
        pytest.skip(f"the templates were compiled by jinja2 {shipped_page.JINJA2}, this is {jinja2.__version__}")
    report = _small_report()
    html._template.cache_clear()
    shipped = html._template("page")
    assert shipped.filename == str(precompiled.FOLDER / "page.py")  # loaded, not compiled
    page, fragment = html.render(report), html.render_fragment(report, id_prefix="r-")
    html._template.cache_clear()
    monkeypatch.setattr(precompiled, "digest", lambda source: "another text")  # no shipped module matches
    assert html._template("page").filename == "<template>"  # compiled here
    assert html.render(report) == page and html.render_fragment(report, id_prefix="r-") == fragment
    assert "got &lt;script&gt;" in page and "<script>" not in page  # escaped as ever
    html._template.cache_clear()


def test_a_template_whose_text_changed_is_compiled_not_taken_from_its_stale_module(monkeypatch):
    from grader.render import html

    html._template.cache_clear()
    monkeypatch.setitem(html._SOURCES, "page", html.TEMPLATE.replace("</body>", "<p>changed</p></body>"))
    assert "<p>changed</p>" in html.render(_small_report())
    html._template.cache_clear()


def test_a_shipped_template_module_that_does_not_load_is_compiled_here_instead(monkeypatch):
    from grader.render import html, precompiled

    def not_loadable(name):
        raise SyntaxError(f"{name}: written for another Python")

    html._template.cache_clear()
    monkeypatch.setattr(precompiled.importlib, "import_module", not_loadable)
    assert html._template("page").filename == "<template>"
    assert "got &lt;script&gt;" in html.render(_small_report())
    html._template.cache_clear()


CHECK_BLOCK = """<div class="check {{ c.status.value }}"><span class="status"><span aria-hidden="true">{{ marks[c.status.value] }} </span>{{ c.status.value }}</span>{{ c.description }}
<span class="points">{% if c.practice %}practice, not counted{% else %}{{ num(c.points) }} / {{ num(c.max_points) }}<span class="sr-only"> points</span>{% endif %}</span>
<span class="note"> &middot; {{ chapter }}/{{ c.id }}</span>
{% if c.status.value != "pass" and c.message %}<pre>{{ c.message }}</pre>{% endif %}
{% if c.status.value != "pass" and c.help %}<p class="help"><strong>Hint:</strong> {{ c.help }}</p>{% endif %}
{% if c.kind == "quiz" and c.got is not none %}<p class="note">your answer: {{ c.got }}</p>{% endif %}
{% if c.status.value == "fail" and c.kind == "code" %}{{ values(c) }}{% endif %}
</div>"""


def test_a_checks_block_is_what_the_template_wrote_of_it_for_every_kind_of_check():
    """A check's block is written in Python (the page's longest part); it is byte for byte what the template's own
    loop wrote, for each status, practice questions, hints, quiz answers of any type, failed code checks with their
    tables, and learner text holding every character HTML escapes."""
    import itertools

    from grader.model import CheckResult, Status
    from grader.render import html, precompiled

    block = precompiled.environment().from_string(CHECK_BLOCK)
    hostile = '<script>alert("x")</script> & \'quoted\'\n\u2028'
    checked = 0
    for status, kind, practice, message, hint, got in itertools.product(
            Status, ("code", "quiz"), (False, True), ("", hostile), ("", hostile),
            (None, hostile, 0.5, [[1.0, 2.0], [3.0, 4.5]])):
        check = CheckResult(f"id_{checked}<", "f&", hostile, status, 0.25, 1.5, message=message, help=hint,
                            kind=kind, practice=practice, got=got,
                            expected=[[1.0, 2.0], [3.0, 4.0]] if isinstance(got, list) else None,
                            details={"wrong": [[1, 1]]})
        expected = block.render(c=check, chapter="ch06", marks=html.MARKS, num=html._num, values=html._values)
        assert html._check_html(check, "ch06") == expected
        checked += 1
    assert checked == 5 * 2 * 2 * 2 * 2 * 4


KINDS_BLOCK = """{% for kind, label in (("code", "Code"), ("quiz", "Quiz")) %}{% set checks = ch.checks | selectattr("kind", "equalto", kind) | list %}
{% if checks %}<h{{ h + 2 }} class="kind-title">{{ label }}: {{ num(ch.score_of(kind)) }} / {{ num(ch.max_score_of(kind)) }}{% if ch.recorded_score_of(kind) %} (+{{ num(ch.recorded_score_of(kind)) }} point{{ '' if ch.recorded_score_of(kind) == 1 else 's' }} recorded, graded when you submit){% endif %}</h{{ h + 2 }}>
{% set folded = not_written(checks) if kind == "code" else {} %}
{% for c in checks %}{% if c.function in folded %}{% if c is sameas folded[c.function][0] %}<div class="check fail"><span class="status"><span aria-hidden="true">{{ marks["fail"] }} </span>fail</span>{{ c.function }}: not implemented yet ({{ folded[c.function] | length }} check{{ "s" if folded[c.function] | length != 1 }})
<span class="points">0 / {{ num(folded[c.function] | sum(attribute="max_points")) }}<span class="sr-only"> points</span></span></div>{% endif %}{% else %}{{ check_html(c, ch.chapter) }}{% endif %}{% endfor %}{% endif %}{% endfor %}"""


def test_a_chapters_checks_are_what_the_template_wrote_of_them():
    """A chapter's checks under their kinds' headings are written in Python; byte for byte what the template's loop
    wrote: code and quiz, either missing, points recorded (one and several), functions not written yet (one check,
    several, and one whose other check ran) folded into a line, hostile names."""
    import itertools

    from grader.model import ChapterResult, CheckResult, Status
    from grader.render import html, precompiled

    block = precompiled.environment().from_string(KINDS_BLOCK)
    hostile = '<b>"f"</b> & \'g\''
    not_written = {"not_implemented": True}
    code = [CheckResult("a", "f", "f at 0", Status.PASS, 1, 1),
            CheckResult("b", hostile, "unwritten", Status.FAIL, 0, 1.5, message="NotImplementedError", details=not_written),
            CheckResult("c", hostile, "unwritten too", Status.FAIL, 0, 2, details=not_written),
            CheckResult("d", "g", "g once", Status.FAIL, 0, 1, details=not_written),
            CheckResult("e", "k", "k half", Status.FAIL, 0, 1, details=not_written),
            CheckResult("f", "k", "k other", Status.ERROR, 0, 1, message=hostile)]
    quiz = [CheckResult("quiz_a", "a", "a?", Status.RECORDED, 0, 1, kind="quiz", got="b"),
            CheckResult("quiz_b", "b", hostile, Status.FAIL, 0, 1.5, kind="quiz", got=hostile),
            CheckResult("quiz_c", "c", "c?", Status.RECORDED, 0, 1.5, kind="quiz", got="1"),
            CheckResult("quiz_d", "d", "d?", Status.PASS, 1, 1, kind="quiz", got="a", practice=True)]
    written = 0
    for code_part, quiz_part, h in itertools.product((code, code[:1], code[1:2], code[3:4], []),
                                                      (quiz, quiz[:1], quiz[1:2], []), (1, 2, 3)):
        chapter = ChapterResult("ch06", "H", list(code_part) + list(quiz_part))
        expected = block.render(ch=chapter, h=h, num=html._num, marks=html.MARKS, not_written=html.not_written,
                                check_html=html._check_html)
        assert html._checks_html(chapter, h) == expected
        written += 1
    assert written == 5 * 4 * 3
