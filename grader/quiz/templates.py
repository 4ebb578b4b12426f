"""The learner's answer template of a chapter, made from its question bank (no keys in it)."""

from __future__ import annotations

import textwrap

from grader.quiz import bank

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
             "# that contain a colon or start with [ if YAML complains. `grade quiz "
             f"{chapter} --show` prints the questions",
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


def reference_answers(chapter: str, learner: str = "reference") -> str:
    """The reference answers file of a chapter for `learner` (solutions/answers/chNN.yaml)."""
    import json

    import numpy as np

    from grader.chapters import BY_ID

    keys = bank.keys(chapter)
    lines = [f"# Reference answers for {chapter}, learner id '{learner}' (see learner.yaml).",
             "# Made by grader.quiz.templates.reference_answers from the keys."]
    for question in bank.questions(chapter):
        value = keys[question.id].value_for(BY_ID[chapter].module, question.values_for(learner, chapter))
        value = np.round(np.asarray(value, dtype=float), 8).tolist() if not isinstance(value, (str, list)) else value
        lines.append(f"{question.id}: {json.dumps(value)}")
    return "\n".join(lines) + "\n"
