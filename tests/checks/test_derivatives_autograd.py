"""The lesson's third route: Jacobians by automatic differentiation are right answers. A submission
whose Jacobians come from jax.jacfwd (float32, jax's default, and float64) gets full marks, in the
sandbox and without it (memory written is capped, not address space reserved); a torch-like tensor
(requires_grad, __array__, __dlpack__; torch's wheel is too large for CI) counts as a numpy array;
what cannot be converted gets a message that says how. Real subprocesses, the real CLI."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.support import (
    HAVE_JAX,
    build_submission,
    grade_json,
    needs_jax,
    replace_function,
)

# the chapters an autograd learner's submission is graded on, code only
GRADED = ("ch03", "ch04", "ch06", "ch07", "ch08", "--no-quiz")


def _jax_module(module: str, function: str, body: str, x64: bool) -> str:
    head = "import jax\nimport jax.numpy as jnp\n" + ('jax.config.update("jax_enable_x64", True)\n' if x64 else "")
    return replace_function(module, function, body).replace("import numpy as np\n", "import numpy as np\n" + head, 1)


def jax_submission(root: Path, x64: bool) -> Path:
    """Every Jacobian of the lesson's maps by jax.jacfwd, returned as jax arrays."""
    return build_submission(root, {
        "ch03_jacobian": _jax_module("ch03_jacobian", "polar_to_cartesian_jacobian", """
            def polar_to_cartesian_jacobian(r, theta):
                polar = lambda v: jnp.stack([v[0] * jnp.cos(v[1]), v[0] * jnp.sin(v[1])])
                return jax.jacfwd(polar)(jnp.array([r, theta], dtype=float))
            """, x64),
        "ch04_chain_rule": _jax_module("ch04_chain_rule", "g_jacobian", """
            def g_jacobian(u):
                g = lambda v: jnp.stack([v[0] ** 2 + v[1], v[0] * v[1]])
                return jax.jacfwd(g)(jnp.asarray(u, dtype=float))
            """, x64),
        "ch06_measurement": _jax_module("ch06_measurement", "H_jacobian", """
            def H_jacobian(x, y):
                if x == 0 and y == 0:
                    raise ValueError("H is undefined at r = 0")
                range_bearing = lambda p: jnp.stack([jnp.hypot(p[0], p[1]), jnp.arctan2(p[1], p[0])])
                return jax.jacfwd(range_bearing)(jnp.array([x, y], dtype=float))
            """, x64),
        "ch07_dynamics": _jax_module("ch07_dynamics", "F_jacobian", """
            def F_jacobian(state, v, omega, dt):
                motion = lambda s: jnp.stack([s[0] + v * jnp.cos(s[2]) * dt, s[1] + v * jnp.sin(s[2]) * dt,
                                              s[2] + omega * dt])
                return jax.jacfwd(motion)(jnp.asarray(state, dtype=float))
            """, x64),
    })


def _failures(report: dict) -> list[str]:
    return [f"{c['chapter']}: {problem}" for c in report["chapters"] for problem in c.get("problems", [])] + [
        f"{c['chapter']}/{k['id']}: {k['message']}" for c in report["chapters"] for k in c["checks"]
        if k["status"] not in ("pass", "skip")]


@pytest.mark.slow
@needs_jax
@pytest.mark.parametrize("x64", [False, True], ids=["float32", "float64"])
@pytest.mark.parametrize("sandbox", [True, False], ids=["sandbox", "no-sandbox"])
def test_jax_jacobians_get_full_marks(tmp_path, x64, sandbox):
    """In float64 every check passes; in float32 every check but the exact-derivative ones, which ask for the
    derivative to float64 rounding and say how to get it (also where a Jacobian is built on a float32 one)."""
    if not HAVE_JAX:
        pytest.fail("CI must have jax (the test extras install it)")
    report = grade_json(*GRADED, "--submission", jax_submission(tmp_path, x64), *([] if sandbox else ["--no-sandbox"]))
    failed = [k for c in report["chapters"] for k in c["checks"] if k["status"] not in ("pass", "skip")]
    if x64:
        assert _failures(report) == []
        assert report["score"] == report["max_score"] > 0
        return
    assert failed and all(k["id"].endswith("_exact") for k in failed), _failures(report)
    # what to change is the check's help, beside its message (what is wrong)
    assert all('jax.config.update("jax_enable_x64", True)' in k.get("help", "") for k in failed), _failures(report)
    own = {"polar_to_cartesian_jacobian", "g_jacobian", "H_jacobian", "F_jacobian"}  # jax.jacfwd's float32 arrays
    assert {k["function"] for k in failed if k["mistake"] == "single precision"} == own, _failures(report)
    assert report["score"] == report["max_score"] - len(failed)


TENSOR = '''
class Tensor:
    """Stands in for torch.Tensor: refuses numpy while it requires grad, as torch does."""
    __module__ = "torch"

    def __init__(self, data, requires_grad=False):
        self.data = np.array(data, dtype=np.float32)
        self.requires_grad = requires_grad

    def detach(self):
        return Tensor(self.data)

    def cpu(self):
        return self

    def __array__(self, dtype=None, copy=None):
        if self.requires_grad:
            raise RuntimeError("Can't call numpy() on Tensor that requires grad. Use tensor.detach().numpy() instead.")
        return self.data if dtype is None else self.data.astype(dtype)

    def __dlpack__(self, stream=None):
        return np.asarray(self).__dlpack__()

    def __dlpack_device__(self):
        return (1, 0)
'''


@pytest.mark.slow
def test_a_torch_tensor_that_requires_grad_is_a_numpy_array(tmp_path):
    module = replace_function("ch06_measurement", "measurement_covariance", """
        def measurement_covariance(x, y, sigma):
            H = H_jacobian(x, y)
            return Tensor(float(sigma) ** 2 * (H @ H.T), requires_grad=True)
        """) + TENSOR
    ch03 = replace_function("ch03_jacobian", "area_scale", """
        def area_scale(r, theta):
            return Tensor(float(r), requires_grad=True)
        """) + TENSOR
    root = build_submission(tmp_path, {"ch06_measurement": module, "ch03_jacobian": ch03})
    report = grade_json(*GRADED, "--submission", root)
    assert _failures(report) == []


def test_numpy_scalars_and_zero_d_arrays_are_numbers(tmp_path):
    ch03 = replace_function("ch03_jacobian", "area_scale", """
        def area_scale(r, theta):
            return np.array(float(r), dtype=np.float32)
        """)
    report = grade_json(*GRADED, "--submission", build_submission(tmp_path, {"ch03_jacobian": ch03}))
    assert _failures(report) == []


@pytest.mark.slow
def test_an_array_that_cannot_be_converted_says_how_to_convert_it(tmp_path):
    module = replace_function("ch06_measurement", "H_jacobian", """
        def H_jacobian(x, y):
            return GpuTensor()
        """) + TENSOR + '''
class GpuTensor(Tensor):
    """A tensor on a GPU: torch refuses to hand it to numpy."""
    __module__ = "torch"

    def __init__(self):
        super().__init__(np.zeros((2, 2)))

    def detach(self):
        return self

    def cpu(self):
        raise RuntimeError("no CUDA device here")
'''
    report = grade_json(*GRADED, "--submission", build_submission(tmp_path, {"ch06_measurement": module}))
    messages = [k["message"] for c in report["chapters"] if c["chapter"] == "ch06" for k in c["checks"]
                if k["id"] == "H_worked_example"]
    assert messages and "np.asarray" in messages[0] and ".detach().cpu().numpy()" in messages[0], messages
