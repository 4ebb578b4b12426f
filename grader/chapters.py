"""The lesson's ten chapters: id, module file name and title. The one table everything else uses."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class ChapterInfo:
    id: str
    module: str
    title: str


CHAPTERS: tuple[ChapterInfo, ...] = (
    ChapterInfo("ch00", "ch00_range_sensor", "The range-sensor problem"),
    ChapterInfo("ch01", "ch01_tangent_line", "Tangent lines"),
    ChapterInfo("ch02", "ch02_gradient", "Gradients"),
    ChapterInfo("ch03", "ch03_jacobian", "The Jacobian"),
    ChapterInfo("ch04", "ch04_chain_rule", "The chain rule in matrix form"),
    ChapterInfo("ch05", "ch05_finite_differences", "Numerical vs analytic Jacobians"),
    ChapterInfo("ch06", "ch06_measurement", "The range-bearing measurement Jacobian H"),
    ChapterInfo("ch07", "ch07_dynamics", "The motion-model Jacobian F and covariance propagation"),
    ChapterInfo("ch08", "ch08_lab", "Linearization lab: Monte Carlo cloud vs linearized ellipse"),
    ChapterInfo("ch09", "ch09_choose_your_tool", "Choose your tool"),
)

BY_ID = {c.id: c for c in CHAPTERS}


def resolve(name: str) -> ChapterInfo:
    """'ch06', '6', '06' or 'ch6' -> the chapter; KeyError with the valid names otherwise."""
    text = name.strip().lower()
    digits = text[2:] if text.startswith("ch") else text
    if digits.isdigit() and f"ch{int(digits):02d}" in BY_ID:
        return BY_ID[f"ch{int(digits):02d}"]
    raise KeyError(f"unknown chapter {name!r}; choose one of {', '.join(BY_ID)} (or a number 0-9, or 'all')")
