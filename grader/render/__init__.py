"""Renderers: each turns a Report (grader.model) into one output format, reading only the model."""


def plural(count: float, word: str, words: str | None = None) -> str:
    """'1 point', '2 points', '0.5 points', '1 hidden check'."""
    return f"{count:g} {word if count == 1 else (words or word + 's')}"
