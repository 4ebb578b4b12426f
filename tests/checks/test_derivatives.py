"""The exact-derivative checks (grader/checks/derivatives.py, add_exact_check): a finite difference passed
off as a derivative loses exactly that check, with a message that names it; an analytic answer or a float64
autograd one passes; a float32 autograd one gets the hint to compute in float64; a course can turn the
checks off (`exact_derivatives: false`), and then they are nowhere: not run, not in any score, not
recorded in its handout. Real child processes, real files."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from grader import checks as check_registry
from grader import course_config as courses
from grader.chapters import CHAPTERS
from grader.core.pipeline import Request, build_report
from grader.model import Status
from tests.support import (
    HAVE_JAX,
    build_submission,
    grade_code,
    needs_jax,
    open_session,
    replace_function,
    replace_functions,
)

DERIVATIVE_CHAPTERS = ("ch02", "ch03", "ch04", "ch06", "ch07")

# numerical Jacobians of the learner's own forward maps: central differences with h = 1e-6
NUMERICAL = {
    "ch06_measurement": ("H_jacobian", """
        def H_jacobian(x, y):
            if x == 0 and y == 0:
                raise ValueError("H is undefined at r = 0")
            h = 1e-6
            columns = [(range_bearing(x + h, y) - range_bearing(x - h, y)) / (2 * h),
                       (range_bearing(x, y + h) - range_bearing(x, y - h)) / (2 * h)]
            return np.column_stack(columns)
        """),
    "ch04_chain_rule": ("lidar_to_world_jacobian", """
        def lidar_to_world_jacobian(r, theta, pose):
            h = 1e-6
            columns = [(lidar_to_world(r + h, theta, pose) - lidar_to_world(r - h, theta, pose)) / (2 * h),
                       (lidar_to_world(r, theta + h, pose) - lidar_to_world(r, theta - h, pose)) / (2 * h)]
            return np.column_stack(columns)
        """),
}


def _numerical_submission(root: Path) -> Path:
    return build_submission(root, {module: replace_function(module, function, source)
                                   for module, (function, source) in NUMERICAL.items()})


def _lost(chapter) -> list[tuple[str, str]]:
    return [(c.function, c.id) for c in chapter.checks if c.points < c.max_points]


def test_every_derivative_of_the_derivative_chapters_has_one_exact_check():
    for chapter_id in DERIVATIVE_CHAPTERS:
        chapter = check_registry.load(chapter_id)
        exact = [c for c in chapter.checks if c.exact_derivative]
        assert len({c.function for c in exact}) == len(exact) >= 2, chapter_id
        assert all(c.id == f"{c.function}_exact" and c.points == 1 for c in exact)
    assert {c.function for cid in DERIVATIVE_CHAPTERS for c in check_registry.load(cid).checks if c.exact_derivative} \
        >= {"H_jacobian", "H3_jacobian", "lidar_to_world_jacobian", "lidar_pose_jacobian", "planner_cost_gradient",
            "spherical_to_cartesian_jacobian", "bicycle_control_jacobian", "F_jacobian", "polar_to_cartesian_jacobian"}
    assert not any(c.exact_derivative for info in CHAPTERS if info.id not in DERIVATIVE_CHAPTERS
                   for c in check_registry.load(info.id).checks)


def test_numerical_H_and_lidar_jacobians_lose_the_exact_check_and_nothing_else(tmp_path):
    report = grade_code(_numerical_submission(tmp_path / "numerical"), ["ch04", "ch06"])
    by_chapter = {c.chapter: c for c in report.chapters}
    assert _lost(by_chapter["ch06"]) == [("H_jacobian", "H_jacobian_exact")]
    assert _lost(by_chapter["ch04"]) == [("lidar_to_world_jacobian", "lidar_to_world_jacobian_exact")]
    for chapter, function in (("ch06", "H_jacobian"), ("ch04", "lidar_to_world_jacobian")):
        check = next(c for c in by_chapter[chapter].checks if c.id == f"{function}_exact")
        assert check.status == Status.FAIL and check.mistake == "finite difference", check.message
        assert "as a finite difference does" in check.help and "digits only" in check.help, check.help


def test_the_course_can_turn_the_exact_checks_off(tmp_path):
    """Then the numerical Jacobians get full marks, and the chapters' maximum drops by those checks' points."""
    root = _numerical_submission(tmp_path / "numerical")
    off = courses.Course(exact_derivatives=False)
    report = build_report(open_session(root), Request(("ch04", "ch06"), 20261122, quiz=False), off)
    for chapter in report.chapters:
        registered = check_registry.load(chapter.chapter)
        assert not any(c.id.endswith("_exact") for c in chapter.checks)
        assert chapter.score == chapter.max_score == registered.max_score - len(registered.exact_derivative_ids)


def test_the_course_setting_is_validated_with_file_and_line(tmp_path):
    path = tmp_path / "course.yaml"
    path.write_text("course: c1\nseed: 12\nexact_derivatives: maybe\n", encoding="utf-8")
    with pytest.raises(courses.CourseError, match=r"course\.yaml, line 3: exact_derivatives is true or false"):
        courses._from_yaml(path)
    path.write_text("course: c1\nexact_derivative: false\n", encoding="utf-8")
    with pytest.raises(courses.CourseError, match=r"line 2: unknown setting\(s\) exact_derivative"):
        courses._from_yaml(path)
    path.write_text("course: c1\nseed: 12\nexact_derivatives: false\n", encoding="utf-8")
    assert courses._from_yaml(path).exact_derivatives is False
    assert courses.current(str(Path("solutions") / "course.yaml")).exact_derivatives is True


def test_a_handout_of_a_course_without_exact_checks_records_none_and_grades_none(tmp_path):
    from grader.course import release

    off = courses.Course(seed=12, exact_derivatives=False)
    recorded = release.record(off).data
    assert recorded["ch06"] and not any(check.endswith("_exact") for chapter in recorded.values() for check in chapter)
    handout = tmp_path / "handout.json"
    handout.write_text(json.dumps({"course": "c1", "public_seed": 20261122, "exact_derivatives": False, "hidden": {}}),
                       encoding="utf-8")
    from grader.core.pipeline import switched_off

    assert switched_off(courses._from_handout(handout), ("ch06",)) == {"ch06/H_jacobian_exact", "ch06/H3_jacobian_exact"}


@pytest.mark.slow
def test_grade_batch_honours_the_course_setting(tmp_path):
    from grader.course.batch import run_batch

    submissions = tmp_path / "submissions"
    _numerical_submission(submissions / "ada")
    config = tmp_path / "course.yaml"
    config.write_text("course: c1\nseed: 12\nexact_derivatives: false\n", encoding="utf-8")
    run_batch(submissions, tmp_path / "out", chapters=["ch06"], jobs=1, seed=12, html=False,
              course=courses._from_yaml(config))
    data = json.loads((tmp_path / "out" / "ada" / "report.json").read_text(encoding="utf-8"))
    ch06 = data["chapters"][0]
    assert ch06["code_score"] == ch06["code_max_score"] and not any(c["id"].endswith("_exact") for c in ch06["checks"])


def _jax_module(module: str, functions: dict[str, str], x64: bool) -> str:
    head = "import jax\nimport jax.numpy as jnp\n" + ('jax.config.update("jax_enable_x64", True)\n' if x64 else "")
    return replace_functions(module, functions).replace("import numpy as np\n", "import numpy as np\n" + head, 1)


JAX_JACOBIANS = {
    "ch06_measurement": {
        "H_jacobian": """
            def H_jacobian(x, y):
                if x == 0 and y == 0:
                    raise ValueError("H is undefined at r = 0")
                measure = lambda p: jnp.stack([jnp.hypot(p[0], p[1]), jnp.arctan2(p[1], p[0])])
                return jax.jacfwd(measure)(jnp.array([x, y], dtype=float))
            """,
        "H3_jacobian": """
            def H3_jacobian(x, y, z):
                if x == 0 and y == 0:
                    raise ValueError("no bearing on the z-axis")
                measure = lambda p: jnp.stack([jnp.sqrt(p[0] ** 2 + p[1] ** 2 + p[2] ** 2), jnp.arctan2(p[1], p[0]),
                                               jnp.arctan2(p[2], jnp.hypot(p[0], p[1]))])
                return jax.jacfwd(measure)(jnp.array([x, y, z], dtype=float))
            """},
    "ch04_chain_rule": {
        "lidar_pose_jacobian": """
            def lidar_pose_jacobian(r, theta, pose):
                def world(q):
                    c, s = jnp.cos(q[2]), jnp.sin(q[2])
                    local = jnp.array([r * jnp.cos(theta), r * jnp.sin(theta)])
                    return jnp.stack([c * local[0] - s * local[1] + q[0], s * local[0] + c * local[1] + q[1]])
                return jax.jacfwd(world)(jnp.asarray(pose, dtype=float))
            """},
}


def _jax_submission(root: Path, x64: bool) -> Path:
    return build_submission(root, {module: _jax_module(module, functions, x64)
                                   for module, functions in JAX_JACOBIANS.items()})


@pytest.mark.slow
@needs_jax
@pytest.mark.parametrize("x64", [False, True], ids=["float32", "float64"])
def test_jax_jacobians_pass_in_float64_and_get_the_float64_hint_in_float32(tmp_path, x64):
    if not HAVE_JAX:
        pytest.fail("CI must have jax (the test extras install it)")
    report = grade_code(_jax_submission(tmp_path / "jax", x64), ["ch04", "ch06"])
    lost = [item for chapter in report.chapters for item in _lost(chapter)]
    if x64:
        assert lost == []
        return
    assert sorted(lost) == [("H3_jacobian", "H3_jacobian_exact"), ("H_jacobian", "H_jacobian_exact"),
                            ("lidar_pose_jacobian", "lidar_pose_jacobian_exact")]
    for chapter in report.chapters:
        for check in (c for c in chapter.checks if c.id.endswith("_exact") and c.status == Status.FAIL):
            assert check.mistake == "single precision", check.message
            assert 'jax.config.update("jax_enable_x64", True)' in check.help
            assert "torch.float64" in check.help
