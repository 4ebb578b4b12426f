"""Chapter 1's expected values: the reference functions applied to catalogue callables by name."""

from __future__ import annotations

from grader.catalogue import CALLABLES
from solutions.ch01_tangent_line import linearization_error, tangent_line, taylor_error_estimate


def tangent_of(f: str, fprime: str, a, x):
    return tangent_line(CALLABLES[f], CALLABLES[fprime], a, x)


def error_of(f: str, fprime: str, a, x):
    return linearization_error(CALLABLES[f], CALLABLES[fprime], a, x)


def estimate_of(fsecond: str, a, delta):
    return taylor_error_estimate(CALLABLES[fsecond], a, delta)
