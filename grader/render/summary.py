"""The class summary page: score histogram, per-check failure rates (worst first), and the most
common failure messages, so an instructor sees which idea the class missed. Self-contained HTML."""

from __future__ import annotations

from collections import Counter
from html import escape as _escape

from grader.model import Report, Status
from grader.safe_text import for_html

STYLE = ("body{font:15px/1.45 system-ui,sans-serif;max-width:1000px;margin:24px auto;color:#1f2937}"
         "table{border-collapse:collapse}td,th{padding:3px 10px;border-bottom:1px solid #e5e7eb;text-align:left}"
         ".bar{background:#2563eb;height:14px;display:inline-block}.num{text-align:right}")


def escape(text: str) -> str:
    """Learner text for the page: escaped, no lone surrogates or control characters."""
    return _escape(for_html(str(text)))


def _count(n: int, word: str, words: str | None = None) -> str:
    return f"{n} {word if n == 1 else (words or word + 's')}"


def render(reports: list[tuple[str, Report]], unreadable: dict[str, str], isolation: str = "",
           skipped: list[tuple[str, str]] = (), flagged: dict[str, list[str]] | None = None) -> str:
    """The page; `unreadable` maps each learner not graded (unreadable submission, infrastructure
    failure) to why, `skipped` lists (entry, why) of what in the submissions folder was not taken as a
    submission at all, `flagged` maps graded learners to what an instructor should look at (a
    learner.yaml naming someone else)."""
    flagged = flagged or {}
    parts = [f"<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'><title>Class summary</title>"
             f"<style>{STYLE}</style></head><body><h1>Class summary</h1>",
             f"<p>{_count(len(reports), 'learner')} graded; {len(unreadable)} could not be graded; "
             f"{len(skipped)} skipped; {len(flagged)} flagged.</p>",
             f"<p id='isolation'>{escape(isolation)}</p>" if isolation else ""]
    if reports:
        top = max(r.max_score for _, r in reports) or 1
        bins = Counter(min(9, int(10 * r.score / top)) for _, r in reports)
        parts.append("<h2 id='histogram'>Scores</h2><table>")
        for b in range(10):
            count = bins.get(b, 0)
            parts.append(f"<tr><td>{10 * b}-{10 * b + 10}%</td><td class='num'>{count}</td>"
                         f"<td><span class='bar' style='width:{8 * count}px'></span></td></tr>")
        parts.append("</table>")
        failures: Counter = Counter()
        seen: Counter = Counter()
        messages: Counter = Counter()
        names = {}
        for _, report in reports:
            for chapter in report.chapters:
                for check in chapter.checks:
                    key = f"{chapter.chapter}/{check.id}"
                    names[key] = check.description
                    seen[key] += 1
                    if check.status != Status.PASS:
                        failures[key] += 1
                        if check.message:
                            messages[(chapter.chapter, check.message.splitlines()[0][:160])] += 1
        parts.append("<h2 id='failure-rates'>Checks by failure rate</h2><table><tr><th>check</th><th>failed</th>"
                     "<th class='num'>rate</th></tr>")
        for key, count in sorted(failures.items(), key=lambda kv: (-kv[1] / seen[kv[0]], kv[0]))[:60]:
            parts.append(f"<tr><td>{escape(key)}<br><small>{escape(names[key])}</small></td><td class='num'>"
                         f"{count}/{seen[key]}</td><td class='num'>{100 * count / seen[key]:.0f}%</td></tr>")
        parts.append("</table><h2 id='messages'>Most common failure messages</h2><table>")
        for (chapter, message), count in messages.most_common(25):
            parts.append(f"<tr><td class='num'>{count}</td><td>{escape(chapter)}</td><td>{escape(message)}</td></tr>")
        parts.append("</table>")
    if flagged:
        parts.append("<h2 id='flagged'>Flagged (graded; look at these)</h2><ul>")
        parts.extend(f"<li>{escape(k)}: {escape('; '.join(v))}</li>" for k, v in sorted(flagged.items()))
        parts.append("</ul>")
    if unreadable:
        parts.append("<h2 id='not-graded'>Not graded</h2><ul>")
        parts.extend(f"<li>{escape(k)}: {escape(v)}</li>" for k, v in sorted(unreadable.items()))
        parts.append("</ul>")
    if skipped:
        parts.append("<h2 id='skipped'>Skipped (not taken as submissions)</h2><ul>")
        parts.extend(f"<li>{escape(k)}: {escape(v)}</li>" for k, v in skipped)
        parts.append("</ul>")
    return "".join(parts) + "</body></html>\n"
