"""The maps beyond the worked examples (the contract's section of that name): the reference solutions get
full marks on every one, at several seeds; so does a submission written from the contract alone
(tests/fixtures/contract_submission, not from solutions/); a one-bug submission of each map (the
misconception corpus) loses points on that function and only on functions declared to build on it; and
every graded input keeps the contract's distance from the singular points, but the one call of each
function the contract says must raise."""

from __future__ import annotations

import shutil
import sys

import numpy as np
import pytest

from grader import checks as check_registry
from grader.boundary.wire import Array
from grader.chapters import BY_ID
from grader.core.grading import DEFAULT_SEED
from grader.core.planning import ChapterPlan
from grader.judging import expected
from grader.model import Status
from tests.support import (
    BEYOND_THE_WORKED_EXAMPLES,
    REPO,
    build_submission,
    first_of_each,
    grade_code,
    replace_function,
)

sys.path.insert(0, str(REPO / "benchmarks"))
from misconceptions import CODE  # noqa: E402

CHAPTERS = sorted(BEYOND_THE_WORKED_EXAMPLES)
NEW_MAPS = {f for functions in BEYOND_THE_WORKED_EXAMPLES.values() for f in functions}
COURSE_SEED = 731904562  # solutions/course.yaml's: what grade batch grades at
CONTRACT_SUBMISSION = REPO / "tests" / "fixtures" / "contract_submission"


@pytest.mark.parametrize("seed", [DEFAULT_SEED, COURSE_SEED, 5])
def test_reference_solutions_get_full_marks_on_every_new_map(seed):
    report = grade_code(REPO, CHAPTERS, "solutions", seed=seed)
    for chapter in report.chapters:
        functions = {c.function for c in chapter.checks}
        assert set(BEYOND_THE_WORKED_EXAMPLES[chapter.chapter]) <= functions
        assert [(c.id, c.message) for c in chapter.checks if c.status != Status.PASS] == [], chapter.chapter


@pytest.mark.parametrize("seed", [DEFAULT_SEED, COURSE_SEED])
def test_a_submission_written_from_the_contract_alone_gets_full_marks(tmp_path, seed):
    package = tmp_path / "exercises"
    shutil.copytree(CONTRACT_SUBMISSION, package)
    (package / "__init__.py").write_text("", encoding="utf-8")
    assert sorted(p.stem for p in package.glob("ch*.py")) == [BY_ID[c].module for c in CHAPTERS]
    report = grade_code(tmp_path, CHAPTERS, seed=seed)
    failed = [(ch.chapter, c.id, c.message) for ch in report.chapters for c in ch.checks if c.status != Status.PASS]
    assert failed == []
    assert report.score == report.max_score == sum(check_registry.load(c).max_score for c in CHAPTERS)


def _dependents(chapter: str, function: str) -> set[str]:
    """The functions declared (CHECKS.uses) to build on `function`."""
    return {f for f, helpers in check_registry.load(chapter).builds_on.items() if function in helpers}


BUGS = [name for name, (_, function, _, _) in CODE.items() if function in NEW_MAPS]


def test_the_corpus_has_one_bug_submissions_of_every_new_map():
    assert {CODE[name][1] for name in BUGS} == NEW_MAPS


@pytest.mark.parametrize("name", first_of_each(BUGS, lambda name: CODE[name][0]))
def test_a_one_bug_submission_loses_points_on_that_function_only(tmp_path, name):
    module, function, source, _ = CODE[name]
    chapter_id = module[:4]
    root = build_submission(tmp_path / "bug", {module: replace_function(module, function, source)})
    chapter = grade_code(root, [chapter_id]).chapters[0]
    lost = {c.function for c in chapter.checks if c.points < c.max_points}
    assert function in lost
    assert lost - {function} <= _dependents(chapter_id, function), (lost, name)


def _values(arg) -> np.ndarray:
    return np.asarray(arg.values if isinstance(arg, Array) else arg, dtype=float)


def _outside(function: str, args: tuple) -> str:
    """Why a call's arguments are closer to a singular point than the contract allows, or ''."""
    if function in ("planner_cost", "planner_cost_gradient"):
        distance = float(np.hypot(args[0] - _values(args[2])[0], args[1] - _values(args[2])[1]))
        return f"distance {distance} to the obstacle" if distance < 0.5 else ""
    if function in ("spherical_to_cartesian", "spherical_to_cartesian_jacobian", "volume_scale"):
        return f"r {args[0]} or elevation {args[2]}" if args[0] < 0.3 or abs(args[2]) > 1.4 else ""
    if function in ("lidar_to_world", "lidar_to_world_jacobian", "lidar_pose_jacobian"):
        return f"r {args[0]}" if args[0] < 0.3 else ""
    if function in ("range_bearing_elevation", "H3_jacobian"):
        x, y, z = (float(a) for a in args)
        ground = x * x + y * y
        lift = abs(np.arctan2(z, np.sqrt(ground)))
        return f"x^2 + y^2 = {ground}, elevation {lift}" if ground < 0.1 or lift > 1.4 else ""
    if function in ("bicycle_model", "bicycle_control_jacobian", "control_noise_covariance"):
        return f"steer {args[2]}" if abs(args[2]) > 1 else ""
    return ""


@pytest.mark.parametrize("seed", [DEFAULT_SEED, COURSE_SEED, 3])
def test_graded_inputs_keep_away_from_the_singular_points(seed):
    """Every call of every check of the new maps, finite-difference steps included; a ValueError is asked for
    only by the checks that call a function exactly at the singular point the contract names."""
    raising = {"planner_cost_raises_at_the_obstacle", "planner_cost_gradient_raises_at_the_obstacle",
               "H3_raises_on_the_z_axis"}
    with expected.using(expected.Live()):
        for chapter_id in CHAPTERS:
            plan = ChapterPlan(check_registry.load(chapter_id), seed)
            for check, pending in plan.pending:
                calls = [plan.calls[i] for i in pending.slots if plan.calls[i].function in NEW_MAPS]
                if check.id in raising:
                    assert calls and all(_outside(c.function, c.args) for c in calls), check.id
                    continue
                for c in calls:
                    assert not _outside(c.function, c.args), (check.id, c.label, _outside(c.function, c.args))


@pytest.mark.slow
def test_the_lidar_scan_is_drawn_in_the_world_frame_from_the_learners_lidar_to_world(tmp_path):
    """ch04's second plot: the learner's lidar_to_world moves a scan into the world (a point not rotated by the
    heading lands elsewhere, and the text says where); without a usable function the reference is drawn."""
    from grader.render.figures import figures

    module, function, source, _ = CODE["lidar point not rotated"]
    unrotated = build_submission(tmp_path / "bug", {module: replace_function(module, function, source)})
    for root, package, whose in ((REPO, "solutions", "drawn from your lidar_to_world"),
                                 (unrotated, "exercises", "drawn from your lidar_to_world"),
                                 (REPO, "exercises", "shows the reference only")):
        chapter = grade_code(root, ["ch04"], package, with_plots=True).chapters[0]
        data = chapter.plots["lidar_world"]
        drawn = [f for f in figures(chapter) if "lidar scan" in f.caption]
        assert len(drawn) == 1 and drawn[0].uri.startswith("data:image/svg+xml;base64,") and whose in drawn[0].caption
        if package == "solutions":
            assert np.allclose(data["learner"], data["reference"])
        elif root == unrotated:
            learner, reference = np.asarray(data["learner"]), np.asarray(data["reference"])
            assert not np.allclose(learner, reference) and np.allclose(learner.mean(0), np.asarray(data["local"]).mean(0)
                                                                       + np.asarray(data["pose"][:2]))
            x, y = learner.mean(0)
            assert f"your lidar_to_world put the 48 returns around [{x:.4g}, {y:.4g}] (reference: [" in drawn[0].gave
        else:
            assert data["learner"] is None


def test_the_readme_lists_every_function_with_its_points():
    """README's table of chapters says what the registry grades: each function's points, the exact-derivative
    ones starred, the maps beyond the worked examples in italics, and each chapter's total."""
    import re

    rows = {}
    for line in (REPO / "README.md").read_text(encoding="utf-8").splitlines():
        match = re.match(r"\| (ch\d\d) [^|]+\| (.+) \| (\d+) \|$", line)
        if match:
            rows[match[1]] = (match[2], float(match[3]))
    assert sorted(rows) == sorted(BY_ID)
    for chapter_id, (functions, total) in rows.items():
        chapter = check_registry.load(chapter_id)
        assert total == chapter.max_score, chapter_id
        listed = {}
        for name, points, star in re.findall(r"\*?(\w+)\*? \((\d+)(\*?)\)", functions):
            listed[name] = (float(points), star == "*", f"*{name}*" in functions)
        expected = {}
        for check in chapter.checks:
            points, exact, _ = expected.get(check.function, (0.0, False, False))
            expected[check.function] = (points + check.points, exact or check.exact_derivative,
                                        check.function in BEYOND_THE_WORKED_EXAMPLES.get(chapter_id, ()))
        assert listed == expected, chapter_id
