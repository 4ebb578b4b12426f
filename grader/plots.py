"""What the HTML report plots, gathered from the learner's own functions (in the child, like checks).

Each gatherer yields learner calls and returns plain data: the learner's values (None where a call
gave no usable value) and the reference values, so the renderer can fall back to the reference and
say so. Nothing here draws; grader/render/html.py does, from this data only.
"""

from __future__ import annotations

import numpy as np

from grader.catalogue import CALLABLES
from grader.compare import value_problem
from grader.wire import Array, Fn, Rng, call


def _value(returned, shape):
    """The returned array if it has the expected shape, else None."""
    if value_problem(returned, shape, "") is not None:
        return None
    return returned.as_array().tolist()


def ch00_mean_shift(ctx):
    import solutions.ch00_range_sensor as ref

    sigmas = [0.25, 0.5, 0.75, 1.0, 1.25, 1.5]
    got = yield [call("mean_shift", (3, 4), s, 20000, 7) for s in sigmas]
    return {"sigma": sigmas, "learner": [_value(g, ()) for g in got],
            "reference": [ref.mean_shift((3, 4), s, 20000, 7) for s in sigmas], "r": 5.0}


def ch01_tangent(ctx):
    xs = np.linspace(0.5, 9.0, 60)
    deltas = np.geomspace(0.05, 4.0, 12)
    got = yield {"line": call("tangent_line", Fn("sqrt"), Fn("sqrt_prime"), 4.0, Array(xs)),
                 "error": call("linearization_error", Fn("sqrt"), Fn("sqrt_prime"), 4.0, Array(4.0 + deltas))}
    return {"x": xs.tolist(), "f": np.sqrt(xs).tolist(), "a": 4.0,
            "line": _value(got["line"], xs.shape), "line_ref": (2.0 + 0.25 * (xs - 4.0)).tolist(),
            "delta": deltas.tolist(), "error": _value(got["error"], deltas.shape),
            "error_ref": np.abs(np.sqrt(4.0 + deltas) - 2.0 - 0.25 * deltas).tolist()}


def ch02_gradients(ctx):
    import solutions.ch02_gradient as ref

    points = [(r * np.cos(t), r * np.sin(t)) for r in (0.8, 1.6, 2.4) for t in np.linspace(0, 2 * np.pi, 8, endpoint=False)]
    got = yield [call("bowl_gradient", float(x), float(y)) for x, y in points]
    return {"points": [list(p) for p in points], "learner": [_value(g, (2,)) for g in got],
            "reference": [ref.bowl_gradient(x, y).tolist() for x, y in points]}


def ch03_circle(ctx):
    import solutions.ch03_jacobian as ref

    r, theta = 2.0, 0.8
    got = yield call("polar_to_cartesian_jacobian", r, theta)
    return {"r": r, "theta": theta, "radius": 0.15, "learner": _value(got, (2, 2)),
            "reference": ref.polar_to_cartesian_jacobian(r, theta).tolist(),
            "center": ref.polar_to_cartesian(r, theta).tolist()}


def ch04_pipeline(ctx):
    import solutions.ch04_chain_rule as ref

    r, theta = 1.5, 0.9
    got = yield call("pipeline_jacobian", r, theta)
    angles = np.linspace(0, 2 * np.pi, 60)
    radius = 0.05
    circle = [(r + radius * np.cos(a), theta + radius * np.sin(a)) for a in angles]
    image = [ref.g_stage(ref.polar_to_cartesian(*p)).tolist() for p in circle]
    return {"point": [r, theta], "radius": radius, "learner": _value(got, (2, 2)),
            "reference": ref.pipeline_jacobian(r, theta).tolist(), "image": image,
            "center": ref.g_stage(ref.polar_to_cartesian(r, theta)).tolist()}


def ch05_error_vs_h(ctx):
    hs = np.geomspace(1e-13, 1e-1, 25)
    got = yield {"forward": [call("forward_difference", Fn("sin"), 1.0, float(h)) for h in hs],
                 "central": [call("central_difference", Fn("sin"), 1.0, float(h)) for h in hs]}
    exact = np.cos(1.0)

    def errors(values):
        if any(v is None for v in values):
            return None
        return [abs(v - exact) for v in values]

    forward_ref = [(np.sin(1 + h) - np.sin(1)) / h for h in hs]
    central_ref = [(np.sin(1 + h) - np.sin(1 - h)) / (2 * h) for h in hs]
    return {"h": hs.tolist(), "forward": errors([_value(g, ()) for g in got["forward"]]),
            "central": errors([_value(g, ()) for g in got["central"]]),
            "forward_ref": [abs(v - exact) for v in forward_ref], "central_ref": [abs(v - exact) for v in central_ref]}


def ch06_bearing_sensitivity(ctx):
    import solutions.ch06_measurement as ref

    ranges = np.geomspace(0.5, 20.0, 30)
    theta, sigma = 0.7, 0.5
    got = yield [call("measurement_covariance", float(r * np.cos(theta)), float(r * np.sin(theta)), sigma)
                 for r in ranges]
    learner = [_value(g, (2, 2)) for g in got]
    return {"r": ranges.tolist(), "sigma": sigma,
            "learner": None if any(v is None for v in learner) else [float(np.sqrt(max(v[1][1], 0))) for v in learner],
            "reference": [float(np.sqrt(ref.measurement_covariance(r * np.cos(theta), r * np.sin(theta), sigma)[1, 1]))
                          for r in ranges]}


def ch07_ellipse(ctx):
    import solutions.ch07_dynamics as ref

    state, v, omega, dt = [0.0, 0.0, np.pi / 6], 2.0, 0.5, 0.5
    P = np.diag([0.04, 0.02, 0.09])
    F = ref.F_jacobian(state, v, omega, dt)
    got = yield {"F": call("F_jacobian", state, v, omega, dt), "P": call("propagate_covariance", Array(P), Array(F))}
    return {"P": P.tolist(), "F": _value(got["F"], (3, 3)), "P_new": _value(got["P"], (3, 3)),
            "F_ref": F.tolist(), "P_new_ref": ref.propagate_covariance(P, F).tolist(),
            "mean_new": ref.motion_model(state, v, omega, dt).tolist()}


def ch08_clouds(ctx):
    import solutions.ch08_lab as ref

    cases = {"far": (3.0, 4.0), "close": (0.3, 0.2)}
    sigma, n = 0.8, 500
    got = yield {name: {"samples": call("sample_positions", list(p), sigma, n, Rng(11)),
                        "cov": call("linearized_measurement_cov", p[0], p[1], sigma)} for name, p in cases.items()}
    out = {"sigma": sigma}
    for name, (x, y) in cases.items():
        samples = _value(got[name]["samples"], (n, 2))
        fallback = samples is None
        if fallback:
            samples = ref.sample_positions([x, y], sigma, n, np.random.default_rng(11)).tolist()
        z = ref.measure_samples(np.asarray(samples), np.arctan2(y, x))
        out[name] = {"point": [x, y], "z": z.tolist(), "samples_are_reference": fallback,
                     "cov": _value(got[name]["cov"], (2, 2)),
                     "cov_ref": ref.linearized_measurement_cov(x, y, sigma).tolist(),
                     "center": [float(np.hypot(x, y)), float(np.arctan2(y, x))]}
    return out


def ch09_hessian(ctx):
    import solutions.ch09_choose_your_tool as ref

    point = [0.0, 0.0]
    got = yield {"H": call("hessian_fd", Fn("example_f_vec"), point),
                 "kind": call("classify_critical_point", [[2.0, 1.0], [1.0, 0.0]])}
    kind = got["kind"].encoded.get("text") if got["kind"].ok and got["kind"].encoded["t"] == "str" else None
    return {"H": _value(got["H"], (2, 2)), "H_ref": ref.hessian_fd(CALLABLES["example_f_vec"], point).tolist(),
            "kind": kind, "kind_ref": ref.classify_critical_point([[2.0, 1.0], [1.0, 0.0]])}


PLOTS = {
    "ch00": [("mean_shift", ch00_mean_shift)],
    "ch01": [("tangent", ch01_tangent)],
    "ch02": [("gradients", ch02_gradients)],
    "ch03": [("circle", ch03_circle)],
    "ch04": [("pipeline", ch04_pipeline)],
    "ch05": [("error_vs_h", ch05_error_vs_h)],
    "ch06": [("bearing_sensitivity", ch06_bearing_sensitivity)],
    "ch07": [("ellipse", ch07_ellipse)],
    "ch08": [("clouds", ch08_clouds)],
    "ch09": [("hessian", ch09_hessian)],
}
