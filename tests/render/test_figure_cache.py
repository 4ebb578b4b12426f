"""The HTML report's figures kept between runs (grader.render.figure_cache): reused while a chapter's plot
data is unchanged, drawn again when it changes, never trusted when damaged, and off when asked."""

from __future__ import annotations

import base64
import json
import os
import sys
from pathlib import Path

import pytest

from grader.render.figure_cache import FigureCache, default_folder
from grader.system import fork_is_safe
from tests.support import (
    build_submission,
    processes_with,
    replace_function,
    run_grade,
)

SVG_MARK = "data:image/svg+xml;base64," + base64.b64encode(b"<svg xmlns='http://www.w3.org/2000/svg'>"
                                                             b"<title>kept</title></svg>").decode()


def _grade_html(args: list[str], out: Path, cache: str | None, home: Path | None = None) -> str:
    environment = {k: v for k, v in os.environ.items() if k not in ("GRADER_CACHE_DIR", "XDG_CACHE_HOME")}
    if cache is not None:
        environment["GRADER_CACHE_DIR"] = cache
    if home is not None:
        environment["HOME"] = str(home)
    proc = run_grade(*args, "--html", out, env=environment)
    assert proc.returncode in (0, 1), proc.stderr[-2000:]
    return out.read_text(encoding="utf-8")


def _mark(entry: Path) -> None:
    """Replace the kept figure's image by a marked one, under the same key: a report showing the mark
    took its figure from the cache."""
    kept = json.loads(entry.read_text(encoding="utf-8"))
    kept["figures"][0]["uri"] = SVG_MARK
    entry.write_text(json.dumps(kept), encoding="utf-8")


@pytest.mark.slow
def test_figures_are_reused_while_a_chapters_plot_data_is_unchanged_and_drawn_when_it_changes(tmp_path):
    cache = tmp_path / "cache"
    first = _grade_html(["ch06", "ch07", "--solutions"], tmp_path / "first.html", str(cache))
    assert first.count("data:image/svg+xml;base64,") == 2
    entries = cache / "figures"
    assert sorted(p.name for p in entries.iterdir()) == ["ch06.json", "ch07.json"]
    _mark(entries / "ch06.json")
    _mark(entries / "ch07.json")

    again = _grade_html(["ch06", "ch07", "--solutions"], tmp_path / "again.html", str(cache))
    assert again.count(SVG_MARK) == 2  # both taken from the cache

    # a learner's ch06 whose measurement_covariance is off by a factor: ch06's plot data changes, ch07's not
    doubled = ("def measurement_covariance(x, y, sigma):\n"
               "    H = H_jacobian(x, y)\n"
               "    return 2 * float(sigma) ** 2 * (H @ H.T)\n")
    learner = build_submission(tmp_path / "learner", {"ch06_measurement": replace_function(
        "ch06_measurement", "measurement_covariance", doubled)})
    edited = _grade_html(["ch06", "ch07", "--submission", str(learner)], tmp_path / "edited.html", str(cache))
    assert edited.count(SVG_MARK) == 1  # ch07's kept figure ...
    assert edited.count("data:image/svg+xml;base64,") == 2  # ... and ch06 drawn again from the learner's values
    assert SVG_MARK not in json.loads((entries / "ch06.json").read_text(encoding="utf-8"))["figures"][0]["uri"]


@pytest.mark.slow
def test_with_the_cache_off_nothing_is_kept_and_by_default_it_is_in_the_users_cache_folder(tmp_path):
    home = tmp_path / "home"
    home.mkdir()
    _grade_html(["ch07", "--solutions"], tmp_path / "off.html", "", home=home)
    assert not any(home.rglob("jacobians-grader"))  # (matplotlib keeps its font list there, its own cache)
    _grade_html(["ch07", "--solutions"], tmp_path / "on.html", None, home=home)
    if sys.platform.startswith("linux"):
        assert (home / ".cache" / "jacobians-grader" / "figures" / "ch07.json").is_file()


@pytest.mark.parametrize("damage", ["not json", "wrong shape", "script uri", "extra field", "other key"])
def test_a_damaged_or_foreign_entry_is_a_miss(tmp_path, damage):
    cache = FigureCache(tmp_path)
    plots = {"ellipse": {"P": [[1.0, 0.0], [0.0, 1.0]], "P_new": None}}
    figure = {"uri": SVG_MARK, "alt": "a", "caption": "c", "width": 600, "height": 340, "gave": ""}
    cache.store("ch07", plots, [figure])
    assert cache.load("ch07", plots) == [figure]
    entry = tmp_path / "ch07.json"
    kept = json.loads(entry.read_text(encoding="utf-8"))
    if damage == "not json":
        entry.write_text("{", encoding="utf-8")
    else:
        if damage == "wrong shape":
            kept["figures"] = {"uri": SVG_MARK}
        elif damage == "script uri":
            kept["figures"][0]["uri"] = "javascript:alert(1)"
        elif damage == "extra field":
            kept["figures"][0]["onload"] = "alert(1)"
        else:
            kept["key"] = "0" * 64
        entry.write_text(json.dumps(kept), encoding="utf-8")
    assert cache.load("ch07", plots) is None
    assert cache.load("ch07", {"ellipse": {"P": [[2.0, 0.0], [0.0, 1.0]], "P_new": None}}) is None


def test_figures_that_could_not_be_drawn_are_not_kept_and_an_unwritable_cache_is_no_error(tmp_path):
    cache = FigureCache(tmp_path / "cache")
    plots = {"p": {"x": [1.0]}}
    cache.store("ch00", plots, [{"uri": "", "alt": "", "caption": "This plot could not be drawn (...)",
                                 "width": 600, "height": 340, "gave": ""}])
    assert not (tmp_path / "cache").exists()
    blocked = tmp_path / "file"
    blocked.write_text("", encoding="utf-8")
    FigureCache(blocked / "cache").store("ch00", plots, [{"uri": SVG_MARK, "alt": "", "caption": "",
                                                          "width": 600, "height": 340, "gave": ""}])


def test_the_default_folder_follows_the_environment(monkeypatch, tmp_path):
    monkeypatch.setenv("GRADER_CACHE_DIR", str(tmp_path))
    assert default_folder() == tmp_path / "figures"
    monkeypatch.setenv("GRADER_CACHE_DIR", "")
    assert default_folder() is None
    monkeypatch.delenv("GRADER_CACHE_DIR")
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    if sys.platform.startswith("linux"):
        assert default_folder() == tmp_path / "xdg" / "jacobians-grader" / "figures"


@pytest.mark.skipif(not fork_is_safe(), reason="the drawing process is forked (Linux)")
def test_a_report_whose_figures_are_all_kept_stops_the_drawing_process_at_once(tmp_path):
    """`grade --html` forks its drawing process before it grades; with every figure kept it has nothing to
    draw, and is stopped then, not left importing matplotlib after the command has ended."""
    cache = str(tmp_path / "cache")
    _grade_html(["ch07", "--solutions"], tmp_path / "first.html", cache)
    out = tmp_path / "second-of-this-test.html"
    _grade_html(["ch07", "--solutions"], out, cache)
    assert not processes_with(str(out))
