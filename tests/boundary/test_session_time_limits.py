"""A time limit is not proof of an endless loop. The first call of a function whose module loaded jax or torch
(which compile a function on its first call) gets the import's time, not a call's; and a call stopped at its
limit is told what that shows: an endless loop where its other calls came back at once, else that it may
never end or be too slow, never a bare "an endless loop?"."""

from __future__ import annotations

import pytest

from grader.boundary import Limits
from tests.support import build_submission, grade_checks, needs_jax, replace_function

# The first call sleeps as a jit compile takes on a busy laptop; the later ones are quick.
SLOW_FIRST = """def range_bearing(x, y):
    import time
    global _compiled
    if not globals().get("_compiled"):
        time.sleep(1.5)
        _compiled = True
    return np.array([np.hypot(x, y), np.arctan2(y, x)])
"""
LIMITS = Limits(call_seconds=1.0, import_seconds=20.0)


def _range_bearing(root, **options) -> dict:
    return {k: c for k, c in grade_checks(root, "ch06", limits=LIMITS, **options).items()
            if c.function == "range_bearing"}


@pytest.mark.slow
def test_a_slow_first_call_without_a_compiling_library_is_stopped_and_told_it_may_be_slow(tmp_path):
    root = build_submission(tmp_path, {"ch06_measurement": replace_function("ch06_measurement", "range_bearing",
                                                                           SLOW_FIRST)})
    checks = _range_bearing(root)
    stopped = [c for c in checks.values() if "did not return in time" in c.message]
    assert stopped, {k: c.message for k, c in checks.items()}
    message = stopped[0].message
    assert "stopped after 1 s" in message and "or be too slow" in message and "endless loop?" not in message


@pytest.mark.slow
def test_the_first_call_after_a_compiling_library_loaded_gets_the_imports_time(tmp_path):
    """The grader reads which of jax and torch the module loaded (here a stand-in in sys.modules, so that the
    test does not pay jax's import): the first call of each function may then take as long as an import."""
    module = replace_function("ch06_measurement", "range_bearing", SLOW_FIRST)
    module = module.replace("import numpy as np", "import numpy as np\nimport sys, types\nsys.modules.setdefault("
                                                  "'jax', types.ModuleType('jax'))", 1)
    root = build_submission(tmp_path, {"ch06_measurement": module})
    checks = _range_bearing(root)
    assert all(c.status.value == "pass" for c in checks.values()), {k: c.message for k, c in checks.items()}


@pytest.mark.slow
@needs_jax
def test_a_jitted_function_gets_its_compile_time_with_jax_itself(tmp_path):
    module = replace_function("ch06_measurement", "range_bearing", SLOW_FIRST)
    module = module.replace("import numpy as np", "import numpy as np\nimport jax  # noqa: F401", 1)
    root = build_submission(tmp_path, {"ch06_measurement": module})
    checks = _range_bearing(root)
    assert all(c.status.value == "pass" for c in checks.values()), {k: c.message for k, c in checks.items()}


@pytest.mark.slow
def test_a_call_that_hangs_where_the_others_came_back_at_once_is_called_a_likely_endless_loop(tmp_path):
    hangs_at_origin_side = replace_function("ch06_measurement", "range_bearing", """def range_bearing(x, y):
    while x < 0:
        pass
    return np.array([np.hypot(x, y), np.arctan2(y, x)])
""")
    root = build_submission(tmp_path, {"ch06_measurement": hangs_at_origin_side})
    checks = _range_bearing(root)
    messages = [c.message for c in checks.values() if "did not return in time" in c.message]
    assert any("while its other calls returned within" in m and "most likely never ends" in m for m in messages), \
        {k: c.message for k, c in checks.items()}
