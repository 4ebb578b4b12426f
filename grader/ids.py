"""The one rule for learner ids: any text is an id, kept exactly as given, but what cannot name a learner's
folder or be shown safely (empty, '.' or '..', a path separator, a control or bidirectional character). grade
batch, grade submit, learner.yaml and Gradescope's metadata all ask it."""

from __future__ import annotations

import unicodedata

_BIDI = frozenset("\u200e\u200f\u202a\u202b\u202c\u202d\u202e\u2066\u2067\u2068\u2069")


def id_problem(learner: str) -> str | None:
    """Why `learner` cannot be a learner id (empty, '.' or '..', a path separator, a control
    character), or None. Any other text is an id, kept exactly as given."""
    if not learner.strip():
        return "is empty"
    if learner in (".", ".."):
        return f"is {learner!r}"
    if "/" in learner or "\\" in learner:
        return "contains a path separator (/ or \\)"
    for ch in learner:
        if ch in _BIDI or unicodedata.category(ch) in ("Cc", "Cs", "Zl", "Zp"):
            return f"contains the control character U+{ord(ch):04X}"
    return None
