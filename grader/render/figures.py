"""The HTML report's figures: what matplotlib draws from the data the report's gatherers collected in the child
(grader/checks/plots.py), values the learner's functions returned with the reference beside them. Where the
learner's values are missing, a plot shows the reference and its caption says so; a plot that fails to draw
becomes a note, never a broken report. matplotlib loads only here (`preload`, `draw`).

Drawn in processes of their own where possible (grader.render.drawer) and kept between runs
(grader.render.figure_cache); the page (grader.render.html) only places them.
"""

from __future__ import annotations

import base64
import functools
import io

import numpy as np

from grader.model import ChapterResult
from grader.render import plural

# Plot colours, each at least 5:1 on white (WCAG 2.1 1.4.11 asks 3:1 for graphics); series are also
# told apart by marker or line style, never by colour alone.
LEARNER, REFERENCE, GUIDE = "#c2410c", "#2563eb", "#6b7280"


class Figure:
    """One drawn figure: its SVG as a data URI, its text alternative and caption, and in numbers what the
    learner's own functions gave."""

    def __init__(self, uri: str, alt: str, caption: str, width: int = 640, height: int = 300, gave: str = "") -> None:
        self.uri, self.alt, self.caption, self.width, self.height = uri, alt, caption, width, height
        self.gave = gave  # what the learner's own functions gave, in numbers (also in alt)


def svg_uri(fig) -> str:
    buffer = io.BytesIO()
    # no date in the file: a reused figure is the same figure; fixed margins: bbox_inches="tight" would
    # draw everything twice
    fig.savefig(buffer, format="svg", metadata={"Date": None})
    return "data:image/svg+xml;base64," + base64.b64encode(buffer.getvalue()).decode("ascii")


def _whose(learner_ok: bool, what: str) -> str:
    return (f"drawn from your {what}" if learner_ok else
            f"your {what} gave no usable value, so this shows the reference only")


def _ellipse(ax, center, cov, **style) -> None:
    values, vectors = np.linalg.eigh(np.asarray(cov, dtype=float)[:2, :2])
    angles = np.linspace(0, 2 * np.pi, 100)
    circle = np.stack([np.cos(angles), np.sin(angles)])
    points = vectors @ (np.sqrt(np.maximum(values, 0))[:, None] * 2 * circle)
    ax.plot(center[0] + points[0], center[1] + points[1], **style)


def _draw_ch00(ax, d):
    sig = np.array(d["sigma"])
    ax.plot(sig, d["reference"], "o--", color=REFERENCE, label="reference")
    ok = all(v is not None for v in d["learner"])
    if ok:
        ax.plot(sig, d["learner"], "s-", color=LEARNER, label="your mean_shift")
    ax.plot(sig, sig**2 / (2 * d["r"]), ":", color=GUIDE, label="sigma^2 / 2r")
    ax.set(xlabel="sigma", ylabel="mean range - range of mean", title="The cloud's mean range moves outward")
    ax.legend(fontsize=8)
    return ok, "Mean shift of the range at (3, 4) as the position noise grows; " + _whose(ok, "mean_shift")


def _draw_ch01(fig, d):
    ax1, ax2 = fig.subplots(1, 2)
    x = np.array(d["x"])
    ax1.plot(x, d["f"], color="black", label="sqrt(x)")
    ok_line = d["line"] is not None
    ax1.plot(x, d["line"] if ok_line else d["line_ref"], "--", color=LEARNER if ok_line else REFERENCE,
             label="your tangent line" if ok_line else "reference tangent line")
    ax1.plot([d["a"]], [2.0], "ko")
    ax1.set(xlabel="x", title="Tangent line at a = 4")
    delta = np.array(d["delta"])
    ok_err = d["error"] is not None
    ax2.loglog(delta, d["error"] if ok_err else d["error_ref"], "o-", color=LEARNER if ok_err else REFERENCE,
               label="your linearization_error" if ok_err else "reference error")
    ax2.loglog(delta, delta**2 / 64, ":", color=GUIDE, label="delta^2 / 64 guide")
    ax2.set(xlabel="delta", title="Error grows like delta^2")
    for ax in (ax1, ax2):
        ax.legend(fontsize=8)
    ok = ok_line and ok_err
    return ok, "Left: sqrt and its tangent line at 4; right: the error against delta with a delta^2 guide; " + \
        _whose(ok, "tangent_line and linearization_error")


def _draw_ch02(ax, d):
    grid = np.linspace(-3, 3, 80)  # a quadratic's contours are smooth: 80 points draw them as well as 200
    X, Y = np.meshgrid(grid, grid)
    ax.contour(X, Y, X**2 + 0.5 * X * Y + Y**2, levels=8, colors=GUIDE, linewidths=0.8)
    ok = all(v is not None for v in d["learner"])
    vectors = np.array(d["learner"] if ok else d["reference"], dtype=float)
    points = np.array(d["points"])
    ax.quiver(points[:, 0], points[:, 1], vectors[:, 0], vectors[:, 1], color=LEARNER if ok else REFERENCE,
              angles="xy", scale_units="xy", scale=6)
    ax.set(aspect="equal", title="Gradient arrows on the contours of g")
    return ok, "Contour rings of g = x^2 + 0.5xy + y^2 with gradient arrows, perpendicular to the rings; " + \
        _whose(ok, "bowl_gradient")


def _draw_jacobian_circle(ax, jac, ok, center, radius, image=None):
    angles = np.linspace(0, 2 * np.pi, 100)
    circle = radius * np.stack([np.cos(angles), np.sin(angles)])
    mapped = np.asarray(jac, dtype=float) @ circle
    if image is not None:
        image = np.asarray(image)
        ax.plot(image[:, 0], image[:, 1], color="black", lw=2, label="true image")
    ax.plot(center[0] + mapped[0], center[1] + mapped[1], "--", color=LEARNER if ok else REFERENCE,
            label="through your J" if ok else "through the reference J")
    ax.set(aspect="equal")
    ax.legend(fontsize=8)


def _draw_ch03(ax, d):
    ok = d["learner"] is not None
    r, t, rad = d["r"], d["theta"], d["radius"]
    _draw_jacobian_circle(ax, d["learner"] if ok else d["reference"], ok, d["center"], rad, d["image"])
    ax.set(title="A small (r, theta) circle mapped to (x, y)")
    return ok, f"A circle of radius {rad} around (r, theta) = ({r}, {t}) mapped by the polar map (black) and by J " \
               "(dashed); " + _whose(ok, "polar_to_cartesian_jacobian")


def _draw_ch04(ax, d):
    ok = d["learner"] is not None
    _draw_jacobian_circle(ax, d["learner"] if ok else d["reference"], ok, d["center"], d["radius"], d["image"])
    ax.set(title="Two-stage map g(p(r, theta)) and its Jacobian")
    return ok, "A small circle around (r, theta) = (1.5, 0.9) through both stages (black) and through the composed " \
               "Jacobian (dashed); " + _whose(ok, "pipeline_jacobian")


def _draw_lidar_world(ax, d):
    """ch04's second plot (grader.checks.plots.ch04_lidar_world): a lidar scan moved into the world frame."""
    ok = d["learner"] is not None
    local, world = np.asarray(d["local"], dtype=float), np.asarray(d["learner"] if ok else d["reference"], dtype=float)
    px, py, phi = d["pose"]
    ax.plot(local[:, 0], local[:, 1], "+", color=GUIDE, ms=4, linestyle="none", label="the scan, as the lidar sees it")
    ax.plot(world[:, 0], world[:, 1], "o" if ok else "x", color=LEARNER if ok else REFERENCE, ms=3, linestyle="none",
            label="in the world, by your lidar_to_world" if ok else "in the world, by the reference")
    ax.plot([px], [py], "^", color="black", linestyle="none", label="the robot (arrow: its heading)")
    ax.annotate("", xy=(px + np.cos(phi), py + np.sin(phi)), xytext=(px, py),
                arrowprops={"arrowstyle": "->", "color": "black"})
    ax.set(aspect="equal", xlabel="x", ylabel="y", title="A lidar scan moved into the world frame")
    ax.legend(fontsize=7, loc="upper left")
    return ok, (f"A lidar scan of a room (crosses, in the lidar's own frame) moved into the world frame for the robot "
                f"at ({px:g}, {py:g}) heading {phi:g} rad: the room turns by the heading and moves to the robot; "
                + _whose(ok, "lidar_to_world"))


def _draw_ch05(ax, d):
    h = np.array(d["h"])
    ok = d["forward"] is not None and d["central"] is not None
    tiny = 1e-17
    ax.loglog(h, np.maximum(d["forward"] if ok else d["forward_ref"], tiny), "o-",
              color=LEARNER if ok else REFERENCE, label="forward")
    ax.loglog(h, np.maximum(d["central"] if ok else d["central_ref"], tiny), "s--",
              color="#7c3aed" if ok else REFERENCE, label="central")
    ax.loglog(h, 0.5 * h, ":", color=GUIDE, label="slope 1")
    ax.loglog(h, 0.1 * h**2, "-.", color=GUIDE, label="slope 2")
    ax.set(xlabel="h", ylabel="|error|", ylim=(1e-17, 1), title="Finite-difference error of d sin/dx at 1")
    ax.legend(fontsize=8)
    return ok, "Log-log error against h: truncation falls with slope 1 (forward) and 2 (central) until " \
               "rounding takes over; " + _whose(ok, "forward_difference and central_difference")


def _draw_ch06(ax, d):
    r = np.array(d["r"])
    ok = d["learner"] is not None
    ax.loglog(r, d["reference"], "--", color=REFERENCE, label="reference sigma / r")
    if ok:
        ax.loglog(r, d["learner"], "o", color=LEARNER, ms=4, label="your measurement_covariance")
    ax.set(xlabel="range r", ylabel="bearing std (rad)", title="Bearing sensitivity grows near the dish")
    ax.legend(fontsize=8)
    return ok, f"Linearized bearing standard deviation against range, sigma = {d['sigma']}; " + \
        _whose(ok, "measurement_covariance")


def _draw_ch07(ax, d):
    ok = d["P_new"] is not None
    _ellipse(ax, (0, 0), d["P"], linestyle=":", color=GUIDE, label="P before")
    _ellipse(ax, d["mean_new"], d["P_new"] if ok else d["P_new_ref"], linestyle="-", color=LEARNER if ok else REFERENCE,
             label="F P F^T after" + ("" if ok else " (reference)"))
    ax.set(aspect="equal", xlabel="x", ylabel="y", title="Covariance ellipse tilts after one step")
    ax.legend(fontsize=8)
    return ok, "2-sigma position ellipses before and after one motion step; " + _whose(ok, "propagate_covariance")


def _draw_ch08(fig, d):
    axes = fig.subplots(1, 2)
    ok = True
    for ax, name, title in zip(axes, ("far", "close"), ("far: (3, 4)", "close: (0.3, 0.2)")):
        case = d[name]
        z = np.array(case["z"])
        ax.plot(z[:, 0], z[:, 1], ".", ms=2, color=GUIDE if case["z_is_reference"] else LEARNER,
                label="reference samples" if case["z_is_reference"] else "your measure_samples")
        cov_ok = case["cov"] is not None
        _ellipse(ax, case["center"], case["cov"] if cov_ok else case["cov_ref"],
                 color=REFERENCE if not cov_ok else "black",
                 label="your 2-sigma ellipse" if cov_ok else "reference 2-sigma ellipse")
        ax.legend(fontsize=7, markerscale=4)
        ok = ok and cov_ok and not case["z_is_reference"]
        ax.set(xlabel="range", ylabel="bearing", title=title)
    return ok, "Monte Carlo measurement clouds with the 2-sigma linearized ellipse, far from and close to the dish; " \
        + _whose(ok, "measure_samples and linearized_measurement_cov")


def _draw_ch09(ax, d):
    ok = d["H"] is not None
    H = np.array(d["H"] if ok else d["H_ref"], dtype=float)
    grid = np.linspace(-2, 2, 80)  # a quadratic's contours are smooth: 80 points draw them as well as 200
    X, Y = np.meshgrid(grid, grid)
    Q = 0.5 * (H[0, 0] * X**2 + 2 * H[0, 1] * X * Y + H[1, 1] * Y**2)
    # one dark colour: matplotlib draws the negative levels dashed, so the sign is told by line style
    ax.contour(X, Y, Q, levels=12, colors="#374151", linewidths=0.9)
    kind = str(d["kind"] or d["kind_ref"])[:60]
    # the learner's text, drawn as plain text: a '$' would start matplotlib's math parser
    ax.set(aspect="equal", title=f"Quadratic model from the Hessian: {kind}".replace("$", r"\$"))
    return ok, "Contours of the quadratic model 0.5 v^T H v (solid where positive, dashed where negative) with " \
        "H at (1, 2) from " + \
        ("your hessian_fd" if ok else "the reference (your hessian_fd gave no usable value)") + \
        f"; your classify_critical_point says: {d['kind'] or 'nothing usable'}"


_DRAW = {"ch00": _draw_ch00, "ch01": _draw_ch01, "ch02": _draw_ch02, "ch03": _draw_ch03, "ch04": _draw_ch04,
         "ch05": _draw_ch05, "ch06": _draw_ch06, "ch07": _draw_ch07, "ch08": _draw_ch08, "ch09": _draw_ch09}
TWO_PANELS = {"ch01", "ch08"}


# What each plot's learner functions gave, in numbers: the plot's text alternative (WCAG 1.1.1) says
# it in its alt text and caption, with the reference beside it where the plot draws one.
def _g(value) -> str:
    """A number, or a nested list of numbers, in 4 significant digits; None as 'nothing usable'."""
    if value is None:
        return "nothing usable"
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_g(v) for v in value) + "]"
    try:
        return f"{float(value):.4g}"
    except (TypeError, ValueError):
        return "nothing usable"


def _at(values, index: int):
    return None if values is None else values[index]


def _samples(n: int) -> list[int]:
    """First, middle and last index of a curve of n points."""
    return sorted({0, n // 2, n - 1})


def _curve(name: str, xname: str, xs, got, ref) -> str:
    picks = _samples(len(xs))
    said = "; ".join(f"{_g(_at(got, i))} at {xname} = {_g(xs[i])}" for i in picks)
    return f"your {name} gave {said} (reference: {', '.join(_g(ref[i]) for i in picks)})"


def _gave_ch00(d) -> str:
    learner = d["learner"] if any(v is not None for v in d["learner"]) else None
    return _curve("mean_shift", "sigma", d["sigma"], learner, d["reference"])


def _gave_ch01(d) -> str:
    return (_curve("tangent_line", "x", d["x"], d["line"], d["line_ref"]) + "; " +
            _curve("linearization_error", "delta", d["delta"], d["error"], d["error_ref"]))


def _gave_ch02(d) -> str:
    picks = range(0, len(d["points"]), 8)  # one point on each ring
    said = "; ".join(f"{_g(d['learner'][i])} at {_g(d['points'][i])}" for i in picks)
    return f"your bowl_gradient gave {said} (reference: {', '.join(_g(d['reference'][i]) for i in picks)})"


def _gave_ch03(d) -> str:
    return (f"your polar_to_cartesian_jacobian({_g(d['r'])}, {_g(d['theta'])}) gave {_g(d['learner'])} "
            f"(reference: {_g(d['reference'])})")


def _gave_ch04(d) -> str:
    r, theta = d["point"]
    return f"your pipeline_jacobian({_g(r)}, {_g(theta)}) gave {_g(d['learner'])} (reference: {_g(d['reference'])})"


def _gave_lidar_world(d) -> str:
    def centre(points):
        return None if points is None else np.asarray(points, dtype=float).mean(axis=0).tolist()

    return (f"your lidar_to_world put the {len(d['reference'])} returns around {_g(centre(d['learner']))} "
            f"(reference: {_g(centre(d['reference']))}); the first at {_g(_at(d['learner'], 0))} "
            f"(reference: {_g(d['reference'][0])})")


def _gave_ch05(d) -> str:
    return (_curve("forward_difference's error", "h", d["h"], d["forward"], d["forward_ref"]) + "; " +
            _curve("central_difference's error", "h", d["h"], d["central"], d["central_ref"]))


def _gave_ch06(d) -> str:
    return _curve("measurement_covariance's bearing standard deviation", "range", d["r"], d["learner"], d["reference"])


def _gave_ch07(d) -> str:
    return (f"your propagate_covariance gave {_g(d['P_new'])} (reference: {_g(d['P_new_ref'])}); "
            f"your F_jacobian gave {_g(d['F'])}")


def _gave_ch08(d) -> str:
    parts = []
    for name in ("far", "close"):
        case = d[name]
        if case["z_is_reference"]:
            cloud = "your measure_samples gave nothing usable (the reference cloud is drawn)"
        else:
            z = np.asarray(case["z"], dtype=float)
            cloud = (f"your measure_samples gave {plural(len(z), 'point')}, mean range {_g(z[:, 0].mean())}, "
                     f"mean bearing {_g(z[:, 1].mean())}")
        parts.append(f"{name} {_g(case['point'])}: {cloud}; your linearized_measurement_cov gave "
                     f"{_g(case['cov'])} (reference: {_g(case['cov_ref'])})")
    return "; ".join(parts)


def _gave_ch09(d) -> str:
    kind = str(d["kind"])[:80] if d["kind"] is not None else "nothing usable"
    return (f"your hessian_fd gave {_g(d['H'])} (reference: {_g(d['H_ref'])}); "
            f"your classify_critical_point gave {kind} (reference: {d['kind_ref']})")


def _gave_any(d) -> str:
    """A plot with no describer of its own: its 'learner' numbers, if it has them."""
    if isinstance(d, dict) and "learner" in d:
        return f"your function gave {_g(d['learner'])}"
    return ""


_GAVE = {"ch00": _gave_ch00, "ch01": _gave_ch01, "ch02": _gave_ch02, "ch03": _gave_ch03, "ch04": _gave_ch04,
         "ch05": _gave_ch05, "ch06": _gave_ch06, "ch07": _gave_ch07, "ch08": _gave_ch08, "ch09": _gave_ch09}
# a chapter's further plots, by the "plot" their data names (drawer, describer)
_NAMED = {"lidar_world": (_draw_lidar_world, _gave_lidar_world)}


def gave(chapter: str, data: dict) -> str:
    """What the learner's own functions gave for one plot, in numbers ('' if that cannot be said)."""
    try:
        said = (_NAMED[data["plot"]][1] if "plot" in data else _GAVE.get(chapter, _gave_any))(data)
    except (KeyError, IndexError, TypeError, ValueError):
        return ""
    return f"In numbers: {said}." if said else ""


def _light_ticks(fig) -> None:
    """At most four labelled ticks per axis and no minor ticks: every tick is a small drawing of its own
    (most of a figure's cost), and four read as well as nine. Log-axis labels as plain text (1e-05, 0.01):
    matplotlib's default 10^k labels go through its mathtext parser, which costs more than the rest."""
    from matplotlib.ticker import FuncFormatter, LogLocator, MaxNLocator, NullLocator

    plain = FuncFormatter(lambda value, _: f"{value:g}")
    for ax in fig.axes:
        for axis, scale in ((ax.xaxis, ax.get_xscale()), (ax.yaxis, ax.get_yscale())):
            if scale == "log":
                axis.set_major_locator(LogLocator(numticks=4))
                axis.set_major_formatter(plain)
            else:
                axis.set_major_locator(MaxNLocator(nbins=4))
            axis.set_minor_locator(NullLocator())


@functools.cache
def preload() -> None:
    """Import matplotlib (about 0.3 s), once; called in a thread while grading waits on the child. Figures
    are made without pyplot (its registry of open figures is for interactive use)."""
    import matplotlib

    matplotlib.use("Agg")
    matplotlib.rcParams["svg.fonttype"] = "none"  # text stays text: smaller and faster than glyph paths
    # titles just above the axes (no ticks are on top): else matplotlib measures every tick label of each
    # axes to place its title, a quarter of a figure's cost
    matplotlib.rcParams["axes.titley"] = 1.0
    # the SVG's ids from a fixed salt, not a fresh random one: the same values draw the same file (each figure
    # is an image of its own, so equal ids in two figures never meet)
    matplotlib.rcParams["svg.hashsalt"] = "jacobians-grader"
    import warnings

    skipped = _without_what_figures_never_read()
    try:
        with warnings.catch_warnings():
            warnings.filterwarnings("ignore", message="Unable to import Axes3D")  # said while the 3D toolkit is held back
            import matplotlib.backends.backend_svg  # noqa: F401
            import matplotlib.figure  # noqa: F401
    finally:
        _put_back(skipped)


_NO_3D = "mpl_toolkits.mplot3d"
_SET_HOOK = "_update_set_signature_and_docstring"


def _without_what_figures_never_read() -> dict:
    """Two parts of matplotlib's import that no figure of ours reads, skipped while matplotlib.figure loads where
    this matplotlib has them as they are here, untouched otherwise (about a third of the import, some 0.2 s):
    - for each Artist class it defines, matplotlib writes the signature and docstring of its `set` by inspecting
      every setter (help() text; `set` itself works the same), and property tables into other docstrings;
    - importing its projections registers the 3D toolkit, which the report never draws.
    Returns what _put_back restores once matplotlib.figure is loaded (later classes and imports as ever)."""
    import sys

    from matplotlib import artist

    skipped: dict = {}
    hook = vars(artist.Artist).get(_SET_HOOK)
    if isinstance(hook, classmethod) and callable(getattr(artist, "kwdoc", None)):
        def _flag_only(cls) -> None:
            cls.set._autogenerated_signature = True  # what the hook marks: subclasses get theirs the same way

        skipped["hook"], skipped["kwdoc"] = hook, artist.kwdoc
        setattr(artist.Artist, _SET_HOOK, classmethod(_flag_only))
        artist.kwdoc = lambda _artist: ""
    if "matplotlib.projections" not in sys.modules and _NO_3D not in sys.modules:
        sys.modules[_NO_3D] = None  # type: ignore[assignment]  an import of it fails, and matplotlib goes on
        skipped["3d"] = True
    return skipped


def _put_back(skipped: dict) -> None:
    import sys

    from matplotlib import artist

    if "hook" in skipped:
        setattr(artist.Artist, _SET_HOOK, skipped["hook"])
        artist.kwdoc = skipped["kwdoc"]
    if skipped.get("3d") and sys.modules.get(_NO_3D, 0) is None:
        del sys.modules[_NO_3D]


def draw(chapter_id: str, data: dict):
    """One plot of a chapter as a matplotlib figure, with its caption: (figure, caption)."""
    preload()
    from matplotlib.figure import Figure

    fig = Figure(figsize=(9, 3.4) if chapter_id in TWO_PANELS else (6, 3.6))
    target = fig if chapter_id in TWO_PANELS else fig.add_subplot()
    _, caption = (_NAMED[data["plot"]][0] if "plot" in data else _DRAW[chapter_id])(target, data)
    _light_ticks(fig)
    fig.subplots_adjust(left=0.12, right=0.97, bottom=0.15, top=0.9, wspace=0.3)
    return fig, caption


def figures(chapter: ChapterResult) -> list[Figure]:
    """The chapter's plots as data-URI images, each with a text alternative that says in numbers what
    the learner's functions gave; a plot that cannot be drawn becomes a caption only."""
    if chapter.chapter not in _DRAW or not chapter.plots:
        return []
    out = []
    for data in chapter.plots.values():
        numbers = gave(chapter.chapter, data)
        try:
            fig, caption = draw(chapter.chapter, data)
        except Exception as exc:  # a plot never breaks the report
            out.append(Figure("", "", f"This plot could not be drawn ({type(exc).__name__}: {exc}).", gave=numbers))
            continue
        try:
            alt = f"{chapter.chapter} plot: {caption}. {numbers}".strip()
            out.append(Figure(svg_uri(fig), alt, caption, 900 if chapter.chapter in TWO_PANELS else 600, 340,
                               numbers))
        except Exception as exc:
            out.append(Figure("", "", f"This plot could not be drawn ({type(exc).__name__}: {exc}).", gave=numbers))
    return out
