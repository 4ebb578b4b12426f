"""Learner text in every output: a learner whose exception name and message, and what it prints, hold
terminal escape sequences, control characters and a lone surrogate ("\\udcff") breaks no output of
`grade chNN` (text on a terminal, JSON, HTML), and each medium gets the text made safe its own way
(grader.safe_text)."""

from __future__ import annotations

import json
import re
import sys

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from grader import safe_text
from tests.support import (
    REPO,
    build_submission,
    code_points,
    hostile_module,
    run_grade,
    run_on_terminal,
)


@pytest.fixture(scope="module")
def hostile(tmp_path_factory):
    return build_submission(tmp_path_factory.mktemp("hostile") / "sub", {"ch06_measurement": hostile_module()})


# ------------------------------------------------------------------------------- each medium

@pytest.mark.parametrize("text, shown", [
    ("\x1b[2Jcleared", "cleared"),
    ("\x1b[1;32mgreen\x1b[0m", "green"),
    ("\x1b]0;window title\x07after", "after"),
    ("\x1b]8;;http://x\x1b\\link\x1b]8;;\x1b\\", "link"),
    ("\x9b2Jeight-bit", "eight-bit"),
    ("over\rwrite", "over?write"),
    ("back\bspace\x00", "back?space?"),
    ("bidi\u202eevil", "bidi?evil"),
    ("lone \udcff", "lone ?"),
    ("two\nlines\tand tab", "two\nlines\tand tab"),
    ("zoë ann+cs101@uni.edu", "zoë ann+cs101@uni.edu"),
])
def test_terminal_text_has_no_control_or_escape_sequence(text, shown):
    assert safe_text.for_terminal(text) == shown
    assert "\n" not in safe_text.for_terminal(text, one_line=True)


@pytest.mark.parametrize("cell, written", [
    ("=HYPERLINK(\"http://x\")", "'=HYPERLINK(\"http://x\")"),
    ("+1+1", "'+1+1"), ("-2+3", "'-2+3"), ("@SUM(A1)", "'@SUM(A1)"),
    ("\t=1", "' =1"), ("\r=1", "' =1"),
    ("ann+cs101@uni.edu", "ann+cs101@uni.edu"), ("zoë", "zoë"), ("a.b", "a.b"),
    ("two\nlines", "two lines"), ("lone \udcff", "lone \ufffd"),
])
def test_csv_cells_are_never_formulas_and_ids_stay_as_given(cell, written):
    assert safe_text.for_csv(cell) == written


def test_xml_json_and_html_text_always_encode():
    text = "a\x00b\x1b[2J\udcff\ufffe\x7f"
    xml = safe_text.for_xml(text)
    assert xml.encode("utf-8") and not re.search("[\x00-\x08\x0b\x0c\x0e-\x1f\ufffe\ud800-\udfff]", xml)
    assert json.dumps(safe_text.for_json({text: [text, (text, 1.5)]}), ensure_ascii=False).encode("utf-8")
    assert "\\ud" not in json.dumps(safe_text.for_json({"k": text}))  # no lone surrogate escapes either
    html = safe_text.for_html(text)
    assert html.encode("utf-8") and "\x1b" not in html and "\x00" not in html


def test_a_report_is_cleaned_as_a_copy(hostile):
    from grader.model import ChapterResult, CheckResult, Report, Status

    check = CheckResult("c", "f", "d", Status.FAIL, 0, 1, message="\x1b[2Jx\udcff", details={"traceback": "\x1b[H"})
    report = Report("s\udcff", [ChapterResult("ch06", "t", [check], ["\x1b[2J"])], learner_output="\x1b[2J")
    clean = safe_text.clean_report(report, safe_text.for_terminal)
    assert clean.chapters[0].checks[0].message == "x?" and clean.chapters[0].checks[0].status is Status.FAIL
    assert clean.chapters[0].checks[0].details["traceback"] == "" and clean.learner_output == ""
    assert clean.submission == "s?" and clean.chapters[0].problems == [""]
    assert report.chapters[0].checks[0].message == "\x1b[2Jx\udcff"  # the original is untouched


# ----------------------------------------------------------------------- grade chNN, for real

def test_grade_chapter_text_output_shows_no_learner_escape_sequence(hostile):
    done = run_grade("ch06", "--submission", hostile, "--no-quiz", "-v", raw=True)
    assert done.returncode == 1, done.stderr.decode(errors="replace")[-2000:]
    out = done.stdout.decode("utf-8")  # strict: a lone surrogate would not have been written at all
    assert "Traceback" not in done.stderr.decode(errors="replace")
    assert "\x1b" not in out and "\r" not in out and "\x9b" not in out and "\u202e" not in out
    assert "H_jacobian raised PASS: \u2713 [2/2] all good" in out  # the text itself is still shown
    assert "H at the lesson's point" in out and f"{code_points('ch06')}/{code_points('ch06')}" not in out


def test_on_a_terminal_only_the_graders_own_colours_remain(hostile):
    code, out = run_on_terminal([sys.executable, "-m", "grader", "ch06", "--submission", str(hostile), "--no-quiz",
                                 "-v"], REPO)
    assert code == 1, out
    assert "\x1b[2J" not in out and "\x1b]0;" not in out and "\x1b[1;32m" not in out
    assert "\x1b[32m" in out  # the grader's own green marks are there, and each is one of its marks
    assert all(out[i:].startswith("\x1b[32m\x1b[1m\u2713\x1b[0m") for i in (m.start() for m in re.finditer(
        re.escape("\x1b[32m"), out))), out


def test_grade_chapter_json_and_html_are_valid_utf8(hostile, tmp_path):
    page = tmp_path / "report.html"
    done = run_grade("ch06", "--submission", hostile, "--no-quiz", "--format", "json", "--html", page, raw=True)
    assert done.returncode == 1, done.stderr.decode(errors="replace")[-2000:]
    data = json.loads(done.stdout.decode("utf-8"))
    messages = [c["message"] for ch in data["chapters"] for c in ch["checks"] if c["function"] == "H_jacobian"]
    assert any("all good" in m for m in messages)
    assert not re.search(r"\\ud[89a-f]", done.stdout.decode("ascii", errors="replace"), re.I)
    html = page.read_bytes().decode("utf-8")
    assert "all good" in html and "\x1b" not in html and "\x00" not in html and "\udcff" not in html
    assert "<script" not in html


@pytest.mark.parametrize("text", ["plain", "\x1b[31mred\x1b[0m", "a\rb", "bi\u202edi", "c1\x85", "lone\udcff",
                                  "back\\slash \\u00e9 \\r", "tab\tnl\n", "\x08\x0c\x0b\x00", "emoji \U0001F600 é",
                                  "\x9b2J", "line\u2028sep", "del\x7f"])
def test_results_json_written_without_a_walk_is_what_the_walk_writes(text):
    """json_for_terminal skips cleaning data with nothing a terminal acts on: for every kind of learner text
    it gives exactly the text that cleaning every string (for_terminal) and encoding gives."""
    from grader.safe_text import clean_value, for_json, for_terminal, json_for_terminal

    data = {"id": text, "tests": [{"output": f"got {text}", "score": 1.5, "tags": [text, None, True]}]}
    assert json_for_terminal(data) == json.dumps(for_json(clean_value(data, for_terminal)), allow_nan=False)


def _reference_clean(value, clean):
    """What clean_value must give: `clean` applied to every string, walked the plain way."""
    import dataclasses
    from enum import Enum

    if isinstance(value, Enum) or not isinstance(value, (str, dict, list, tuple)) and not dataclasses.is_dataclass(
            value):
        return value
    if isinstance(value, str):
        return clean(value)
    if isinstance(value, dict):
        return {_reference_clean(k, clean): _reference_clean(v, clean) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return type(value)(_reference_clean(v, clean) for v in value)
    return dataclasses.replace(value, **{f.name: _reference_clean(getattr(value, f.name), clean)
                                         for f in dataclasses.fields(value) if f.init})


def test_every_cleaner_reaches_every_string_however_the_walk_is_shortened():
    """clean_value skips strings it need not clean (ASCII without controls, for the cleaners that keep those) and
    copies only what changes: for text with every ASCII character, C1 controls, bidirectional marks, lone
    surrogates and more, in dicts, lists, tuples and a report's dataclasses, it gives what cleaning every string
    gives, keeps what did not change, and json_text writes what json.dumps(for_json(...)) writes."""
    import random

    from grader.model import ChapterResult, CheckResult, Report, Status

    alphabet = [chr(i) for i in range(0xa0)] + ["\u200e", "\u202e", "\u2028", "\udcff", "\ufffe", "é", "\U0001F600"]
    cleaners = (safe_text.unicode_clean, safe_text.for_html, safe_text.for_xml, safe_text.for_terminal,
                safe_text.for_csv, lambda text: safe_text.for_terminal(text, one_line=True))
    draw = random.Random(7)
    for _ in range(3000):
        text = "".join(draw.choice(alphabet) if draw.random() < 0.3 else draw.choice("ab =+-@\\")
                       for _ in range(draw.randint(0, 6)))
        kept = CheckResult("x", "f", "d", Status.PASS, 1, 1)
        report = Report(text, [ChapterResult("ch06", "t", [CheckResult(
            "c", "f", "d", Status.FAIL, 0, 1, message=text, details={"rows": [[1.0, text], (2, 3)], text: 1},
            got=[text]), kept], [text], plots={"curve": [(1.0, 2.0)], text: text})], learner_output=text)
        data = {"k" + text: [text, (text, 1.5), {"x": text}], "n": None}
        for clean in cleaners:
            assert safe_text.clean_value(data, clean) == _reference_clean(data, clean), (clean, text)
            cleaned = safe_text.clean_value(report, clean)
            assert cleaned == _reference_clean(report, clean), (clean, text)
            assert cleaned.chapters[0].checks[1] is kept and (cleaned is report) == (clean(text) == text)
        for indent in (None, 2):
            assert safe_text.json_text(data, indent) == json.dumps(safe_text.for_json(data), allow_nan=False,
                                                                    indent=indent), text


# ------------------------------------------------------------------------------- a report's JSON written in parts

_LEAF = (st.none() | st.booleans() | st.integers() | st.floats() |
         st.text(st.characters(blacklist_categories=()) | st.sampled_from("\x1b\"\\\u2028\ud800"), max_size=12))
_VALUE = st.recursive(_LEAF, lambda inner: st.lists(inner, max_size=3) | st.dictionaries(st.text(max_size=5), inner,
                                                                                          max_size=3), max_leaves=8)
_CHECK = st.dictionaries(st.sampled_from(["id", "message", "got", "expected", "details"]), _VALUE, max_size=4)
_CHAPTER = st.fixed_dictionaries({"chapter": st.text(max_size=4), "checks": st.lists(_CHECK, max_size=4)},
                                 optional={"score": _LEAF, "notes": _VALUE})
_REPORT = st.fixed_dictionaries({"chapters": st.lists(_CHAPTER | _VALUE, max_size=3)},
                                optional={"seed": _LEAF, "batch": _VALUE, "learner": _LEAF})


@settings(max_examples=300, deadline=None)
@given(report=_REPORT | _VALUE, given_texts=st.lists(st.booleans(), max_size=12), allow_nan=st.booleans(),
       ensure_ascii=st.booleans())
def test_a_reports_json_written_in_parts_is_json_dumps_text(report, given_texts, allow_nan, ensure_ascii):
    """Whatever the data (non-finite numbers, control characters, lone surrogates, another shape than a report's),
    the text written with some check dicts' texts given is json.dumps's, and what json.dumps refuses is refused."""
    dumps = json.JSONEncoder(ensure_ascii=ensure_ascii, allow_nan=allow_nan).encode
    checks = [c for ch in (report.get("chapters") if isinstance(report, dict) else None) or []
              if isinstance(ch, dict) and isinstance(ch.get("checks"), list) for c in ch["checks"]]
    try:
        texts = {id(c): dumps(c) for c, given in zip(checks, given_texts) if given}
        whole = dumps(report)
    except ValueError:
        with pytest.raises(ValueError):
            safe_text.json_spliced(report, {}, dumps, ("chapters", "checks"))
        return
    assert safe_text.json_spliced(report, texts, dumps, ("chapters", "checks")) == whole


def test_a_given_text_is_written_for_its_check_dict_only():
    data = {"chapters": [{"chapter": "ch06", "checks": [{"id": "a"}, {"id": "b"}, {"id": "c"}]}], "seed": 4}
    first, second, third = data["chapters"][0]["checks"]
    spliced = safe_text.json_spliced(data, {id(second): '{"id": "B"}'}, json.dumps, ("chapters", "checks"))
    assert json.loads(spliced)["chapters"][0]["checks"] == [first, {"id": "B"}, third]
    non_string_keys = {"chapters": [{"checks": [{1: "one"}]}], 2: "two"}
    assert safe_text.json_spliced(non_string_keys, {}, json.dumps, ("chapters", "checks")) == json.dumps(non_string_keys)


@settings(max_examples=200, deadline=None)
@given(tests=st.lists(_CHECK, max_size=6), given_texts=st.lists(st.booleans(), max_size=6), output=_LEAF)
def test_results_json_for_the_terminal_is_the_same_with_its_tests_texts_given(tests, given_texts, output):
    """results.json's text (grader.render.lms.for_display): its tests' texts given or not, the same text, learner
    text cleaned for the terminal alike."""
    data = {"score": 1, "output": output, "tests": tests}
    try:
        texts = {id(t): safe_text.unicode_json(t) for t, given in zip(tests, given_texts) if given}
        whole = safe_text.json_for_terminal(data)
    except ValueError:
        return
    assert safe_text.json_for_terminal(data, texts, ("tests",)) == whole
