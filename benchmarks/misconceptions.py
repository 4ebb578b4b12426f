"""The misconception corpora, graded for real; prints the share named correctly and any diagnosis offered on
a right answer (there must be none).

- CODE and QUIZ: one-bug submissions and wrong quiz answers written from the catalogue of named
  mistakes, each with the mistake the grader should name (quiz keys of per-learner questions computed by
  the installed references). Target: at least 80% named.
- The generated corpus, made independently of that catalogue: every single-slip variant of each graded
  function's reference (grader.judging.mutants: a term dropped, a factor 2, a power off by one, sin for cos,
  a sign, degrees, the point of evaluation moved, integer arithmetic, mean for max, an index for its
  value, a missing normalisation, ...), each written into the reference solutions as a learner's file
  would hold it and graded through the normal pipeline on its function's checks. Counted are the
  variants some check tells from right (the others are listed); a variant is named when a failing check
  of its function names a mistake: its own sentence, an equivalent slip's (one the learner's outputs
  equal at every input), or a check's own or generic entry (they take precedence). Target: at least 90%
  named, and no diagnosis on any right submission (the references at several seeds, and the submission
  written from the contract alone, tests/fixtures/contract_submission).
- The realistic corpus (benchmarks/realistic_slips.py), written by hand from the contract and from the mistakes
  learners of such courses make, independently of both the catalogue and the mutator: SLIPS, one wrong function
  each with the words a good grader would say, and RIGHT, right functions written otherwise. Each is written
  into the reference solutions and its chapter graded through the normal pipeline. Printed per slip: caught
  (some check of its function loses points), named (a losing check of its function offers a diagnosis) and
  the diagnosis beside the expected words: whether it is the right one is for a reader to judge; then the
  totals, the collateral failures (checks of other functions) and, for RIGHT, full marks and the diagnoses
  offered (there must be none).

    python benchmarks/misconceptions.py [--corpus catalogue|generated|realistic|all] [--chapter ch05 ...] [--verbose]
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from tests.support import build_submission, replace_function  # noqa: E402

# (module, function, wrong source, the mistake name it should get)
CODE = {
    "range squared": ("ch00_range_sensor", "range_reading", """
        def range_reading(x, y):
            return float(x) ** 2 + float(y) ** 2
        """, "squared range"),
    "gap reversed": ("ch00_range_sensor", "superposition_gap", """
        def superposition_gap(p, q):
            p, q = np.asarray(p, dtype=float), np.asarray(q, dtype=float)
            return float(np.hypot(*p) + np.hypot(*q) - np.hypot(*(p + q)))
        """, "every sign"),
    "mean range, not its shift": ("ch00_range_sensor", "mean_shift", """
        def mean_shift(mean, sigma, n, seed):
            rng = np.random.default_rng(seed)
            samples = np.asarray(mean, dtype=float) + sigma * rng.standard_normal((int(n), 2))
            return float(np.mean(np.hypot(samples[:, 0], samples[:, 1])))
        """, "mean range"),
    "tangent slope at x": ("ch01_tangent_line", "tangent_line", """
        def tangent_line(f, fprime, a, x):
            xs = np.asarray(x, dtype=float)
            value = f(a) + fprime(xs) * (xs - a)
            return float(value) if np.ndim(x) == 0 else value
        """, "slope at x"),
    "error without abs": ("ch01_tangent_line", "linearization_error", """
        def linearization_error(f, fprime, a, x):
            xs = np.asarray(x, dtype=float)
            value = f(xs) - (f(a) + fprime(a) * (xs - a))
            return float(value) if np.ndim(x) == 0 else value
        """, "signed error"),
    "taylor without the half": ("ch01_tangent_line", "taylor_error_estimate", """
        def taylor_error_estimate(fsecond, a, delta):
            return float(abs(fsecond(a)) * delta ** 2)
        """, "missing 0.5"),
    "gradient entries swapped": ("ch02_gradient", "example_gradient", """
        def example_gradient(x, y):
            return np.array([float(x), 2 * float(x) + float(y)])
        """, "entries swapped"),
    "gradient as a row": ("ch02_gradient", "example_gradient", """
        def example_gradient(x, y):
            return np.array([[2 * float(x) + float(y), float(x)]])
        """, "row instead of flat"),
    "bowl coefficients swapped": ("ch02_gradient", "bowl_gradient", """
        def bowl_gradient(x, y):
            return np.array([0.5 * x + 2 * y, 2 * x + 0.5 * y], dtype=float)
        """, "entries swapped"),
    "contour along the gradient": ("ch02_gradient", "contour_direction", """
        def contour_direction(x, y):
            g = np.array([2 * x + 0.5 * y, 0.5 * x + 2 * y], dtype=float)
            if not g.any():
                raise ValueError("no direction at the origin")
            return g / np.linalg.norm(g)
        """, "normal, not tangent"),
    "tangent plane with grad at x": ("ch02_gradient", "tangent_plane", """
        def tangent_plane(f, grad, a, x):
            a, x = np.asarray(a, dtype=float), np.asarray(x, dtype=float)
            return float(f(a) + np.dot(grad(x), x - a))
        """, "gradient at x"),
    "polar J transposed": ("ch03_jacobian", "polar_to_cartesian_jacobian", """
        def polar_to_cartesian_jacobian(r, theta):
            return np.array([[np.cos(theta), np.sin(theta)], [-r * np.sin(theta), r * np.cos(theta)]])
        """, "transpose"),
    "polar J sign slip": ("ch03_jacobian", "polar_to_cartesian_jacobian", """
        def polar_to_cartesian_jacobian(r, theta):
            return np.array([[np.cos(theta), r * np.sin(theta)], [np.sin(theta), r * np.cos(theta)]])
        """, "entry sign"),
    "polar in degrees": ("ch03_jacobian", "polar_to_cartesian", """
        def polar_to_cartesian(r, theta):
            t = np.radians(theta)
            return np.array([r * np.cos(t), r * np.sin(t)], dtype=float)
        """, "degrees"),
    "area scale unsigned": ("ch03_jacobian", "area_scale", """
        def area_scale(r, theta):
            return float(abs(r))
        """, "unsigned determinant"),
    "g jacobian transposed": ("ch04_chain_rule", "g_jacobian", """
        def g_jacobian(u):
            u1, u2 = np.asarray(u, dtype=float)
            return np.array([[2 * u1, u2], [1.0, u1]])
        """, "transpose"),
    "chain order swapped": ("ch04_chain_rule", "compose_jacobian", """
        def compose_jacobian(f, jac_f, jac_g, x):
            x = np.asarray(x, dtype=float)
            return np.asarray(jac_f(x)) @ np.asarray(jac_g(f(x)))
        """, "order"),
    "outer jacobian at x": ("ch04_chain_rule", "compose_jacobian", """
        def compose_jacobian(f, jac_f, jac_g, x):
            x = np.asarray(x, dtype=float)
            return np.asarray(jac_g(x)) @ np.asarray(jac_f(x))
        """, "at_x"),
    "pipeline order swapped": ("ch04_chain_rule", "pipeline_jacobian", """
        def pipeline_jacobian(r, theta):
            p = polar_to_cartesian(r, theta)
            return polar_to_cartesian_jacobian(r, theta) @ g_jacobian(p)
        """, "order"),
    "central is forward": ("ch05_finite_differences", "central_difference", """
        def central_difference(f, x, h):
            return float((f(x + h) - f(x)) / h)
        """, "forward difference"),
    "forward is central": ("ch05_finite_differences", "forward_difference", """
        def forward_difference(f, x, h):
            return float((f(x + h) - f(x - h)) / (2 * h))
        """, "central difference"),
    "jacobian by forward differences": ("ch05_finite_differences", "jacobian_fd", """
        def jacobian_fd(f, x, h=1e-5):
            x = np.asarray(x, dtype=float)
            base = np.atleast_1d(np.asarray(f(x), dtype=float))
            columns = []
            for j in range(x.size):
                e = np.zeros_like(x)
                e[j] = h
                columns.append((np.atleast_1d(np.asarray(f(x + e), dtype=float)) - base) / h)
            return np.stack(columns, axis=1)
        """, "forward difference"),
    "jacobian half step": ("ch05_finite_differences", "jacobian_fd", """
        def jacobian_fd(f, x, h=1e-5):
            x = np.asarray(x, dtype=float)
            columns = []
            for j in range(x.size):
                e = np.zeros_like(x)
                e[j] = h / 2
                columns.append((np.atleast_1d(np.asarray(f(x + e), dtype=float))
                                - np.atleast_1d(np.asarray(f(x - e), dtype=float))) / h)
            return np.stack(columns, axis=1)
        """, "half step"),
    "one-output jacobian flat": ("ch05_finite_differences", "jacobian_fd", """
        def jacobian_fd(f, x, h=1e-5):
            x = np.asarray(x, dtype=float)
            columns = []
            for j in range(x.size):
                e = np.zeros_like(x)
                e[j] = h
                columns.append((np.asarray(f(x + e), dtype=float) - np.asarray(f(x - e), dtype=float)) / (2 * h))
            return np.squeeze(np.stack(columns, axis=-1))
        """, "flat instead of row"),
    "jacobian check without abs": ("ch05_finite_differences", "max_jacobian_error", """
        def max_jacobian_error(jac, f, x, h=1e-5):
            analytic = np.asarray(jac(np.asarray(x, dtype=float)), dtype=float)
            return float(np.max(analytic - jacobian_fd(f, x, h)))
        """, "signed difference"),
    "H transposed": ("ch06_measurement", "H_jacobian", """
        def H_jacobian(x, y):
            r2 = float(x) ** 2 + float(y) ** 2
            if r2 == 0:
                raise ValueError("r = 0")
            r = np.sqrt(r2)
            return np.array([[x / r, -y / r2], [y / r, x / r2]])
        """, "transpose"),
    "bearing row sign": ("ch06_measurement", "H_jacobian", """
        def H_jacobian(x, y):
            r2 = float(x) ** 2 + float(y) ** 2
            if r2 == 0:
                raise ValueError("r = 0")
            r = np.sqrt(r2)
            return np.array([[x / r, y / r], [y / r2, -x / r2]])
        """, "row sign"),
    "H of the sensor, not the target": ("ch06_measurement", "H_jacobian", """
        def H_jacobian(x, y):
            r2 = float(x) ** 2 + float(y) ** 2
            if r2 == 0:
                raise ValueError("r = 0")
            r = np.sqrt(r2)
            return -np.array([[x / r, y / r], [-y / r2, x / r2]])
        """, "every sign"),
    "bearing row over r": ("ch06_measurement", "H_jacobian", """
        def H_jacobian(x, y):
            r2 = float(x) ** 2 + float(y) ** 2
            if r2 == 0:
                raise ValueError("r = 0")
            r = np.sqrt(r2)
            return np.array([[x / r, y / r], [-y / r, x / r]])
        """, "bearing over r"),
    "bearing by atan": ("ch06_measurement", "range_bearing", """
        def range_bearing(x, y):
            return np.array([np.hypot(x, y), np.arctan(y / x)], dtype=float)
        """, "atan"),
    "bearing from the drone": ("ch06_measurement", "range_bearing", """
        def range_bearing(x, y):
            return np.array([np.hypot(x, y), np.arctan2(-y, -x)], dtype=float)
        """, "reversed bearing"),
    "bearing in degrees": ("ch06_measurement", "range_bearing", """
        def range_bearing(x, y):
            return np.array([np.hypot(x, y), np.degrees(np.arctan2(y, x))], dtype=float)
        """, "degrees"),
    "covariance with sigma": ("ch06_measurement", "measurement_covariance", """
        def measurement_covariance(x, y, sigma):
            H = H_jacobian(x, y)
            return float(sigma) * (H @ H.T)
        """, "sigma not squared"),
    "F without dt": ("ch07_dynamics", "F_jacobian", """
        def F_jacobian(state, v, omega, dt):
            th = float(np.asarray(state, dtype=float)[2])
            return np.array([[1.0, 0.0, -v * np.sin(th)], [0.0, 1.0, v * np.cos(th)], [0.0, 0.0, 1.0]])
        """, "missing dt"),
    "F with a fixed dt": ("ch07_dynamics", "F_jacobian", """
        def F_jacobian(state, v, omega, dt):
            th = float(np.asarray(state, dtype=float)[2])
            return np.array([[1.0, 0.0, -v * np.sin(th) * 0.1], [0.0, 1.0, v * np.cos(th) * 0.1], [0.0, 0.0, 1.0]])
        """, "fixed dt"),
    "F sign": ("ch07_dynamics", "F_jacobian", """
        def F_jacobian(state, v, omega, dt):
            th = float(np.asarray(state, dtype=float)[2])
            return np.array([[1.0, 0.0, v * np.sin(th) * dt], [0.0, 1.0, v * np.cos(th) * dt], [0.0, 0.0, 1.0]])
        """, "entry sign"),
    "motion without dt": ("ch07_dynamics", "motion_model", """
        def motion_model(state, v, omega, dt):
            x, y, th = np.asarray(state, dtype=float)
            return np.array([x + v * np.cos(th), y + v * np.sin(th), th + omega])
        """, "missing dt"),
    "arc motion model": ("ch07_dynamics", "motion_model", """
        def motion_model(state, v, omega, dt):
            x, y, th = np.asarray(state, dtype=float)
            return np.array([x + v / omega * (np.sin(th + omega * dt) - np.sin(th)),
                             y - v / omega * (np.cos(th + omega * dt) - np.cos(th)), th + omega * dt])
        """, "arc model"),
    "F^T P F": ("ch07_dynamics", "propagate_covariance", """
        def propagate_covariance(P, F, Q=None):
            out = np.asarray(F).T @ np.asarray(P) @ np.asarray(F)
            return out if Q is None else out + np.asarray(Q)
        """, "F^T P F"),
    "Q left out": ("ch07_dynamics", "propagate_covariance", """
        def propagate_covariance(P, F, Q=None):
            return np.asarray(F, dtype=float) @ np.asarray(P, dtype=float) @ np.asarray(F, dtype=float).T
        """, "missing Q"),
    "biased sample covariance": ("ch08_lab", "sample_covariance", """
        def sample_covariance(z):
            z = np.asarray(z, dtype=float)
            centred = z - z.mean(axis=0)
            return centred.T @ centred / z.shape[0]
        """, "n, not n - 1"),
    "bearings not unwrapped": ("ch08_lab", "measure_samples", """
        def measure_samples(samples, ref_bearing):
            samples = np.asarray(samples, dtype=float)
            return np.column_stack([np.hypot(samples[:, 0], samples[:, 1]), np.arctan2(samples[:, 1], samples[:, 0])])
        """, "not unwrapped"),
    "linearized covariance with sigma": ("ch08_lab", "linearized_measurement_cov", """
        def linearized_measurement_cov(x, y, sigma):
            H = H_jacobian(x, y)
            return float(sigma) * (H @ H.T)
        """, "sigma not squared"),
    "innovation not wrapped": ("ch08_lab", "ekf_update", """
        def ekf_update(x, P, z, R):
            x, P, z, R = (np.asarray(a, dtype=float) for a in (x, P, z, R))
            H = H_jacobian(x[0], x[1])
            innovation = z - range_bearing(x[0], x[1])
            S = H @ P @ H.T + R
            K = P @ H.T @ np.linalg.inv(S)
            return x + K @ innovation, (np.eye(2) - K @ H) @ P
        """, "innovation not wrapped"),
    "R left out of the gain": ("ch08_lab", "ekf_update", """
        def ekf_update(x, P, z, R):
            x, P, z, R = (np.asarray(a, dtype=float) for a in (x, P, z, R))
            H = H_jacobian(x[0], x[1])
            innovation = z - range_bearing(x[0], x[1])
            innovation[1] = (innovation[1] + np.pi) % (2 * np.pi) - np.pi
            S = H @ P @ H.T
            K = P @ H.T @ np.linalg.inv(S)
            return x + K @ innovation, (np.eye(2) - K @ H) @ P
        """, "R missing"),
    "gradient by forward differences": ("ch09_choose_your_tool", "gradient_fd", """
        def gradient_fd(f, x, h=1e-5):
            x = np.asarray(x, dtype=float)
            base = float(f(x))
            out = np.zeros(x.size)
            for j in range(x.size):
                e = np.zeros_like(x)
                e[j] = h
                out[j] = (f(x + e) - base) / h
            return out
        """, "forward difference"),
    "gradient_fd as a row": ("ch09_choose_your_tool", "gradient_fd", """
        def gradient_fd(f, x, h=1e-5):
            x = np.asarray(x, dtype=float)
            out = np.zeros((1, x.size))
            for j in range(x.size):
                e = np.zeros_like(x)
                e[j] = h
                out[0, j] = (f(x + e) - f(x - e)) / (2 * h)
            return out
        """, "row instead of flat"),
    # ---------------------------------------------------------------- the maps beyond the worked examples
    "planner obstacle term over d^2": ("ch02_gradient", "planner_cost_gradient", """
        def planner_cost_gradient(x, y, obstacle):
            ox, oy = np.asarray(obstacle, dtype=float)
            d2 = (x - ox) ** 2 + (y - oy) ** 2
            if d2 == 0:
                raise ValueError("at the obstacle")
            return np.array([-2 * (x - ox) / d2, 2 * y - 2 * (y - oy) / d2], dtype=float)
        """, "d^2 for d^4"),
    "planner obstacle derivative with a plus": ("ch02_gradient", "planner_cost_gradient", """
        def planner_cost_gradient(x, y, obstacle):
            ox, oy = np.asarray(obstacle, dtype=float)
            d2 = (x - ox) ** 2 + (y - oy) ** 2
            if d2 == 0:
                raise ValueError("at the obstacle")
            return np.array([2 * (x - ox) / d2**2, 2 * y + 2 * (y - oy) / d2**2], dtype=float)
        """, "obstacle term sign"),
    "planner without the inner 2": ("ch02_gradient", "planner_cost_gradient", """
        def planner_cost_gradient(x, y, obstacle):
            ox, oy = np.asarray(obstacle, dtype=float)
            d2 = (x - ox) ** 2 + (y - oy) ** 2
            if d2 == 0:
                raise ValueError("at the obstacle")
            return np.array([-(x - ox) / d2**2, 2 * y - (y - oy) / d2**2], dtype=float)
        """, "missing 2"),
    "planner cost with 1/d": ("ch02_gradient", "planner_cost", """
        def planner_cost(x, y, obstacle):
            ox, oy = np.asarray(obstacle, dtype=float)
            d = np.hypot(x - ox, y - oy)
            if d == 0:
                raise ValueError("at the obstacle")
            return float(y * y + 1 / d)
        """, "1/d for 1/d^2"),
    "spherical J transposed": ("ch03_jacobian", "spherical_to_cartesian_jacobian", """
        def spherical_to_cartesian_jacobian(r, azimuth, elevation):
            ca, sa, ce, se = np.cos(azimuth), np.sin(azimuth), np.cos(elevation), np.sin(elevation)
            return np.array([[ce * ca, ce * sa, se], [-r * ce * sa, r * ce * ca, 0.0], [-r * se * ca, -r * se * sa, r * ce]])
        """, "transpose"),
    "spherical J without r": ("ch03_jacobian", "spherical_to_cartesian_jacobian", """
        def spherical_to_cartesian_jacobian(r, azimuth, elevation):
            ca, sa, ce, se = np.cos(azimuth), np.sin(azimuth), np.cos(elevation), np.sin(elevation)
            return np.array([[ce * ca, -ce * sa, -se * ca], [ce * sa, ce * ca, -se * sa], [se, 0.0, ce]])
        """, "missing r"),
    "spherical J azimuth column without cos(el)": ("ch03_jacobian", "spherical_to_cartesian_jacobian", """
        def spherical_to_cartesian_jacobian(r, azimuth, elevation):
            ca, sa, ce, se = np.cos(azimuth), np.sin(azimuth), np.cos(elevation), np.sin(elevation)
            return np.array([[ce * ca, -r * sa, -r * se * ca], [ce * sa, r * ca, -r * se * sa], [se, 0.0, r * ce]])
        """, "missing cos(elevation)"),
    "spherical with the elevation from the z-axis": ("ch03_jacobian", "spherical_to_cartesian", """
        def spherical_to_cartesian(r, azimuth, elevation):
            return r * np.array([np.sin(elevation) * np.cos(azimuth), np.sin(elevation) * np.sin(azimuth),
                                 np.cos(elevation)])
        """, "colatitude"),
    "volume scale with one r": ("ch03_jacobian", "volume_scale", """
        def volume_scale(r, azimuth, elevation):
            return float(r * np.cos(elevation))
        """, "r for r^2"),
    "lidar point not rotated": ("ch04_chain_rule", "lidar_to_world", """
        def lidar_to_world(r, theta, pose):
            px, py, phi = np.asarray(pose, dtype=float)
            return polar_to_cartesian(r, theta) + np.array([px, py])
        """, "missing rotation"),
    "lidar Jacobian in the wrong order": ("ch04_chain_rule", "lidar_to_world_jacobian", """
        def lidar_to_world_jacobian(r, theta, pose):
            phi = float(np.asarray(pose, dtype=float)[2])
            rotation = np.array([[np.cos(phi), -np.sin(phi)], [np.sin(phi), np.cos(phi)]])
            return polar_to_cartesian_jacobian(r, theta) @ rotation
        """, "order"),
    "lidar Jacobian without the rotation": ("ch04_chain_rule", "lidar_to_world_jacobian", """
        def lidar_to_world_jacobian(r, theta, pose):
            return polar_to_cartesian_jacobian(r, theta)
        """, "missing rotation"),
    "pose Jacobian without the rotation derivative": ("ch04_chain_rule", "lidar_pose_jacobian", """
        def lidar_pose_jacobian(r, theta, pose):
            return np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
        """, "missing rotation derivative"),
    "pose Jacobian turning the world point": ("ch04_chain_rule", "lidar_pose_jacobian", """
        def lidar_pose_jacobian(r, theta, pose):
            wx, wy = lidar_to_world(r, theta, pose)
            return np.array([[1.0, 0.0, -wy], [0.0, 1.0, wx]])
        """, "world point"),
    "elevation from the z-axis": ("ch06_measurement", "range_bearing_elevation", """
        def range_bearing_elevation(x, y, z):
            ground = np.hypot(x, y)
            return np.array([np.sqrt(x * x + y * y + z * z), np.arctan2(y, x), np.arctan2(ground, z)], dtype=float)
        """, "colatitude"),
    "H3 elevation row sign": ("ch06_measurement", "H3_jacobian", """
        def H3_jacobian(x, y, z):
            rho2 = float(x * x + y * y)
            if rho2 == 0:
                raise ValueError("on the z-axis")
            r2, rho = rho2 + z * z, np.sqrt(rho2)
            r = np.sqrt(r2)
            return np.array([[x / r, y / r, z / r], [-y / rho2, x / rho2, 0.0],
                             [z * x / (r2 * rho), z * y / (r2 * rho), rho / r2]])
        """, "elevation row sign"),
    "H3 bearing row over r^2": ("ch06_measurement", "H3_jacobian", """
        def H3_jacobian(x, y, z):
            rho2 = float(x * x + y * y)
            if rho2 == 0:
                raise ValueError("on the z-axis")
            r2, rho = rho2 + z * z, np.sqrt(rho2)
            r = np.sqrt(r2)
            return np.array([[x / r, y / r, z / r], [-y / r2, x / r2, 0.0],
                             [-z * x / (r2 * rho), -z * y / (r2 * rho), rho / r2]])
        """, "bearing over r^2"),
    "H3 transposed": ("ch06_measurement", "H3_jacobian", """
        def H3_jacobian(x, y, z):
            rho2 = float(x * x + y * y)
            if rho2 == 0:
                raise ValueError("on the z-axis")
            r2, rho = rho2 + z * z, np.sqrt(rho2)
            r = np.sqrt(r2)
            return np.array([[x / r, -y / rho2, -z * x / (r2 * rho)], [y / r, x / rho2, -z * y / (r2 * rho)],
                             [z / r, 0.0, rho / r2]])
        """, "transpose"),
    "bicycle steering angle as turn rate": ("ch07_dynamics", "bicycle_model", """
        def bicycle_model(state, v, steer, wheelbase, dt):
            x, y, th = np.asarray(state, dtype=float)
            return np.array([x + v * np.cos(th) * dt, y + v * np.sin(th) * dt, th + steer * dt])
        """, "steer as turn rate"),
    "control Jacobian without 1/cos^2": ("ch07_dynamics", "bicycle_control_jacobian", """
        def bicycle_control_jacobian(state, v, steer, wheelbase, dt):
            th = float(np.asarray(state, dtype=float)[2])
            return np.array([[np.cos(th) * dt, 0.0], [np.sin(th) * dt, 0.0],
                             [np.tan(steer) / wheelbase * dt, v * dt / wheelbase]])
        """, "missing 1/cos^2"),
    "control Jacobian without dt": ("ch07_dynamics", "bicycle_control_jacobian", """
        def bicycle_control_jacobian(state, v, steer, wheelbase, dt):
            th = float(np.asarray(state, dtype=float)[2])
            return np.array([[np.cos(th), 0.0], [np.sin(th), 0.0],
                             [np.tan(steer) / wheelbase, v / (wheelbase * np.cos(steer) ** 2)]])
        """, "missing dt"),
    "control noise with standard deviations": ("ch07_dynamics", "control_noise_covariance", """
        def control_noise_covariance(state, v, steer, wheelbase, dt, sigma_v, sigma_steer):
            V = bicycle_control_jacobian(state, v, steer, wheelbase, dt)
            return V @ np.diag([sigma_v, sigma_steer]) @ V.T
        """, "sigma not squared"),
    "control noise sigmas swapped": ("ch07_dynamics", "control_noise_covariance", """
        def control_noise_covariance(state, v, steer, wheelbase, dt, sigma_v, sigma_steer):
            V = bicycle_control_jacobian(state, v, steer, wheelbase, dt)
            return V @ np.diag([sigma_steer ** 2, sigma_v ** 2]) @ V.T
        """, "sigmas swapped"),
}


# (chapter, question id, the answer as a learner writes it after `id: ` in exercises/answers/chNN.yaml,
# the learner id whose numbers it was worked out for (None: the question has no per-learner numbers),
# the mistake name it should get). alice's numbers: superposition_gap px 2.5, qy 4.2; range_value
# (-3.2, 1.5); tangent_value a 7.9, x 6.2; bowl_gradient (-2, 1.1); polar_jacobian r 4.7, theta 0.5;
# area_scale r 0.6; g_jacobian u (-0.5, -2.5); forward_value x 1.6; H_at_point (-3.1, 3.3);
# bearing_variance r 2.3; F_at_state theta 0.5, v 1.7; linearized_cov (0.5, 2.8); gradient_value (-1.5, -1.6).
# Her derivations (the maps hold her numbers): obstacle_cost_dy obstacle (3.9, 1.8); geared_dx_dtheta k 2.5, c 1.3;
# stage_dg1_dtheta p 3.5, q 3.4; dish_dbearing_dx dish (1.4, 0.9); steering_dtheta_dsteer L 3.8, k 19.5.
QUIZ = [
    ("ch00", "superposition_gap", "1.81", "alice", "every sign"),
    ("ch00", "superposition_gap", "0", "alice", "linear"),
    ("ch00", "superposition_gap", "4.89", "alice", "missing the sum"),
    ("ch00", "range_value", "12.49", "alice", "squared range"),
    ("ch00", "range_value", "4.7", "alice", "sum of coordinates"),
    ("ch00", "drange_dx", "y/r", None, "d/dy"),
    ("ch00", "drange_dx", "x/(x² + y²)", None, "r^2 for r"),
    ("ch00", "drange_dx", "x/(2sqrt(x^2 + y^2))", None, "constant factor"),
    ("ch00", "drange_dx", "1/(2r)", None, "missing inner derivative"),
    ("ch01", "tangent_value", "2.490", "alice", "function value"),
    ("ch01", "tangent_value", "2.469", "alice", "slope at x"),
    ("ch01", "tangent_value", "2.206", "alice", "missing 0.5"),
    ("ch01", "taylor_estimate", "0.037", None, "missing 0.5"),
    ("ch01", "taylor_estimate", "1/108", None, "delta not squared"),
    ("ch01", "tangent_of_square", "6x", None, "not through (a, f(a))"),
    ("ch01", "tangent_of_square", "6(x - 3)", None, "missing f(a)"),
    ("ch01", "tangent_of_square", "9 + 6x", None, "x for x - a"),
    ("ch02", "bowl_gradient", "-2.9, 0.2", "alice", "missing 0.5"),
    ("ch02", "bowl_gradient", "1.2, -3.45", "alice", "entries swapped"),
    ("ch02", "bowl_gradient", "[3.45, -1.2]", "alice", "every sign"),
    ("ch02", "tangent_plane", "3.52", None, "true value"),
    ("ch02", "tangent_plane", "3", None, "missing gradient term"),
    ("ch02", "partial_x", "2xy + cos y", None, "constant term differentiated"),
    ("ch02", "partial_x", "x² + cos(y)", None, "d/dy"),
    ("ch02", "obstacle_cost_dy", "2y - 2y/(x^2 + y^2)^2", "alice", "obstacle at the origin"),
    ("ch02", "obstacle_cost_dy", "2y - 2(y - 1.8)/((x - 3.9)^2 + (y - 1.8)^2)", "alice", "d^2 for d^4"),
    ("ch02", "obstacle_cost_dy", "2(y - 1.8) - 2(y - 1.8)/((x - 3.9)^2 + (y - 1.8)^2)^2", "alice", "lane centre moved"),
    ("ch02", "obstacle_cost_dy", "2y + 2(y - 1.8)/((x - 3.9)² + (y - 1.8)²)²", "alice", "obstacle term sign"),
    ("ch02", "obstacle_cost_dy", "-2(y - 1.8)/((x - 3.9)^2 + (y - 1.8)^2)^2", "alice", "missing lane term"),
    ("ch03", "polar_jacobian", "[[0.88, 0.48], [-2.25, 4.12]]", "alice", "transpose"),
    ("ch03", "polar_jacobian", "[[0.88, -0.48], [0.48, 0.88]]", "alice", "missing r"),
    ("ch03", "polar_jacobian", "[[1, -0.04], [0.01, 4.7]]", "alice", "degrees"),
    ("ch03", "polar_jacobian", "[[0.88, 2.25], [0.48, 4.12]]", "alice", "entry sign"),
    ("ch03", "area_scale", "1", "alice", "missing r"),
    ("ch03", "area_scale", "0.36", "alice", "r^2 for r"),
    ("ch03", "dy_dtheta", "cos(θ)", None, "missing r"),
    ("ch03", "dy_dtheta", "-r sin(theta)", None, "d x/d theta"),
    ("ch03", "geared_dx_dtheta", "-r sin(theta)", "alice", "ungeared map"),
    ("ch03", "geared_dx_dtheta", "-r sin(2.5θ + 1.3)", "alice", "missing inner derivative"),
    ("ch03", "geared_dx_dtheta", "-2.5 r sin(2.5 theta)", "alice", "mounting angle dropped"),
    ("ch03", "geared_dx_dtheta", "2.5 r cos(2.5 theta + 1.3)", "alice", "d y/d theta"),
    ("ch04", "g_jacobian", "[[-1, -2.5], [1, -0.5]]", "alice", "transpose"),
    ("ch04", "g_jacobian", "[[-0.5, 1], [-2.5, -0.5]]", "alice", "missing 2"),
    ("ch04", "g_jacobian", "[[-2.5, -0.5], [-1, 1]]", "alice", "rows swapped"),
    ("ch04", "pipeline", "[[-10, -6.428], [10.392, 4.866]]", None, "order"),
    ("ch04", "pipeline", "[[4.866, -25.713], [3.988, 4.372]]", None, "at_x"),
    ("ch04", "derivative_sin_square", "cos(x²)", None, "missing inner derivative"),
    ("ch04", "derivative_sin_square", "2x cos x", None, "outer derivative at x"),
    ("ch04", "stage_dg1_dtheta", "-2 r^2 sin(theta) cos(theta) + r cos(theta)", "alice", "the lesson's g"),
    ("ch04", "stage_dg1_dtheta", "-7 r^2 sin(theta) + 3.4 r cos(theta)", "alice", "at_x"),
    ("ch04", "stage_dg1_dtheta", "3.4 cos(theta) - r^2 sin(theta) cos(theta)", "alice", "order"),
    ("ch04", "stage_dg1_dtheta", "-3.5 r^2 sin(theta) cos(theta) + 3.4 r cos(theta)", "alice", "missing 2"),
    ("ch05", "forward_value", "5.68", "alice", "exact derivative"),
    ("ch05", "forward_value", "5.69", "alice", "central difference"),
    ("ch05", "central_shrink", "10", None, "order h"),
    ("ch05", "central_shrink", "0.01", None, "reciprocal"),
    ("ch05", "forward_error", "0.0084", None, "missing 0.5"),
    ("ch05", "forward_error", "0.0027", None, "f' for f''"),
    ("ch06", "H_at_point", "[[-0.68, -0.16], [0.73, -0.15]]", "alice", "transpose"),
    ("ch06", "H_at_point", "[[-0.68, 0.73], [0.16, 0.15]]", "alice", "row sign"),
    ("ch06", "H_at_point", "[[-0.68, 0.73], [-0.73, -0.68]]", "alice", "bearing over r"),
    ("ch06", "H_at_point", "[[0.68, -0.73], [0.16, 0.15]]", "alice", "every sign"),
    ("ch06", "dbearing_dx", "x/r²", None, "d/dy"),
    ("ch06", "dbearing_dx", "−y/r", None, "bearing over r"),
    ("ch06", "dbearing_dx", "y/(x^2 + y^2)", None, "every sign"),
    ("ch06", "bearing_variance", "1/2.3", "alice", "r for r^2"),
    ("ch06", "dish_dbearing_dx", "-y/(x^2 + y^2)", "alice", "dish at the origin"),
    ("ch06", "dish_dbearing_dx", "-(y - 0.9)/(x^2 + y^2)", "alice", "range from the origin"),
    ("ch06", "dish_dbearing_dx", "(x - 1.4)/((x - 1.4)^2 + (y - 0.9)^2)", "alice", "d/dy"),
    ("ch06", "dish_dbearing_dx", "-(y - 0.9)/sqrt((x - 1.4)^2 + (y - 0.9)^2)", "alice", "bearing over r"),
    ("ch06", "bearing_variance", "5.29", "alice", "reciprocal"),
    ("ch07", "F_at_state", "[[1, 0, -0.815], [0, 1, 1.492], [0, 0, 1]]", "alice", "missing dt"),
    ("ch07", "F_at_state", "[[1, 0, 0], [0, 1, 0], [-0.082, 0.149, 1]]", "alice", "transpose"),
    ("ch07", "F_at_state", "[[1, 0, 0.082], [0, 1, 0.149], [0, 0, 1]]", "alice", "entry sign"),
    ("ch07", "F_at_state", "[[1, 0, -0.149], [0, 1, 0.082], [0, 0, 1]]", "alice", "sin and cos swapped"),
    ("ch07", "propagated_entry", "-0.004", None, "F^T P F"),
    ("ch07", "propagated_entry", "0", None, "diagonal P"),
    ("ch07", "propagated_entry", "-0.01", None, "missing dt"),
    ("ch07", "dx_dtheta", "-v sin(theta)", None, "missing dt"),
    ("ch07", "dx_dtheta", "v·sin(θ)·dt", None, "every sign"),
    ("ch07", "steering_dtheta_dsteer", "v dt/(3.8 cos(steer)^2)", "alice", "steering ratio dropped"),
    ("ch07", "steering_dtheta_dsteer", "v*dt/(3.8*cos(steer/19.5)^2)", "alice", "missing inner derivative"),
    ("ch07", "steering_dtheta_dsteer", "v dt/(19.5*3.8)", "alice", "missing 1/cos^2"),
    ("ch07", "steering_dtheta_dsteer", "v*dt/(74.1*cos(steer/19.5))", "alice", "1/cos for 1/cos^2"),
    ("ch07", "steering_dtheta_dsteer", "19.5 v dt/(3.8 cos(steer/19.5)^2)", "alice", "k for 1/k"),
    ("ch08", "linearized_cov", "[[0.8, 0], [0, 0.099]]", "alice", "sigma not squared"),
    ("ch08", "linearized_cov", "[[1, 0], [0, 0.124]]", "alice", "missing sigma^2"),
    ("ch08", "unbiased", "1", None, "n, not n - 1"),
    ("ch08", "wrapped_innovation", "6.2", None, "not wrapped"),
    ("ch08", "wrapped_innovation", "-4.77", None, "degrees"),
    ("ch08", "wrapped_innovation", "0.0832", None, "every sign"),
    ("ch09", "gradient_value", "-1.5, -4.6", "alice", "entries swapped"),
    ("ch09", "gradient_value", "-3, -1.5", "alice", "missing cross term"),
    ("ch09", "mixed_partial", "2xy³", None, "d/dx only"),
    ("ch09", "mixed_partial", "3x²y²", None, "d/dy only"),
]
QUIZ_LEARNERS = ["reference", "alice", "bob", *(f"learner{i}" for i in range(12))]  # right answers: no diagnosis


def grade_quiz_answer(folder: Path, chapter: str, question: str, text: str, learner: str | None):
    """The quiz result of one answer, written as a learner would (`question: text`) in a fresh answer file."""
    from grader.quiz import DEFAULT_LEARNER, grade_quiz

    folder.mkdir(parents=True, exist_ok=True)
    (folder / f"{chapter}.yaml").write_text(f"{question}: {text}\n", encoding="utf-8")
    results, _ = grade_quiz(chapter, folder, learner or DEFAULT_LEARNER, "exercises/answers")
    return next(r for r in results if r.function == question)


def quiz_diagnoses_on_right_answers(folder: Path) -> list[tuple[str, str, str, str]]:
    """(learner, chapter, question, mistake) for every right answer (the reference answers of
    QUIZ_LEARNERS) that got a diagnosis: there must be none."""
    from grader.chapters import CHAPTERS
    from grader.quiz import grade_quiz
    from grader.quiz.templates import reference_answers

    offered = []
    folder.mkdir(parents=True, exist_ok=True)
    for learner in QUIZ_LEARNERS:
        for info in CHAPTERS:
            (folder / f"{info.id}.yaml").write_text(reference_answers(info.id, learner), encoding="utf-8")
            results, _ = grade_quiz(info.id, folder, learner, "exercises/answers")
            offered += [(learner, info.id, r.function, r.mistake) for r in results if r.mistake]
    return offered


def grade_one(root: Path, chapter: str):
    """One chapter of the submission at root/exercises, graded as `grade` grades it (in a child, no sandbox)."""
    from tests.support import grade_code

    return grade_code(root, [chapter]).chapters[0]


RIGHT_SEEDS = (None, 1, 2, 5, 7, 731904562)  # the public seed, the test suite's others and the course's


def diagnoses_on_right_submissions(folder: Path) -> list[tuple]:
    """(submission, seed, chapter, check, mistake) for every check of a right submission that got a diagnosis:
    the references at RIGHT_SEEDS and the submission written from the contract alone (there must be none)."""
    import shutil

    from grader.chapters import CHAPTERS
    from tests.support import grade_code

    offered = []
    for seed in RIGHT_SEEDS:
        report = grade_code(ROOT, [c.id for c in CHAPTERS], "solutions", seed=seed)
        offered += [("solutions", seed, ch.chapter, c.id, c.mistake) for ch in report.chapters for c in ch.checks
                    if c.mistake or c.help]
    package = folder / "contract" / "exercises"
    shutil.copytree(ROOT / "tests" / "fixtures" / "contract_submission", package)
    (package / "__init__.py").write_text("", encoding="utf-8")
    chapters = sorted(p.stem[:4] for p in package.glob("ch*.py"))
    for seed in (None, 731904562):
        report = grade_code(folder / "contract", chapters, seed=seed)
        offered += [("contract", seed, ch.chapter, c.id, c.mistake) for ch in report.chapters for c in ch.checks
                    if c.mistake or c.help]
    return offered


def generated_corpus(chapters: list[str]) -> list[tuple[str, str, object]]:
    """(chapter, function, mutant) for every single slip grader.judging.mutants makes of every graded function."""
    from grader import checks
    from grader.judging import mutants

    out = []
    for chapter in chapters:
        functions = list(dict.fromkeys(c.function for c in checks.load(chapter).checks))
        out += [(chapter, function, mutant) for function in functions for mutant in mutants.mutants(chapter, function)]
    return out


def grade_mutant(folder: Path, chapter: str, function: str, mutant) -> list:
    """The results of `function`'s checks for the reference solutions with `function` replaced by `mutant`."""
    from grader import checks
    from grader.chapters import BY_ID
    from grader.core.grading import DEFAULT_SEED, judge_chapters
    from grader.judging import mutants
    from tests.support import open_session

    module = BY_ID[chapter].module
    root = build_submission(folder, {module: replace_function(module, function, mutants.standalone(mutant))})
    others = frozenset(f"{chapter}/{c.id}" for c in checks.load(chapter).checks if c.function != function)
    report = judge_chapters(open_session(root), [chapter], seed=DEFAULT_SEED, exclude=others)
    return report.chapters[0].checks


def planned_calls(chapter: str) -> dict[str, list]:
    """The learner calls every check of `chapter` makes at the public seed, by function."""
    from grader import checks
    from grader.core.grading import DEFAULT_SEED
    from grader.core.planning import ChapterPlan

    out: dict[str, list] = {}
    for call in ChapterPlan(checks.load(chapter), DEFAULT_SEED).calls:
        out.setdefault(call.function, []).append(call)
    return out


def equivalent(chapter: str, function: str, mutant, calls: dict, copies: int = 3) -> bool:
    """Whether the mutant gives the reference's value also at random perturbations of its checks' inputs (then no
    input would tell it from right: it is the right function written otherwise)."""
    import numpy as np

    from grader.judging import mutants

    rng = np.random.default_rng(0)
    probes = [mutants.perturbed(c, rng) for c in calls.get(function, []) for _ in range(copies)]
    return not mutants.told_apart(chapter, mutant, probes)


def run_generated(chapters: list[str], verbose: bool) -> tuple[int, int]:
    from collections import Counter

    from grader.judging import mutants

    corpus = generated_corpus(chapters)
    calls = {chapter: planned_calls(chapter) for chapter in chapters}
    kinds = {m.name for _, _, m in corpus}
    outcome: Counter = Counter()
    by_kind: dict[str, Counter] = {}
    quiet, raising = [], []
    with tempfile.TemporaryDirectory() as folder:
        for i, (chapter, function, mutant) in enumerate(corpus):
            results = grade_mutant(Path(folder) / f"m{i}", chapter, function, mutant)
            failed = [c for c in results if c.status.value in ("fail", "error")]
            if not failed:
                quiet.append((chapter, function, mutant))
                continue
            if all(mutants.evaluate(mutant.function, *mutants.arguments_of(c)()) is None
                   for c in calls[chapter].get(function, [])):
                raising.append((chapter, function, mutant))  # it returns no value to name: its traceback is shown
                continue
            said = [(c.mistake, c.help) for c in failed if c.mistake]
            if (mutant.name, mutant.help) in said:
                verdict = "itself"
            elif any(name == mutant.name for name, _ in said):
                verdict = "same kind"
            elif any(name not in kinds for name, _ in said):
                verdict = "own"
            elif said:
                verdict = "equivalent"
            else:
                verdict = "unnamed"
            outcome[verdict] += 1
            by_kind.setdefault(mutant.name, Counter())[verdict] += 1
            if verbose or verdict == "unnamed":
                print(f"{verdict:11} {chapter} {mutant.key:28} {mutant.name:18} {mutant.help[:70]!r} "
                      f"got {sorted({n for n, _ in said})}")
        offered = diagnoses_on_right_submissions(Path(folder))
    told = sum(outcome.values())
    named = told - outcome["unnamed"]
    print(f"\ngenerated corpus: {len(corpus)} single-slip variants of the references in {len(chapters)} chapters; "
          f"{told + len(raising)} told from right by the checks ({len(raising)} of them raise at every input, so no "
          f"value is there to name: their traceback is shown), {len(quiet)} not")
    print(f"named: {named} of {told} ({named / max(told, 1):.1%}; target >= 90%): as itself {outcome['itself']}, "
          f"by another slip of its kind {outcome['same kind']}, by an equivalent slip {outcome['equivalent']}, "
          f"by the check's own or a generic entry {outcome['own']}; unnamed {outcome['unnamed']}")
    print(f"{'kind':20} {'told':>5} {'named':>6}")
    for kind, counts in sorted(by_kind.items()):
        total = sum(counts.values())
        print(f"{kind:20} {total:5} {total - counts['unnamed']:6}")
    same = [(c, f, m) for c, f, m in quiet if equivalent(c, f, m, calls[c])]
    print(f"not told from right: {len(quiet)}, of which {len(same)} give the right value at random inputs too "
          "(equivalent: the right function written otherwise)")
    for chapter, function, mutant in quiet:
        if verbose or (chapter, function, mutant) not in same:
            print(f"  {'equivalent' if (chapter, function, mutant) in same else 'NOT TOLD':10} {chapter} "
                  f"{mutant.key:28} {mutant.name:18} {mutant.help[:70]!r}")
    print(f"diagnoses offered on right submissions (the references at {len(RIGHT_SEEDS)} seeds, the contract's "
          f"submission at 2): {len(offered)}" + (f" {offered}" if offered else ""))
    return named, told


def run_catalogue(verbose: bool) -> None:
    named = 0
    with tempfile.TemporaryDirectory() as folder:
        offered = []
        for chapter in [f"ch0{i}" for i in range(10)]:
            report = grade_one(build_submission(Path(folder) / f"right-{chapter}"), chapter)
            offered += [(chapter, c.id, c.mistake) for c in report.checks if c.mistake]
        for i, (name, (module, function, source, wanted)) in enumerate(CODE.items()):
            root = build_submission(Path(folder) / f"bug{i}", {module: replace_function(module, function, source)})
            chapter = module[:4]
            result = grade_one(root, chapter)
            got = sorted({c.mistake for c in result.checks if c.function == function and c.mistake})
            ok = wanted in got
            named += ok
            if verbose or not ok:
                print(f"{'named' if ok else 'MISSED':6} {name:34} wanted {wanted!r:24} got {got}")
    share = named / len(CODE)
    print(f"\ncode: {named} of {len(CODE)} one-bug submissions named correctly ({share:.0%}; target >= 80%)")
    print(f"diagnoses offered on right answers: {len(offered)}" + (f" {offered}" if offered else ""))
    quiz_named = 0
    with tempfile.TemporaryDirectory() as folder:
        for i, (chapter, question, text, learner, wanted) in enumerate(QUIZ):
            result = grade_quiz_answer(Path(folder) / f"answer{i}", chapter, question, text, learner)
            ok = result.mistake == wanted and result.status.value == "fail"
            quiz_named += ok
            if verbose or not ok:
                print(f"{'named' if ok else 'MISSED':6} {chapter} {question:22} {text!r:40} wanted {wanted!r:28} "
                      f"got {result.mistake!r}")
        quiz_offered = quiz_diagnoses_on_right_answers(Path(folder))
    quiz_share = quiz_named / len(QUIZ)
    print(f"\nquiz: {quiz_named} of {len(QUIZ)} wrong answers named correctly ({quiz_share:.0%}; target >= 80%)")
    print(f"quiz diagnoses offered on right answers ({len(QUIZ_LEARNERS)} learners' reference answers): "
          f"{len(quiz_offered)}" + (f" {quiz_offered}" if quiz_offered else ""))


def _first_line(text: str) -> str:
    """A message's first line, with the next one when it ends with a colon (`wrong at 6 of 6 inputs; the first:`)."""
    lines = [line.strip() for line in str(text).splitlines() if line.strip()]
    if len(lines) > 1 and lines[0].endswith(":"):
        return f"{lines[0]} {lines[1]}"
    return lines[0] if lines else ""


def run_realistic(verbose: bool) -> tuple[int, int, int]:
    """The hand-written corpus (benchmarks/realistic_slips.py): (named, caught, slips)."""
    from benchmarks.realistic_slips import RIGHT, SLIPS

    def lost(checks) -> list:
        return [c for c in checks if c.points < c.max_points]

    caught = named = 0
    collateral, missed = [], []
    by_chapter: dict[str, list[int]] = {}  # chapter -> [slips, caught, named]
    with tempfile.TemporaryDirectory() as folder:
        print(f"{'verdict':10} {'slip':44} what the learner did / the diagnosis given")
        for i, (label, (module, function, source, wanted)) in enumerate(SLIPS.items()):
            root = build_submission(Path(folder) / f"slip{i}", {module: replace_function(module, function, source)})
            chapter = module[:4]
            checks = grade_one(root, chapter).checks
            losing = lost([c for c in checks if c.function == function])
            others = lost([c for c in checks if c.function != function])
            said = list(dict.fromkeys((c.mistake, c.help) for c in losing if c.mistake))
            caught += bool(losing)
            named += bool(said)
            collateral += [(label, c.id, function in c.upstream) for c in others]
            counts = by_chapter.setdefault(chapter, [0, 0, 0])
            counts[0] += 1
            counts[1] += bool(losing)
            counts[2] += bool(said)
            verdict = "named" if said else "unnamed" if losing else "NOT CAUGHT"
            if not losing:
                missed.append(label)
            print(f"{verdict:10} {chapter} {label:39} expected: {wanted}")
            for name, help_ in said:
                print(f"{'':16} got {name!r}: {help_}")
            if losing and (verbose or not said):
                for c in losing:
                    print(f"{'':16} [{c.points:g}/{c.max_points:g}] {c.id}: {_first_line(c.message)!r}"
                          + (f" ({c.mistake})" if c.mistake else ""))
            for c in others:
                print(f"{'':16} collateral: {c.id} ({c.function}) lost points too"
                      + (f", pointed to {function} (it calls it)" if function in c.upstream else ""))
        full = 0
        offered = []
        for i, (label, (module, function, source)) in enumerate(RIGHT.items()):
            root = build_submission(Path(folder) / f"right{i}", {module: replace_function(module, function, source)})
            chapter = module[:4]
            checks = grade_one(root, chapter).checks
            losing = lost(checks)
            given = [(c.id, c.mistake, c.help) for c in checks if c.mistake or c.help]
            full += not losing
            offered += [(label, *g) for g in given]
            if verbose or losing or given:
                print(f"{'full' if not losing else 'LOST':10} {chapter} right: {label}")
            for c in losing:
                print(f"{'':16} [{c.points:g}/{c.max_points:g}] {c.id}: {_first_line(c.message)!r}")
            for check, name, help_ in given:
                print(f"{'':16} diagnosis offered on {check}: {name!r}: {help_}")
    n = len(SLIPS)
    print(f"\nrealistic corpus: {n} hand-written slips; caught {caught}/{n} ({caught / n:.0%}), named {named}/{n} "
          f"({named / n:.0%}; of the caught: {named}/{caught}, {named / max(caught, 1):.0%}); whether each name is "
          "the right one is for the reader to judge from the table")
    print(f"{'chapter':8} {'slips':>5} {'caught':>6} {'named':>6}")
    for chapter, (total, told, said) in sorted(by_chapter.items()):
        print(f"{chapter:8} {total:5} {told:6} {said:6}")
    print(f"not caught: {len(missed)}" + (f" {missed}" if missed else ""))
    unexplained = [(label, check) for label, check, upstream in collateral if not upstream]
    print(f"collateral: {len(collateral)} checks of other functions lost points, in "
          f"{len({label for label, _, _ in collateral})} slips; {len(collateral) - len(unexplained)} of them are "
          f"pointed to the slipped function (their function calls it), {len(unexplained)} are not"
          + (f" {unexplained}" if unexplained else ""))
    print(f"right rewrites: full marks {full}/{len(RIGHT)}; diagnoses offered {len(offered)} (must be 0)"
          + (f" {offered}" if offered else ""))
    return named, caught, n


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--corpus", choices=("catalogue", "generated", "realistic", "all"), default="all")
    parser.add_argument("--chapter", action="append", help="the generated corpus of these chapters only")
    parser.add_argument("--verbose", action="store_true")
    args = parser.parse_args()
    if args.corpus in ("catalogue", "all"):
        run_catalogue(args.verbose)
    if args.corpus in ("generated", "all"):
        generated = run_generated(args.chapter or [f"ch0{i}" for i in range(10)], args.verbose)
    if args.corpus in ("realistic", "all"):
        realistic = run_realistic(args.verbose)
    if args.corpus == "all":
        (g_named, g_told), (r_named, r_caught, r_all) = generated, realistic
        print(f"\nnamed: generated corpus {g_named}/{g_told} of the told ({g_named / max(g_told, 1):.1%}); "
              f"realistic corpus {r_named}/{r_caught} of the caught ({r_named / max(r_caught, 1):.1%}), "
              f"{r_named}/{r_all} of all its slips ({r_named / max(r_all, 1):.1%})")


if __name__ == "__main__":
    main()
