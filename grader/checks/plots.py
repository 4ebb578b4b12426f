"""What the HTML report plots, gathered from the learner's own functions (in the child, like checks).

Each gatherer is planned like a check: it asks the reference (grader.judging.expected) for the curves it
draws beside the learner's, yields the learner calls, and returns plain data: the learner's values
(None where a call gave no usable value) and the reference's, so the renderer can fall back to the
reference and say so. In a handout the reference curves are replayed from the release's check data.
Nothing here draws; grader/render/html.py does, from this data only.
"""

from __future__ import annotations

import numpy as np

from grader.boundary.wire import Array, Fn, call
from grader.judging.compare import value_problem
from grader.judging.expected import reference


def _value(returned, shape):
    """The returned array if it has the expected shape, else None."""
    if value_problem(returned, shape, "") is not None:
        return None
    return returned.as_array().tolist()


def _list(value) -> list:
    return np.asarray(value, dtype=float).tolist()


def ch00_mean_shift(ctx):
    ref = reference("ch00")
    sigmas = [0.25, 0.5, 0.75, 1.0, 1.25, 1.5]
    expected = [ref.mean_shift((3, 4), s, 20000, 7) for s in sigmas]
    got = yield [call("mean_shift", (3, 4), s, 20000, 7) for s in sigmas]
    return {"sigma": sigmas, "learner": [_value(g, ()) for g in got], "reference": expected, "r": 5.0}


def ch01_tangent(ctx):
    ref = reference("ch01")
    xs = np.linspace(0.5, 9.0, 60)
    deltas = np.geomspace(0.05, 4.0, 12)
    line_ref = _list(ref.tangent_of("sqrt", "sqrt_prime", 4.0, xs))
    error_ref = _list(ref.error_of("sqrt", "sqrt_prime", 4.0, 4.0 + deltas))
    got = yield {"line": call("tangent_line", Fn("sqrt"), Fn("sqrt_prime"), 4.0, Array(xs)),
                 "error": call("linearization_error", Fn("sqrt"), Fn("sqrt_prime"), 4.0, Array(4.0 + deltas))}
    return {"x": xs.tolist(), "f": np.sqrt(xs).tolist(), "a": 4.0,
            "line": _value(got["line"], xs.shape), "line_ref": line_ref,
            "delta": deltas.tolist(), "error": _value(got["error"], deltas.shape), "error_ref": error_ref}


def ch02_gradients(ctx):
    ref = reference("ch02")
    points = [(r * np.cos(t), r * np.sin(t)) for r in (0.8, 1.6, 2.4) for t in np.linspace(0, 2 * np.pi, 8, endpoint=False)]
    expected = [_list(ref.bowl_gradient(x, y)) for x, y in points]
    got = yield [call("bowl_gradient", float(x), float(y)) for x, y in points]
    return {"points": [list(p) for p in points], "learner": [_value(g, (2,)) for g in got], "reference": expected}


def _circle(center, radius: float, count: int) -> list:
    return [(center[0] + radius * np.cos(a), center[1] + radius * np.sin(a)) for a in np.linspace(0, 2 * np.pi, count)]


def ch03_circle(ctx):
    ref = reference("ch03")
    r, theta, radius = 2.0, 0.8, 0.15
    jacobian, center = _list(ref.polar_to_cartesian_jacobian(r, theta)), _list(ref.polar_to_cartesian(r, theta))
    image = [_list(ref.polar_to_cartesian(*p)) for p in _circle((r, theta), radius, 100)]
    got = yield call("polar_to_cartesian_jacobian", r, theta)
    return {"r": r, "theta": theta, "radius": radius, "learner": _value(got, (2, 2)), "reference": jacobian,
            "center": center, "image": image}


def ch04_pipeline(ctx):
    ref = reference("ch04")
    r, theta, radius = 1.5, 0.9, 0.05
    jacobian, center = _list(ref.pipeline_jacobian(r, theta)), _list(ref.pipeline_forward(r, theta))
    image = [_list(ref.pipeline_forward(*p)) for p in _circle((r, theta), radius, 60)]
    got = yield call("pipeline_jacobian", r, theta)
    return {"point": [r, theta], "radius": radius, "learner": _value(got, (2, 2)), "reference": jacobian,
            "image": image, "center": center}


LIDAR_POSE = (5.0, 3.0, 0.6)  # px, py, phi of the robot that scans the room (apart from the scan as seen)
ROOM = (-1.5, 3.0, -1.0, 2.0)  # the room's walls in the robot's frame: x from -1.5 to 3, y from -1 to 2


def _room_range(theta: float) -> float:
    """The range at which a ray from the lidar at angle theta meets the room's walls (the scan's input)."""
    c, s = np.cos(theta), np.sin(theta)
    x_low, x_high, y_low, y_high = ROOM
    hits = [wall / c for wall in (x_low, x_high) if c and wall / c > 0] + \
           [wall / s for wall in (y_low, y_high) if s and wall / s > 0]
    return float(min(hits))


def ch04_lidar_world(ctx):
    """A lidar scan of a room, as the lidar sees it, and moved into the world frame by the learner's lidar_to_world
    (the reference's in its place where the learner's gives nothing usable)."""
    ref = reference("ch04")
    scan = [(_room_range(t), float(t)) for t in np.linspace(-np.pi, np.pi, 48, endpoint=False)]
    local = [_list(ref.polar_to_cartesian(r, t)) for r, t in scan]
    world = [_list(ref.lidar_to_world(r, t, LIDAR_POSE)) for r, t in scan]
    got = yield [call("lidar_to_world", r, t, LIDAR_POSE) for r, t in scan]
    learner = [_value(g, (2,)) for g in got]
    return {"plot": "lidar_world", "pose": list(LIDAR_POSE), "local": local,
            "learner": None if any(v is None for v in learner) else learner, "reference": world}


def ch05_error_vs_h(ctx):
    ref = reference("ch05")
    hs = np.geomspace(1e-13, 1e-1, 25)
    laws = [ref.difference_law("sin", 1.0, float(h)) for h in hs]
    exact = laws[0]["exact"]
    got = yield {"forward": [call("forward_difference", Fn("sin"), 1.0, float(h)) for h in hs],
                 "central": [call("central_difference", Fn("sin"), 1.0, float(h)) for h in hs]}

    def errors(values):
        if any(v is None for v in values):
            return None
        return [abs(v - exact) for v in values]

    return {"h": hs.tolist(), "forward": errors([_value(g, ()) for g in got["forward"]]),
            "central": errors([_value(g, ()) for g in got["central"]]),
            "forward_ref": [abs(law["forward_value"] - exact) for law in laws],
            "central_ref": [abs(law["central_value"] - exact) for law in laws]}


def ch06_bearing_sensitivity(ctx):
    ref = reference("ch06")
    ranges = np.geomspace(0.5, 20.0, 30)
    theta, sigma = 0.7, 0.5
    points = [(float(r * np.cos(theta)), float(r * np.sin(theta))) for r in ranges]
    expected = [float(np.sqrt(ref.measurement_covariance(x, y, sigma)[1, 1])) for x, y in points]
    got = yield [call("measurement_covariance", x, y, sigma) for x, y in points]
    learner = [_value(g, (2, 2)) for g in got]
    return {"r": ranges.tolist(), "sigma": sigma,
            "learner": None if any(v is None for v in learner) else [float(np.sqrt(max(v[1][1], 0))) for v in learner],
            "reference": expected}


def ch07_ellipse(ctx):
    ref = reference("ch07")
    state, v, omega, dt = [0.0, 0.0, np.pi / 6], 2.0, 0.5, 0.5
    P = np.diag([0.04, 0.02, 0.09])
    F = ref.F_jacobian(state, v, omega, dt)
    P_new, mean_new = ref.propagate_covariance(P, F), ref.motion_model(state, v, omega, dt)
    got = yield {"F": call("F_jacobian", state, v, omega, dt), "P": call("propagate_covariance", Array(P), Array(F))}
    return {"P": P.tolist(), "F": _value(got["F"], (3, 3)), "P_new": _value(got["P"], (3, 3)),
            "F_ref": _list(F), "P_new_ref": _list(P_new), "mean_new": _list(mean_new)}


def ch08_clouds(ctx):
    """The cloud: reference samples measured by the learner's measure_samples; the ellipse: the learner's
    linearized_measurement_cov (each with the reference's in its place where the learner's gives nothing)."""
    ref = reference("ch08")
    cases = {"far": (3.0, 4.0), "close": (0.3, 0.2)}
    sigma, n = 0.8, 500
    planned = {}
    for name, (x, y) in cases.items():
        samples = ref.cloud([x, y], sigma, n, 11)
        bearing = float(np.arctan2(y, x))
        planned[name] = (samples, bearing, ref.measure_samples(samples, bearing),
                         ref.linearized_measurement_cov(x, y, sigma), ref.range_bearing(x, y))
    got = yield {name: {"z": call("measure_samples", Array(planned[name][0]), planned[name][1]),
                        "cov": call("linearized_measurement_cov", x, y, sigma)} for name, (x, y) in cases.items()}
    out = {"sigma": sigma}
    for name, (x, y) in cases.items():
        _, _, z_ref, cov_ref, center = planned[name]
        z = _value(got[name]["z"], (n, 2))
        out[name] = {"point": [x, y], "z": z if z is not None else _list(z_ref), "z_is_reference": z is None,
                     "cov": _value(got[name]["cov"], (2, 2)), "cov_ref": _list(cov_ref), "center": _list(center)}
    return out


def ch09_hessian(ctx):
    ref = reference("ch09")
    point = [1.0, 2.0]
    hessian = _list(ref.hessian_of("hessian_twin_vec", point))
    kind_ref = ref.classify_critical_point(np.array(hessian))
    got = yield {"H": call("hessian_fd", Fn("hessian_twin_vec"), point),
                 "kind": call("classify_critical_point", Array(hessian))}
    return {"H": _value(got["H"], (2, 2)), "H_ref": hessian, "kind": got["kind"].text, "kind_ref": kind_ref}


PLOTS = {
    "ch00": [("mean_shift", ch00_mean_shift)],
    "ch01": [("tangent", ch01_tangent)],
    "ch02": [("gradients", ch02_gradients)],
    "ch03": [("circle", ch03_circle)],
    "ch04": [("pipeline", ch04_pipeline), ("lidar_world", ch04_lidar_world)],
    "ch05": [("error_vs_h", ch05_error_vs_h)],
    "ch06": [("bearing_sensitivity", ch06_bearing_sensitivity)],
    "ch07": [("ellipse", ch07_ellipse)],
    "ch08": [("clouds", ch08_clouds)],
    "ch09": [("hessian", ch09_hessian)],
}
