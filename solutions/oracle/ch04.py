"""Chapter 4's expected values: the two-stage pipeline, and the chain rule on catalogue maps with
its usual slips (the check names the slip a wrong answer matches)."""

from __future__ import annotations

import numpy as np

from grader.catalogue import CALLABLES
from solutions.ch03_jacobian import polar_to_cartesian
from solutions.ch04_chain_rule import compose_jacobian, g_stage


def pipeline_forward(r, theta) -> np.ndarray:
    """g_stage(polar_to_cartesian(r, theta))."""
    return g_stage(polar_to_cartesian(r, theta))


def compose_candidates(f: str, jac_f: str, jac_g: str, x) -> dict:
    """The right composed Jacobian of catalogue maps at x, and what the usual slips give instead."""
    f, jac_f, jac_g = CALLABLES[f], CALLABLES[jac_f], CALLABLES[jac_g]
    x = np.asarray(x, dtype=float)
    jf, jg_at_fx, jg_at_x = jac_f(x), jac_g(f(x)), jac_g(x)
    return {"right": compose_jacobian(f, jac_f, jac_g, x), "order": jf @ jg_at_fx, "at_x": jg_at_x @ jf,
            "at_x_and_order": jf @ jg_at_x, "elementwise": jg_at_fx * jf}





def pipeline_mistakes(r, theta) -> dict:
    """What the usual chain-rule slips give for the two-stage pipeline."""
    from solutions.ch03_jacobian import polar_to_cartesian_jacobian
    from solutions.ch04_chain_rule import g_jacobian

    inner, outer = polar_to_cartesian_jacobian(r, theta), g_jacobian(polar_to_cartesian(r, theta))
    return {"order": inner @ outer, "at_x": g_jacobian([r, theta]) @ inner}


__all__ = ["compose_candidates", "pipeline_forward", "pipeline_mistakes", "polar_to_cartesian"]
