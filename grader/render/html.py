"""The HTML renderer: one self-contained file (inline CSS, SVG plots as data URIs, no network).

Plots are drawn from the data the report's gatherers collected in the child (grader/plots.py):
values the learner's functions returned, with the reference beside them. Where the learner's
values are missing, the plot shows the reference and its caption says so. A plot that fails to
draw becomes a note; it never breaks the report. matplotlib and jinja2 load only here.
"""

from __future__ import annotations

import base64
import functools
import io
import os

import numpy as np

from grader.model import ChapterResult, CheckResult, Report

LEARNER, REFERENCE = "#c2410c", "#2563eb"

TEMPLATE = r"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<meta http-equiv="Content-Security-Policy" content="default-src 'none'; img-src data:; style-src 'unsafe-inline'">
<title>Jacobians &amp; Linearization: grading report</title>
<style>
body{font:15px/1.45 system-ui,-apple-system,"Segoe UI",Roboto,sans-serif;margin:0;color:#1f2937;background:#f8fafc}
main{max-width:1020px;margin:0 auto;padding:24px}
h1{font-size:1.6em;margin:.2em 0}h2{margin:1.6em 0 .4em;border-bottom:2px solid #e5e7eb;padding-bottom:.2em}
table{border-collapse:collapse;margin:.5em 0}td,th{padding:4px 10px;border-bottom:1px solid #e5e7eb;text-align:left}
.summary td.num,.summary th.num{text-align:right;font-variant-numeric:tabular-nums}
.check{background:#fff;border:1px solid #e5e7eb;border-left:5px solid #9ca3af;border-radius:6px;padding:8px 12px;margin:8px 0}
.pass{border-left-color:#16a34a}.fail{border-left-color:#dc2626}.error{border-left-color:#9333ea}.skip{border-left-color:#ca8a04}.recorded{border-left-color:#0e7490}
.status{font-weight:700;text-transform:uppercase;font-size:.8em;margin-right:.6em}
.pass .status{color:#16a34a}.fail .status{color:#dc2626}.error .status{color:#9333ea}.skip .status{color:#ca8a04}.recorded .status{color:#0e7490}
.points{float:right;color:#6b7280}
pre{white-space:pre-wrap;background:#f3f4f6;padding:6px 8px;border-radius:4px;font-size:.9em;margin:.4em 0}
table.matrix td{border:1px solid #d1d5db;font-family:ui-monospace,monospace;text-align:right}
table.matrix td.wrong{background:#fee2e2;font-weight:700}
.pair{display:flex;gap:24px;flex-wrap:wrap;align-items:flex-start}.pair div{font-size:.85em;color:#6b7280}
figure{background:#fff;border:1px solid #e5e7eb;border-radius:6px;padding:10px;margin:12px 0}
figure img{max-width:100%;height:auto}figcaption{color:#374151;font-size:.9em}
.problem{background:#fef2f2;border:1px solid #fecaca;padding:8px 12px;border-radius:6px}
.note{color:#6b7280}
</style></head>
<body><main>
<h1>Jacobians &amp; Linearization: grading report</h1>
<p class="note">Submission {{ report.submission }} &middot; seed {{ report.seed }}{% if report.learner %} &middot; quiz learner {{ report.learner }}{% endif %}</p>
<section id="summary"><h2>Summary</h2>
<table class="summary"><tr><th>chapter</th><th>title</th><th class="num">code</th><th class="num">quiz</th><th class="num">total</th></tr>
{% for ch in report.chapters %}<tr><td><a href="#{{ ch.chapter }}">{{ ch.chapter }}</a></td><td>{{ ch.title }}</td>
<td class="num" data-code="{{ ch.chapter }}">{{ num(ch.score_of('code')) }} / {{ num(ch.max_score_of('code')) }}</td>
<td class="num" data-quiz="{{ ch.chapter }}">{{ num(ch.score_of('quiz')) }} / {{ num(ch.max_score_of('quiz')) }}</td>
<td class="num" data-total="{{ ch.chapter }}">{{ num(ch.score) }} / {{ num(ch.max_score) }}</td></tr>{% endfor %}
<tr><th colspan="4">Total</th><th class="num" id="total">{{ num(report.score) }} / {{ num(report.max_score) }}</th></tr></table>
<p id="verdict">{{ verdict }}</p>
</section>
{% for ch in report.chapters %}
<section class="chapter" id="{{ ch.chapter }}"><h2>{{ ch.chapter }} &middot; {{ ch.title }}</h2>
{% for problem in ch.problems %}<pre class="problem">{{ problem }}</pre>{% endfor %}
{% if ch.hidden_checks %}<p class="note">{{ ch.hidden_checks }} hidden check(s) ({{ num(ch.hidden_points) }} points) run when you submit.</p>{% endif %}
{% for fig in figures[ch.chapter] %}<figure>{% if fig.uri %}<img src="{{ fig.uri }}" alt="{{ fig.alt }}" width="{{ fig.width }}" height="{{ fig.height }}">{% endif %}
<figcaption>{{ fig.caption }}</figcaption></figure>{% endfor %}
{% for kind, label in (("code", "Code"), ("quiz", "Quiz")) %}{% set checks = ch.checks | selectattr("kind", "equalto", kind) | list %}
{% if checks %}<h3>{{ label }}: {{ num(ch.score_of(kind)) }} / {{ num(ch.max_score_of(kind)) }}{% if ch.recorded_score_of(kind) %} (+{{ num(ch.recorded_score_of(kind)) }} points recorded, graded when you submit){% endif %}</h3>
{% for c in checks %}<div class="check {{ c.status.value }}"><span class="status">{{ c.status.value }}</span>{{ c.description }}
<span class="points">{{ num(c.points) }} / {{ num(c.max_points) }}</span>
{% if c.status.value != "pass" and c.message %}<pre>{{ c.message }}</pre>{% endif %}
{% if c.kind == "quiz" and c.got is not none %}<div class="note">your answer: {{ c.got }}</div>{% endif %}
{% if c.status.value == "fail" and c.kind == "code" %}{{ values(c) }}{% endif %}
</div>{% endfor %}{% endif %}{% endfor %}
</section>{% endfor %}
</main></body></html>
"""


def _num(value: float) -> str:
    return f"{value:g}"


def _matrix_html(values, wrong: set) -> str:
    array = np.atleast_1d(np.asarray(values, dtype=float))
    if array.ndim == 1:
        array = array[None, :]
        wrong = {(0, i[0]) if len(i) == 1 else tuple(i) for i in wrong}
    if array.size > 36:
        return ""
    rows = []
    for i, row in enumerate(array):
        cells = "".join(f'<td class="{"wrong" if (i, j) in wrong else ""}">{v:.6g}</td>' for j, v in enumerate(row))
        rows.append(f"<tr>{cells}</tr>")
    return f'<table class="matrix">{"".join(rows)}</table>'


def _values(check: CheckResult) -> str:
    """Expected vs got as small tables, the wrong entries marked."""
    from markupsafe import Markup

    try:
        if check.expected is None or check.got is None:
            return Markup("")
        wrong = {tuple(i) for i in check.details.get("wrong", [])}
        got, expected = _matrix_html(check.got, wrong), _matrix_html(check.expected, wrong)
        if not got or not expected:
            return Markup("")
        return Markup(f'<div class="pair"><div>expected{expected}</div><div>got{got}</div></div>')
    except (TypeError, ValueError):
        return Markup("")


class _Figure:
    def __init__(self, uri: str, alt: str, caption: str, width: int = 640, height: int = 300) -> None:
        self.uri, self.alt, self.caption, self.width, self.height = uri, alt, caption, width, height


def _svg_uri(fig) -> str:
    buffer = io.BytesIO()
    fig.savefig(buffer, format="svg")  # fixed margins: bbox_inches="tight" would draw everything twice
    return "data:image/svg+xml;base64," + base64.b64encode(buffer.getvalue()).decode("ascii")


def _whose(learner_ok: bool, what: str) -> str:
    return (f"drawn from your {what}" if learner_ok else
            f"your {what} gave no usable value, so this shows the reference only")


def _ellipse(ax, center, cov, **style) -> None:
    values, vectors = np.linalg.eigh(np.asarray(cov, dtype=float)[:2, :2])
    angles = np.linspace(0, 2 * np.pi, 100)
    circle = np.stack([np.cos(angles), np.sin(angles)])
    points = vectors @ (np.sqrt(np.maximum(values, 0))[:, None] * 2 * circle)
    ax.plot(center[0] + points[0], center[1] + points[1], **style)


def _draw_ch00(ax, d):
    sig = np.array(d["sigma"])
    ax.plot(sig, d["reference"], "o--", color=REFERENCE, label="reference")
    ok = all(v is not None for v in d["learner"])
    if ok:
        ax.plot(sig, d["learner"], "s-", color=LEARNER, label="your mean_shift")
    ax.plot(sig, sig**2 / (2 * d["r"]), ":", color="gray", label="sigma^2 / 2r")
    ax.set(xlabel="sigma", ylabel="mean range - range of mean", title="The cloud's mean range moves outward")
    ax.legend(fontsize=8)
    return ok, "Mean shift of the range at (3, 4) as the position noise grows; " + _whose(ok, "mean_shift")


def _draw_ch01(fig, d):
    ax1, ax2 = fig.subplots(1, 2)
    x = np.array(d["x"])
    ax1.plot(x, d["f"], color="black", label="sqrt(x)")
    ok_line = d["line"] is not None
    ax1.plot(x, d["line"] if ok_line else d["line_ref"], color=LEARNER if ok_line else REFERENCE,
             label="your tangent line" if ok_line else "reference tangent line")
    ax1.plot([d["a"]], [2.0], "ko")
    ax1.set(xlabel="x", title="Tangent line at a = 4")
    delta = np.array(d["delta"])
    ok_err = d["error"] is not None
    ax2.loglog(delta, d["error"] if ok_err else d["error_ref"], "o-", color=LEARNER if ok_err else REFERENCE,
               label="your linearization_error" if ok_err else "reference error")
    ax2.loglog(delta, delta**2 / 64, ":", color="gray", label="delta^2 / 64 guide")
    ax2.set(xlabel="delta", title="Error grows like delta^2")
    for ax in (ax1, ax2):
        ax.legend(fontsize=8)
    ok = ok_line and ok_err
    return ok, "Left: sqrt and its tangent line at 4; right: the error against delta with a delta^2 guide; " + \
        _whose(ok, "tangent_line and linearization_error")


def _draw_ch02(ax, d):
    grid = np.linspace(-3, 3, 200)
    X, Y = np.meshgrid(grid, grid)
    ax.contour(X, Y, X**2 + 0.5 * X * Y + Y**2, levels=8, colors="#9ca3af", linewidths=0.8)
    ok = all(v is not None for v in d["learner"])
    vectors = np.array(d["learner"] if ok else d["reference"], dtype=float)
    points = np.array(d["points"])
    ax.quiver(points[:, 0], points[:, 1], vectors[:, 0], vectors[:, 1], color=LEARNER if ok else REFERENCE,
              angles="xy", scale_units="xy", scale=6)
    ax.set(aspect="equal", title="Gradient arrows on the contours of g")
    return ok, "Contour rings of g = x^2 + 0.5xy + y^2 with gradient arrows, perpendicular to the rings; " + \
        _whose(ok, "bowl_gradient")


def _draw_jacobian_circle(ax, jac, ok, center, radius, image=None):
    angles = np.linspace(0, 2 * np.pi, 100)
    circle = radius * np.stack([np.cos(angles), np.sin(angles)])
    mapped = np.asarray(jac, dtype=float) @ circle
    if image is not None:
        image = np.asarray(image)
        ax.plot(image[:, 0], image[:, 1], color="black", lw=2, label="true image")
    ax.plot(center[0] + mapped[0], center[1] + mapped[1], "--", color=LEARNER if ok else REFERENCE,
            label="through your J" if ok else "through the reference J")
    ax.set(aspect="equal")
    ax.legend(fontsize=8)


def _draw_ch03(ax, d):
    ok = d["learner"] is not None
    r, t, rad = d["r"], d["theta"], d["radius"]
    _draw_jacobian_circle(ax, d["learner"] if ok else d["reference"], ok, d["center"], rad, d["image"])
    ax.set(title="A small (r, theta) circle mapped to (x, y)")
    return ok, f"A circle of radius {rad} around (r, theta) = ({r}, {t}) mapped by the polar map (black) and by J " \
               "(dashed); " + _whose(ok, "polar_to_cartesian_jacobian")


def _draw_ch04(ax, d):
    ok = d["learner"] is not None
    _draw_jacobian_circle(ax, d["learner"] if ok else d["reference"], ok, d["center"], d["radius"], d["image"])
    ax.set(title="Two-stage map g(p(r, theta)) and its Jacobian")
    return ok, "A small circle around (r, theta) = (1.5, 0.9) through both stages (black) and through the composed " \
               "Jacobian (dashed); " + _whose(ok, "pipeline_jacobian")


def _draw_ch05(ax, d):
    h = np.array(d["h"])
    ok = d["forward"] is not None and d["central"] is not None
    tiny = 1e-17
    ax.loglog(h, np.maximum(d["forward"] if ok else d["forward_ref"], tiny), "o-",
              color=LEARNER if ok else REFERENCE, label="forward")
    ax.loglog(h, np.maximum(d["central"] if ok else d["central_ref"], tiny), "s-",
              color="#7c3aed" if ok else "#60a5fa", label="central")
    ax.loglog(h, 0.5 * h, ":", color="gray", label="slope 1")
    ax.loglog(h, 0.1 * h**2, "--", color="gray", label="slope 2")
    ax.set(xlabel="h", ylabel="|error|", ylim=(1e-17, 1), title="Finite-difference error of d sin/dx at 1")
    ax.legend(fontsize=8)
    return ok, "Log-log error against h: truncation falls with slope 1 (forward) and 2 (central) until " \
               "rounding takes over; " + _whose(ok, "forward_difference and central_difference")


def _draw_ch06(ax, d):
    r = np.array(d["r"])
    ok = d["learner"] is not None
    ax.loglog(r, d["reference"], "--", color=REFERENCE, label="reference sigma / r")
    if ok:
        ax.loglog(r, d["learner"], "o", color=LEARNER, ms=4, label="your measurement_covariance")
    ax.set(xlabel="range r", ylabel="bearing std (rad)", title="Bearing sensitivity grows near the dish")
    ax.legend(fontsize=8)
    return ok, f"Linearized bearing standard deviation against range, sigma = {d['sigma']}; " + \
        _whose(ok, "measurement_covariance")


def _draw_ch07(ax, d):
    ok = d["P_new"] is not None
    _ellipse(ax, (0, 0), d["P"], color="gray", label="P before")
    _ellipse(ax, d["mean_new"], d["P_new"] if ok else d["P_new_ref"], color=LEARNER if ok else REFERENCE,
             label="F P F^T after" + ("" if ok else " (reference)"))
    ax.set(aspect="equal", xlabel="x", ylabel="y", title="Covariance ellipse tilts after one step")
    ax.legend(fontsize=8)
    return ok, "2-sigma position ellipses before and after one motion step; " + _whose(ok, "propagate_covariance")


def _draw_ch08(fig, d):
    axes = fig.subplots(1, 2)
    ok = True
    for ax, name, title in zip(axes, ("far", "close"), ("far: (3, 4)", "close: (0.3, 0.2)")):
        case = d[name]
        z = np.array(case["z"])
        ax.plot(z[:, 0], z[:, 1], ".", ms=2, color="#9ca3af" if case["z_is_reference"] else LEARNER)
        cov_ok = case["cov"] is not None
        _ellipse(ax, case["center"], case["cov"] if cov_ok else case["cov_ref"], color=REFERENCE if not cov_ok else "black")
        ok = ok and cov_ok and not case["z_is_reference"]
        ax.set(xlabel="range", ylabel="bearing", title=title)
    return ok, "Monte Carlo measurement clouds with the 2-sigma linearized ellipse, far from and close to the dish; " \
        + _whose(ok, "measure_samples and linearized_measurement_cov")


def _draw_ch09(ax, d):
    ok = d["H"] is not None
    H = np.array(d["H"] if ok else d["H_ref"], dtype=float)
    grid = np.linspace(-2, 2, 200)
    X, Y = np.meshgrid(grid, grid)
    Q = 0.5 * (H[0, 0] * X**2 + 2 * H[0, 1] * X * Y + H[1, 1] * Y**2)
    ax.contour(X, Y, Q, levels=12, cmap="coolwarm")
    kind = str(d["kind"] or d["kind_ref"])[:60]
    # the learner's text, drawn as plain text: a '$' would start matplotlib's math parser
    ax.set(aspect="equal", title=f"Quadratic model from the Hessian: {kind}".replace("$", r"\$"))
    return ok, "Contours of the quadratic model 0.5 v^T H v with H at (1, 2) from " + \
        ("your hessian_fd" if ok else "the reference (your hessian_fd gave no usable value)") + \
        f"; your classify_critical_point says: {d['kind'] or 'nothing usable'}"


_DRAW = {"ch00": _draw_ch00, "ch01": _draw_ch01, "ch02": _draw_ch02, "ch03": _draw_ch03, "ch04": _draw_ch04,
         "ch05": _draw_ch05, "ch06": _draw_ch06, "ch07": _draw_ch07, "ch08": _draw_ch08, "ch09": _draw_ch09}
_TWO_PANELS = {"ch01", "ch08"}


def _plain_log_labels(fig) -> None:
    """Log-axis labels as plain text (1e-05, 0.01): matplotlib's default 10^k labels go through its
    mathtext parser, which costs more than drawing the rest of the figure."""
    from matplotlib.ticker import FuncFormatter, NullFormatter

    plain = FuncFormatter(lambda value, _: f"{value:g}")
    for ax in fig.axes:
        for axis, scale in ((ax.xaxis, ax.get_xscale()), (ax.yaxis, ax.get_yscale())):
            if scale == "log":
                axis.set_major_formatter(plain)
                axis.set_minor_formatter(NullFormatter())


def preload() -> None:
    """Import matplotlib (about 0.4 s); called in a thread while grading waits on the child."""
    import matplotlib

    matplotlib.use("Agg")
    matplotlib.rcParams["svg.fonttype"] = "none"  # text stays text: smaller and faster than glyph paths
    import matplotlib.pyplot  # noqa: F401


def figures(chapter: ChapterResult) -> list[_Figure]:
    """The chapter's plots as data-URI images; a plot that cannot be drawn becomes a caption only."""
    draw = _DRAW.get(chapter.chapter)
    if draw is None or not chapter.plots:
        return []
    preload()
    import matplotlib.pyplot as plt

    out = []
    for name, data in chapter.plots.items():
        fig = plt.figure(figsize=(9, 3.4) if chapter.chapter in _TWO_PANELS else (6, 3.6))
        try:
            target = fig if chapter.chapter in _TWO_PANELS else fig.add_subplot()
            ok, caption = draw(target, data)
            _plain_log_labels(fig)
            fig.subplots_adjust(left=0.1, right=0.97, bottom=0.15, top=0.9, wspace=0.28)
            alt = f"{chapter.chapter} plot: {caption}"
            out.append(_Figure(_svg_uri(fig), alt, caption, 900 if chapter.chapter in _TWO_PANELS else 600, 340))
        except Exception as exc:  # a plot never breaks the report
            out.append(_Figure("", "", f"This plot could not be drawn ({type(exc).__name__}: {exc})."))
        finally:
            plt.close(fig)
    return out


@functools.lru_cache(maxsize=1)
def _template():
    """The page template, compiled once per process (compiling costs more than rendering)."""
    import jinja2

    environment = jinja2.Environment(autoescape=True, undefined=jinja2.StrictUndefined)
    return environment.from_string(TEMPLATE)


def render(report: Report) -> str:
    """The report as one self-contained HTML page. Learner text is escaped by the template and has
    no lone surrogates or control characters (grader.safe_text.for_html), so the page always encodes."""
    from grader import safe_text
    from grader.render.text import verdict_line

    report = safe_text.clean_report(report, safe_text.for_html)
    return _template().render(report=report, figures=_all_figures(report), num=_num, values=_values,
                              verdict=verdict_line(report))


def _all_figures(report: Report) -> dict[str, list[_Figure]]:
    """Every chapter's figures, drawn by two forked processes where forking is safe (drawing is most of
    the report's cost); serially where it is not (Windows, macOS) or fails."""
    chapters = [c for c in report.chapters if c.plots]
    out: dict[str, list[_Figure]] = {c.chapter: [] for c in report.chapters}
    from grader.spawn import fork_is_safe

    if len(chapters) > 1 and fork_is_safe():
        try:
            import multiprocessing
            from concurrent.futures import ProcessPoolExecutor

            preload()
            with ProcessPoolExecutor(max_workers=min(2, os.cpu_count() or 1),
                                     mp_context=multiprocessing.get_context("fork")) as pool:
                for chapter, drawn in zip(chapters, pool.map(figures, chapters)):
                    out[chapter.chapter] = drawn
            return out
        except (OSError, ValueError, ImportError, RuntimeError):
            pass
    for chapter in chapters:
        out[chapter.chapter] = figures(chapter)
    return out

