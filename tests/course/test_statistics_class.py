"""The class summary of a real batch of 76 (right, buggy and hostile submissions, every chapter, quizzes answered,
some answers wrong, some chapters' quizzes left blank): the course has no bad item, so few items are flagged, each
with its evidence; blank answers are counted apart; the page shows no Python None; it says it is a first run.

The buggy code is the hand-written corpus of realistic slips (benchmarks/realistic_slips.py), the wrong quiz answers
what learners write (another option, a sign dropped, a transpose, a reciprocal, one fact of several missed)."""

from __future__ import annotations

import html
import json
import random
import re
import shutil
import sys
from pathlib import Path

import pytest
import yaml

from grader.chapters import CHAPTERS
from grader.quiz.templates import reference_answers
from tests.support import REPO, build_submission, replace_functions, run_grade

sys.path.insert(0, str(REPO / "benchmarks"))
from realistic_slips import SLIPS  # noqa: E402

HOSTILE = [  # (module, function, source): what a hostile or broken submission does to one function
    ("ch06_measurement", "H_jacobian", "def H_jacobian(x, y):\n    import sys\n    sys.exit(1)\n"),
    ("ch06_measurement", "H_jacobian", "def H_jacobian(x, y):\n    return 'H'\n"),
    ("ch02_gradient", "example_gradient", "def example_gradient(x, y):\n    return np.array([np.nan, np.nan])\n"),
    ("ch05_finite_differences", "best_step", "def best_step(f, fprime, x, hs):\n    import os\n    os._exit(3)\n"),
    ("ch03_jacobian", "polar_to_cartesian_jacobian",
     "def polar_to_cartesian_jacobian(r, theta):\n    print('\\x1b[2J<script>alert(1)</script>' * 50)\n"
     "    raise RuntimeError('=HYPERLINK(\"http://x\")')\n"),
    ("ch07_dynamics", "propagate_covariance", "def propagate_covariance(P, F, Q=None):\n"
                                              "    return open('/etc/passwd').read()\n"),
]


def _wrong(value):
    """A wrong answer as a learner writes it, from the right one."""
    if isinstance(value, str) and len(value) == 1:
        return "abcde"[("abcde".index(value) + 1) % 5]
    if isinstance(value, str):
        return value[1:] if value.startswith("-") else f"-({value})"
    if isinstance(value, list) and value and isinstance(value[0], str):
        return value[:-1] if len(value) > 1 else [_wrong(value[0])]
    if isinstance(value, list):
        return [list(row) for row in zip(*value)] if isinstance(value[0], list) and len(value) > 1 else value + [0]
    return round(1 / value, 6) if value else 1.0


def make_class(folder: Path, seed: int = 76) -> dict[str, str]:
    """76 submissions in `folder`: 16 right, 48 buggy (1 to 3 realistic slips each, and about as many quiz answers
    wrong as slips; one in six leaves a chapter's quiz blank), 12 hostile. Returns each learner's kind."""
    draw = random.Random(seed)
    slips = sorted(SLIPS.values(), key=lambda s: (s[0], s[1], s[2]))
    kinds = {}
    for i in range(76):
        kind = "right" if i < 16 else "buggy" if i < 64 else "hostile"
        learner = f"{kind}-{i:02d}"
        kinds[learner] = kind
        chosen = (draw.sample(slips, draw.randint(1, 3)) if kind == "buggy" else
                  [HOSTILE[i % len(HOSTILE)]] if kind == "hostile" else [])
        by_module: dict[str, dict[str, str]] = {}
        for module, function, source, *_ in chosen:
            by_module.setdefault(module, {})[function] = source
        root = build_submission(folder / learner, {m: replace_functions(m, f) for m, f in by_module.items()})
        answers = root / "exercises" / "answers"
        answers.mkdir()
        (answers / "learner.yaml").write_text(f"learner: {learner}\n", encoding="utf-8")
        wrong_answers = 0 if kind == "right" else draw.randint(len(chosen), 4 * len(chosen))
        blank = draw.choice([c.id for c in CHAPTERS]) if kind == "buggy" and i % 6 == 0 else None
        keyed = [(c.id, q) for c in CHAPTERS for q in yaml.safe_load(reference_answers(c.id, learner)) or {}]
        wrong = set(draw.sample(keyed, min(wrong_answers, len(keyed))))
        for chapter in CHAPTERS:
            if chapter.id == blank:
                continue
            values = yaml.safe_load(reference_answers(chapter.id, learner)) or {}
            values = {q: _wrong(v) if (chapter.id, q) in wrong else v for q, v in values.items()}
            (answers / f"{chapter.id}.yaml").write_text(yaml.safe_dump(values, sort_keys=False), encoding="utf-8")
    return kinds


@pytest.fixture(scope="module")
def class_of_76(tmp_path_factory) -> tuple[dict, str, dict]:
    folder = tmp_path_factory.mktemp("class76")
    kinds = make_class(folder / "submissions")
    out = folder / "out"
    done = run_grade("batch", folder / "submissions", "--out", out, "--no-html", timeout=1200)
    assert (out / "summary.json").exists(), done.stdout[-2000:] + done.stderr[-2000:]
    return (json.loads((out / "summary.json").read_text(encoding="utf-8")),
            (out / "summary.html").read_text(encoding="utf-8"), kinds)


@pytest.mark.slow
def test_a_class_of_76_right_buggy_and_hostile_flags_few_items_each_with_its_evidence(class_of_76):
    summary, page, kinds = class_of_76
    found = summary["statistics"]
    assert summary["learners"]["graded"] == 76 and not found["rough"]
    flagged = [item for item in found["items"] if item["flags"]]
    assert len(flagged) <= 3, [(i["id"], i["flags"]) for i in flagged]  # the course has no bad item
    for item in flagged:
        assert len(item["evidence"]) == len(item["flags"])
        assert all("confidence interval" in flag or "Holm" in flag for flag in item["flags"])
    assert not any(f.startswith("very easy") for i in found["items"] if i["kind"] == "code" for f in i["flags"])


@pytest.mark.slow
def test_a_class_of_76_counts_blank_answers_apart_and_shows_no_none(class_of_76):
    summary, page, kinds = class_of_76
    items = summary["statistics"]["items"]
    blank = [i for i in items if i["unanswered"]]
    assert blank and all(i["learners"] + i["unanswered"] == 76 for i in blank if i["kind"] == "quiz")
    assert "left it blank" in page
    assert ">None<" not in page and not re.search(r"\bNone\b(?! \()", re.sub(r"<small>.*?</small>", "", page))
    assert summary["first_run"] and "the history's first run: 76 learners graded first" in html.unescape(page)
    messages = summary["messages"]
    assert messages and all(m["check"].startswith(m["chapter"] + "/") for m in messages)
    assert not any(m["message"].endswith(":") for m in messages)  # a lead-in always with what follows it
    rates = page[page.index("id='failure-rates'"):page.index("id='options'")]
    first = rates.split("</tr>", 2)[1]  # no question left blank by all who saw it opens the table at 100%
    assert "/0<" not in rates and "100%" not in first


if __name__ == "__main__":  # python tests/course/test_statistics_class.py FOLDER: the class, to look at by hand
    target = Path(sys.argv[1])
    shutil.rmtree(target, ignore_errors=True)
    print(make_class(target))
