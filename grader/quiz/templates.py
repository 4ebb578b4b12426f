"""The learner's answer template of a chapter, made from its question bank (no keys in it)."""

from __future__ import annotations

import textwrap
from pathlib import Path

from grader.quiz import bank

REFERENCE_LEARNER = "reference"

FORMATS = {
    "choice": "one letter, e.g. b",
    "multi": "the letters of every true statement, e.g. a, c",
    "numeric": "a number, e.g. 0.6 or 3/5",
    "vector": "numbers separated by commas, e.g. 4, 1",
    "matrix": "rows in brackets, e.g. [[0.6, 0.8], [-0.16, 0.12]]",
    "symbolic": "an expression, e.g. x/sqrt(x^2 + y^2)",
}


def template(chapter: str) -> str:
    lines = [f"# Quiz answers for {chapter}. Fill in each answer after the colon; quote answers",
             f"# that contain a colon or start with [ if YAML complains. `grade quiz {chapter} --show` prints the questions",
             "# with your own numbers (parametrised questions differ per learner id).", ""]
    for question in bank.questions(chapter):
        prompt = question.prompt
        for name in question.params:
            prompt = prompt.replace("{" + name + "}", f"<{name}>")
        lines.extend("# " + line for line in textwrap.wrap(prompt, 94))
        if question.params:
            lines.append(f"#   (your own numbers for <{'>, <'.join(question.params)}>: grade quiz {chapter} --show)")
        for letter, option in question.options.items():
            lines.extend(textwrap.wrap(f"{letter}) {option}", 94, initial_indent="#   ",
                                       subsequent_indent="#      "))
        lines.append(f"# format: {question.answer_format or FORMATS[question.kind]}")
        lines.append(f"{question.id}:")
        lines.append("")
    return "\n".join(lines)


def reference_answers(chapter: str, learner: str = REFERENCE_LEARNER) -> str:
    """The reference answers file of a chapter for `learner` (solutions/answers/chNN.yaml)."""
    import json

    import numpy as np

    keys = bank.keys(chapter)
    lines = [f"# Reference answers for {chapter}, learner id '{learner}' (see learner.yaml).",
             "# Made by grader.quiz.templates.reference_answers from the keys."]
    for question in bank.questions(chapter):
        value = keys[question.id].value_for(chapter, question.values_for(learner, chapter))
        value = np.round(np.asarray(value, dtype=float), 8).tolist() if not isinstance(value, (str, list)) else value
        lines.append(f"{question.id}: {json.dumps(value)}")
    return "\n".join(lines) + "\n"


LEARNER_TEMPLATE = """\
# Your learner id (e.g. your login). Parametrised quiz questions draw your own numbers from it;
# `grade quiz chNN --show` prints them. `grade ... --learner ID` overrides this file.
learner:
"""


def write_all(root: Path) -> list[Path]:
    """Regenerate the shipped files from the banks and keys: the learner templates
    (exercises/answers/) and the reference answers (solutions/answers/, learner 'reference')."""
    from grader.chapters import CHAPTERS

    written = []
    for folder, make in (("exercises", template), ("solutions", reference_answers)):
        out = root / folder / "answers"
        out.mkdir(parents=True, exist_ok=True)
        for info in CHAPTERS:
            path = out / f"{info.id}.yaml"
            path.write_text(make(info.id), encoding="utf-8")
            written.append(path)
    (root / "exercises" / "answers" / "learner.yaml").write_text(LEARNER_TEMPLATE, encoding="utf-8")
    (root / "solutions" / "answers" / "learner.yaml").write_text(
        f"# Whose per-learner quiz numbers the reference answers are for.\nlearner: {REFERENCE_LEARNER}\n",
        encoding="utf-8")
    return written


if __name__ == "__main__":  # python -m grader.quiz.templates
    for written_path in write_all(bank.QUIZ_DIR.parent):
        print(written_path)
