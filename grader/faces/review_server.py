"""`grade review OUT`: a local web application where an instructor reads a batch's learners, their code beside
each failing check, and records an override with its reason (grader.course.review reads the history and records
through it). Starlette served by uvicorn (the `review` extra), on 127.0.0.1 only.

Safe by construction: every request needs the secret token the command prints (in the URL once, then an
HttpOnly, SameSite=Strict cookie), compared in constant time; every form carries a CSRF token checked the same
way; learner text is escaped by jinja2's autoescape, and the pages' Content-Security-Policy allows only the
page's own script and style (a nonce per response), so that text that got through could still not run; files
are served only from inside OUT; `read_only` (a TA) shows no form and refuses every POST.
"""

from __future__ import annotations

import hmac
import secrets
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from urllib.parse import parse_qs, quote

from jinja2 import Environment

from grader.course import review
from grader.model import points_text

COOKIE = "grade_review"
_STYLE = """
body{font:15px/1.45 system-ui,sans-serif;margin:0;color:#1f2937;background:#fff}
header,main{max-width:1400px;margin:0 auto;padding:8px 16px}
a{color:#1d4ed8}a:focus,button:focus,input:focus,select:focus,tr:focus{outline:3px solid #f59e0b;outline-offset:1px}
table{border-collapse:collapse;width:100%}th,td{padding:3px 8px;border-bottom:1px solid #e5e7eb;text-align:left;
vertical-align:top}th button{font:inherit;font-weight:600;background:none;border:0;padding:0;cursor:pointer;color:#111827}
td.num,th.num{text-align:right;white-space:nowrap}.tag{display:inline-block;border-radius:4px;padding:0 5px;margin:1px;
font-size:.85em;background:#eef2ff;color:#1e3a8a}.warn{background:#fef3c7;color:#7c2d12}.bad{background:#fee2e2;color:#7f1d1d}
.filters{display:flex;flex-wrap:wrap;gap:12px;align-items:end;margin:8px 0}.filters label{display:flex;flex-direction:column;
font-size:.9em}pre{margin:0;overflow-x:auto}.code{border:1px solid #d1d5db;border-radius:6px;margin:8px 0 18px}
.code h3{margin:0;padding:6px 10px;background:#f3f4f6;font-size:1em}.blame{margin:4px 10px;padding:4px 8px;
border-left:4px solid #b91c1c;background:#fef2f2}.blame p{margin:2px 0}.hll{background:#fde68a}
.lineno{color:#4b5563;user-select:none;padding-right:8px}.pair{display:grid;grid-template-columns:1fr 1fr;gap:8px}
.shared{background:#dbeafe}form.override{display:grid;grid-template-columns:repeat(auto-fill,minmax(180px,1fr));gap:8px;
align-items:end;border:1px solid #d1d5db;border-radius:6px;padding:10px}form.override label{display:flex;
flex-direction:column;font-size:.9em}.message{white-space:pre-wrap;font-family:ui-monospace,monospace;font-size:.85em}
.notice{padding:8px 12px;border-radius:6px;background:#ecfdf5;color:#064e3b}.error{background:#fef2f2;color:#7f1d1d}
.visually-hidden{position:absolute;width:1px;height:1px;overflow:hidden;clip:rect(0 0 0 0);white-space:nowrap}
.scroll{overflow-x:auto}#learners td:last-child{min-width:16em}#learners .tag{white-space:nowrap}
"""

_CLASS_SCRIPT = """
(function(){
  const rows = Array.from(document.querySelectorAll('#learners tbody tr'));
  const body = document.querySelector('#learners tbody');
  const inputs = ['q','flag','chapter','check','mistake'].map(id => document.getElementById(id));
  const count = document.getElementById('shown');
  function apply(){
    const [q, flag, chapter, check, mistake] = inputs.map(i => i.value);
    let shown = 0;
    for (const row of rows) {
      const ok = (!q || row.dataset.learner.toLowerCase().includes(q.toLowerCase()))
        && (!flag || row.dataset.flags.split(' ').includes(flag))
        && (!chapter || row.dataset.checks.split('|').some(c => c.startsWith(chapter + '/')))
        && (!check || row.dataset.checks.split('|').includes(check))
        && (!mistake || row.dataset.mistakes.split('|').includes(mistake));
      row.hidden = !ok; if (ok) shown++;
    }
    count.textContent = shown;
  }
  inputs.forEach(i => i.addEventListener('input', apply));
  document.querySelectorAll('#learners th button').forEach((button, column) => {
    button.addEventListener('click', () => {
      const th = button.closest('th');
      const ascending = th.getAttribute('aria-sort') !== 'ascending';
      document.querySelectorAll('#learners th').forEach(h => h.removeAttribute('aria-sort'));
      th.setAttribute('aria-sort', ascending ? 'ascending' : 'descending');
      const index = Array.from(th.parentNode.children).indexOf(th);
      const key = row => row.children[index].dataset.sort;
      rows.sort((a, b) => {
        const x = key(a), y = key(b), nx = parseFloat(x), ny = parseFloat(y);
        const order = (!isNaN(nx) && !isNaN(ny)) ? nx - ny : x.localeCompare(y);
        return ascending ? order : -order;
      });
      rows.forEach(row => body.appendChild(row));
    });
  });
  document.addEventListener('keydown', event => {
    if (event.target.matches('input, select, textarea')) return;
    if (event.key !== 'j' && event.key !== 'k') return;
    const visible = rows.filter(row => !row.hidden);
    const at = visible.indexOf(document.activeElement.closest && document.activeElement.closest('tr'));
    const next = visible[Math.max(0, Math.min(visible.length - 1, at + (event.key === 'j' ? 1 : -1)))];
    if (next) { next.querySelector('a').focus(); event.preventDefault(); }
  });
  apply();
})();
"""

_LAYOUT = """<!DOCTYPE html><html lang="en"><head><meta charset="utf-8"><meta name="viewport"
content="width=device-width, initial-scale=1"><title>{{ title }}</title><style nonce="{{ nonce }}">{{ style }}</style>
</head><body><header><nav aria-label="review"><a href="/">Class</a>{% if read_only %} · read-only{% endif %}</nav>
</header><main id="main">{{ body }}</main>{% if script %}<script nonce="{{ nonce }}">{{ script }}</script>{% endif %}
</body></html>"""

_CLASS = """<h1>{{ out_name }}: {{ view.rows|length }} learners</h1>
<p>Run {{ view.run }} ({{ view.run_info.reason or "grade batch" }}, {{ view.run_info.started }}). Filter, sort by a column
(its header's button), move with <kbd>j</kbd> and <kbd>k</kbd>; <span id="shown">{{ view.rows|length }}</span> shown.</p>
<div class="filters" role="search">
<label for="q">Learner<input id="q" type="search" autocomplete="off"></label>
<label for="flag">Flag<select id="flag"><option value="">any</option><option value="notgraded">not graded</option>
<option value="late">late</option><option value="untimed">untimed</option><option value="overridden">overridden</option>
<option value="similar">similar to another</option><option value="flagged">flagged</option></select></label>
<label for="chapter">Failing in chapter<select id="chapter"><option value="">any</option>{% for c in view.chapters %}
<option value="{{ c }}">{{ c }}</option>{% endfor %}</select></label>
<label for="check">Failing check<select id="check"><option value="">any</option>{% for c in view.checks %}
<option value="{{ c }}">{{ c }}</option>{% endfor %}</select></label>
<label for="mistake">Named mistake<select id="mistake"><option value="">any</option>{% for m in view.mistakes %}
<option value="{{ m }}">{{ m }}</option>{% endfor %}</select></label></div>
<div class="scroll"><table id="learners"><caption class="visually-hidden">Learners of run {{ view.run }}</caption><thead><tr>
<th scope="col"><button type="button">learner</button></th><th scope="col"><button type="button">status</button></th>
<th scope="col" class="num"><button type="button">total</button></th>{% for c in view.chapters %}
<th scope="col" class="num"><button type="button">{{ c }}</button></th>{% endfor %}
<th scope="col"><button type="button">late</button></th><th scope="col"><button type="button">overrides</button></th>
<th scope="col"><button type="button">similar</button></th><th scope="col"><button type="button">named mistakes</button></th>
</tr></thead><tbody>{% for row in view.rows %}
<tr data-learner="{{ row.learner }}" data-flags="{{ flags(row) }}" data-checks="{{ row.failing|join('|') }}"
data-mistakes="{{ row.mistakes|join('|') }}"><td data-sort="{{ row.learner }}"><a href="/learner/{{ url(row.learner) }}">{{ row.learner }}</a></td>
<td data-sort="{{ row.status }}">{% if row.status != "graded" %}<span class="tag bad">{{ row.status }}</span> {{ row.message }}{% else %}graded{% endif %}</td>
<td class="num" data-sort="{{ row.score if row.score is not none else -1 }}">{{ points(row.score) }}</td>{% for c in view.chapters %}
<td class="num" data-sort="{{ row.chapters.get(c) if row.chapters.get(c) is not none else -1 }}">{{ points(row.chapters.get(c)) }}</td>{% endfor %}
<td data-sort="{{ row.late }}">{{ row.late }}{% if row.untimed %}<span class="tag warn">untimed</span>{% endif %}</td>
<td data-sort="{{ row.overrides|length }}">{% for o in row.overrides %}<span class="tag">{{ o }}</span>{% endfor %}</td>
<td data-sort="{{ row.similar|length }}">{{ row.similar|join(", ") }}</td>
<td data-sort="{{ row.mistakes|length }}">{% for m in row.mistakes %}<span class="tag warn">{{ m }}</span>{% endfor %}</td>
</tr>{% endfor %}</tbody></table></div>"""

_LEARNER = """<h1>{{ v.learner }}</h1>
{% if notice %}<p class="notice" role="status">{{ notice }}</p>{% endif %}
{% if error %}<p class="notice error" role="alert">{{ error }}</p>{% endif %}
<p>Run {{ v.run }}: {{ v.row.status }}{% if v.row.score is not none %}, {{ points(v.row.score) }} of {{ points(v.row.max_score) }}{% endif %}
{% if v.report_html %} · <a href="/out/{{ url(v.report_html) }}">their report</a>{% endif %}</p>
<table><caption>Chapters</caption><thead><tr>{% for c in v.row.chapters %}<th scope="col" class="num">{{ c }}</th>{% endfor %}</tr></thead>
<tbody><tr>{% for c, s in v.row.chapters.items() %}<td class="num">{{ points(s) }}</td>{% endfor %}</tr></tbody></table>
<h2>Overrides</h2>
{% if v.overrides %}<ul>{% for o in v.overrides %}<li>{{ o.target }}: {{ o.points if o.points is not none else "factor " ~ o.factor }}
by {{ o.who }}: {{ o.reason }} <small>({{ o.applied }})</small>{% if not read_only and o.points is not none %}
<form method="post" action="/learner/{{ url(v.learner) }}/override" class="inline"><input type="hidden" name="csrf" value="{{ csrf }}">
<input type="hidden" name="seen_run" value="{{ v.run }}"><input type="hidden" name="target" value="{{ o.target }}">
<input type="hidden" name="points" value="{{ -o.points }}"><input type="hidden" name="reason" value="undo: {{ o.reason }}">
<input type="hidden" name="who" value="{{ who }}"><button type="submit">Undo (another entry: {{ "%+g"|format(-o.points) }})</button></form>{% endif %}</li>{% endfor %}</ul>
{% else %}<p>None in force.</p>{% endif %}
{% if not read_only and v.row.status == "graded" %}
<form method="post" action="/learner/{{ url(v.learner) }}/override" class="override" aria-label="record an override">
<input type="hidden" name="csrf" value="{{ csrf }}"><input type="hidden" name="seen_run" value="{{ v.run }}">
<label for="target">Target<select id="target" name="target"><option value="total">total</option>{% for c in v.row.chapters %}
<option value="{{ c }}">{{ c }}</option>{% endfor %}{% for b in v.blames %}<option value="{{ b.check }}">{{ b.check }}</option>{% endfor %}
<option value="late">late (factor; 0 waives)</option></select></label>
<label for="points">Points (+/-)<input id="points" name="points" inputmode="decimal"></label>
<label for="factor">or factor<input id="factor" name="factor" inputmode="decimal"></label>
<label for="reason">Reason (the learner reads it)<input id="reason" name="reason" required></label>
<label for="who">Who<input id="who" name="who" value="{{ who }}" required></label>
<button type="submit">Record override</button></form>{% endif %}
<h2>Grade history</h2><table><thead><tr><th scope="col">run</th><th scope="col">when</th><th scope="col">why</th>
<th scope="col" class="num">score</th><th scope="col">adjustments</th></tr></thead><tbody>{% for h in v.history %}
<tr><td>{{ h.run }}</td><td>{{ h.started }}</td><td>{{ h.reason }}</td><td class="num">{{ points(h.score) }}</td>
<td>{{ h.adjustments|join("; ") }}</td></tr>{% endfor %}</tbody></table>
<h2>Code and failing checks</h2>
{% for name, text in v.files.items() %}<section class="code" aria-labelledby="f{{ loop.index }}"><h3 id="f{{ loop.index }}">{{ name }}</h3>
{% for b in v.blames if b.file == name %}<div class="blame"><p><strong>{{ b.check }}</strong> ({{ b.status }}, {{ points(b.points) }}/{{ points(b.max_points) }})
{% if b.lines %}blames <a href="#{{ anchor(name) }}-{{ b.lines[0] }}">{{ b.function }}, lines {{ b.lines[0] }}-{{ b.lines[1] }}</a>{% endif %}
{% if b.mistake %}<span class="tag warn">{{ b.mistake }}</span>{% endif %}</p><p class="message">{{ b.message }}</p>
{% if b.help %}<p>{{ b.help }}</p>{% endif %}</div>{% endfor %}
{{ highlighted(name, text, v.blames) }}</section>{% endfor %}
{% set unplaced = v.blames|selectattr("file", "equalto", "")|list %}{% if unplaced %}<h3>Other failing checks</h3>
{% for b in unplaced %}<div class="blame"><p><strong>{{ b.check }}</strong> ({{ b.status }}){% if b.mistake %}
<span class="tag warn">{{ b.mistake }}</span>{% endif %}</p><p class="message">{{ b.message }}</p></div>{% endfor %}{% endif %}
{% if pairs %}<h2>Similar submissions</h2>{% for p in pairs %}<h3>{{ p.first }} and {{ p.second }} ({{ "%.2f"|format(p.score) }})</h3>
{% for name, left, right in p.files %}<h4>{{ name }}</h4><div class="pair"><pre aria-label="{{ p.first }}">{% for line, shared in left %}<span{% if shared %} class="shared"{% endif %}>{{ line }}</span>
{% endfor %}</pre><pre aria-label="{{ p.second }}">{% for line, shared in right %}<span{% if shared %} class="shared"{% endif %}>{{ line }}</span>
{% endfor %}</pre></div>{% endfor %}{% endfor %}{% endif %}"""


def _flags(row: review.ClassRow) -> str:
    said = []
    if row.status != "graded":
        said.append("notgraded")
    if row.late:
        said.append("late")
    if row.untimed:
        said.append("untimed")
    if row.overrides:
        said.append("overridden")
    if row.similar:
        said.append("similar")
    if row.flags:
        said.append("flagged")
    return " ".join(said)


def _anchor(name: str) -> str:
    return "L-" + "".join(c if c.isalnum() else "-" for c in name)


@dataclass
class Review:
    """The application's state: the folder, the secrets, who records, and the class view kept per run."""

    out: Path
    token: str = field(default_factory=lambda: secrets.token_urlsafe(32))
    csrf: str = field(default_factory=lambda: secrets.token_urlsafe(32))
    read_only: bool = False
    who: str = "the instructor"
    _kept: review.ClassView | None = None
    _said: dict = field(default_factory=dict)  # what each kept report says, by its hash: read once
    _lock: threading.Lock = field(default_factory=threading.Lock)

    def class_view(self) -> review.ClassView:
        """The class of the last finished run, made once per run (a save makes a new run)."""
        with self._lock:
            if self._kept is None or self._kept.run != review.last_run(self.out):
                self._kept = review.class_view(self.out, self._said)
            return self._kept


def _highlighter():
    try:
        from pygments import highlight
        from pygments.formatters import HtmlFormatter
        from pygments.lexers import get_lexer_for_filename
        from pygments.util import ClassNotFound
    except ImportError:  # the review extra brings Pygments; without it the code is shown as plain text
        return None

    def code(name: str, text: str, lines: list[int]) -> str:
        try:
            lexer = get_lexer_for_filename(name, stripnl=False)
        except ClassNotFound:
            from pygments.lexers import TextLexer

            lexer = TextLexer(stripnl=False)
        formatter = HtmlFormatter(linenos="inline", lineanchors=_anchor(name), anchorlinenos=True, hl_lines=lines,
                                  style=CODE_STYLE, wrapcode=True)
        return highlight(text, lexer, formatter)
    return code


CODE_STYLE = "default"  # Pygments' style whose colours meet WCAG AA on white


def _code_css() -> str:
    """The code's colours as CSS classes (the page's policy allows no inline style attribute)."""
    try:
        from pygments.formatters import HtmlFormatter
    except ImportError:
        return ""
    return HtmlFormatter(style=CODE_STYLE).get_style_defs(".highlight")


def _pairs(out: Path, learner: str, view: review.LearnerView) -> list[dict]:
    """Each similar pair with this learner: per chapter file both have, the lines side by side, shared ones marked."""
    from grader.course.staging import STAGING, kept_files

    shown = []
    for pair in view.pairs[:3]:
        other = pair["second"] if pair.get("first") == learner else pair["first"]
        mine = view.files
        kept = kept_files(out / STAGING, other) or {}
        files = []
        for name, text in mine.items():
            if not name.endswith(".py") or name not in kept:
                continue
            theirs = kept[name].decode("utf-8", "replace")
            ours_lines, their_lines = text.splitlines(), theirs.splitlines()
            common = {line.strip() for line in ours_lines if line.strip()} & \
                     {line.strip() for line in their_lines if line.strip()}
            files.append((name, [(line, line.strip() in common) for line in ours_lines],
                          [(line, line.strip() in common) for line in their_lines]))
        first, second = (learner, other) if pair.get("first") == learner else (other, learner)
        if pair.get("first") != learner:
            files = [(name, right, left) for name, left, right in files]
        shown.append({"first": first, "second": second, "score": float(pair.get("score") or 0), "files": files})
    return shown


def make_app(state: Review):
    """The Starlette application of `state`."""
    from markupsafe import Markup
    from starlette.applications import Starlette
    from starlette.requests import Request
    from starlette.responses import FileResponse, HTMLResponse, RedirectResponse, Response
    from starlette.routing import Route

    environment = Environment(autoescape=True)
    layout, class_page, learner_page = (environment.from_string(t) for t in (_LAYOUT, _CLASS, _LEARNER))
    code = _highlighter()
    code_css = _code_css()

    def highlighted(name: str, text: str, blames: list) -> Markup:
        lines = sorted({n for b in blames if b.file == name and b.lines for n in range(b.lines[0], b.lines[1] + 1)})
        if code is None:
            return Markup("<pre>{}</pre>").format(text)
        return Markup(code(name, text, lines))  # Pygments escapes the text it formats

    helpers = {"points": points_text, "flags": _flags, "url": lambda s: quote(str(s), safe=""), "anchor": _anchor,
               "highlighted": highlighted}

    def page(title: str, body: str, script: str = "", status: int = 200) -> HTMLResponse:
        nonce = secrets.token_urlsafe(16)
        html = layout.render(title=title, body=Markup(body), style=Markup(_STYLE + code_css), script=Markup(script),
                             nonce=nonce, read_only=state.read_only)
        return HTMLResponse(html, status, headers={
            "Content-Security-Policy": f"default-src 'none'; script-src 'nonce-{nonce}'; style-src 'nonce-{nonce}'; "
                                       "img-src 'self' data:; form-action 'self'; frame-ancestors 'none'; "
                                       "base-uri 'none'",
            # same-origin: a form's POST carries the page's own Origin (no-referrer would send "null")
            "X-Content-Type-Options": "nosniff", "Referrer-Policy": "same-origin", "Cache-Control": "no-store"})

    def allowed(request: Request) -> bool:
        given = request.cookies.get(COOKIE) or request.query_params.get("token") or ""
        return hmac.compare_digest(given.encode(), state.token.encode())

    def refused(why: str, status: int = 403) -> HTMLResponse:
        return page("Refused", Markup("<h1>Refused</h1><p>{}</p>").format(why), status=status)

    def guarded(handler):
        async def run(request: Request) -> Response:
            if not allowed(request):
                return refused("This review needs the address `grade review` printed (with its token).")
            if "token" in request.query_params:  # once: the token moves into a cookie and out of the address
                response = RedirectResponse(request.url.path, 303)
                response.set_cookie(COOKIE, state.token, httponly=True, samesite="strict", path="/")
                return response
            return await handler(request)
        return run

    async def class_handler(request: Request) -> Response:
        started = time.perf_counter()
        view = state.class_view()
        body = class_page.render(view=view, out_name=state.out.name, **helpers)
        response = page(f"Review: {state.out.name}", body, _CLASS_SCRIPT)
        response.headers["Server-Timing"] = f"page;dur={1000 * (time.perf_counter() - started):.1f}"
        return response

    def learner_response(learner: str, notice: str = "", error: str = "", status: int = 200) -> Response:
        try:
            view = review.learner_view(state.out, learner, state.class_view())
        except review.ReviewError as exc:
            return refused(str(exc), 404)
        body = learner_page.render(v=view, csrf=state.csrf, read_only=state.read_only, who=state.who,
                                   notice=notice, error=error, pairs=_pairs(state.out, learner, view), **helpers)
        return page(f"Review: {learner}", body, status=status)

    async def learner_handler(request: Request) -> Response:
        return learner_response(request.path_params["learner"], notice=request.query_params.get("saved", "") and
                                "Recorded: every output of the class is rebuilt.")

    async def override_handler(request: Request) -> Response:
        learner = request.path_params["learner"]
        if state.read_only:
            return refused("This review is read-only (--read-only): nothing can be recorded here.")
        form = {k: v[-1] for k, v in parse_qs((await request.body()).decode("utf-8", "replace"),
                                              keep_blank_values=True).items()}
        if not hmac.compare_digest(form.get("csrf", "").encode(), state.csrf.encode()):
            return refused("The form's CSRF token is missing or wrong: reload the page and save again.")
        origin = request.headers.get("origin")
        if origin is not None and origin != f"{request.url.scheme}://{request.url.netloc}":
            return refused("A form from another site is refused.")
        try:
            points = float(form["points"]) if form.get("points", "").strip() else None
            factor = float(form["factor"]) if form.get("factor", "").strip() else None
            seen = int(form.get("seen_run", ""))
        except ValueError:
            return learner_response(learner, error="Points, factor and the run are numbers.", status=400)
        try:
            review.record_override(state.out, learner, form.get("target", "total"), points, factor,
                                   form.get("reason", ""), form.get("who", ""), seen)
        except review.StaleError as exc:
            return learner_response(learner, error=f"Not recorded: {exc}", status=409)
        except review.ReviewError as exc:
            return learner_response(learner, error=f"Not recorded: {exc}", status=400)
        return RedirectResponse(f"/learner/{quote(learner, safe='')}?saved=1", 303)

    async def out_file(request: Request) -> Response:
        root = state.out.resolve()
        path = (state.out / request.path_params["path"]).resolve()
        if not path.is_relative_to(root) or not path.is_file() or path.name == "gradebook.db" or \
                ".staging" in path.relative_to(root).parts:
            return refused("Not a file of this review.", 404)
        return FileResponse(path, headers={"Content-Security-Policy": "default-src 'none'; img-src data:; "
                                           "style-src 'unsafe-inline'; sandbox", "X-Content-Type-Options": "nosniff",
                                           "Referrer-Policy": "no-referrer"})

    return Starlette(routes=[
        Route("/", guarded(class_handler)),
        Route("/learner/{learner:str}", guarded(learner_handler)),
        Route("/learner/{learner:str}/override", guarded(override_handler), methods=["POST"]),
        Route("/out/{path:path}", guarded(out_file)),
    ])


def serve(out: Path, *, port: int = 0, read_only: bool = False, who: str = "the instructor", open_browser: bool = True,
          announce=print) -> None:
    """Serve the review of `out` on 127.0.0.1 (`port` 0: one the system gives) until interrupted; announce its
    address with the token, and open it in the browser unless told not to."""
    import socket

    import uvicorn

    review.class_view(out)  # a folder that cannot be reviewed says so before anything listens
    state = Review(out, read_only=read_only, who=who)
    listener = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    listener.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    listener.bind(("127.0.0.1", port))
    listener.listen(128)  # connections wait in the queue from now on: the address printed next answers
    address = f"http://127.0.0.1:{listener.getsockname()[1]}/?token={state.token}"
    announce(f"Reviewing {out}{' (read-only)' if read_only else ''} at {address}")
    announce("Anyone with this address can read and record grades: do not share it. Ctrl-C stops it.")
    if open_browser:
        import webbrowser

        threading.Timer(0.5, webbrowser.open, (address,)).start()
    config = uvicorn.Config(make_app(state), log_level="warning", access_log=False, lifespan="off")
    uvicorn.Server(config).run(sockets=[listener])
