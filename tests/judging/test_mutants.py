"""Named mistakes that generalise (grader.judging.mutants, grader.judging.diagnose): slips nobody listed are named from the
reference's own single-slip variants, in one sentence of the lesson's language, kept apart from the message as
the result's help; a mistake is named only when it explains every failing input of a check; a slip that equals
the right answer at a check's inputs is never named; a handout names the same mistakes from recorded values;
and a check whose inputs cannot tell a slip of the reference from the right answer is reported here."""

from __future__ import annotations

import json
import shutil

import numpy as np
import pytest

from grader.chapters import CHAPTERS
from grader.checks import load
from grader.core.grading import DEFAULT_SEED
from grader.core.planning import ChapterPlan
from grader.judging import expected, mutants
from grader.judging.diagnose import Evidence, Mistake, explain, weigh
from grader.model import CheckResult, Report, Status
from grader.render.html import render as render_html
from grader.render.text import render_check
from tests.support import REPO, build_submission, grade_code, replace_function

# The slips of held-out submissions that no catalogue entry lists: (module, function, the learner's source,
# the check aimed at, the sentence it must get).
SLIPS = {
    "the polar Jacobian in degrees": ("ch03_jacobian", "polar_to_cartesian_jacobian", """
        def polar_to_cartesian_jacobian(r, theta):
            t = np.radians(theta)
            return np.array([[np.cos(t), -r * np.sin(t)], [np.sin(t), r * np.cos(t)]])
        """, "polar_to_cartesian_jacobian_random_points", "the angles are read as degrees: they are in radians."),
    "area_scale returning r^2": ("ch03_jacobian", "area_scale", """
        def area_scale(r, theta):
            return float(r) ** 2
        """, "area_scale_is_r", "your result is the right value squared: a power one too high (or a variance where a "
                                "standard deviation belongs)."),
    "the tangent plane without f(a)": ("ch02_gradient", "tangent_plane", """
        def tangent_plane(f, grad, a, x):
            a, x = np.asarray(a, dtype=float), np.asarray(x, dtype=float)
            return float(np.dot(grad(a), x - a))
        """, "tangent_plane_random_inputs", "your value equals the right one without its term f(a)."),
    "a central difference over h": ("ch05_finite_differences", "central_difference", """
        def central_difference(f, x, h):
            return (f(x + h) - f(x - h)) / h
        """, "central_difference_random_inputs", "your quotient is twice the right value: a factor 2 too many (or a "
                                                 "division by 2 missing)."),
    "the mean Jacobian error": ("ch05_finite_differences", "max_jacobian_error", """
        def max_jacobian_error(jac, f, x, h=1e-5):
            x = np.asarray(x, dtype=float)
            return float(np.mean(np.abs(np.asarray(jac(x)) - jacobian_fd(f, x, h))))
        """, "max_jacobian_error_wrong_jacobian", "this takes the mean where the largest value belongs."),
    "the motion model on the new heading": ("ch07_dynamics", "motion_model", """
        def motion_model(state, v, omega, dt):
            x, y, th = np.asarray(state, dtype=float)
            th_new = th + omega * dt
            return np.array([x + v * np.cos(th_new) * dt, y + v * np.sin(th_new) * dt, th_new])
        """, "motion_model_random_inputs", "you move with the new th, after the step, where the old one belongs: the "
                                           "step starts from the state as given."),
    "gradient_fd on an integer array": ("ch09_choose_your_tool", "gradient_fd", """
        def gradient_fd(f, x, h=1e-5):
            x = np.asarray(x)
            g = np.zeros(len(x))
            for i in range(len(x)):
                xp = x.copy(); xp[i] += h
                xm = x.copy(); xm[i] -= h
                g[i] = (f(xp) - f(xm)) / (2 * h)
            return g
        """, "gradient_fd_integer_input", "integer arithmetic: with an integer x the points where you evaluate are "
                                          "truncated to integers (x + h is x again); convert x to float first "
                                          "(np.asarray(x, dtype=float))."),
    "best_step returning the index": ("ch05_finite_differences", "best_step", """
        def best_step(f, fprime, x, hs):
            errors = [abs(central_difference(f, x, h) - fprime(x)) for h in hs]
            return int(np.argmin(errors))
        """, "best_step_random_inputs", "this is the index of the entry of hs you chose, not the entry itself."),
    "the contour direction not normalised": ("ch02_gradient", "contour_direction", """
        def contour_direction(x, y):
            gx, gy = bowl_gradient(x, y)
            if gx == 0 and gy == 0:
                raise ValueError("no direction at the origin")
            return np.array([gy, -gx])
        """, "contour_direction_is_unit_and_perpendicular", "your value is not normalised: divide it by the norm it is "
                                                            "measured against (a vector by its length)."),
    "gradient_fd with a halved step (statsmodels' form)": ("ch09_choose_your_tool", "gradient_fd", """
        def gradient_fd(f, x, h=1e-5):
            x = np.asarray(x, dtype=float)
            g = np.zeros(x.size)
            for i in range(x.size):
                e = np.zeros(x.size)
                e[i] = h / 2
                g[i] = (f(x + e) - f(x - e)) / h
            return g
        """, "gradient_fd_uses_the_step_as_given", "the step h is used as h/2: use it exactly as given."),
}
BEARING_OFF_BY_PI = {
    "atan2(-y, -x)": "return np.array([np.hypot(x, y), np.arctan2(-y, -x)])",
    "atan2(y, x) + pi": "return np.array([np.hypot(x, y), np.arctan2(y, x) + np.pi])",
}


def _graded(tmp_path, module: str, function: str, source: str) -> dict[str, CheckResult]:
    root = build_submission(tmp_path / "slip", {module: replace_function(module, function, source)})
    return {c.id: c for c in grade_code(root, [module[:4]]).chapters[0].checks}


@pytest.mark.parametrize("name", list(SLIPS))
def test_a_slip_nobody_listed_gets_its_sentence(tmp_path, name):
    module, function, source, aimed, sentence = SLIPS[name]
    check = _graded(tmp_path, module, function, source)[aimed]
    assert check.status == Status.FAIL and check.points == 0, check.message
    assert check.help == sentence, (check.mistake, check.help, check.message)
    assert check.mistake and sentence not in check.message  # the rationale says what is wrong, the help what to change


def test_gradient_fd_with_a_halved_step_loses_the_step_as_given_check(tmp_path):
    module, function, source, aimed, _ = SLIPS["gradient_fd with a halved step (statsmodels' form)"]
    checks = _graded(tmp_path, module, function, source)
    assert checks[aimed].status == Status.FAIL
    failed = {c.id for c in checks.values() if c.status != Status.PASS and c.function == function}
    assert failed == {aimed}  # the small steps of the other checks cannot show it


@pytest.mark.parametrize("form", list(BEARING_OFF_BY_PI))
def test_a_bearing_off_by_pi_everywhere_is_named_as_that_not_as_atan(tmp_path, form):
    source = f"def range_bearing(x, y):\n    {BEARING_OFF_BY_PI[form]}\n"
    check = _graded(tmp_path, "ch06_measurement", "range_bearing", source)["range_bearing_all_quadrants"]
    assert check.status == Status.FAIL
    # atan(y/x) matches the points left of the dish, where the two coincide, and not the others: not named
    assert check.mistake == "reversed bearing" and "off by pi everywhere" in check.help, (check.mistake, check.help)


def test_atan_for_atan2_is_still_named_where_it_explains_every_failure(tmp_path):
    source = "def range_bearing(x, y):\n    return np.array([np.hypot(x, y), np.arctan(y / x)])\n"
    check = _graded(tmp_path, "ch06_measurement", "range_bearing", source)["range_bearing_all_quadrants"]
    assert check.status == Status.FAIL and check.mistake == "atan"


def test_no_diagnosis_on_right_submissions(tmp_path):
    ids = [c.id for c in CHAPTERS]
    references = grade_code(REPO, ids, "solutions")
    package = tmp_path / "contract" / "exercises"
    shutil.copytree(REPO / "tests" / "fixtures" / "contract_submission", package)
    (package / "__init__.py").write_text("", encoding="utf-8")
    contract = grade_code(tmp_path / "contract", sorted(p.stem[:4] for p in package.glob("ch*.py")))
    for report in (references, contract):
        checks = [c for ch in report.chapters for c in ch.checks]
        assert all(c.status == Status.PASS for c in checks)
        assert [(c.id, c.mistake, c.help) for c in checks if c.mistake or c.help] == []


# ------------------------------------------------------------------------------ the rule, on its own

def _slip(key: str, help: str = "", value=None, name: str = "sign") -> Mistake:
    return Mistake(name, help or f"slip {key}.", value, "generated", key)


def test_a_slip_equal_to_the_right_answer_at_an_input_says_nothing_there():
    right = np.array([1.0, 2.0])
    evidence = weigh(right * 2, right, [_slip("same", value=right), _slip("double", value=right * 2),
                                        _slip("other", value=-right)], 1e-9, 1e-12)
    assert list(evidence.matched) == ["double"] and evidence.ruled_out == {"other"}


def test_a_mistake_must_explain_every_failing_input_and_be_told_apart_at_no_passing_one():
    a, b = _slip("a", "slip a."), _slip("b", "slip b.", name="power")
    assert explain([Evidence({"a": a}), Evidence({"a": a, "b": b})]) is a
    assert explain([Evidence({"a": a}), Evidence({"b": b})]) is None  # each explains one input only
    assert explain([Evidence({"a": a})], [Evidence(ruled_out={"a"})]) is None  # a passing input tells it apart
    assert explain([Evidence({"a": a}), None]) is None  # a failure nothing can explain (no value to compare)


def test_two_slips_that_say_different_things_alike_name_nothing_but_one_kind_is_said_as_that_kind():
    a, b = _slip("a", "a minus where a plus belongs."), _slip("b", "a plus where a minus belongs.")
    named = explain([Evidence({"a": a, "b": b})])
    assert named is not None and named.help == "one sign is wrong."
    c = _slip("c", "a power is off by one.", name="power")
    assert explain([Evidence({"a": a, "c": c})]) is None
    own = Mistake("slope at x", "the slope is taken at x.")
    assert explain([Evidence({"a": a, own.id: own})]) is own  # a check's own entry keeps precedence


# ------------------------------------------------------------------------------ the handout names the same

def test_a_handout_names_the_same_mistakes_from_recorded_values_and_holds_no_mutated_source(tmp_path):
    module, function, source, aimed, sentence = SLIPS["the tangent plane without f(a)"]
    chapter = module[:4]
    recording = expected.Recording(seed=DEFAULT_SEED)
    with expected.using(recording):
        ChapterPlan(load(chapter), DEFAULT_SEED)
    written = recording.write(tmp_path / "data")
    slips_file = tmp_path / "data" / f"{chapter}.mutants.json"
    assert slips_file in written
    root = build_submission(tmp_path / "slip", {module: replace_function(module, function, source)})
    with expected.using(expected.Replay(tmp_path / "data")):
        replayed = {c.id: c for c in grade_code(root, [chapter]).chapters[0].checks}
    live = {c.id: c for c in grade_code(root, [chapter]).chapters[0].checks}
    assert replayed[aimed].help == live[aimed].help == sentence
    assert [(c.id, c.mistake, c.help) for c in replayed.values()] == [(c.id, c.mistake, c.help) for c in live.values()]
    text = slips_file.read_text(encoding="utf-8")
    data = json.loads(text)
    assert set(data) == {"seed", "mistakes", "checks"}
    sources = [m.source for f in {c.function for c in load(chapter).checks} for m in mutants.mutants(chapter, f)]
    lines = {line.strip() for s in sources for line in s.splitlines()[1:] if len(line.strip()) >= 20}
    assert not [line for line in lines if line in text]


@pytest.mark.slow
def test_the_secrecy_scan_finds_a_mutated_reference_in_a_handout(tmp_path):
    from grader.course import release

    slip = next(m for m in mutants.mutants("ch02", "tangent_plane") if m.help.endswith("without its term f(a)."))
    (tmp_path / "notes.py").write_text(f"# what a right answer is not\n{slip.source}\n", encoding="utf-8")
    (tmp_path / "harmless.py").write_text("def tangent_plane(f, grad, a, x):\n    raise NotImplementedError\n",
                                          encoding="utf-8")
    found = release.scan(tmp_path)
    assert found and all(line.startswith("notes.py: ") for line in found), found


# ------------------------------------------------------------------------------ the result keeps its help apart

def test_the_help_is_a_field_of_its_own_in_every_output():
    check = CheckResult("c", "f", "d", Status.FAIL, 0.0, 1.0, message="f(1): got 2, expected 1", mistake="factor 2",
                        help="your value is a factor of 2 too large.")
    data = check.to_dict("ch05")
    assert data["help"] == check.help and check.help not in data["message"]
    report = Report("s", seed=1)
    from grader.model import ChapterResult

    report.chapters.append(ChapterResult("ch05", "t", [check]))
    again = Report.from_dict(report.to_dict()).chapters[0].checks[0]
    assert again.help == check.help
    lines = render_check(check, colour=False, unicode_ok=True, verbose=False)
    assert lines[-1] == f"      hint: {check.help}" and all(check.help not in line for line in lines[:-1])
    html = render_html(report)
    assert '<p class="help"><strong>Hint:</strong> your value is a factor of 2 too large.</p>' in html
    assert CheckResult("c", "f", "d", Status.PASS, 1.0, 1.0).to_dict().get("help") is None


# ------------------------------------------------------------------------------ inputs that cannot tell a slip

# Slips of the sampling functions that change the draw but not its distribution: graded statistically (the
# contract), they are right answers, not weak inputs. (chapter, function, kind, sentence)
SAME_DISTRIBUTION = {
    ("ch00", "mean_shift", "sign", mutants.SIGN),  # mean - sigma N(0, 1)
    ("ch08", "sample_positions", "sign", mutants.SIGN),
    ("ch08", "linearization_mismatch", "arguments swapped",  # the cloud mirrored in x = y: the same mismatch
     "x and y are swapped: the arguments are (x, y, sigma, n, seed)."),
}


class _ReferenceValues(expected.Live):
    """The live references without their generated slips: this report asks only whether a check fails."""

    def slips(self, *args) -> list:
        return []


def _returned(function: str, compute) -> object:
    """What the child would send for `compute()`: its value, or the exception it raised."""
    from grader.boundary.wire import RAISED_EVENT, RETURNED, encode_value, from_event

    try:
        with mutants.quiet():
            value = compute()
    except Exception as exc:  # noqa: BLE001  (a slip may raise anything; the checks judge it as they would)
        error = {"exception": type(exc).__name__, "message": str(exc), "traceback": "",
                 "bases": [k.__name__ for k in type(exc).__mro__]}
        return from_event(function, {"event": RAISED_EVENT, "error": error})
    return from_event(function, {"event": RETURNED, "value": encode_value(value)})


def _failing_checks(chapter: str, function: str, slip: mutants.Mutant, exclude: frozenset = frozenset()) -> list:
    """The checks of `function` that fail for a learner whose `function` is the slip (and every other function the
    reference's), judged by the checks themselves on the values that learner's calls return."""
    from grader.boundary.session import ChapterRun

    others = frozenset(f"{chapter}/{c.id}" for c in load(chapter).checks if c.function != function)
    with expected.using(_ReferenceValues(memo=True)):
        plan = ChapterPlan(load(chapter), DEFAULT_SEED, exclude=others | exclude)
        results = []
        for call in plan.calls:
            target = slip.function if call.function == function else mutants.reference(chapter, call.function)
            arguments = mutants.arguments_of(call)
            results.append(_returned(call.function, lambda t=target, a=arguments: t(*a()[0], **a()[1])))
        judged = plan.judge(ChapterRun(chapter, None, results), f"{chapter}.py")
    return [c.id for c in judged.checks if c.status != Status.PASS]


def untold_slips(chapter: str, function: str, exclude: frozenset = frozenset()) -> list[tuple]:
    """(chapter, function, kind, sentence) of every slip of `function`'s reference that no check of it tells from
    right, though it gives other values than the reference at random inputs (it is not the right function written
    otherwise): the checks' inputs cannot see it."""
    calls = [c for c in ChapterPlan(load(chapter), DEFAULT_SEED).calls if c.function == function]
    rng = np.random.default_rng(0)
    probes = [mutants.perturbed(c, rng) for c in calls for _ in range(3)]
    return [(chapter, function, slip.name, slip.help) for slip in mutants.mutants(chapter, function)
            if not _failing_checks(chapter, function, slip, exclude) and mutants.told_apart(chapter, slip, probes)]


def test_the_report_finds_a_check_whose_inputs_cannot_tell_a_halved_step():
    halved = ("ch09", "gradient_fd", "step as given", "the step h is used as h/2: use it exactly as given.")
    assert halved in untold_slips("ch09", "gradient_fd", frozenset({"ch09/gradient_fd_uses_the_step_as_given"}))
    assert halved not in untold_slips("ch09", "gradient_fd")


@pytest.mark.slow
@pytest.mark.parametrize("chapter", [c.id for c in CHAPTERS])
def test_every_slip_of_a_reference_is_told_from_right_by_some_check(chapter):
    untold = [slip for function in dict.fromkeys(c.function for c in load(chapter).checks)
              for slip in untold_slips(chapter, function) if slip not in SAME_DISTRIBUTION]
    assert untold == [], "change these checks' inputs so that they tell the slip from the right answer"
