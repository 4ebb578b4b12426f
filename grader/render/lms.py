"""Renderers for instructors' systems: Gradescope results.json, GitHub Classroom results, JUnit XML,
and the gradebooks (generic, Canvas, Moodle).

Learner text (ids, messages) is made safe for each format by grader.safe_text: JSON that is valid
UTF-8, XML without the characters XML forbids, CSV cells that no spreadsheet runs as a formula.
The JSON outputs are described by the JSON Schemas in grader/schemas/ (grader.schemas_path)."""

from __future__ import annotations

import csv
import io
import itertools
import json
import re
import shutil
from collections.abc import Collection, Iterable, Iterator
from pathlib import Path
from xml.etree import ElementTree

from grader import provenance
from grader.chapters import BY_ID
from grader.model import LearnerResult
from grader.model import ChapterResult, CheckResult, Report, Status, made_once, made_text, points_text
from grader.render import plural
from grader.safe_text import for_csv, for_xml, json_for_terminal, unicode_json

SCHEMA_DIR = Path(__file__).resolve().parent.parent / "schemas"
SCHEMAS = ("report", "batch-report", "gradescope-results", "classroom", "summary")


def schema(name: str) -> dict:
    """The JSON Schema (draft 2020-12) of one JSON output: report (grade ... --format json), batch-report
    (grade batch's report.json), gradescope-results (results.json), classroom (grade classroom), summary
    (grade batch's summary.json)."""
    return json.loads((SCHEMA_DIR / f"{name}.schema.json").read_text(encoding="utf-8"))


# What a status means where a format has fewer words for it than the grader (Gradescope: passed or
# failed; GitHub Classroom: pass, fail or error).
ERROR_PREFIX = "Could not be graded (an error, not a wrong answer): "
SKIP_PREFIX = "Not judged (skipped): "
RECORDED_PREFIX = "Recorded, graded on submission: "


def check_message(check: CheckResult, chapter: ChapterResult) -> str:
    """The check's message and its hint; for a check that could not be graded (error) the chapter's messages too, which
    its message points to ("see the chapter's message")."""
    message = "\n".join(part for part in (check.message, f"hint: {check.help}" if check.help else "") if part)
    if check.status == Status.ERROR and chapter.problems:
        message = f"{message}\n\nThe chapter's message:\n" + "\n".join(chapter.problems)
    return message


def _explained(check: CheckResult, chapter: ChapterResult) -> str:
    """The message with what its status means, for formats that only know passed and failed."""
    prefix = {Status.ERROR: ERROR_PREFIX, Status.SKIP: SKIP_PREFIX, Status.RECORDED: RECORDED_PREFIX}
    return prefix.get(check.status, "") + check_message(check, chapter)


def chapter_status(chapter: ChapterResult) -> str:
    """What a chapter's messages are: "error" where they stopped its checks being graded (its file does not
    import), "fail" where they are the learner's to fix and graded nonetheless (an answer file missing)."""
    return "error" if any(c.status == Status.ERROR for c in chapter.checks) else "fail"


def check_key(chapter: str, check: CheckResult) -> str:
    """The check's id as the course config names it: ch06/H_rows_orthogonal (quiz questions: ch06/quiz_...)."""
    return f"{chapter}/{check.id}"


# ------------------------------------------------------------------------------------ Gradescope

def counted_quiz(check: CheckResult) -> bool:
    """A quiz question that counts: its verdict is shown only once grades are published, so that trying
    every option and submitting again tells nothing (a practice question's verdict is shown at once)."""
    return check.kind == "quiz" and not check.practice


def summary_lines(report: Report) -> list[str]:
    """Score per chapter, what stopped a chapter being graded, and overrides and penalties: the top of every
    results file."""
    lines = []
    for chapter in report.chapters:
        parts = [f"code {chapter.score_of('code'):g}/{chapter.max_score_of('code'):g}"]
        if chapter.max_score_of("quiz") or chapter.recorded_score_of("quiz"):
            parts.append(f"quiz {chapter.score_of('quiz'):g}/{chapter.max_score_of('quiz'):g}")
        lines.append(f"{chapter.chapter} {chapter.title}: {chapter.score:g}/{chapter.max_score:g} ({', '.join(parts)})")
        lines += [f"  {chapter.chapter}: {problem.splitlines()[0] if problem else ''}" for problem in chapter.problems]
    lines += [f"{'late penalty' if a.kind == 'late' else 'override'}: {a.describe()}" for a in report.all_adjustments()]
    errors = sum(c.status == Status.ERROR for ch in report.chapters for c in ch.checks)
    if errors:
        lines.append(f"{plural(errors, 'check')} could not be graded (status error: the file did not import, hung, "
                     "or the grader broke); they are not wrong answers. Their tests say why.")
    return lines


def gradescope_data(report: Report, *, hidden: Collection[str] = (), execution_time: float | None = None,
                    heading: Iterable[str] = (), notes: Iterable[str] = (), isolation: str = "",
                    submission: str | None = None, texts: dict[int, str] | None = None) -> dict:
    """Gradescope's results.json as data (its autograder specification): score, execution_time, output and
    output_format, stdout_visibility, and one test per check with name, number, score, max_score, status
    ("passed"/"failed"; an error or skipped check is "failed", told apart by its output, its tags and
    extra_data.status), output, tags (chapter, kind, function, status) and visibility: checks the course
    hides (`hidden`, "ch06/H_rows_orthogonal") are "after_published", all others "visible". Chapter-level
    messages (a file that does not import) are tests of 0 points. `heading` and `notes` go before and after
    the score lines of the top-level output. No seed is in it (a course seed is the instructor's secret): its
    `extra_data.submission` is the Gradescope submission whose id, with the course seed and the learner, the seed
    was drawn from (grader.course.gradescope.submission_seed), so a regrade draws it again. A check made unchanged
    from a kept verdict has its test made once (grader.model.made_once: the same dict, not to be changed), and with
    `texts`, its JSON text (safe_text.unicode_json's) put there by the test's id."""
    tests = []
    for chapter_index, chapter in enumerate(report.chapters):
        number = int(chapter.chapter[2:]) if chapter.chapter[2:].isdigit() else chapter_index
        for problem in chapter.problems:
            tests.append({"name": f"{chapter.chapter}: chapter message", "number": f"{number}.0",
                          "score": 0, "max_score": 0, "status": "failed", "output": problem, "output_format": "text",
                          "tags": [chapter.chapter, "chapter", chapter_status(chapter)], "visibility": "visible",
                          "extra_data": {"id": f"{chapter.chapter}/chapter", "status": chapter_status(chapter)}})
        for index, check in enumerate(chapter.checks, 1):
            visibility = ("after_published" if check_key(chapter.chapter, check) in hidden or counted_quiz(check)
                          else "visible")
            if check.status == Status.ERROR and chapter.problems:  # its output holds the chapter's messages
                test = _test(check, chapter, f"{number}.{index}", visibility)
            else:
                what = ("gradescope test", chapter.chapter, number, index, visibility)
                test = made_once(check, what, _test, check, chapter, f"{number}.{index}", visibility)
                text = made_text(check, (*what, "text"), unicode_json, test) if texts is not None else None
                if text is not None:
                    texts[id(test)] = text
            tests.append(test)
    output = [*heading, *summary_lines(report), *notes]
    if isolation:
        output.append(isolation)
    output.append(provenance.footer(report, learner_sees=True))
    data = {"score": report.score, "output": "\n".join(output), "output_format": "simple_format",
            "test_output_format": "text", "stdout_visibility": "hidden",
            "extra_data": {"max_score": report.max_score, "learner": report.learner,
                           "provenance": {k: v for k, v in report.provenance().items() if k != "seed"},
                           "submission": submission, "raw_score": report.raw_score,
                           "adjustments": [a.to_dict() for a in report.all_adjustments()]}, "tests": tests}
    if execution_time is not None:
        data["execution_time"] = round(max(0.0, execution_time), 2)
    return data


def _test(check: CheckResult, chapter: ChapterResult, number: str, visibility: str) -> dict:
    """One check's test in results.json."""
    test = {
        "name": f"{chapter.chapter} {check.kind}: {check.description}",
        "number": number,
        "score": check.points, "max_score": check.max_points if check.status.counted else 0,
        "output": _explained(check, chapter), "output_format": "text",
        "tags": [chapter.chapter, check.kind, check.function, check.status.value],
        "visibility": visibility,
        "extra_data": {"id": check_key(chapter.chapter, check), "status": check.status.value},
    }
    if check.status != Status.RECORDED:
        test["status"] = "passed" if check.status == Status.PASS else "failed"
    return test


def for_display(data: dict, texts: dict[int, str] | None = None) -> str:
    """JSON text whose strings show as they read: no terminal escape sequence or control character (but
    line breaks and tabs) from learner text survives into what Gradescope's page or GitHub's log shows
    (the log renders colours), and valid UTF-8. `texts`: the tests' texts made already (gradescope_data's)."""
    return json_for_terminal(data, texts, ("tests",)) + "\n"


def gradescope(report: Report, **options) -> str:
    """gradescope_data as the text of results.json."""
    texts: dict[int, str] = {}
    return for_display(gradescope_data(report, texts=texts, **options), texts)


def gradescope_not_graded(message: str, *, execution_time: float | None = None, heading: Iterable[str] = (),
                          isolation: str = "", not_graded: str | None = None) -> str:
    """results.json for a submission that could not be graded at all (no chapter files, not a readable
    submission): score 0, the reason on top and as the one test; `not_graded`: why it could not be graded for a
    reason outside the learner's code (in extra_data.not_graded, for the instructor)."""
    output = [*heading, message]
    if isolation:
        output.append(isolation)
    data = {"score": 0, "output": "\n".join(output), "output_format": "simple_format", "stdout_visibility": "hidden",
            "tests": [{"name": "submission", "score": 0, "max_score": 0, "status": "failed", "output": message,
                       "output_format": "text", "tags": ["submission"], "visibility": "visible",
                       "extra_data": {"id": "submission", "status": "fail"}}]}
    if execution_time is not None:
        data["execution_time"] = round(max(0.0, execution_time), 2)
    if not_graded is not None:
        data["extra_data"] = {"not_graded": not_graded}
    return for_display(data)


# ------------------------------------------------------------------------------------ GitHub Classroom

def classroom_data(report: Report, *, message: str = "") -> dict:
    """The results format GitHub Classroom's autograding-grading-reporter reads from a runner (base64 in
    the step output `result`): version, status ("pass", "fail" or "error"), max_score, message and one test
    per judged check with name, status, score (the check's own points: the reporter adds them up),
    max_score, message, filename and line_no; each adjustment (an override, a late penalty) is a test of its own
    points (max_score 0), so that the reporter's sum of the scores is the grade. Answers recorded for grading on
    submission and hidden checks are not judged here: they are in no test, and `message` says how many points they
    hold."""
    tests = []
    for chapter in report.chapters:
        info = BY_ID.get(chapter.chapter)
        filename = chapter.source if chapter.source.startswith("exercises/") else f"exercises/{info.module}.py" if info else ""
        for problem in chapter.problems:
            tests.append({"name": f"{chapter.chapter}: chapter message", "status": chapter_status(chapter), "score": 0,
                          "max_score": 0, "message": problem, "filename": filename, "line_no": 0})
        for check in chapter.checks:
            if not check.status.counted:
                continue
            status = {Status.PASS: "pass", Status.ERROR: "error"}.get(check.status, "fail")
            quiz_file = f"exercises/answers/{chapter.chapter}.yaml"
            tests.append({"name": f"{chapter.chapter} {check.kind}: {check.description}", "status": status,
                          "score": check.points, "max_score": check.max_points,
                          "message": _explained(check, chapter),
                          "filename": quiz_file if check.kind == "quiz" else filename, "line_no": 0})
    statuses = {t["status"] for t in tests}
    status = "error" if "error" in statuses else "fail" if "fail" in statuses else "pass"
    for adjustment in report.all_adjustments():  # so that the reporter's sum of the scores is the grade
        tests.append({"name": f"{'late penalty' if adjustment.kind == 'late' else 'override'} on {adjustment.target}",
                      "status": "pass", "score": adjustment.points, "max_score": 0, "message": adjustment.describe(),
                      "filename": "", "line_no": 0})
    pending = report.pending_score
    said = [f"{report.score:g}/{plural(report.max_score, 'point')} judged here"]
    if pending:
        said.append(f"{plural(pending, 'more point')} (recorded quiz answers, hidden checks) "
                    f"{'is' if pending == 1 else 'are'} graded when you submit")
    if message:
        said.append(message)
    said.append(provenance.footer(report))
    return {"version": 1, "status": status, "max_score": report.max_score, "message": "; ".join(said),
            "tests": tests}


def classroom(report: Report, **options) -> str:
    return for_display(classroom_data(report, **options))


# ------------------------------------------------------------------------------------ JUnit

def _time(seconds: float) -> str:
    return f"{max(0.0, seconds):.3f}"


def junit(reports: list[tuple[str, Report]], extras: dict[str, dict] | None = None) -> str:
    """One <testsuite> per learner (its time: that learner's grading, all chapters), one <testcase> per check
    and one per chapter with chapter-level messages (a file that did not import); a failed check has a
    <failure>, a check that could not be graded an <error>, both with the first line as `message` and the
    whole message (with the chapter's message for errors) as text; skipped and recorded checks <skipped>.
    `extras` maps a learner to {"seconds": ..., "output": what their code printed} (from report.json).
    Valid against Jenkins' junit-10.xsd. JUnit writes the same, learner by learner."""
    extras = extras or {}
    suites, text = JUnit(io.StringIO()), io.StringIO()
    for learner, report in reports:
        suites.add(learner, report, extras.get(learner))
    suites.write(text)
    return text.getvalue()


class JUnit:
    """junit.xml written learner by learner into `stream` (a text file: each learner's <testsuite> as it
    comes, so that no report need be kept until the end), then put together with the totals (write)."""

    def __init__(self, stream) -> None:
        self.stream = stream
        self.totals = {"tests": 0, "failures": 0, "errors": 0, "time": 0.0}
        self.count = 0

    def add(self, learner: str, report: Report, extra: dict | None = None) -> None:
        """One learner's <testsuite>; `extra` is {"seconds": ..., "output": what their code printed}."""
        suite, counts, seconds = _suite(learner, report, extra or {})
        self.stream.write(suite)
        self.count += 1
        self.totals["tests"] += counts["tests"]
        self.totals["failures"] += counts["failure"]
        self.totals["errors"] += counts["error"]
        self.totals["time"] += seconds

    def _ends(self) -> tuple[str, str]:
        """The text before the suites (the declaration and <testsuites> with the totals) and after them."""
        suites = ElementTree.Element("testsuites", name="jacobians-grader")
        for key in ("tests", "failures", "errors"):
            suites.set(key, str(self.totals[key]))
        suites.set("time", _time(self.totals["time"]))
        if not self.count:
            return ElementTree.tostring(suites, encoding="unicode", xml_declaration=True) + "\n", ""
        ElementTree.SubElement(suites, "suites")
        head, tail = ElementTree.tostring(suites, encoding="unicode", xml_declaration=True).split("<suites />")
        return head, tail + "\n"

    def write(self, target) -> None:
        """The whole junit.xml into the text file `target`, the suites copied from `stream`."""
        head, tail = self._ends()
        target.write(head)
        self.stream.seek(0)
        shutil.copyfileobj(self.stream, target)
        target.write(tail)


def _suite(learner: str, report: Report, extra: dict) -> tuple[str, dict[str, int], float]:
    """One learner's <testsuite> as XML text (as ElementTree writes it: _element), its counts (tests, failure,
    error, skipped) and its seconds."""
    name = for_xml(learner)
    cases = []
    for chapter in report.chapters:
        classname = f"{name}.{chapter.chapter}"
        if chapter.problems:
            tag = "error" if chapter_status(chapter) == "error" else "failure"
            cases.append((classname, f"{chapter.chapter}:chapter", tag, "\n".join(chapter.problems), "chapter"))
        for check in chapter.checks:
            tag = _CASE_TAGS.get(check.status)
            cases.append((classname, f"{check.kind}:{check.id}", tag, check_message(check, chapter) if tag else "",
                          check.status.value))
    counts = {tag: sum(c[2] == tag for c in cases) for tag in ("failure", "error", "skipped")}
    seconds = float(extra.get("seconds") or 0.0)
    parts = [_element("testsuite", (("name", name), ("tests", str(len(cases))), ("failures", str(counts["failure"])),
                                    ("errors", str(counts["error"])), ("skipped", str(counts["skipped"])),
                                    ("time", _time(seconds))), open_=True),
             "<properties>"]
    parts.extend(_element("property", (("name", key), ("value", for_xml("" if value is None else str(value)))))
                 for key, value in report.provenance().items())
    parts.append("</properties>")
    for classname, case_name, tag, text, kind in cases:
        attributes = (("classname", classname), ("name", for_xml(case_name)))
        if not tag:
            parts.append(_element("testcase", attributes))
            continue
        first = text.splitlines()[0][:200] if text else ""
        inner = _element(tag, (("message", for_xml(first)), ("type", kind)),
                         for_xml(text) if tag != "skipped" or text else "")
        parts.append(f"{_element('testcase', attributes, open_=True)}{inner}</testcase>")
    output = extra.get("output") or ""
    if output:
        parts.append(_element("system-out", (), for_xml(output)))
    parts.append("</testsuite>")
    return "".join(parts), {**counts, "tests": len(cases)}, seconds


_CASE_TAGS = {Status.FAIL: "failure", Status.ERROR: "error", Status.SKIP: "skipped", Status.RECORDED: "skipped"}
_ATTRIBUTE_ESCAPES = (("&", "&amp;"), ("<", "&lt;"), (">", "&gt;"), ('"', "&quot;"), ("\r", "&#13;"),
                      ("\n", "&#10;"), ("\t", "&#09;"))
_TEXT_ESCAPES = _ATTRIBUTE_ESCAPES[:3]


_ESCAPED_IN_ATTRIBUTES = re.compile('[&<>"\r\n\t]').search


def _escaped(text: str, escapes: tuple[tuple[str, str], ...]) -> str:
    for character, entity in escapes:
        if character in text:
            text = text.replace(character, entity)
    return text


def _attribute(text: str) -> str:
    """An attribute value escaped as ElementTree escapes it (almost every value has nothing to escape)."""
    return text if _ESCAPED_IN_ATTRIBUTES(text) is None else _escaped(text, _ATTRIBUTE_ESCAPES)


def _element(tag: str, attributes: tuple[tuple[str, str], ...], text: str = "", open_: bool = False) -> str:
    """An element as ElementTree.tostring(encoding="unicode") writes it: its attributes in order, escaped as it
    escapes them (xml.etree.ElementTree._escape_attrib, _escape_cdata), `text` inside, or no text and no content
    as `<tag ... />`; with `open_`, only its start tag (the caller writes what it holds and its end)."""
    start = f"<{tag}" + "".join(f' {key}="{_attribute(value)}"' for key, value in attributes)
    if open_:
        return start + ">"
    if not text:
        return start + " />"
    return f"{start}>{_escaped(text, _TEXT_ESCAPES)}</{tag}>"


# ------------------------------------------------------------------------------------ gradebooks
# Every gradebook is an export of grade batch's history (grader.course.history): one LearnerResult per learner.

def _csv(rows: Iterable[list[str]]) -> str:
    buffer = io.StringIO()
    csv.writer(buffer).writerows(rows)
    return buffer.getvalue()




def gradebook_header(chapters: list[str]) -> list[str]:
    columns = ["learner"]
    for chapter in chapters:
        columns += [f"{chapter}_code", f"{chapter}_quiz"]
    return columns + ["total", "max_total", "status", "message", "adjustments", "grader", "handout", "seed"]


def gradebook_row(result: LearnerResult, chapters: list[str]) -> list[str]:
    """The learner's row: their id as given (a spreadsheet formula neutralised), code and quiz score per
    chapter (overrides of a check included), the total (every override and penalty included), status, why
    it is not graded or what was flagged, the adjustments in words, and what graded it: the grader's
    version, the handout the archive was packed with, the seed. Not graded (unreadable, an infrastructure
    failure): every score cell is empty, never 0."""
    row = [for_csv(result.learner)]
    for chapter in chapters:
        scores = result.chapters.get(chapter)
        row += ["", ""] if scores is None else [points_text(scores["code"]), points_text(scores["quiz"])]
    adjustments = "; ".join(f"{'late penalty' if a['kind'] == 'late' else 'override'} {a['points']:+g} on "
                            f"{a['target']} ({a['reason']})" for a in result.adjustments)
    return row + [points_text(result.score), points_text(result.max_score), result.status,
                  for_csv("; ".join([result.message, *result.flags]).strip("; ")), for_csv(adjustments),
                  result.grader or "", for_csv(result.manifest_handout or ""),
                  "" if result.seed is None else str(result.seed)]


def gradebook_lines(results: Iterable[LearnerResult], chapters: list[str]) -> Iterator[str]:
    """gradebook.csv line by line (a cell may hold a line break: a line is a row as CSV writes it)."""
    buffer = io.StringIO()
    writer = csv.writer(buffer)
    for row in itertools.chain([gradebook_header(chapters)], (gradebook_row(r, chapters) for r in results)):
        buffer.seek(0)
        buffer.truncate()
        writer.writerow(row)
        yield buffer.getvalue()


def points_possible(results: list[LearnerResult], chapters: list[str]) -> dict[str, float]:
    """Per chapter, the points a graded learner could get (every learner is graded on the same checks)."""
    possible: dict[str, float] = {}
    for result in results:
        for chapter, scores in result.chapters.items():
            if chapter in chapters:
                possible[chapter] = max(possible.get(chapter, 0), scores["max"])
    return possible


def _column(chapter: str) -> str:
    info = BY_ID.get(chapter)
    return f"{chapter} {info.title}" if info else chapter


def _score(result: LearnerResult, chapter: str) -> str:
    scores = result.chapters.get(chapter)
    return "" if scores is None else points_text(scores["score"])


LMS_LAYOUTS = ("canvas", "moodle")
CANVAS_ID_COLUMNS = ["Student", "ID", "SIS User ID", "SIS Login ID", "Section"]
# The part of a total no chapter column holds: a late penalty and overrides of the total. With it, the columns
# of an LMS that adds up its columns give the learner's total, exactly as printed.
BEYOND_CHAPTERS = "Late penalty and total overrides"


def beyond_chapters(result: LearnerResult, chapters: list[str]) -> str:
    """The cell of BEYOND_CHAPTERS: the learner's total less their chapter cells, in decimal as printed (so the
    printed cells add up to the printed total); "" for a learner not graded."""
    if result.score is None:
        return ""
    from decimal import Decimal

    cells = [Decimal(points_text(result.chapters[c]["score"])) for c in chapters if c in result.chapters]
    rest = (Decimal(points_text(result.score)) - sum(cells, Decimal(0))).normalize()
    return format(rest + 0, "f")  # + 0: no "-0"


def canvas_gradebook(results: list[LearnerResult], chapters: list[str]) -> str:
    """Canvas' gradebook import: the columns Student, ID, SIS User ID, SIS Login ID and Section (the learner
    id in Student and SIS Login ID; Canvas matches a row by ID, SIS User ID or SIS Login ID), one column per
    chapter ("ch06 <title>", a new assignment on import; overrides of checks and chapters included), one for
    what belongs to no chapter (BEYOND_CHAPTERS: a late penalty, overrides of the total; 0 points possible),
    so that Canvas' sum of a row is the learner's total, and a "Points Possible" row as Canvas' own export
    writes it. A learner not graded has empty cells (Canvas changes nothing there)."""
    possible = points_possible(results, chapters)
    rows = [CANVAS_ID_COLUMNS + [_column(c) for c in chapters] + [BEYOND_CHAPTERS],
            ["    Points Possible", "", "", "", ""] + [points_text(possible.get(c)) for c in chapters] + ["0"]]
    for result in results:
        cell = for_csv(result.learner)
        rows.append([cell, "", "", cell, ""] + [_score(result, c) for c in chapters] + [beyond_chapters(result,
                                                                                                   chapters)])
    return _csv(rows)


def moodle_gradebook(results: list[LearnerResult], chapters: list[str]) -> str:
    """Moodle's "Import grades from CSV": a column identifying the learner ("Learner id": map it to the user
    field your ids are, ID number, email address or username), one grade column per chapter with the points
    possible in its name ("ch06 <title> (out of 25)": give the grade item that maximum, or map to an
    existing one), one for what belongs to no chapter (BEYOND_CHAPTERS, out of 0: a late penalty is negative,
    so give its grade item a negative minimum), so that the columns add up to the total; then the total (with
    overrides and penalties) and a feedback column, which the learner sees (learner_feedback: why they are not
    graded, or the adjustments with their reasons). A learner not graded has empty grade cells."""
    possible = points_possible(results, chapters)
    total = sum(possible.values())
    rows = [["Learner id"] + [f"{_column(c)} (out of {possible.get(c, 0):g})" for c in chapters]
            + [f"{BEYOND_CHAPTERS} (out of 0)", f"Total (out of {total:g})", "Feedback"]]
    for result in results:
        rows.append([for_csv(result.learner)] + [_score(result, c) for c in chapters]
                    + [beyond_chapters(result, chapters), points_text(result.score), for_csv(learner_feedback(result))])
    return _csv(rows)


def learner_feedback(result: LearnerResult) -> str:
    """What a learner reads beside their grade in an LMS: why they are not graded, or each adjustment with its reason,
    in sentences that start with a word (no spreadsheet takes them for a formula, so none needs escaping). What
    was flagged is for the instructor's eyes, and is not in it."""
    if result.status != "graded":
        return f"Not graded ({result.status}): {result.message}"
    said = []
    for a in result.adjustments:
        what = "Late penalty" if a["kind"] == "late" else "Override"
        where = "" if a["target"] == "total" else f" on {a['target']}"
        said.append(f"{what}{where}: {a['points']:+g} ({a['reason']})")
    return "; ".join(said)


def changes_csv(changes: list[tuple]) -> str:
    """changes.csv: learner, before, after, delta, why: each learner whose score moved since the last run."""
    return _csv([["learner", "before", "after", "delta", "why"]]
                + [[for_csv(learner), points_text(before), points_text(after), points_text(delta), for_csv(why)]
                   for learner, before, after, delta, why in changes])
