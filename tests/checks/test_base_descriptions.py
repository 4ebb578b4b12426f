"""A check's description (grader.checks.base: its docstring's first paragraph) is what every output shows: a whole
sentence, never one cut at the docstring's line break."""

from __future__ import annotations

import re

import pytest

from grader import checks
from grader.chapters import CHAPTERS

# Words a sentence does not end with: it goes on after them.
_GOES_ON = {"a", "an", "the", "for", "of", "to", "in", "on", "at", "by", "with", "from", "into", "onto", "as",
            "than", "and", "or", "nor", "but", "via", "per", "between", "within", "about", "its", "their", "your",
            "this", "these", "whose", "which", "where", "when", "if", "is", "are"}
_ALLOWED_LAST = {"is"}  # "..., where no finite difference is": a sentence that ends on its verb


def cut_short(text: str) -> str | None:
    """Why `text` is not a whole sentence, or None when it is."""
    if not text or text != " ".join(text.split()):
        return "empty, or not on one line"
    stack = []
    for ch in text:
        if ch in "([":
            stack.append(ch)
        elif ch in ")]":  # either closes either: a half-open interval [-pi, pi)
            if not stack:
                return f"an unopened {ch!r}"
            stack.pop()
    if stack:
        return f"an unclosed {stack[-1]!r}"
    if text.count('"') % 2 or text.count("`") % 2:
        return "an unclosed quote"
    if text[-1] in ",;:-=+*/(":
        return f"ends with {text[-1]!r}"
    last = re.findall(r"[A-Za-z]+", text)[-1:]
    if last and text.endswith(last[0]) and last[0] in _GOES_ON - _ALLOWED_LAST:
        return f"ends with {last[0]!r}"
    return None


@pytest.mark.parametrize("truncated", [
    "H accepts integers and numpy scalars: H_jacobian(a, b) and H_jacobian(np.int64(a), b) at integers drawn for",
    "F_jacobian takes the state as a list, a numpy array or an integer array (an integer state drawn for this",
    "gradient_fd converts integer x to float first: integer points (drawn for this run) as an int64 array, a",
    "H at the lesson's point (3, 4",
    "range_reading(3, 4) is 5,",
])
def test_a_description_cut_short_is_caught(truncated):
    assert cut_short(truncated) is not None


def test_every_checks_description_is_a_whole_sentence():
    cut = [f"{info.id}/{check.id}: {why}: {check.description!r}" for info in CHAPTERS
           for check in checks.load(info.id).checks if (why := cut_short(check.description))]
    assert cut == []


def test_a_docstring_wrapped_over_lines_gives_its_whole_first_paragraph():
    from grader.checks.base import first_paragraph

    doc = """F_jacobian takes the state as a list, a numpy array or an integer array (an integer state drawn for this
    run)

    What the check does, for whoever reads the code."""
    assert first_paragraph(doc) == ("F_jacobian takes the state as a list, a numpy array or an integer array (an "
                                    "integer state drawn for this run)")
    assert first_paragraph("H at (3, 4)\n    \n    more") == "H at (3, 4)"
    assert [c.description for c in checks.load("ch07").checks if c.id == "F_integer_and_array_states"] == [
        "F_jacobian takes the state as a list, a numpy array or an integer array (an integer state drawn for this run)"]
