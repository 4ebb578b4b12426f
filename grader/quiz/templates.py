"""What learners see of a question bank (never a key): the answer templates in exercises/answers/,
the questions of `grade quiz chNN --show` with one learner's numbers and option letters, and, made
from the keys, the reference answers in solutions/answers/ (learner 'reference').

Format hints show the syntax of an answer with examples in backticks; no example is a right or a
known wrong answer of its question (tests/quiz/test_templates_hints.py), and letter answers have no example
at all, since every letter is right for some learner.
"""

from __future__ import annotations

import textwrap
from pathlib import Path

from grader.quiz import bank

REFERENCE_LEARNER = "reference"
WIDTH = 94

FORMATS = {
    "choice": "the letter of one option",
    "multi": "the letters of every true statement, separated by commas",
    "numeric": "a number, e.g. `-40` or `1/500`",
    "vector": "numbers separated by commas, e.g. `12, -0.5`",
    "matrix": "rows in brackets, e.g. `[[2, -1], [0.5, 3]]`",
    "symbolic": "an expression, e.g. `(x - 2*y)/sqrt(x^2 + 1)`",
}


def hint(question: bank.Question) -> str:
    """The question's answer format: its own `format`, else the default of its kind."""
    return question.answer_format or FORMATS[question.kind]


def template(chapter: str) -> str:
    """The learner's empty answer file of `chapter`: every question with its prompt (numbers as
    <name>), its options as bullets without letters (letters differ per learner) and its format."""
    lines = [f"# Quiz answers for {chapter}. Fill in each answer after the colon; quote answers",
             "# that contain a colon or start with [ if YAML complains. Set your learner id in learner.yaml first:",
             f"# `grade quiz {chapter} --show` then prints the questions with your own numbers and your own",
             "# letters for the options (both differ per learner id).", ""]
    for question in bank.questions(chapter):
        prompt = question.prompt
        for name in question.params:
            prompt = prompt.replace("{" + name + "}", f"<{name}>")
        lines.extend("# " + line for line in textwrap.wrap(prompt, WIDTH))
        if question.params:
            lines.append(f"#   (your own numbers for <{'>, <'.join(question.params)}>: grade quiz {chapter} --show)")
        for option in question.options.values():
            lines.extend(textwrap.wrap(f"- {option}", WIDTH, initial_indent="#   ", subsequent_indent="#     "))
        if question.options:
            lines.append(f"#   (your letters for these options: grade quiz {chapter} --show)")
        lines.append(f"# format: {hint(question)}")
        lines.append(f"{question.id}:")
        lines.append("")
    return "\n".join(lines)


def show_text(chapters: list[str], root: Path, package: str, learner: str | None) -> str:
    """`grade quiz CHAPTER... --show`: the questions with this learner's numbers and option letters."""
    from grader.chapters import BY_ID
    from grader.quiz import answers_dir, learner_id

    who, source = learner_id(answers_dir(root, package), learner, package)
    lines = [f"Questions for learner {who} (from {source}); answer in {package}/answers/chNN.yaml", ""]
    for chapter in chapters:
        lines.append(f"{chapter}  {BY_ID[chapter].title}")
        for question in bank.questions(chapter):
            worth = f"{question.points:g} point{'' if question.points == 1 else 's'}"
            lines.append(f"  [{question.id}] ({question.kind}, {worth})")
            lines.append("    " + question.text_for(question.values_for(who, chapter)).replace("\n", "\n    "))
            lines.extend(f"      {letter}) {question.options[canonical]}"
                         for letter, canonical in question.lettering(who, chapter).items())
            lines.append(f"    format: {hint(question)}")
        lines.append("")
    return "\n".join(lines) + "\n"


def reference_answers(chapter: str, learner: str = REFERENCE_LEARNER) -> str:
    """The reference answers file of a chapter for `learner` (solutions/answers/chNN.yaml), with
    that learner's numbers and option letters."""
    import json

    import numpy as np

    from grader.quiz.judge import right_answer, shown_key

    keys = bank.keys(chapter)
    lines = [f"# Reference answers for {chapter}, learner id '{learner}' (see learner.yaml).",
             "# Made by grader.quiz.templates.reference_answers from the keys."]
    for question in bank.questions(chapter):
        values = question.values_for(learner, chapter)
        key = keys[question.id]
        value = right_answer(question, key, key.value_for(chapter, values), values)
        value = shown_key(question, value, question.lettering(learner, chapter))
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
