"""A hand-written corpus of realistic learner mistakes, and of right functions written otherwise.

Data only, read by `python benchmarks/misconceptions.py --corpus realistic`, which grades each entry through
the normal pipeline: the reference solutions with that one function replaced by the entry's source.

How it was written: by hand, from the exercise contract and from the mistakes learners
typically make in courses of this kind (a norm or a formula confused with the right one, a convention mixed up,
a wrong quantity returned, numpy used the way a beginner uses it). It is deliberately NOT derived from the
grader's mutator (grader/judging/mutants.py) nor from the catalogue of named mistakes (CODE and QUIZ in
benchmarks/misconceptions.py): every function is rewritten whole, the way a learner would write it, not as a
one-token edit of the reference. It measures how often the grader catches such a slip and names it in words.

- SLIPS = {label: (module, function, source, what_the_learner_did)}: one wrong function each; the last field
  is the phrase a good grader would say (the measure's key, to be compared by a reader with the diagnosis
  given), not a mistake id of the grader.
- RIGHT = {label: (module, function, source)}: right functions written otherwise (other algebra, solve for inv,
  einsum, math for numpy, another equivalent form): full marks are due and no diagnosis may be offered.

A source is the function's full `def`, using only what the chapter file already has (np, the chapter's own
functions and its imports) or importing inside the def.
"""

# (module, function, wrong source, what the learner did)
SLIPS = {
    # ------------------------------------------------------------------------------------------- ch00
    "range as the taxicab norm": ("ch00_range_sensor", "range_reading", """
        def range_reading(x, y):
            return float(abs(x) + abs(y))
        """, "taxicab norm |x| + |y| for the range"),
    "range as the max-norm": ("ch00_range_sensor", "range_reading", """
        def range_reading(x, y):
            return float(max(abs(x), abs(y)))
        """, "max-norm for the range"),
    "range without the square root": ("ch00_range_sensor", "range_reading", """
        def range_reading(x, y):
            x = float(x)
            y = float(y)
            return x * x + y * y
        """, "squared range (the square root forgotten)"),
    "gap with range(q) added": ("ch00_range_sensor", "superposition_gap", """
        def superposition_gap(p, q):
            s = np.add(p, q)
            return float(np.linalg.norm(s) - np.linalg.norm(p) + np.linalg.norm(q))
        """, "range(q) added, not subtracted (missing parentheses)"),
    "gap as its size": ("ch00_range_sensor", "superposition_gap", """
        def superposition_gap(p, q):
            p = np.asarray(p, dtype=float)
            q = np.asarray(q, dtype=float)
            return float(abs(np.linalg.norm(p + q) - (np.linalg.norm(p) + np.linalg.norm(q))))
        """, "absolute value of the gap (its sign lost)"),
    "mean shift with a fixed seed": ("ch00_range_sensor", "mean_shift", """
        def mean_shift(mean, sigma, n, seed):
            rng = np.random.default_rng(0)
            pts = rng.normal(mean, sigma, size=(n, 2))
            return float(np.sqrt(pts[:, 0] ** 2 + pts[:, 1] ** 2).mean() - np.hypot(mean[0], mean[1]))
        """, "fixed seed 0 instead of the seed given"),
    "mean shift from the global generator": ("ch00_range_sensor", "mean_shift", """
        def mean_shift(mean, sigma, n, seed):
            pts = np.random.normal(mean, sigma, size=(n, 2))
            ranges = np.sqrt(pts[:, 0] ** 2 + pts[:, 1] ** 2)
            return float(ranges.mean() - np.hypot(mean[0], mean[1]))
        """, "global np.random instead of default_rng(seed) (seed ignored)"),
    "mean shift with the variance as scale": ("ch00_range_sensor", "mean_shift", """
        def mean_shift(mean, sigma, n, seed):
            rng = np.random.default_rng(seed)
            pts = rng.normal(loc=mean, scale=sigma ** 2, size=(n, 2))
            ranges = np.linalg.norm(pts, axis=1)
            return float(ranges.mean() - np.linalg.norm(mean))
        """, "sigma^2 used as the scale (variance for standard deviation)"),
    "mean shift with uniform draws": ("ch00_range_sensor", "mean_shift", """
        def mean_shift(mean, sigma, n, seed):
            rng = np.random.default_rng(seed)
            mean = np.asarray(mean, dtype=float)
            pts = rng.uniform(mean - sigma, mean + sigma, size=(n, 2))
            return float(np.linalg.norm(pts, axis=1).mean() - np.linalg.norm(mean))
        """, "uniform draws instead of normal"),
    "range of the mean sample": ("ch00_range_sensor", "mean_shift", """
        def mean_shift(mean, sigma, n, seed):
            rng = np.random.default_rng(seed)
            mean = np.asarray(mean, dtype=float)
            pts = mean + sigma * rng.standard_normal((n, 2))
            centre = pts.mean(axis=0)
            return float(np.hypot(*centre) - np.hypot(*mean))
        """, "range of the sample mean, not the mean of the ranges"),
    # ------------------------------------------------------------------------------------------- ch01
    "tangent line with (a - x)": ("ch01_tangent_line", "tangent_line", """
        def tangent_line(f, fprime, a, x):
            x = np.asarray(x, dtype=float)
            L = f(a) + fprime(a) * (a - x)
            return float(L) if L.ndim == 0 else L
        """, "(a - x) for (x - a): slope term with the wrong sign"),
    "tangent line without f(a)": ("ch01_tangent_line", "tangent_line", """
        def tangent_line(f, fprime, a, x):
            x = np.asarray(x, dtype=float)
            L = fprime(a) * (x - a)
            return float(L) if L.ndim == 0 else L
        """, "f(a) left out (only the increment)"),
    "relative linearization error": ("ch01_tangent_line", "linearization_error", """
        def linearization_error(f, fprime, a, x):
            x = np.asarray(x, dtype=float)
            L = f(a) + fprime(a) * (x - a)
            err = np.abs(f(x) - L) / np.abs(f(x))
            return float(err) if err.ndim == 0 else err
        """, "relative error |f - L| / |f| where the absolute error is asked"),
    "squared linearization error": ("ch01_tangent_line", "linearization_error", """
        def linearization_error(f, fprime, a, x):
            x = np.asarray(x, dtype=float)
            err = (f(x) - f(a) - fprime(a) * (x - a)) ** 2
            return float(err) if err.ndim == 0 else err
        """, "squared error instead of its absolute value"),
    "taylor estimate without abs": ("ch01_tangent_line", "taylor_error_estimate", """
        def taylor_error_estimate(fsecond, a, delta):
            return fsecond(a) * delta ** 2 / 2
        """, "no absolute value of f''(a) (signed estimate)"),
    "taylor estimate with delta not squared": ("ch01_tangent_line", "taylor_error_estimate", """
        def taylor_error_estimate(fsecond, a, delta):
            return 0.5 * abs(fsecond(a)) * abs(delta)
        """, "delta not squared"),
    "taylor estimate with f'' at a + delta": ("ch01_tangent_line", "taylor_error_estimate", """
        def taylor_error_estimate(fsecond, a, delta):
            return 0.5 * abs(fsecond(a + delta)) * delta ** 2
        """, "f'' taken at a + delta, not at a"),
    # ------------------------------------------------------------------------------------------- ch02
    "example_f with ^ for power": ("ch02_gradient", "example_f", """
        def example_f(x, y):
            return x ^ 2 + x * y
        """, "^ (bitwise xor) for the power **"),
    "gradient without the cross term": ("ch02_gradient", "example_gradient", """
        def example_gradient(x, y):
            return np.array([2.0 * x, 1.0 * x])
        """, "cross term xy missing from d/dx (2x instead of 2x + y)"),
    "gradient d/dy as y": ("ch02_gradient", "example_gradient", """
        def example_gradient(x, y):
            dfdx = 2 * x + y
            dfdy = y
            return np.array([dfdx, dfdy], dtype=float)
        """, "d(xy)/dy taken as y instead of x"),
    "tangent plane with (a - x)": ("ch02_gradient", "tangent_plane", """
        def tangent_plane(f, grad, a, x):
            a = np.array(a, dtype=float)
            x = np.array(x, dtype=float)
            return float(f(a) + grad(a) @ (a - x))
        """, "(a - x) for (x - a) in the tangent plane"),
    "tangent plane from f(x)": ("ch02_gradient", "tangent_plane", """
        def tangent_plane(f, grad, a, x):
            a = np.array(a, dtype=float)
            x = np.array(x, dtype=float)
            return float(f(x) + np.dot(grad(a), x - a))
        """, "f(x) instead of f(a) as the plane's base value"),
    "bowl cross term without the half": ("ch02_gradient", "bowl_gradient", """
        def bowl_gradient(x, y):
            return np.array([2 * x + y, x + 2 * y], dtype=float)
        """, "0.5xy differentiated as xy (the 0.5 lost)"),
    "bowl cross term missing in d/dy": ("ch02_gradient", "bowl_gradient", """
        def bowl_gradient(x, y):
            return np.array([2 * x + 0.5 * y, 2 * y], dtype=float)
        """, "cross term missing from d/dy"),
    "contour along the gradient": ("ch02_gradient", "contour_direction", """
        def contour_direction(x, y):
            g = bowl_gradient(x, y)
            n = np.linalg.norm(g)
            if n == 0:
                raise ValueError("no contour at the origin")
            return g / n
        """, "gradient direction instead of the tangent"),
    "contour tangent not normalised": ("ch02_gradient", "contour_direction", """
        def contour_direction(x, y):
            gx, gy = bowl_gradient(x, y)
            if gx == 0 and gy == 0:
                raise ValueError("no contour at the origin")
            return np.array([-gy, gx])
        """, "tangent not normalised to unit length"),
    "contour with one sign flipped, not rotated": ("ch02_gradient", "contour_direction", """
        def contour_direction(x, y):
            gx, gy = bowl_gradient(x, y)
            n = np.hypot(gx, gy)
            if n == 0:
                raise ValueError("no contour at the origin")
            return np.array([gx, -gy]) / n
        """, "gradient reflected (one sign flipped) instead of turned by 90 degrees"),
    "contour without the ValueError": ("ch02_gradient", "contour_direction", """
        def contour_direction(x, y):
            gx, gy = bowl_gradient(x, y)
            t = np.array([-gy, gx])
            return t / np.linalg.norm(t)
        """, "no ValueError at (0, 0) (returns nan)"),
    "planner cost over each offset": ("ch02_gradient", "planner_cost", """
        def planner_cost(x, y, obstacle):
            ox, oy = obstacle
            if x == ox and y == oy:
                raise ValueError("at the obstacle")
            return float(y ** 2 + 1 / (x - ox) ** 2 + 1 / (y - oy) ** 2)
        """, "1/dx^2 + 1/dy^2 instead of 1/(dx^2 + dy^2)"),
    "planner cost without the lane term": ("ch02_gradient", "planner_cost", """
        def planner_cost(x, y, obstacle):
            d2 = (x - obstacle[0]) ** 2 + (y - obstacle[1]) ** 2
            if d2 == 0:
                raise ValueError("at the obstacle")
            return float(1.0 / d2)
        """, "lane term y^2 left out"),
    "planner gradient without the lane term": ("ch02_gradient", "planner_cost_gradient", """
        def planner_cost_gradient(x, y, obstacle):
            dx, dy = x - obstacle[0], y - obstacle[1]
            d2 = dx * dx + dy * dy
            if d2 == 0:
                raise ValueError("at the obstacle")
            return np.array([-2 * dx / d2 ** 2, -2 * dy / d2 ** 2], dtype=float)
        """, "lane term 2y missing from d/dy"),
    "planner gradient without the inner derivative": ("ch02_gradient", "planner_cost_gradient", """
        def planner_cost_gradient(x, y, obstacle):
            dx, dy = x - obstacle[0], y - obstacle[1]
            d = np.sqrt(dx * dx + dy * dy)
            if d == 0:
                raise ValueError("at the obstacle")
            return np.array([-2 * dx / d ** 3, 2 * y - 2 * dy / d ** 3], dtype=float)
        """, "d(1/d^2) = -2/d^3 without the inner derivative dd/dx = dx/d (chain rule)"),
    # ------------------------------------------------------------------------------------------- ch03
    "polar with sin and cos swapped": ("ch03_jacobian", "polar_to_cartesian", """
        def polar_to_cartesian(r, theta):
            return np.array([r * np.sin(theta), r * np.cos(theta)], dtype=float)
        """, "sin and cos swapped (angle from the y-axis)"),
    "polar J without r": ("ch03_jacobian", "polar_to_cartesian_jacobian", """
        def polar_to_cartesian_jacobian(r, theta):
            c, s = np.cos(theta), np.sin(theta)
            return np.array([[c, -s], [s, c]], dtype=float)
        """, "r missing from the theta column (the rotation matrix)"),
    "polar J rows swapped": ("ch03_jacobian", "polar_to_cartesian_jacobian", """
        def polar_to_cartesian_jacobian(r, theta):
            c, s = np.cos(theta), np.sin(theta)
            dy = [s, r * c]
            dx = [c, -r * s]
            return np.array([dy, dx], dtype=float)
        """, "rows swapped (y row first)"),
    "area scale with a plus": ("ch03_jacobian", "area_scale", """
        def area_scale(r, theta):
            J = polar_to_cartesian_jacobian(r, theta)
            return float(J[0, 0] * J[1, 1] + J[0, 1] * J[1, 0])
        """, "determinant ad + bc (sign of the cross product)"),
    "area scale as r^2": ("ch03_jacobian", "area_scale", """
        def area_scale(r, theta):
            return float(r) ** 2
        """, "r^2 (the spherical factor) for r"),
    "spherical with z = r cos(el)": ("ch03_jacobian", "spherical_to_cartesian", """
        def spherical_to_cartesian(r, azimuth, elevation):
            x = r * np.cos(elevation) * np.cos(azimuth)
            y = r * np.cos(elevation) * np.sin(azimuth)
            z = r * np.cos(elevation)
            return np.array([x, y, z])
        """, "z as r cos(elevation) instead of r sin(elevation)"),
    "spherical with the angles swapped": ("ch03_jacobian", "spherical_to_cartesian", """
        def spherical_to_cartesian(r, azimuth, elevation):
            return r * np.array([np.cos(azimuth) * np.cos(elevation),
                                 np.cos(azimuth) * np.sin(elevation),
                                 np.sin(azimuth)])
        """, "azimuth and elevation swapped"),
    "spherical J with d cos = + sin": ("ch03_jacobian", "spherical_to_cartesian_jacobian", """
        def spherical_to_cartesian_jacobian(r, azimuth, elevation):
            ca, sa = np.cos(azimuth), np.sin(azimuth)
            ce, se = np.cos(elevation), np.sin(elevation)
            return np.array([[ce * ca, -r * ce * sa, r * se * ca],
                             [ce * sa, r * ce * ca, r * se * sa],
                             [se, 0.0, r * ce]])
        """, "d cos(el)/d el taken as +sin(el) (elevation column sign)"),
    "volume scale with sin": ("ch03_jacobian", "volume_scale", """
        def volume_scale(r, azimuth, elevation):
            return float(r ** 2 * np.sin(elevation))
        """, "r^2 sin(elevation), the colatitude textbook formula, for r^2 cos(elevation)"),
    # ------------------------------------------------------------------------------------------- ch04
    "g outputs in the wrong order": ("ch04_chain_rule", "g_stage", """
        def g_stage(u):
            u1, u2 = u
            return np.array([u1 * u2, u1 ** 2 + u2], dtype=float)
        """, "outputs in the wrong order"),
    "g jacobian product rule swapped": ("ch04_chain_rule", "g_jacobian", """
        def g_jacobian(u):
            u1, u2 = float(u[0]), float(u[1])
            return np.array([[2 * u1, 1.0], [u1, u2]])
        """, "d(u1 u2)/du1 and d(u1 u2)/du2 swapped (product rule)"),
    "g jacobian with d(u2)/du2 = 0": ("ch04_chain_rule", "g_jacobian", """
        def g_jacobian(u):
            u1, u2 = float(u[0]), float(u[1])
            return np.array([[2 * u1, 0.0], [u2, u1]])
        """, "d(u1^2 + u2)/du2 taken as 0"),
    "chain rule elementwise": ("ch04_chain_rule", "compose_jacobian", """
        def compose_jacobian(f, jac_f, jac_g, x):
            x = np.asarray(x, dtype=float)
            return np.asarray(jac_g(f(x))) * np.asarray(jac_f(x))
        """, "elementwise * instead of the matrix product"),
    "pipeline with Jg at the input": ("ch04_chain_rule", "pipeline_jacobian", """
        def pipeline_jacobian(r, theta):
            return g_jacobian([r, theta]) @ polar_to_cartesian_jacobian(r, theta)
        """, "outer Jacobian taken at (r, theta), not at the inner function's output"),
    "lidar rotated by -phi": ("ch04_chain_rule", "lidar_to_world", """
        def lidar_to_world(r, theta, pose):
            px, py, phi = pose
            c, s = np.cos(phi), np.sin(phi)
            R = np.array([[c, s], [-s, c]])
            return R @ polar_to_cartesian(r, theta) + np.array([px, py], dtype=float)
        """, "rotation transposed (turned by -phi)"),
    "lidar Jacobian with R transposed": ("ch04_chain_rule", "lidar_to_world_jacobian", """
        def lidar_to_world_jacobian(r, theta, pose):
            phi = pose[2]
            R = np.array([[np.cos(phi), np.sin(phi)], [-np.sin(phi), np.cos(phi)]])
            return R @ polar_to_cartesian_jacobian(r, theta)
        """, "rotation transposed in the Jacobian"),
    "pose Jacobian heading column sign": ("ch04_chain_rule", "lidar_pose_jacobian", """
        def lidar_pose_jacobian(r, theta, pose):
            phi = pose[2]
            lx, ly = polar_to_cartesian(r, theta)
            c, s = np.cos(phi), np.sin(phi)
            # d/dphi of (c lx - s ly, s lx + c ly)
            return np.array([[1.0, 0.0, s * lx + c * ly], [0.0, 1.0, -c * lx + s * ly]])
        """, "heading column with the wrong sign (d cos = +sin, d sin = -cos)"),
    "pose Jacobian without the translation": ("ch04_chain_rule", "lidar_pose_jacobian", """
        def lidar_pose_jacobian(r, theta, pose):
            phi = pose[2]
            lx, ly = polar_to_cartesian(r, theta)
            c, s = np.cos(phi), np.sin(phi)
            return np.array([[0.0, 0.0, -s * lx - c * ly], [0.0, 0.0, c * lx - s * ly]])
        """, "translation block (identity) left out"),
    # ------------------------------------------------------------------------------------------- ch05
    "backward difference": ("ch05_finite_differences", "forward_difference", """
        def forward_difference(f, x, h):
            return (f(x) - f(x - h)) / h
        """, "backward difference (f(x) - f(x - h)) / h"),
    "central with / 2 * h": ("ch05_finite_differences", "central_difference", """
        def central_difference(f, x, h):
            return (f(x + h) - f(x - h)) / 2 * h
        """, "operator precedence: / 2 * h multiplies by h"),
    "central over h": ("ch05_finite_differences", "central_difference", """
        def central_difference(f, x, h):
            return (f(x + h) - f(x - h)) / h
        """, "divided by h, not 2h"),
    "central done forward": ("ch05_finite_differences", "central_difference", """
        def central_difference(f, x, h):
            return (f(x + h) - f(x)) / h
        """, "forward difference where central is asked"),
    "jacobian_fd rows per input": ("ch05_finite_differences", "jacobian_fd", """
        def jacobian_fd(f, x, h=1e-5):
            x = np.asarray(x, dtype=float)
            rows = []
            for j in range(len(x)):
                step = np.zeros(len(x))
                step[j] = h
                rows.append(np.atleast_1d((np.asarray(f(x + step)) - np.asarray(f(x - step))) / (2 * h)))
            return np.array(rows)
        """, "Jacobian transposed (one row per input)"),
    "jacobian_fd steps every input at once": ("ch05_finite_differences", "jacobian_fd", """
        def jacobian_fd(f, x, h=1e-5):
            x = np.asarray(x, dtype=float)
            col = np.atleast_1d((np.asarray(f(x + h), dtype=float) - np.asarray(f(x - h), dtype=float)) / (2 * h))
            return np.tile(col[:, None], (1, x.size))
        """, "every input stepped at once (no unit vector e_j)"),
    "jacobian check as the signed max": ("ch05_finite_differences", "max_jacobian_error", """
        def max_jacobian_error(jac, f, x, h=1e-5):
            diff = np.asarray(jac(np.asarray(x, dtype=float))) - jacobian_fd(f, x, h)
            return float(diff.max())
        """, "signed max, no absolute value"),
    "jacobian check as the mean": ("ch05_finite_differences", "max_jacobian_error", """
        def max_jacobian_error(jac, f, x, h=1e-5):
            diff = np.asarray(jac(np.asarray(x, dtype=float))) - jacobian_fd(f, x, h)
            return float(np.mean(np.abs(diff)))
        """, "mean absolute difference instead of the max"),
    "best step returns the error": ("ch05_finite_differences", "best_step", """
        def best_step(f, fprime, x, hs):
            errors = [abs(central_difference(f, x, h) - fprime(x)) for h in hs]
            return min(errors)
        """, "the smallest error returned instead of its step"),
    "best step returns the index": ("ch05_finite_differences", "best_step", """
        def best_step(f, fprime, x, hs):
            errors = np.array([abs(central_difference(f, x, h) - fprime(x)) for h in hs])
            return int(np.argmin(errors))
        """, "the index of the best step instead of the step"),
    "best step by forward differences": ("ch05_finite_differences", "best_step", """
        def best_step(f, fprime, x, hs):
            best, best_err = None, np.inf
            for h in hs:
                err = abs(forward_difference(f, x, h) - fprime(x))
                if err < best_err:
                    best, best_err = h, err
            return best
        """, "forward difference where central is asked (error measured on the wrong quotient)"),
    # ------------------------------------------------------------------------------------------- ch06
    "bearing atan + pi unwrapped": ("ch06_measurement", "range_bearing", """
        def range_bearing(x, y):
            r = np.sqrt(x ** 2 + y ** 2)
            b = np.arctan(y / x)
            if x < 0:
                b = b + np.pi
            return np.array([r, b], dtype=float)
        """, "atan(y/x) + pi, angle not wrapped by a whole turn into [-pi, pi]"),
    "bearing atan2(x, y)": ("ch06_measurement", "range_bearing", """
        def range_bearing(x, y):
            return np.array([np.hypot(x, y), np.arctan2(x, y)], dtype=float)
        """, "atan2(x, y): arguments swapped (angle from the y-axis)"),
    "bearing plain atan": ("ch06_measurement", "range_bearing", """
        def range_bearing(x, y):
            import math
            return np.array([math.sqrt(x * x + y * y), math.atan(y / x)])
        """, "atan(y/x) instead of atan2 (wrong half-plane for x < 0)"),
    "H range row over r^2": ("ch06_measurement", "H_jacobian", """
        def H_jacobian(x, y):
            r2 = x ** 2 + y ** 2
            if r2 == 0:
                raise ValueError("r = 0")
            return np.array([[x / r2, y / r2], [-y / r2, x / r2]], dtype=float)
        """, "range row over r^2 instead of r"),
    "H without the ValueError": ("ch06_measurement", "H_jacobian", """
        def H_jacobian(x, y):
            r = np.hypot(x, y)
            return np.array([[x / r, y / r], [-y / r ** 2, x / r ** 2]])
        """, "no ValueError at r = 0 (nan returned)"),
    "measurement covariance with sigma": ("ch06_measurement", "measurement_covariance", """
        def measurement_covariance(x, y, sigma):
            H = H_jacobian(x, y)
            return H @ H.T * sigma
        """, "sigma not squared: H H^T sigma"),
    "measurement covariance H^T H": ("ch06_measurement", "measurement_covariance", """
        def measurement_covariance(x, y, sigma):
            H = H_jacobian(x, y)
            return sigma ** 2 * H.T @ H
        """, "H^T H instead of H H^T"),
    "elevation in degrees": ("ch06_measurement", "range_bearing_elevation", """
        def range_bearing_elevation(x, y, z):
            ground = np.sqrt(x ** 2 + y ** 2)
            r = np.sqrt(x ** 2 + y ** 2 + z ** 2)
            return np.array([r, np.arctan2(y, x), np.degrees(np.arctan2(z, ground))])
        """, "elevation in degrees (range and bearing right)"),
    "elevation over the 3-D range": ("ch06_measurement", "range_bearing_elevation", """
        def range_bearing_elevation(x, y, z):
            r = np.sqrt(x ** 2 + y ** 2 + z ** 2)
            return np.array([r, np.arctan2(y, x), np.arctan2(z, r)])
        """, "elevation atan2(z, r) with the 3-D range instead of the ground range"),
    "H3 rows permuted": ("ch06_measurement", "H3_jacobian", """
        def H3_jacobian(x, y, z):
            rho2 = x * x + y * y
            if rho2 == 0:
                raise ValueError("no bearing on the z-axis")
            rho = np.sqrt(rho2)
            r2 = rho2 + z * z
            r = np.sqrt(r2)
            d_range = [x / r, y / r, z / r]
            d_bearing = [-y / rho2, x / rho2, 0.0]
            d_elev = [-x * z / (rho * r2), -y * z / (rho * r2), rho / r2]
            return np.array([d_bearing, d_elev, d_range])
        """, "rows permuted (bearing, elevation, range)"),
    "H3 elevation dz over r": ("ch06_measurement", "H3_jacobian", """
        def H3_jacobian(x, y, z):
            rho2 = x * x + y * y
            if rho2 == 0:
                raise ValueError("no bearing on the z-axis")
            rho = np.sqrt(rho2)
            r = np.sqrt(rho2 + z * z)
            return np.array([[x / r, y / r, z / r],
                             [-y / rho2, x / rho2, 0.0],
                             [-x * z / (rho * r * r), -y * z / (rho * r * r), rho / r]])
        """, "d elevation/dz as rho/r instead of rho/r^2"),
    # ------------------------------------------------------------------------------------------- ch07
    "motion with sin and cos swapped": ("ch07_dynamics", "motion_model", """
        def motion_model(state, v, omega, dt):
            x, y, th = state
            return np.array([x + v * np.sin(th) * dt, y + v * np.cos(th) * dt, th + omega * dt], dtype=float)
        """, "sin and cos swapped (heading from the y-axis)"),
    "motion with the new heading": ("ch07_dynamics", "motion_model", """
        def motion_model(state, v, omega, dt):
            x, y, th = state
            th = th + omega * dt
            x = x + v * np.cos(th) * dt
            y = y + v * np.sin(th) * dt
            return np.array([x, y, th], dtype=float)
        """, "heading updated first, so the new heading moves the position"),
    "F with d y/d th sign": ("ch07_dynamics", "F_jacobian", """
        def F_jacobian(state, v, omega, dt):
            th = state[2]
            F = np.eye(3)
            F[0, 2] = -v * np.sin(th) * dt
            F[1, 2] = -v * np.cos(th) * dt
            return F
        """, "F[1,2] = d y'/d theta with the wrong sign"),
    "F with dt in one entry only": ("ch07_dynamics", "F_jacobian", """
        def F_jacobian(state, v, omega, dt):
            th = state[2]
            return np.array([[1, 0, -v * np.sin(th)],
                             [0, 1, v * np.cos(th) * dt],
                             [0, 0, 1]], dtype=float)
        """, "dt forgotten in one entry (F[0,2])"),
    "F transposed": ("ch07_dynamics", "F_jacobian", """
        def F_jacobian(state, v, omega, dt):
            th = state[2]
            return np.array([[1.0, 0.0, 0.0],
                             [0.0, 1.0, 0.0],
                             [-v * np.sin(th) * dt, v * np.cos(th) * dt, 1.0]])
        """, "F transposed"),
    "F without the identity": ("ch07_dynamics", "F_jacobian", """
        def F_jacobian(state, v, omega, dt):
            th = state[2]
            F = np.zeros((3, 3))
            F[0, 2] = -v * np.sin(th) * dt
            F[1, 2] = v * np.cos(th) * dt
            return F
        """, "identity left out (Jacobian of the increment only)"),
    "propagate F P": ("ch07_dynamics", "propagate_covariance", """
        def propagate_covariance(P, F, Q=None):
            out = F @ P
            if Q is not None:
                out = out + Q
            return out
        """, "F P instead of F P F^T"),
    "propagate with Q twice": ("ch07_dynamics", "propagate_covariance", """
        def propagate_covariance(P, F, Q=None):
            P_pred = F @ P @ F.T
            if Q is not None:
                P_pred += Q
            return P_pred + Q if Q is not None else P_pred
        """, "Q added twice"),
    "propagate with Q inside": ("ch07_dynamics", "propagate_covariance", """
        def propagate_covariance(P, F, Q=None):
            if Q is None:
                Q = np.zeros_like(P)
            return F @ (P + Q) @ F.T
        """, "Q inside the sandwich: F (P + Q) F^T"),
    "bicycle times the wheelbase": ("ch07_dynamics", "bicycle_model", """
        def bicycle_model(state, v, steer, wheelbase, dt):
            x, y, th = state
            return np.array([x + v * np.cos(th) * dt, y + v * np.sin(th) * dt,
                             th + v * np.tan(steer) * wheelbase * dt], dtype=float)
        """, "turn rate times the wheelbase instead of divided by it"),
    "bicycle d tan = 1/cos": ("ch07_dynamics", "bicycle_control_jacobian", """
        def bicycle_control_jacobian(state, v, steer, wheelbase, dt):
            th = state[2]
            return np.array([[np.cos(th) * dt, 0.0],
                             [np.sin(th) * dt, 0.0],
                             [np.tan(steer) * dt / wheelbase, v * dt / (wheelbase * np.cos(steer))]])
        """, "d tan/d steer as 1/cos instead of 1/cos^2"),
    "bicycle steer column without v": ("ch07_dynamics", "bicycle_control_jacobian", """
        def bicycle_control_jacobian(state, v, steer, wheelbase, dt):
            th = state[2]
            return np.array([[np.cos(th) * dt, 0.0],
                             [np.sin(th) * dt, 0.0],
                             [np.tan(steer) * dt / wheelbase, dt / (wheelbase * np.cos(steer) ** 2)]])
        """, "v dropped from d theta'/d steer"),
    "control noise with sigmas not squared": ("ch07_dynamics", "control_noise_covariance", """
        def control_noise_covariance(state, v, steer, wheelbase, dt, sigma_v, sigma_steer):
            V = bicycle_control_jacobian(state, v, steer, wheelbase, dt)
            return V @ np.diag([sigma_v, sigma_steer]) @ V.T
        """, "sigmas not squared (standard deviations used as variances)"),
    "control noise V^T M V": ("ch07_dynamics", "control_noise_covariance", """
        def control_noise_covariance(state, v, steer, wheelbase, dt, sigma_v, sigma_steer):
            V = bicycle_control_jacobian(state, v, steer, wheelbase, dt)
            M = np.diag([sigma_v ** 2, sigma_steer ** 2])
            return V.T @ V @ M
        """, "V^T V M: sandwich in the wrong order (2 x 2)"),
    # ------------------------------------------------------------------------------------------- ch08
    "samples with a fixed seed": ("ch08_lab", "sample_positions", """
        def sample_positions(mean, sigma, n, rng):
            rng = np.random.default_rng(0)
            return rng.normal(mean, sigma, size=(n, 2))
        """, "fixed seed np.random.default_rng(0) instead of the rng given"),
    "samples from the global generator": ("ch08_lab", "sample_positions", """
        def sample_positions(mean, sigma, n, rng):
            return np.random.normal(mean, sigma, size=(n, 2))
        """, "global np.random instead of the generator given"),
    "samples uniform": ("ch08_lab", "sample_positions", """
        def sample_positions(mean, sigma, n, rng):
            mean = np.asarray(mean, dtype=float)
            return mean + sigma * rng.random((n, 2))
        """, "uniform draws instead of normal"),
    "samples with the variance as scale": ("ch08_lab", "sample_positions", """
        def sample_positions(mean, sigma, n, rng):
            return rng.normal(loc=mean, scale=sigma ** 2, size=(n, 2))
        """, "sigma^2 used as the scale"),
    "bearings wrapped to [0, 2pi)": ("ch08_lab", "measure_samples", """
        def measure_samples(samples, ref_bearing):
            samples = np.asarray(samples, dtype=float)
            r = np.hypot(samples[:, 0], samples[:, 1])
            b = np.arctan2(samples[:, 1], samples[:, 0]) % (2 * np.pi)
            return np.column_stack([r, b])
        """, "bearings wrapped to [0, 2pi) instead of around ref_bearing"),
    "bearings moved with floor": ("ch08_lab", "measure_samples", """
        def measure_samples(samples, ref_bearing):
            samples = np.asarray(samples, dtype=float)
            r = np.hypot(samples[:, 0], samples[:, 1])
            b = np.arctan2(samples[:, 1], samples[:, 0])
            b = b + 2 * np.pi * np.floor((ref_bearing - b) / (2 * np.pi))
            return np.column_stack([r, b])
        """, "floor instead of round for the number of turns"),
    "linearized covariance times sigma": ("ch08_lab", "linearized_measurement_cov", """
        def linearized_measurement_cov(x, y, sigma):
            H = H_jacobian(x, y)
            return H @ H.T * sigma
        """, "sigma not squared: H H^T sigma"),
    "linearized covariance H^T H": ("ch08_lab", "linearized_measurement_cov", """
        def linearized_measurement_cov(x, y, sigma):
            H = H_jacobian(x, y)
            return H.T @ (sigma ** 2 * np.eye(2)) @ H
        """, "H^T Sigma H instead of H Sigma H^T"),
    "biased sample covariance": ("ch08_lab", "sample_covariance", """
        def sample_covariance(z):
            return np.cov(np.asarray(z, dtype=float).T, bias=True)
        """, "biased covariance (divide by n, not n - 1)"),
    "uncentred second moment": ("ch08_lab", "sample_covariance", """
        def sample_covariance(z):
            z = np.asarray(z, dtype=float)
            return z.T @ z / (len(z) - 1)
        """, "not centred: z^T z / (n - 1), the mean not subtracted"),
    "np.cov of the rows": ("ch08_lab", "sample_covariance", """
        def sample_covariance(z):
            return np.cov(z)
        """, "np.cov(z) treats each sample as a variable (n x n, not 2 x 2)"),
    "absolute mismatch": ("ch08_lab", "linearization_mismatch", """
        def linearization_mismatch(x, y, sigma, n, seed):
            rng = np.random.default_rng(seed)
            pts = sample_positions([x, y], sigma, n, rng)
            z = measure_samples(pts, np.arctan2(y, x))
            return float(np.linalg.norm(sample_covariance(z) - linearized_measurement_cov(x, y, sigma)))
        """, "absolute error where the relative error is asked"),
    "mismatch with bearings around 0": ("ch08_lab", "linearization_mismatch", """
        def linearization_mismatch(x, y, sigma, n, seed):
            rng = np.random.default_rng(seed)
            pts = sample_positions([x, y], sigma, n, rng)
            z = measure_samples(pts, 0.0)
            S_mc = sample_covariance(z)
            S_lin = linearized_measurement_cov(x, y, sigma)
            return float(np.linalg.norm(S_mc - S_lin) / np.linalg.norm(S_lin))
        """, "bearings unwrapped around 0, not around the operating point's bearing"),
    "mismatch relative to the sampled covariance": ("ch08_lab", "linearization_mismatch", """
        def linearization_mismatch(x, y, sigma, n, seed):
            rng = np.random.default_rng(seed)
            pts = sample_positions([x, y], sigma, n, rng)
            S_mc = sample_covariance(measure_samples(pts, np.arctan2(y, x)))
            S_lin = linearized_measurement_cov(x, y, sigma)
            return float(np.linalg.norm(S_mc - S_lin) / np.linalg.norm(S_mc))
        """, "divided by the sampled covariance's norm, not the linearized one's"),
    "ekf innovation wrapped with %": ("ch08_lab", "ekf_update", """
        def ekf_update(x, P, z, R):
            x = np.asarray(x, dtype=float)
            H = H_jacobian(x[0], x[1])
            nu = np.asarray(z, dtype=float) - range_bearing(x[0], x[1])
            nu[1] = nu[1] % (2 * np.pi)
            S = H @ P @ H.T + R
            K = P @ H.T @ np.linalg.inv(S)
            return x + K @ nu, (np.eye(2) - K @ H) @ P
        """, "bearing innovation wrapped with % 2pi into [0, 2pi), not into [-pi, pi)"),
    "ekf with R as a standard deviation": ("ch08_lab", "ekf_update", """
        def ekf_update(x, P, z, R):
            x = np.asarray(x, dtype=float)
            H = H_jacobian(x[0], x[1])
            nu = np.asarray(z, dtype=float) - range_bearing(x[0], x[1])
            nu[1] = (nu[1] + np.pi) % (2 * np.pi) - np.pi
            S = H @ P @ H.T + R @ R
            K = P @ H.T @ np.linalg.inv(S)
            return x + K @ nu, (np.eye(2) - K @ H) @ P
        """, "R used as a standard deviation (R @ R in the innovation covariance)"),
    "ekf innovation reversed": ("ch08_lab", "ekf_update", """
        def ekf_update(x, P, z, R):
            x = np.asarray(x, dtype=float)
            H = H_jacobian(x[0], x[1])
            nu = range_bearing(x[0], x[1]) - np.asarray(z, dtype=float)
            nu[1] = (nu[1] + np.pi) % (2 * np.pi) - np.pi
            S = H @ P @ H.T + R
            K = P @ H.T @ np.linalg.inv(S)
            return x + K @ nu, (np.eye(2) - K @ H) @ P
        """, "innovation h(x) - z instead of z - h(x)"),
    # ------------------------------------------------------------------------------------------- ch09
    "gradient_fd on integers": ("ch09_choose_your_tool", "gradient_fd", """
        def gradient_fd(f, x, h=1e-5):
            x = np.asarray(x)
            g = np.zeros(len(x))
            for i in range(len(x)):
                e = np.zeros_like(x)
                e[i] = h
                g[i] = (f(x + e) - f(x - e)) / (2 * h)
            return g
        """, "integer x not converted to float (the step rounds to 0)"),
    "gradient_fd over h": ("ch09_choose_your_tool", "gradient_fd", """
        def gradient_fd(f, x, h=1e-5):
            x = np.asarray(x, dtype=float)
            return np.array([(f(x + h * e) - f(x - h * e)) / h for e in np.eye(len(x))])
        """, "central difference divided by h, not 2h"),
    "hessian not symmetrised": ("ch09_choose_your_tool", "hessian_fd", """
        def hessian_fd(f, x, h=1e-4):
            return jacobian_fd(lambda v: gradient_fd(f, v, h), x, h)
        """, "not symmetrised"),
    "hessian symmetrised without the half": ("ch09_choose_your_tool", "hessian_fd", """
        def hessian_fd(f, x, h=1e-4):
            J = jacobian_fd(lambda v: gradient_fd(f, v, h), x, h)
            return J + J.T
        """, "symmetrised as J + J^T without the half"),
    "hessian with the default outer step": ("ch09_choose_your_tool", "hessian_fd", """
        def hessian_fd(f, x, h=1e-4):
            J = jacobian_fd(lambda v: gradient_fd(f, v, h), x)
            return (J + J.T) / 2
        """, "outer difference with jacobian_fd's default step, not h"),
    "classify without a tolerance": ("ch09_choose_your_tool", "classify_critical_point", """
        def classify_critical_point(hessian):
            A = np.asarray(hessian, dtype=float)
            ev = np.linalg.eigvalsh((A + A.T) / 2)
            if ev.min() < 0 < ev.max():
                return "saddle"
            if np.all(ev > 0):
                return "minimum"
            if np.all(ev < 0):
                return "maximum"
            return "degenerate"
        """, "no tolerance: eigenvalues compared with 0 exactly"),
    "classify by the determinant": ("ch09_choose_your_tool", "classify_critical_point", """
        def classify_critical_point(hessian):
            A = np.asarray(hessian, dtype=float)
            A = (A + A.T) / 2
            d = np.linalg.det(A)
            if abs(d) <= 1e-8:
                return "degenerate"
            if d < 0:
                return "saddle"
            return "minimum" if A[0, 0] > 0 else "maximum"
        """, "second-derivative test on the determinant only (the 2 x 2 rule)"),
    "classify not symmetrised": ("ch09_choose_your_tool", "classify_critical_point", """
        def classify_critical_point(hessian):
            ev = np.linalg.eigvals(np.asarray(hessian, dtype=float)).real
            tol = 1e-8 * max(1.0, np.abs(ev).max())
            if (ev > tol).any() and (ev < -tol).any():
                return "saddle"
            if (np.abs(ev) <= tol).any():
                return "degenerate"
            return "minimum" if (ev > 0).all() else "maximum"
        """, "not symmetrised: eigenvalues of the raw matrix"),
    "classify with an absolute tolerance": ("ch09_choose_your_tool", "classify_critical_point", """
        def classify_critical_point(hessian):
            A = np.asarray(hessian, dtype=float)
            ev = np.linalg.eigvalsh(0.5 * (A + A.T))
            pos = ev > 1e-8
            neg = ev < -1e-8
            if pos.any() and neg.any():
                return "saddle"
            if pos.all():
                return "minimum"
            if neg.all():
                return "maximum"
            return "degenerate"
        """, "absolute tolerance 1e-8, not scaled by the largest eigenvalue"),
    "classify degenerate before saddle": ("ch09_choose_your_tool", "classify_critical_point", """
        def classify_critical_point(hessian):
            A = np.asarray(hessian, dtype=float)
            ev = np.linalg.eigvalsh(0.5 * (A + A.T))
            tol = 1e-8 * max(1.0, np.max(np.abs(ev)))
            if np.any(np.abs(ev) <= tol):
                return "degenerate"
            if np.all(ev > 0):
                return "minimum"
            if np.all(ev < 0):
                return "maximum"
            return "saddle"
        """, "a zero eigenvalue checked before the signs: a saddle with a zero eigenvalue called degenerate"),
}

# (module, function, right source written otherwise)
RIGHT = {
    "range with math": ("ch00_range_sensor", "range_reading", """
        def range_reading(x, y):
            import math
            return math.sqrt(x * x + y * y)
        """),
    "gap with norms": ("ch00_range_sensor", "superposition_gap", """
        def superposition_gap(p, q):
            p = np.array(p, dtype=float)
            q = np.array(q, dtype=float)
            return float(np.linalg.norm(p + q) - np.linalg.norm(p) - np.linalg.norm(q))
        """),
    "mean shift with rng.normal": ("ch00_range_sensor", "mean_shift", """
        def mean_shift(mean, sigma, n, seed):
            rng = np.random.default_rng(seed)
            mean = np.asarray(mean, dtype=float)
            pts = mean + sigma * rng.standard_normal(size=(n, 2))
            return float(np.mean(np.linalg.norm(pts, axis=1)) - np.linalg.norm(mean))
        """),
    "tangent line for scalars and arrays": ("ch01_tangent_line", "tangent_line", """
        def tangent_line(f, fprime, a, x):
            if np.isscalar(x):
                return float(f(a) + fprime(a) * (x - a))
            x = np.asarray(x, dtype=float)
            return f(a) + fprime(a) * (x - a)
        """),
    "taylor estimate by hand": ("ch01_tangent_line", "taylor_error_estimate", """
        def taylor_error_estimate(fsecond, a, delta):
            return abs(fsecond(a)) * delta * delta / 2
        """),
    "contour turned the other way, with hypot": ("ch02_gradient", "contour_direction", """
        def contour_direction(x, y):
            gx = 2 * x + 0.5 * y
            gy = 0.5 * x + 2 * y
            length = np.hypot(gx, gy)
            if length == 0:
                raise ValueError("no contour direction at (0, 0)")
            return np.array([gy / length, -gx / length])
        """),
    "tangent plane as a sum": ("ch02_gradient", "tangent_plane", """
        def tangent_plane(f, grad, a, x):
            g = np.asarray(grad(np.asarray(a, dtype=float)), dtype=float)
            total = f(np.asarray(a, dtype=float))
            for gi, xi, ai in zip(g, x, a):
                total += gi * (xi - ai)
            return float(total)
        """),
    "polar J with math": ("ch03_jacobian", "polar_to_cartesian_jacobian", """
        def polar_to_cartesian_jacobian(r, theta):
            import math
            c, s = math.cos(theta), math.sin(theta)
            return np.array([[c, -r * s], [s, r * c]])
        """),
    "area scale by hand": ("ch03_jacobian", "area_scale", """
        def area_scale(r, theta):
            J = polar_to_cartesian_jacobian(r, theta)
            return float(J[0, 0] * J[1, 1] - J[0, 1] * J[1, 0])
        """),
    "volume scale as r^2 cos(el)": ("ch03_jacobian", "volume_scale", """
        def volume_scale(r, azimuth, elevation):
            return float(r * r * np.cos(elevation))
        """),
    "compose with einsum": ("ch04_chain_rule", "compose_jacobian", """
        def compose_jacobian(f, jac_f, jac_g, x):
            x = np.asarray(x, dtype=float)
            return np.einsum("ik,kj->ij", np.asarray(jac_g(f(x)), dtype=float), np.asarray(jac_f(x), dtype=float))
        """),
    "pipeline by hand": ("ch04_chain_rule", "pipeline_jacobian", """
        def pipeline_jacobian(r, theta):
            u = polar_to_cartesian(r, theta)
            return np.matmul(g_jacobian(u), polar_to_cartesian_jacobian(r, theta))
        """),
    "jacobian_fd with an explicit loop": ("ch05_finite_differences", "jacobian_fd", """
        def jacobian_fd(f, x, h=1e-5):
            x = np.array(x, dtype=float)
            m = np.atleast_1d(np.asarray(f(x), dtype=float)).size
            J = np.empty((m, x.size))
            for j in range(x.size):
                xp, xm = x.copy(), x.copy()
                xp[j] += h
                xm[j] -= h
                fp = np.atleast_1d(np.asarray(f(xp), dtype=float))
                fm = np.atleast_1d(np.asarray(f(xm), dtype=float))
                for i in range(m):
                    J[i, j] = (fp[i] - fm[i]) / (2 * h)
            return J
        """),
    "best step with min over pairs": ("ch05_finite_differences", "best_step", """
        def best_step(f, fprime, x, hs):
            exact = fprime(x)
            return float(min(hs, key=lambda h: abs((f(x + h) - f(x - h)) / (2 * h) - exact)))
        """),
    "H with hypot": ("ch06_measurement", "H_jacobian", """
        def H_jacobian(x, y):
            r = np.hypot(float(x), float(y))
            if r == 0:
                raise ValueError("H is undefined at the dish")
            return np.array([[x / r, y / r], [-y / r ** 2, x / r ** 2]], dtype=float)
        """),
    "measurement covariance as a diagonal": ("ch06_measurement", "measurement_covariance", """
        def measurement_covariance(x, y, sigma):
            r2 = float(x) ** 2 + float(y) ** 2
            if r2 == 0:
                raise ValueError("r = 0")
            return sigma ** 2 * np.diag([1.0, 1.0 / r2])
        """),
    "H3 with math": ("ch06_measurement", "H3_jacobian", """
        def H3_jacobian(x, y, z):
            import math
            rho2 = x * x + y * y
            if rho2 == 0:
                raise ValueError("no bearing on the z-axis")
            rho = math.sqrt(rho2)
            r2 = rho2 + z * z
            r = math.sqrt(r2)
            return np.array([[x / r, y / r, z / r],
                             [-y / rho2, x / rho2, 0.0],
                             [-z * x / (rho * r2), -z * y / (rho * r2), rho / r2]], dtype=float)
        """),
    "F from the identity": ("ch07_dynamics", "F_jacobian", """
        def F_jacobian(state, v, omega, dt):
            th = float(state[2])
            F = np.eye(3)
            F[0, 2] = -v * dt * np.sin(th)
            F[1, 2] = v * dt * np.cos(th)
            return F
        """),
    "propagate with einsum": ("ch07_dynamics", "propagate_covariance", """
        def propagate_covariance(P, F, Q=None):
            out = np.einsum("ij,jk,lk->il", F, P, F)
            return out if Q is None else out + Q
        """),
    "control jacobian with 1 + tan^2": ("ch07_dynamics", "bicycle_control_jacobian", """
        def bicycle_control_jacobian(state, v, steer, wheelbase, dt):
            th = state[2]
            t = np.tan(steer)
            return np.array([[np.cos(th) * dt, 0.0], [np.sin(th) * dt, 0.0],
                             [t * dt / wheelbase, v * dt * (1 + t * t) / wheelbase]])
        """),
    "sample covariance with rowvar": ("ch08_lab", "sample_covariance", """
        def sample_covariance(z):
            return np.cov(np.asarray(z, dtype=float), rowvar=False)
        """),
    "sample covariance with einsum": ("ch08_lab", "sample_covariance", """
        def sample_covariance(z):
            z = np.asarray(z, dtype=float)
            d = z - z.mean(axis=0)
            return np.einsum("ni,nj->ij", d, d) / (len(z) - 1)
        """),
    "samples with rng.normal": ("ch08_lab", "sample_positions", """
        def sample_positions(mean, sigma, n, rng):
            return np.asarray(mean, dtype=float) + sigma * rng.standard_normal(size=(n, 2))
        """),
    "mismatch with a hand-written Frobenius norm": ("ch08_lab", "linearization_mismatch", """
        def linearization_mismatch(x, y, sigma, n, seed):
            rng = np.random.default_rng(seed)
            pts = sample_positions(np.array([x, y], dtype=float), sigma, n, rng)
            z = measure_samples(pts, np.arctan2(y, x))
            diff = sample_covariance(z) - linearized_measurement_cov(x, y, sigma)
            lin = linearized_measurement_cov(x, y, sigma)
            return float(np.sqrt(np.sum(diff ** 2)) / np.sqrt(np.sum(lin ** 2)))
        """),
    "ekf standard form, symmetrised": ("ch08_lab", "ekf_update", """
        def ekf_update(x, P, z, R):
            x = np.asarray(x, dtype=float)
            P = np.asarray(P, dtype=float)
            H = H_jacobian(x[0], x[1])
            nu = np.asarray(z, dtype=float) - range_bearing(x[0], x[1])
            nu[1] = np.arctan2(np.sin(nu[1]), np.cos(nu[1]))
            if nu[1] >= np.pi:
                nu[1] -= 2 * np.pi
            S = H @ P @ H.T + R
            K = P @ H.T @ np.linalg.inv(S)
            P_new = P - K @ S @ K.T
            return x + K @ nu, (P_new + P_new.T) / 2
        """),
    "ekf Joseph form with solve": ("ch08_lab", "ekf_update", """
        def ekf_update(x, P, z, R):
            x = np.asarray(x, dtype=float)
            P = np.asarray(P, dtype=float)
            R = np.asarray(R, dtype=float)
            H = H_jacobian(x[0], x[1])
            nu = np.asarray(z, dtype=float) - range_bearing(x[0], x[1])
            nu[1] = (nu[1] + np.pi) % (2 * np.pi) - np.pi
            S = H @ P @ H.T + R
            K = np.linalg.solve(S.T, (P @ H.T).T).T
            A = np.eye(2) - K @ H
            P_new = A @ P @ A.T + K @ R @ K.T
            return x + K @ nu, 0.5 * (P_new + P_new.T)
        """),
    "gradient_fd vectorised": ("ch09_choose_your_tool", "gradient_fd", """
        def gradient_fd(f, x, h=1e-5):
            x = np.asarray(x, dtype=float)
            steps = h * np.eye(x.size)
            return np.array([(f(x + e) - f(x - e)) / (2 * h) for e in steps], dtype=float)
        """),
    "hessian symmetrised over two": ("ch09_choose_your_tool", "hessian_fd", """
        def hessian_fd(f, x, h=1e-4):
            J = jacobian_fd(lambda v: gradient_fd(f, v, h), x, h)
            return (J + J.T) / 2
        """),
    "classify with eigh": ("ch09_choose_your_tool", "classify_critical_point", """
        def classify_critical_point(hessian):
            A = np.asarray(hessian, dtype=float)
            w = np.linalg.eigh((A + A.T) / 2)[0]
            zero = 1e-8 * max(1.0, float(np.abs(w).max()))
            signs = {int(np.sign(v)) if abs(v) > zero else 0 for v in w}
            if {1, -1} <= signs:
                return "saddle"
            if 0 in signs:
                return "degenerate"
            return "minimum" if signs == {1} else "maximum"
        """),
}
