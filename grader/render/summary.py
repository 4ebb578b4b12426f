"""The class summary: what the class got wrong and what to re-teach, as summary.html and summary.json.

From the per-learner reports of a batch: the score histogram; per check how many failed on their own
and how many failed because a helper of theirs fails (grader.core.grading.point_upstream: blame once),
worst first; per named mistake (grader.judging.diagnose, the quiz keys' wrong answers) how many learners made
it; per choice question how many chose each option (letters are each learner's own, so counted by
the option, not the letter); per symbolic question each answer form; the most common failure
messages; quiz questions shown as templates, each per-learner number as its range; and who was
flagged, not graded or skipped, whose score moved since the last run, the overrides that could not
apply, and the pairs of learners whose code is most alike (grader.course.similarity, for a person to look
at). With 5 or more learners, item statistics of every check and question (grader.course.statistics computes them; here
they are only shown): facility, discrimination, the options' shares, Cronbach's alpha per chapter, facility by
parameter, what is flagged, and a figure per chapter (grader.render.item_plots). Self-contained HTML; learner
text escaped.
"""

from __future__ import annotations

import functools
import json
import sqlite3
import statistics
from collections import Counter, defaultdict
from collections.abc import Iterator
from dataclasses import dataclass, field
from html import escape as _escape

from grader.model import Report, Status
from grader.safe_text import for_html, for_json

STYLE = ("body{font:15px/1.45 system-ui,sans-serif;max-width:1180px;margin:24px auto;padding:0 16px;"
         "color:#1f2937}table{border-collapse:collapse;width:100%}td,th{padding:3px 10px;border-bottom:1px solid "
         "#e5e7eb;text-align:left;vertical-align:top;overflow-wrap:break-word}td.num,th.num{white-space:nowrap}"
         "ul.flagged>li{margin:0 0 10px}.bar{background:#2563eb;height:14px;display:inline-block}.num{text-align:right}"
         "pre{white-space:pre-wrap;background:#f3f4f6;padding:4px 6px;margin:2px 0;font-size:.85em}"
         "figure{border:1px solid #d1d5db;border-radius:6px;padding:10px;margin:12px 0}figure img{max-width:100%;"
         "height:auto;display:block}figcaption{font-size:.9em;color:#374151}.flag{color:#9a3412}")
VERSION = "1"


def escape(text: str) -> str:
    """Learner text for the page: escaped, no lone surrogates or control characters."""
    return _escape(for_html(str(text)))


def _count(n: int, word: str, words: str | None = None) -> str:
    return f"{n} {word if n == 1 else (words or word + 's')}"


@dataclass
class Summary:
    """Everything the class summary shows, gathered by grade batch: `graded` has counted the graded
    learners' reports one by one (Tally), so that no report need be kept."""

    graded: Tally
    not_graded: dict[str, str] = field(default_factory=dict)
    isolation: str = ""
    skipped: list[tuple[str, str]] = field(default_factory=list)
    flagged: dict[str, list[str]] = field(default_factory=dict)
    changes: list[tuple] = field(default_factory=list)  # (learner, before, after, delta, why)
    notes: list[str] = field(default_factory=list)  # for the instructor: overrides that could not apply, ...
    untimed: list[str] = field(default_factory=list)  # graded with a deadline but no trusted submission time
    similar: list = field(default_factory=list)  # grader.course.similarity.Pair, most alike first
    statistics: dict | None = None  # grader.course.statistics.compute's numbers (None: fewer than 5 learners)
    first_run: bool = False  # the history's first finished run: no score moved, each was graded first
    roster: dict = field(default_factory=dict)  # the roster's disagreements with the folder: file, unmatched, said

    @functools.cached_property
    def counts(self) -> dict:
        return self.graded.counts()


# ------------------------------------------------------------------------------------ what is counted

class Tally:
    """What the class summary counts, added learner by learner in the batch's order (add) and read at the end
    (counts): the counts summary.html and summary.json show, the scores, the first learner's provenance and
    the archives per handout. It keeps counts and a score per learner, never a report, and the failure
    messages (many hold a learner's own numbers: tens of distinct ones per learner) in a private temporary
    SQLite database (Messages): a class of any size is summarised in the memory of a few reports."""

    def __init__(self, questions: dict | None = None) -> None:
        # each quiz question as every learner has it (grader.quiz.class_questions): its template, its options'
        # texts and which are right; given by the batch, so that nothing here reads a bank or a key
        self.questions = questions or {}
        self.seen, self.own, self.upstream, self.errors = Counter(), Counter(), Counter(), Counter()
        self.unanswered: Counter = Counter()  # quiz questions left blank: apart from the failures
        self.names: dict[str, str] = {}
        self.kinds: dict[str, str] = {}
        self.mistakes: dict[tuple, set] = defaultdict(set)
        self.messages = Messages()
        self.chosen: Counter = Counter()
        self.forms: dict[tuple, dict] = {}
        self.scores: list[float] = []
        self.max_score: float | None = None
        self.first: dict | None = None  # the first learner's provenance: grader, handout, course, seed
        self.handouts: Counter = Counter()  # archives per handout they were packed with (grade submit's manifest)

    def __len__(self) -> int:
        return len(self.scores)

    def add(self, learner: str, report: Report, extra: dict | None = None) -> None:
        """Count one graded learner's report; `extra` is what its report.json's batch data says (the manifest)."""
        if self.first is None:
            self.first = {"grader": report.grader, "handout": report.handout, "course": report.course,
                          "seed": report.seed}
        self.scores.append(report.score)
        self.max_score = report.max_score if self.max_score is None else max(self.max_score, report.max_score)
        manifest = (extra or {}).get("manifest")
        self.handouts[(manifest or {}).get("handout") or ("none" if manifest is None else "the project")] += 1
        for chapter in report.chapters:
            for check in chapter.checks:
                key = f"{chapter.chapter}/{check.id}"
                self.kinds[key] = check.kind
                question = self.questions.get((chapter.chapter, check.function)) if check.kind == "quiz" else None
                self.names[key] = question.template if question else check.description
                self.seen[key] += 1
                caused_upstream = bool(check.upstream) or (check.status == Status.SKIP
                                                           and check.points < check.max_points)
                if check.unanswered:
                    self.unanswered[key] += 1
                elif check.status == Status.ERROR:
                    self.errors[key] += 1
                elif caused_upstream:
                    self.upstream[key] += 1
                elif check.status == Status.FAIL:
                    self.own[key] += 1
                    if check.mistake:
                        self.mistakes[(chapter.chapter, check.function, check.kind, check.mistake)].add(learner)
                    if check.message:
                        self.messages.add(key, check.mistake or "", first_line(check.message)[:160])
                if check.kind == "quiz" and check.status in (Status.PASS, Status.FAIL):  # judged: `answer` says
                    for option in check.answer.get("options", ()):
                        self.chosen[(chapter.chapter, check.function, option)] += 1
                    if "form" in check.answer:
                        entry = self.forms.setdefault((chapter.chapter, check.function, check.answer["form"],
                                                       check.status.value),
                                                      {"learners": 0, "verdict": check.status.value,
                                                       "mistake": check.mistake or None})
                        entry["learners"] += 1

    def counts(self) -> dict:
        """The counts summary.html and summary.json show."""
        seen, own, upstream, errors = self.seen, self.own, self.upstream, self.errors
        options = []
        for (chapter, question_id, option), count in sorted(self.chosen.items()):
            question = self.questions.get((chapter, question_id))
            options.append({"question": f"{chapter}/quiz_{question_id}", "option": option,
                            "text": question.options.get(option, "") if question else "",
                            "right": option in question.right if question else False, "chosen": count})
        blank = self.unanswered

        def rate(key: str) -> float:  # among the learners who answered (a blank quiz question is no failure)
            return own[key] / max(seen[key] - blank[key], 1)

        return {
            "checks": [{"id": key, "description": self.names[key], "kind": self.kinds[key], "seen": seen[key],
                        "unanswered": blank[key], "failed": own[key], "failed_upstream": upstream[key],
                        "errors": errors[key]}
                       for key in sorted(seen, key=lambda k: (-rate(k), -(upstream[k] + errors[k]) / seen[k], k))],
            "mistakes": [{"chapter": c, "function": f, "kind": k, "mistake": m, "learners": len(who)}
                         for (c, f, k, m), who in sorted(self.mistakes.items(), key=lambda kv: (-len(kv[1]), kv[0]))],
            "options": options,
            "answer_forms": [{"question": f"{c}/quiz_{q}", "form": form, **entry}
                             for (c, q, form, _), entry in sorted(self.forms.items(),
                                                                   key=lambda kv: (kv[0][:2], -kv[1]["learners"],
                                                                                   kv[0]))],
            "messages": [{"check": key, "chapter": key.split("/", 1)[0], "mistake": mistake or None, "message": m,
                          "count": n} for (key, mistake, m), n in self.messages.most_common(25)],
        }

    def close(self) -> None:
        self.messages.close()


def first_line(message: str) -> str:
    """A failure message's first line that says something: with the line after a lead-in that ends in a colon
    ("wrong at 6 of 6 inputs; the first:"), so that messages group by what went wrong."""
    lines = [line.strip() for line in message.splitlines() if line.strip()]
    if len(lines) > 1 and lines[0].endswith(":"):
        return f"{lines[0]} {lines[1]}"
    return lines[0] if lines else ""


class Messages:
    """How often each failure message was seen per check and named mistake, as a Counter counts them, kept in a
    private temporary SQLite database (its cache small, the rest on disk) instead of in memory; most_common gives
    what Counter.most_common gives: the most frequent first, ties in the order first seen."""

    def __init__(self) -> None:
        self.db = sqlite3.connect("")  # "": a temporary database of its own, deleted when closed
        self.db.execute("CREATE TABLE seen (item TEXT, mistake TEXT, message BLOB, n INTEGER, first INTEGER, "
                        "PRIMARY KEY (item, mistake, message))")
        self.order = 0

    def add(self, item: str, mistake: str, message: str) -> None:
        self.order += 1  # the message as UTF-8, lone surrogates as they are (a text column refuses them)
        self.db.execute("INSERT INTO seen VALUES (?, ?, ?, 1, ?) ON CONFLICT (item, mistake, message) "
                        "DO UPDATE SET n = n + 1", (item, mistake, message.encode("utf-8", "surrogatepass"), self.order))

    def most_common(self, count: int) -> list[tuple[tuple[str, str, str], int]]:
        return [((item, mistake, message.decode("utf-8", "surrogatepass")), n) for item, mistake, message, n in
                self.db.execute("SELECT item, mistake, message, n FROM seen ORDER BY n DESC, first LIMIT ?", (count,))]

    def close(self) -> None:
        self.db.close()


def _handouts(view: Summary) -> dict[str, int]:
    """How many archives were packed with each handout (grade submit's manifests); "none": no manifest."""
    return dict(view.graded.handouts)


# ------------------------------------------------------------------------------------ JSON

def write_json(view: Summary, handle) -> None:
    """summary.json (grader/schemas/summary.schema.json) into the text file `handle`, piece by piece."""
    json.dump(_json_data(view), handle, indent=1, allow_nan=False)
    handle.write("\n")


def _json_data(view: Summary) -> dict:
    counts = view.counts
    scores = view.graded.scores
    first = view.graded.first
    data = {
        "version": VERSION,
        "provenance": {"grader": first["grader"] or None, "handout": first["handout"], "course": first["course"],
                       "seed": first["seed"]} if first else None,
        "learners": {"graded": len(view.graded), "not_graded": len(view.not_graded), "skipped": len(view.skipped),
                     "flagged": len(view.flagged)},
        "scores": {"mean": round(statistics.fmean(scores), 3) if scores else None,
                   "median": round(statistics.median(scores), 3) if scores else None,
                   "max_score": view.graded.max_score},
        **counts,
        "handouts": _handouts(view),
        "flagged": view.flagged,
        "not_graded": view.not_graded,
        "skipped": [{"name": n, "reason": r} for n, r in view.skipped],
        "first_run": view.first_run,
        "changes": [{"learner": c[0], "before": c[1], "after": c[2], "delta": c[3], "why": c[4]} for c in view.changes],
        "roster": {"file": view.roster.get("file"), "unmatched": list(view.roster.get("unmatched", []))},
        "similar": [pair.to_dict() for pair in view.similar],
        "notes": list(view.notes),
        "untimed": list(view.untimed),
        "isolation": view.isolation,
        "statistics": view.statistics,
    }
    return for_json(data)


# ------------------------------------------------------------------------------------ HTML

def _number(value: float | None, digits: int = 2) -> str:
    return "n/a" if value is None else f"{value:.{digits}f}"


def _values(low: float, high: float) -> str:
    return f"{low:g}" if low == high else f"{low:g} to {high:g}"


def _statistics_parts(found: dict | None) -> Iterator[str]:
    """The item statistics section: how they are computed and flagged, the flagged items, then per chapter its
    alpha, its figure (a class of RELIABLE_LEARNERS or more) and every item; the options of the choice questions;
    the facility by parameter of the parametrised ones."""
    if found is None:
        return
    rules = found["rules"]
    yield ("<h2 id='item-statistics'>Item statistics</h2>"
           f"<p>From {_count(found['learners'], 'graded learner')}, every check and quiz question: its "
           "<em>facility</em> (the mean share of its points), its <em>discrimination</em> (the correlation of its "
           "points with the rest of the learner's score) and the upper-lower index (facility among the 27% with the "
           "highest rest scores minus among the 27% with the lowest). An item is flagged only with evidence (the "
           "instructor's guide states the rules): where its "
           f"{rules['confidence']:.0%} confidence interval lies wholly beyond a rule's bound: facility below "
           f"{rules['facility_low']:g}, or above {rules['facility_high']:g} for a quiz question (passing is a check's "
           f"goal), discrimination below {rules['discrimination_low']:g}, a wrong option chosen by "
           f"{rules['distractor_learners']} or more whose choice goes with a higher rest score; and where facility "
           f"differs between the learners' own numbers beyond chance ({escape(found['parameter_test'])}, p below "
           f"{rules['parameter_alpha']:g} after Holm's correction over every parameter tested).</p>")
    if found["rough"]:
        yield (f"<p id='statistics-rough'><strong>Rough:</strong> fewer than {rules['reliable_learners']} learners; "
               "these numbers move a lot by chance, so nothing is flagged and no figure is drawn.</p>")
    items = found["items"]
    flagged = [item for item in items if item["flags"]]
    if flagged:
        yield "<h2 id='flagged-items'>Flagged items: what a course author should look at</h2><ul class='flagged'>"
        for i in flagged:
            yield (f"<li><strong>{escape(i['id'])}</strong>: facility {_number(i['facility'])}, discrimination "
                   f"{_number(i['discrimination'])}, {_count(i['learners'], 'learner')}<br><small>"
                   f"{escape(i['description'])}</small><ul>"
                   + "".join(f"<li class='flag'>{escape(flag)}</li>" for flag in i["flags"]) + "</ul></li>")
        yield "</ul>"
    elif not found["rough"]:
        yield "<p id='flagged-items'>No item is flagged.</p>"
    drawn = {}
    if not found["rough"]:
        from grader.render import item_plots

        drawn = item_plots.figures(found)
    for chapter in found["chapters"]:
        name = chapter["chapter"]
        alpha = "n/a" if chapter["alpha"] is None else f"{chapter['alpha']:.2f}"
        yield (f"<h3 id='items-{escape(name)}'>{escape(name)}: Cronbach's alpha {alpha} ({chapter['items']} items, "
               f"{_count(chapter['learners'], 'learner')} judged on all)</h3>")
        figure = drawn.get(name)
        if figure is not None:
            image = (f"<img src='{figure.uri}' alt='{escape(figure.alt)}' width='{figure.width}' "
                     f"height='{figure.height}'>" if figure.uri else "")
            yield f"<figure>{image}<figcaption>{escape(figure.caption)}</figcaption></figure>"
        rows = [[str(number), f"{escape(i['id'])}<br><small>{escape(i['description'])}</small>",
                 str(i["learners"]) + (f" <small>({i['unanswered']} left it blank)</small>"
                                       if i.get("unanswered") else ""),
                 _number(i["facility"]), _number(i["discrimination"]), _number(i["upper_lower"]),
                 "flagged" if i["flags"] else ""]
                for number, i in enumerate((i for i in items if i["chapter"] == name), 1)]
        yield f"<details><summary>Every item of {escape(name)} (numbered as in the figure)</summary>"
        yield _table(f"item-table-{escape(name)}", f"Items of {name}",
                     ["#", "item", "learners", "facility", "discrimination", "upper-lower", ""], rows, {0, 2, 3, 4, 5})
        yield "</details>"
    options = [(i, o) for i in items for o in i["options"]]
    if options:
        yield _table("option-statistics", "Options: who chose each (letters are each learner's own; by option)",
                     ["question", "option", "right", "chosen by", "discrimination"],
                     [[escape(i["id"]), f"{escape(o['option'])}) {escape(o['text'])}", "yes" if o["right"] else "no",
                       f"{o['chosen']} ({_number(o['share'])})", _number(o["discrimination"])] for i, o in options],
                     {3, 4})
    parameters = [(i, p) for i in items for p in i["parameters"]]
    if parameters:
        yield _table("parameter-statistics", "Facility by the learner's own numbers (parametrised questions)",
                     ["question", "parameter", "facility per bin (learners)", "test", "p (Holm)"],
                     [[escape(i["id"]), escape(p["name"]),
                       "<br>".join(f"{escape(_values(b['low'], b['high']))}: {_number(b['facility'])} "
                                   f"({b['learners']})" for b in p["bins"]),
                       escape(p["test"] or "not tested (one bin)"),
                       ("n/a" if p["p_holm"] is None else f"{p['p_holm']:.2g}") +
                       (" <span class='flag'>differs</span>" if p["differs"] and not found["rough"] else "")]
                      for i, p in parameters], {4})

def moved_line(view: Summary) -> str:
    """How many scores moved since the last run ("the first run: 16 learners graded first" on a first run)."""
    if view.first_run:
        return f"the history's first run: {_count(len(view.changes), 'learner')} graded first"
    return f"{_count(len(view.changes), 'score')} moved since the last run"


def change_text(change: tuple) -> str:
    """One line of changes.csv in words: "182.7 -> 203: why", "first graded: 198", "no longer graded (was 12)"."""
    _, before, after, _, why = change
    if before is None:
        return f"{why}: {after:g}" if after is not None else why
    if after is None:
        return f"{why} (was {before:g})"
    return f"{before:g} -> {after:g}: {why}"


def _table(caption_id: str, title: str, header: list[str], rows: list[list[str]],
           numeric: set[int] = frozenset()) -> str:
    """A titled table; `rows` hold HTML already escaped; columns in `numeric` are right-aligned."""
    def cell(tag: str, i: int, content: str) -> str:
        return f"<{tag}{' class=num' if i in numeric else ''}>{content}</{tag}>"

    head = "".join(cell("th", i, escape(h)) for i, h in enumerate(header))
    body = "".join("<tr>" + "".join(cell("td", i, c) for i, c in enumerate(row)) + "</tr>" for row in rows)
    return f"<h2 id='{caption_id}'>{escape(title)}</h2><table><tr>{head}</tr>{body}</table>"


def html_parts(view: Summary) -> Iterator[str]:
    """summary.html piece by piece, to be written as they come: a large class's lists are never in memory whole."""
    counts = view.counts
    yield (f"<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'><title>Class summary</title>"
           f"<style>{STYLE}</style></head><body><main><h1>Class summary</h1>")
    yield (f"<p>{_count(len(view.graded), 'learner')} graded; {len(view.not_graded)} could not be graded; "
           f"{len(view.skipped)} skipped; {len(view.flagged)} flagged; {escape(moved_line(view))}.</p>")
    yield f"<p id='isolation'>{escape(view.isolation)}</p>" if view.isolation else ""
    if len(view.graded):
        first = view.graded.first
        yield (f"<p id='provenance'>Graded by grader {escape(first['grader'] or 'unknown')}, course "
               f"{escape(first['course'] or 'none')}, current handout {escape(first['handout'] or 'not set')}, "
               f"seed {escape(first['seed'])}.</p>")
        top = view.graded.max_score or 1
        bins = Counter(min(9, int(10 * score / top)) for score in view.graded.scores)
        yield "<h2 id='histogram'>Scores</h2><table>"
        for b in range(10):
            count = bins.get(b, 0)
            yield (f"<tr><td>{10 * b}-{10 * b + 10}%</td><td class='num'>{count}</td>"
                   f"<td><span class='bar' style='width:{8 * count}px'></span></td></tr>")
        yield "</table>"
        yield _table("mistakes", "Named mistakes (learners who made each; failures of their own)",
                     ["check", "mistake", "learners"],
                     [[escape(f"{m['chapter']}/{m['function']}") + f" <small>{m['kind']}</small>",
                       escape(m["mistake"]), str(m["learners"])] for m in counts["mistakes"]], {2})
        failing = [c for c in counts["checks"] if c["failed"] + c["failed_upstream"] + c["errors"]][:60]
        yield _table("failure-rates", "Checks by failure rate among those who answered (a helper's failure and a "
                                      "blank quiz question counted apart)",
                     ["check", "failed", "rate", "because a helper fails", "could not be graded", "left blank"],
                     [[f"{escape(c['id'])}<br><small>{escape(c['description'])}</small>",
                       f"{c['failed']}/{c['seen'] - c['unanswered']}",
                       f"{100 * c['failed'] / max(c['seen'] - c['unanswered'], 1):.0f}%",
                       str(c["failed_upstream"]), str(c["errors"]), str(c["unanswered"])] for c in failing],
                     {1, 2, 3, 4, 5})
        yield _table("options", "Options chosen (by option: each learner has their own letters)",
                     ["question", "option", "right", "chosen by"],
                     [[escape(o["question"]), f"{escape(o['option'])}) {escape(o['text'])}",
                       "yes" if o["right"] else "no", str(o["chosen"])] for o in counts["options"]], {3})
        yield _table("answer-forms", "Symbolic answers by form", ["question", "answer", "verdict", "learners"],
                     [[escape(f["question"]), f"<code>{escape(f['form'])}</code>",
                       escape(f["verdict"] + (f" ({f['mistake']})" if f["mistake"] else "")),
                       str(f["learners"])] for f in counts["answer_forms"]], {3})
        yield _table("messages", "Most common failures, by check and named mistake",
                     ["learners", "check", "named mistake", "message"],
                     [[str(m["count"]), escape(m["check"]), escape(m["mistake"] or "none named"),
                       escape(m["message"])] for m in counts["messages"]], {0})
        yield from _statistics_parts(view.statistics)
    if view.similar:
        rows = []
        for pair in view.similar:
            shared = "".join(f"<pre>{escape(block)}</pre>" for block in pair.shared[:3])
            rows.append([escape(f"{pair.first} and {pair.second}"), f"{pair.score:.2f}",
                         escape(", ".join(pair.functions[:6])), shared])
        yield _table("similar", "Most similar submissions (for a person to look at; not an accusation)",
                     ["learners", "similarity", "functions most alike", "shared lines"], rows, {1})
    handouts = _handouts(view)
    if handouts:
        yield "<h2 id='handouts'>Archives by handout</h2><ul>"
        yield from (f"<li>{escape(h)}: {n}</li>" for h, n in sorted(handouts.items()))
        yield "</ul>"
    sections = (("flagged", "Flagged (graded; look at these)", view.flagged,
                 ((k, "; ".join(v)) for k, v in view.flagged.items())),  # in the class's order, as the gradebook
                ("roster", "The roster and the submissions disagree", view.roster.get("said"),
                 (("", said) for said in view.roster.get("said", []))),
                ("changes", "First grades" if view.first_run else "Scores that moved since the last run",
                 view.changes, ((c[0], change_text(c)) for c in view.changes)),
                ("notes", "For the instructor", view.notes, (("", n) for n in view.notes)),
                ("not-graded", "Not graded", view.not_graded, view.not_graded.items()),
                ("skipped", "Skipped (not taken as submissions)", view.skipped, view.skipped))
    for section, title, present, items in sections:
        if present:
            yield f"<h2 id='{section}'>{title}</h2><ul>"
            yield from (f"<li>{escape(k) + ': ' if k else ''}{escape(v)}</li>" for k, v in items)
            yield "</ul>"
    yield "</main></body></html>\n"
