"""A check made again from a kept verdict (a batch worker's memo) is rendered once per verdict: every renderer gives
what it would give the same check made afresh, and a check changed since it was made is rendered afresh."""

from __future__ import annotations

import copy
import pickle

from hypothesis import given, settings
from hypothesis import strategies as st

from grader import safe_text
from grader.model import ChapterResult, CheckResult, Report, Status
from grader.course.history import kept_report
from grader.render import html, lms


def _kept_chapter(message: str = "H[1][0] differs", description: str = "H at (3, 4)", got: object = None) -> dict:
    """A chapter as a memo keeps it (to_kept): a failed code check with its matrices and the entries that differ, a
    passed one, one with a named mistake and its hint, one that errored."""
    checks = [
        CheckResult("H_worked_example", "H_jacobian", description, Status.FAIL, 0, 2, message=message,
                    expected=[[0.6, 0.8], [-0.16, 0.12]], got=got if got is not None else [[0.6, 0.8], [0.16, 0.12]],
                    details={"wrong": [[1, 0]], "digits": 6}),
        CheckResult("H_shape", "H_jacobian", "H is 2x2", Status.PASS, 1, 1),
        CheckResult("H_rows", "H_jacobian", "rows of H", Status.FAIL, 0, 1, message="the bearing row's sign",
                    mistake="bearing_sign", help="d(bearing)/dx is -y / r^2", upstream=["range_of"]),
        CheckResult("H_at_origin", "H_jacobian", "H at the origin", Status.ERROR, 0, 1, message="ZeroDivisionError"),
    ]
    return ChapterResult("ch06", "The range-bearing Jacobian H", checks).to_kept()


def _renders(chapter: ChapterResult) -> list:
    report = Report("learner", [chapter])
    cleaned = safe_text.clean_report(report, safe_text.for_html, html._KNOWN_CLEAN).chapters[0]
    return [[check.to_dict("ch06") for check in chapter.checks], chapter.to_kept(),
            [str(html._check_html(check, "ch06")) for check in cleaned.checks],
            [(check.message, check.description, check.got) for check in cleaned.checks],
            str(html._checks_html(chapter, 2)), lms.gradescope(report, hidden={"ch06/H_shape"}),
            kept_report(report), report.to_kept()]


def test_a_check_made_from_a_kept_verdict_renders_as_the_same_check_made_afresh_and_once():
    kept = _kept_chapter()
    first, second = ChapterResult.from_dict(kept, kept=True), ChapterResult.from_dict(kept, kept=True)
    assert _renders(first) == _renders(ChapterResult.from_dict(kept)) == _renders(second)
    # made once: the second learner's check gives the very dict and block the first one's made
    assert second.checks[0].to_dict("ch06") is first.checks[0].to_dict("ch06")
    assert html._check_html(second.checks[0], "ch06") is html._check_html(first.checks[0], "ch06")
    # never for a check made afresh
    afresh = ChapterResult.from_dict(kept)
    assert afresh.checks[0].to_dict("ch06") is not afresh.checks[0].to_dict("ch06")


def test_a_check_changed_after_it_was_made_is_rendered_afresh():
    kept = _kept_chapter()
    ChapterResult.from_dict(kept, kept=True).to_kept()  # its renders made once
    changed = ChapterResult.from_dict(kept, kept=True)
    changed.checks[0].message = "H_jacobian calls your range_of, which fails its own checks: fix it first.\nH[1][0]"
    changed.checks[1].upstream.append("range_of")  # in place
    changed.checks[2].details["wrong"] = [[0, 1]]  # in place
    changed.checks[3].status = Status.FAIL
    fresh = [CheckResult(**{name: copy.deepcopy(getattr(c, name)) for name in CheckResult.__dataclass_fields__})
             for c in changed.checks]
    assert _renders(changed) == _renders(ChapterResult("ch06", changed.title, fresh))
    assert "fix it first" in changed.checks[0].to_dict("ch06")["message"]
    assert changed.checks[1].to_dict("ch06")["upstream"] == ["range_of"]
    assert "fail" in html._check_html(changed.checks[3], "ch06").split('"')[1]
    # the very check whose render was made once, its list changed in place after
    same = ChapterResult.from_dict(_kept_chapter(), kept=True)
    assert same.checks[1].to_dict("ch06")["upstream"] == []
    same.checks[1].upstream.append("range_of")
    assert same.checks[1].to_dict("ch06")["upstream"] == ["range_of"]


def test_a_kept_verdict_changed_in_place_is_rendered_afresh():
    kept = _kept_chapter()
    before = ChapterResult.from_dict(kept, kept=True).checks[0].to_dict("ch06")
    kept["checks"][0]["message"] = "another message"
    after = ChapterResult.from_dict(kept, kept=True).checks[0].to_dict("ch06")
    assert before["message"] == "H[1][0] differs" and after["message"] == "another message"


def test_a_pickled_or_copied_check_leaves_the_kept_verdict_behind():
    """The report a worker sends the coordinator carries its checks' fields only, not the memo's dicts."""
    kept = _kept_chapter()
    made, afresh = ChapterResult.from_dict(kept, kept=True), ChapterResult.from_dict(kept)
    assert pickle.dumps(made) == pickle.dumps(afresh)
    for again in (pickle.loads(pickle.dumps(made.checks[0])), copy.copy(made.checks[0]),
                  copy.deepcopy(made.checks[0])):
        assert again == afresh.checks[0]
        assert again.to_dict("ch06") is not again.to_dict("ch06")  # not made once: a copy is not the kept verdict's


_TEXT = st.text(st.characters(blacklist_categories=("Cs",)) | st.sampled_from("\x1b\x00\r\x7f\u202e\u2028<>&'\""),
                max_size=30)


@settings(max_examples=150, deadline=None)
@given(message=_TEXT, description=_TEXT, got=st.one_of(_TEXT, st.lists(st.lists(st.floats(allow_nan=False), min_size=2,
                                                                                  max_size=2), min_size=1, max_size=2)))
def test_every_render_of_a_kept_check_is_that_of_the_check_made_afresh(message, description, got):
    """Whatever the texts (control characters, bidirectional marks, markup), rendered once or afresh alike, and the
    learner's text cleaned for the page either way."""
    kept = _kept_chapter(message, description, got)
    made_once = _renders(ChapterResult.from_dict(kept, kept=True))
    assert made_once == _renders(ChapterResult.from_dict(kept)) == _renders(ChapterResult.from_dict(kept, kept=True))
    assert all("\x1b" not in block for block in made_once[2])
