"""Renderers for instructors' systems: Gradescope results.json, JUnit XML, the gradebook CSV row.

Learner text (ids, messages) is made safe for each format by grader.safe_text: JSON that is valid
UTF-8, XML without the characters XML forbids, CSV cells that no spreadsheet runs as a formula."""

from __future__ import annotations

import json
from xml.etree import ElementTree

from grader.model import Report, Status
from grader.safe_text import for_csv, for_json, for_xml


def gradescope(report: Report) -> str:
    """Gradescope's autograder format: score, tests[] with name, score, max_score, status, output."""
    tests = []
    for chapter in report.chapters:
        for problem in chapter.problems:
            tests.append({"name": f"{chapter.chapter}: problem", "score": 0, "max_score": 0,
                          "status": "failed", "output": problem, "visibility": "visible"})
        for check in chapter.checks:
            tests.append({
                "name": f"{chapter.chapter} {check.kind}: {check.description}",
                "score": check.points, "max_score": check.max_points,
                "status": "passed" if check.status == Status.PASS else "failed",
                "output": check.message, "visibility": "visible",
            })
    return json.dumps(for_json({"score": report.score, "tests": tests})) + "\n"


def junit(reports: list[tuple[str, Report]]) -> str:
    """One <testsuite> per learner, one <testcase> per check."""
    suites = ElementTree.Element("testsuites", name="jacobians-grader")
    for learner, report in reports:
        learner = for_xml(learner)
        checks = [(ch, c) for ch in report.chapters for c in ch.checks]
        suite = ElementTree.SubElement(suites, "testsuite", name=learner, tests=str(len(checks)),
                                       failures=str(sum(c.status == Status.FAIL for _, c in checks)),
                                       errors=str(sum(c.status == Status.ERROR for _, c in checks)),
                                       skipped=str(sum(c.status in (Status.SKIP, Status.RECORDED) for _, c in checks)))
        for chapter, check in checks:
            case = ElementTree.SubElement(suite, "testcase", classname=f"{learner}.{chapter.chapter}",
                                          name=for_xml(f"{check.kind}:{check.id}"))
            tag = {Status.FAIL: "failure", Status.ERROR: "error", Status.SKIP: "skipped",
                   Status.RECORDED: "skipped"}.get(check.status)
            if tag:
                message = check.message.splitlines()[0][:200] if check.message else ""
                ElementTree.SubElement(case, tag, message=for_xml(message))
    return ElementTree.tostring(suites, encoding="unicode", xml_declaration=True) + "\n"


def gradebook_header(chapters: list[str]) -> list[str]:
    columns = ["learner"]
    for chapter in chapters:
        columns += [f"{chapter}_code", f"{chapter}_quiz"]
    return columns + ["total", "max_total", "status", "message"]


def gradebook_row(learner: str, report: Report | None, chapters: list[str], status: str,
                  message: str = "") -> list[str]:
    """The learner's row: their id as given (a spreadsheet formula neutralised), code and quiz score
    per chapter, total, status and why it is not graded. Without a report (not graded: unreadable, an
    infrastructure failure) every score cell is empty, never 0."""
    row = [for_csv(learner)]
    by_id = {c.chapter: c for c in report.chapters} if report else {}
    for chapter in chapters:
        result = by_id.get(chapter)
        row += ["", ""] if result is None else [f"{result.score_of('code'):g}", f"{result.score_of('quiz'):g}"]
    row += ["", ""] if report is None else [f"{report.score:g}", f"{report.max_score:g}"]
    return row + [status, for_csv(message)]
