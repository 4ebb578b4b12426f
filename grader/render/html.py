"""The HTML renderer: one self-contained file (inline CSS, SVG plots as data URIs, no network).

The page places the figures grader.render.figures draws (from the data the report's gatherers collected in
the child, grader/checks/plots.py), drawn elsewhere meanwhile where possible (grader.render.drawer) or reused
from the figure cache (grader.render.figure_cache). jinja2 loads only here.

`render_fragment` gives the same report for a notebook's output: a <div> with its own scoped style.
Page and fragment meet WCAG 2.1 AA (tests/render/test_html_accessibility.py runs axe-core on them in chromium):
contrast of 6.4:1 or more, verdicts as words and marks, and plots whose series differ by marker or
line style and whose text alternative says in numbers what the learner's functions gave.
"""

from __future__ import annotations

import functools
import re
from typing import TYPE_CHECKING

import numpy as np
from markupsafe import Markup, escape

from grader.model import ChapterResult, CheckResult, Report, made_once, not_written
from grader.numbers import fmt
from grader.render import plural
from grader.render.figures import Figure

if TYPE_CHECKING:
    from collections.abc import Callable

    from grader.render.figure_cache import FigureCache

# Text colours with their contrast on white (the report's cards) and on the page's #f8fafc; WCAG 2.1 AA
# asks 4.5:1 for text. Each verdict is a word with a mark as well as a colour.
#   body #1f2937 14.7:1 / 14.0:1   muted #4b5563 7.6:1 / 7.2:1   link #1d4ed8 6.7:1 / 6.4:1
#   pass #166534 7.1:1   fail #b91c1c 6.5:1   error #7e22ce 7.0:1   skip #854d0e 6.9:1   recorded #155e75 7.3:1
#   a matrix entry that differs: #1f2937 on #fee2e2 12.0:1, outlined, marked with a cross and the word "differs"
# Every rule is scoped under the report's root id (#S below), which outranks a notebook's own rules
# (JupyterLab styles tables, pre and links of rendered HTML, in dark themes light on dark).
STYLE = """
#S{font:15px/1.45 system-ui,-apple-system,"Segoe UI",Roboto,sans-serif;color:#1f2937;background:#fff;text-align:left}
#S.page{max-width:1020px;margin:0 auto;padding:24px;background:#f8fafc}
#S.fragment{padding:12px 16px;border:1px solid #d1d5db;border-radius:6px}
#S *{box-sizing:border-box}
#S h1,#S h2,#S h3,#S h4,#S h5{color:#111827;font-weight:700;line-height:1.25}
#S .title{font-size:1.6em;margin:.2em 0}
#S .chapter-title,#S .summary-title{font-size:1.35em;margin:1.6em 0 .4em;border-bottom:2px solid #d1d5db;padding-bottom:.2em}
#S .kind-title{font-size:1.1em;margin:1em 0 .4em}
#S a:link,#S a:visited{color:#1d4ed8;text-decoration:underline}
#S p{margin:.5em 0;text-align:left}
#S table{border-collapse:collapse;margin:.5em 0;color:#1f2937;background:#fff;table-layout:auto;font-size:1em}
#S td,#S th{padding:4px 10px;border:0;border-bottom:1px solid #d1d5db;text-align:left;color:#1f2937;background:#fff;
  vertical-align:top;line-height:1.45}
#S caption{text-align:left;font-weight:700;color:#1f2937;padding:2px 0}
#S .summary .num{text-align:right;font-variant-numeric:tabular-nums}
#S .summary tfoot th,#S .summary tfoot td{font-weight:700;border-top:2px solid #4b5563}
#S .check{background:#fff;color:#1f2937;border:1px solid #d1d5db;border-left:6px solid #4b5563;border-radius:6px;
  padding:8px 12px;margin:8px 0}
#S .check.pass{border-left-color:#166534}#S .check.fail{border-left-color:#b91c1c}
#S .check.error{border-left-color:#7e22ce}#S .check.skip{border-left-color:#854d0e}#S .check.recorded{border-left-color:#155e75}
#S .status{font-weight:700;text-transform:uppercase;font-size:.85em;margin-right:.6em}
#S .pass .status{color:#166534}#S .fail .status{color:#b91c1c}#S .error .status{color:#7e22ce}
#S .skip .status{color:#854d0e}#S .recorded .status{color:#155e75}
#S .points{float:right;color:#4b5563;margin-left:1em}
#S pre{white-space:pre-wrap;overflow-wrap:anywhere;background:#f3f4f6;color:#1f2937;border:0;padding:6px 8px;
  border-radius:4px;font:.9em/1.4 ui-monospace,"DejaVu Sans Mono",monospace;margin:.4em 0}
#S .pair{display:flex;gap:24px;flex-wrap:wrap;align-items:flex-start;margin:.4em 0}
#S table.matrix td{border:1px solid #6b7280;font-family:ui-monospace,"DejaVu Sans Mono",monospace;text-align:right}
#S table.matrix td.wrong{background:#fee2e2;color:#1f2937;font-weight:700;outline:2px solid #b91c1c;outline-offset:-2px}
#S .legend{font-size:.9em;color:#4b5563;margin:.2em 0}
#S figure{background:#fff;border:1px solid #d1d5db;border-radius:6px;padding:10px;margin:12px 0}
#S figure img{max-width:100%;height:auto;display:block}
#S figcaption{color:#374151;font-size:.9em;margin-top:.4em}
#S figcaption .gave{display:block;margin-top:.3em;color:#1f2937}
#S .problem{background:#fef2f2;color:#1f2937;border:1px solid #b91c1c;padding:8px 12px;border-radius:6px}
#S .note{color:#4b5563}
#S .help{background:#eff6ff;color:#1e3a8a;border-left:3px solid #1d4ed8;padding:4px 8px;margin:.4em 0}
#S .sr-only{position:absolute;width:1px;height:1px;padding:0;margin:-1px;overflow:hidden;clip:rect(0,0,0,0);
  white-space:nowrap;border:0}
"""

# The mark beside each verdict's word (hidden from screen readers, which read the word).
MARKS = {"pass": "\u2713", "fail": "\u2717", "error": "!", "skip": "\u2013", "recorded": "\u2022"}

BODY = r"""<{{ root }} class="jl-report {{ kind }}" id="{{ pid }}report" lang="en">
<h{{ h }} class="title" id="{{ pid }}title">Jacobians &amp; Linearization: grading report</h{{ h }}>
<p class="note">Submission {{ report.submission }} &middot; seed {{ seed }}{% if report.learner %} &middot; quiz learner {{ report.learner }}{% endif %}</p>
<p class="note" id="{{ pid }}provenance">{{ footer }}</p>
<section id="{{ pid }}summary"{{ landmark("summary") }}><h{{ h + 1 }} class="summary-title" id="{{ pid }}summary-title">Summary</h{{ h + 1 }}>
<table class="summary"><caption>Points by chapter</caption>
<thead><tr><th scope="col">chapter</th><th scope="col">title</th><th scope="col" class="num">code</th><th scope="col" class="num">quiz</th><th scope="col" class="num">total</th></tr></thead>
<tbody>{% for ch in report.chapters %}<tr><th scope="row"><a href="#{{ pid }}{{ ch.chapter }}">{{ ch.chapter }}</a></th><td>{{ ch.title }}</td>
<td class="num" data-code="{{ ch.chapter }}">{{ num(ch.score_of('code')) }} / {{ num(ch.max_score_of('code')) }}</td>
<td class="num" data-quiz="{{ ch.chapter }}">{{ num(ch.score_of('quiz')) }} / {{ num(ch.max_score_of('quiz')) }}</td>
<td class="num" data-total="{{ ch.chapter }}">{{ num(ch.score) }} / {{ num(ch.max_score) }}</td></tr>{% endfor %}</tbody>
<tfoot><tr><th scope="row" colspan="4">Total</th><td class="num" id="{{ pid }}total">{{ num(report.score) }} / {{ num(report.max_score) }}</td></tr></tfoot></table>
{% if adjustments %}<ul id="{{ pid }}adjustments">{% for a in adjustments %}<li>{{ "late penalty" if a.kind == "late" else "override" }}: {{ a.describe() }}</li>{% endfor %}</ul>{% endif %}
<p id="{{ pid }}verdict">{{ verdict }}</p>
</section>
{% for ch in report.chapters %}
<section class="chapter" id="{{ pid }}{{ ch.chapter }}"{{ landmark(ch.chapter) }}><h{{ h + 1 }} class="chapter-title" id="{{ pid }}{{ ch.chapter }}-title">{{ ch.chapter }} &middot; {{ ch.title }}</h{{ h + 1 }}>
{% if ch.source and not ch.unread and (ch.source.endswith(".ipynb") or ch.source.startswith("the code")) %}<p class="note">graded: {{ ch.source }}</p>{% endif %}
{% for note in ch.notes %}<p class="note">note: {{ note }}</p>{% endfor %}
{% for problem in ch.problems %}<pre class="problem">{{ problem }}</pre>{% endfor %}
{% if ch.hidden_checks %}<p class="note">{{ plural(ch.hidden_checks, "hidden check") }} ({{ plural(ch.hidden_points, "point") }}) run{{ "s" if ch.hidden_checks == 1 }} when you submit.</p>{% endif %}
{% for fig in figures[ch.chapter] %}<figure>{% if fig.uri %}<img src="{{ fig.uri }}" alt="{{ fig.alt }}" width="{{ fig.width }}" height="{{ fig.height }}">{% endif %}
<figcaption>{{ fig.caption }}{% if fig.gave %}<span class="gave">{{ fig.gave }}</span>{% endif %}</figcaption></figure>{% endfor %}
{{ checks_html(ch, h) }}
</section>{% endfor %}
</{{ root }}>"""

TEMPLATE = r"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<meta http-equiv="Content-Security-Policy" content="default-src 'none'; img-src data:; style-src 'unsafe-inline'">
<title>Jacobians &amp; Linearization: grading report</title>
<style>body{margin:0;background:#f8fafc}{{ style }}</style></head>
<body>
""" + BODY + """
</body></html>
"""

FRAGMENT = "<style>{{ style }}</style>\n" + BODY + "\n"


def _num(value: float) -> str:
    return f"{value:g}"


def _matrix_html(values, wrong: set, caption: str, zero_below: float = 0.0, digits: int = 6) -> str:
    """A small matrix as a captioned table; each entry where got and expected differ is outlined and
    marked with a cross and, for screen readers, the word "differs" (never by its colour alone). Each entry is
    written as the check's message writes it (grader.numbers.fmt, with the comparison's `zero_below` and `digits`)."""
    array = np.atleast_1d(np.asarray(values, dtype=float))
    if array.ndim == 1:
        array = array[None, :]
        wrong = {(0, i[0]) if len(i) == 1 else tuple(i) for i in wrong}
    if array.size > 36:
        return ""
    rows = []
    for i, row in enumerate(array):
        shown = [fmt(v, zero_below, digits) for v in row]
        cells = "".join(f'<td class="wrong">{v}{WRONG_MARK}</td>' if (i, j) in wrong else f"<td>{v}</td>"
                        for j, v in enumerate(shown))
        rows.append(f"<tr>{cells}</tr>")
    return f'<table class="matrix"><caption>{caption}</caption>{"".join(rows)}</table>'


WRONG_MARK = '<span aria-hidden="true"> \u2717</span><span class="sr-only"> (differs)</span>'


def _checks_html(chapter: ChapterResult, h: int) -> str:
    """A chapter's checks, code then quiz, each kind under a heading with its points (and those recorded, graded on
    submission); a function none of whose checks is written yet as one line. Written in Python as the template's
    loop wrote it (its per-check calls and filters were most of the page's time)."""
    parts = []
    for kind, label in (("code", "Code"), ("quiz", "Quiz")):
        parts.append("\n")
        checks = [c for c in chapter.checks if c.kind == kind]
        if not checks:
            continue
        recorded = chapter.recorded_score_of(kind)
        pending = (f" (+{escape(_num(recorded))} point{'' if recorded == 1 else 's'} recorded, graded when you submit)"
                   if recorded else "")
        parts.append(f'<h{h + 2} class="kind-title">{label}: {escape(_num(chapter.score_of(kind)))} / '
                     f'{escape(_num(chapter.max_score_of(kind)))}{pending}</h{h + 2}>\n\n')
        folded = not_written(checks) if kind == "code" else {}
        for check in checks:
            group = folded.get(check.function)
            if group is None:
                parts.append(_check_html(check, chapter.chapter))
            elif check is group[0]:
                parts.append(f'<div class="check fail"><span class="status"><span aria-hidden="true">'
                             f'{escape(MARKS["fail"])} </span>fail</span>{escape(check.function)}: not implemented yet '
                             f'({len(group)} check{"s" if len(group) != 1 else ""})\n<span class="points">0 / '
                             f'{escape(_num(sum(c.max_points for c in group)))}<span class="sr-only"> points</span>'
                             '</span></div>')
    return Markup("".join(parts))


def _check_html(check: CheckResult, chapter: str) -> str:
    """One check's block: its verdict, description, points and id; where it did not pass, its message and hint; a
    quiz answer as written; a failed code check's values as tables (_values). Every text escaped: a Python function
    rather than the template's loop, the page's longest part, which it writes as the template would (made once
    for a check made unchanged from a kept verdict, grader.model.made_once)."""
    return made_once(check, ("html", chapter), _check_block, check, chapter)


def _check_block(check: CheckResult, chapter: str) -> str:
    status = check.status.value
    wrong = status != "pass"
    points = ("practice, not counted" if check.practice else
              f'{escape(_num(check.points))} / {escape(_num(check.max_points))}<span class="sr-only"> points</span>')
    message = f"<pre>{escape(check.message)}</pre>" if wrong and check.message else ""
    hint = f'<p class="help"><strong>Hint:</strong> {escape(check.help)}</p>' if wrong and check.help else ""
    answer = (f'<p class="note">your answer: {escape(check.got)}</p>' if check.kind == "quiz" and check.got is not None
              else "")
    values = escape(_values(check)) if status == "fail" and check.kind == "code" else ""
    return Markup(f'<div class="check {escape(status)}"><span class="status"><span aria-hidden="true">'
                  f'{escape(MARKS[status])} </span>{escape(status)}</span>{escape(check.description)}\n'
                  f'<span class="points">{points}</span>\n<span class="note"> &middot; {escape(chapter)}/'
                  f'{escape(check.id)}</span>\n{message}\n{hint}\n{answer}\n{values}\n</div>')


def _needs_no_cleaning(check: CheckResult) -> bool:
    from grader import safe_text

    return safe_text.clean_value(check, safe_text.for_html) is check


# a check made unchanged from a kept verdict is walked for the page's cleaning once per verdict (made_once)
_KNOWN_CLEAN = {CheckResult: lambda check: made_once(check, ("clean for html",), _needs_no_cleaning, check)}


def _values(check: CheckResult) -> str:
    """Expected vs got as small tables, the wrong entries marked."""
    try:
        if check.expected is None or check.got is None:
            return Markup("")
        wrong = {tuple(i) for i in check.details.get("wrong", [])}
        shown = {k: check.details[k] for k in ("zero_below", "digits") if k in check.details}  # as the message
        got, expected = (_matrix_html(check.got, wrong, "got", **shown),
                         _matrix_html(check.expected, wrong, "expected", **shown))
        if not got or not expected:
            return Markup("")
        legend = '<p class="legend">\u2717 marks each entry where got differs from expected.</p>' if wrong else ""
        return Markup(f'<div class="pair">{expected}{got}</div>{legend}')
    except (TypeError, ValueError):
        return Markup("")


_SOURCES = {"page": TEMPLATE, "fragment": FRAGMENT}


@functools.lru_cache(maxsize=2)
def _template(kind: str):
    """The page's or the fragment's template, once per process: as shipped compiled (grader.render.precompiled),
    else compiled here (compiling costs more than rendering)."""
    from grader.render import precompiled

    return precompiled.template(kind, _SOURCES[kind])


def _verdict(report: Report, verdict_line) -> str:
    """The text renderer's verdict, but where it points at marks "above" (a place on a terminal's
    screen), saying what to look for instead: the page lists the checks below it (WCAG 1.3.3)."""
    if not report.all_passed:
        return "Not all checks pass yet: each chapter below marks its checks \u2717 fail, ! error or \u2013 skip."
    return verdict_line(report)


def _render(report: Report, pid: str, root: str, kind: str, heading: int, kept: FigureCache | None,
            draw_here: bool = False, meanwhile: Callable[[], None] | None = None, learner_sees: bool = False) -> str:
    import dataclasses

    from grader import provenance, safe_text
    from grader.render import drawer
    from grader.render.text import verdict_line

    # the figures' data cleaned first and sent to be drawn; the rest of the report is cleaned while they draw
    plotted = [dataclasses.replace(c, plots=safe_text.clean_value(c.plots, safe_text.for_html))
               for c in report.chapters if c.plots]
    figures: dict[str, list[Figure]] = {c.chapter: [] for c in report.chapters}
    if kept is not None:
        for chapter in plotted:
            found = kept.load(chapter.chapter, chapter.plots)
            if found is not None:
                figures[chapter.chapter] = [Figure(**figure) for figure in found]
        plotted = [c for c in plotted if not figures[c.chapter]]
    drawn = drawer.figures_due(plotted, here=draw_here)
    report = safe_text.clean_report(report, safe_text.for_html, _KNOWN_CLEAN)
    style = Markup(STYLE.replace("#S", f"#{pid}report"))

    def landmark(section: str) -> Markup:
        """A page's sections are landmarks named by their headings; a fragment's are not, as two
        reports in one notebook would repeat the names (axe: landmark-unique)."""
        return Markup(f' aria-labelledby="{pid}{section}-title"') if kind == "page" else Markup("")

    template = _template(kind)
    if meanwhile is not None:
        meanwhile()
    for chapter, its_figures in zip(plotted, drawn()):
        figures[chapter.chapter] = its_figures
        if kept is not None:
            kept.store(chapter.chapter, chapter.plots, [vars(figure) for figure in its_figures])
    return template.render(report=report, figures=figures, num=_num, checks_html=_checks_html, plural=plural,
                           verdict=_verdict(report, verdict_line), style=style, pid=pid, root=root,
                           kind=kind, h=heading, landmark=landmark, footer=provenance.footer(report, learner_sees),
                           seed=provenance.shown_seed(report, learner_sees), adjustments=report.all_adjustments())


def render(report: Report, kept: FigureCache | None = None, draw_here: bool = False,
           meanwhile: Callable[[], None] | None = None, learner_sees: bool = False) -> str:
    """The report as one self-contained HTML page. Learner text is escaped by the template and has
    no lone surrogates or control characters (grader.safe_text.for_html), so the page always encodes.
    Figures found in `kept` for the same plot data are reused, the others drawn and kept there; with
    `draw_here`, drawn by this process alone (see grader.render.drawer.figures_due). `meanwhile`: the
    caller's own work, done while the figures are drawn elsewhere (its exceptions are the caller's). With
    `learner_sees` (a batch's page for its learner), a seed other than the public one is not shown."""
    return _render(report, "", "main", "page", 1, kept, draw_here, meanwhile, learner_sees)


def render_fragment(report: Report, id_prefix: str | None = None, heading_level: int = 2,
                    kept: FigureCache | None = None) -> str:
    """The report as an HTML fragment for a notebook's output (no <html>, <head> or <body>): one <div>
    with its own <style>, every rule scoped to that div's id, and every id starting with `id_prefix`
    (a fresh one if None, so several reports can share a page). Headings start at `heading_level`,
    below the notebook's own title. Escaped and self-contained like the page; figures as in `render`."""
    if id_prefix is None:
        import uuid

        id_prefix = f"grade-{uuid.uuid4().hex[:10]}-"
    if not re.fullmatch(r"[A-Za-z][A-Za-z0-9_-]*", id_prefix):
        raise ValueError(f"id_prefix must be letters, digits, '-' or '_', starting with a letter: {id_prefix!r}")
    if not 1 <= heading_level <= 4:
        raise ValueError(f"heading_level must be 1 to 4 (the report uses three levels): {heading_level}")
    return _render(report, id_prefix, "div", "fragment", heading_level, kept)


if __name__ == "__main__":  # after a template's text changed: ship it compiled again (grader.render.precompiled)
    from grader.render import precompiled

    for written in precompiled.write(_SOURCES):
        print(f"wrote {written}")
