"""The class summary's figure per chapter: each item's facility against its discrimination on axes fitted to the
items, labelled (by their number in the chapter's table; a flagged one by its name too) where no label overlaps
another or leaves the figure, the flagging rules' bounds in view as guide lines; drawn by matplotlib as the HTML
report's figures are (grader.render.figures: an SVG data URI with a text alternative that says the same in
numbers). It reads only the numbers grader.course.statistics computed."""

from __future__ import annotations

from typing import NamedTuple

from grader.render.figures import GUIDE, LEARNER, REFERENCE, Figure, preload, svg_uri


def figures(statistics: dict) -> dict[str, Figure]:
    """Per chapter, its facility-discrimination figure (a figure that cannot be drawn is a caption saying so);
    drawn by the drawing process the batch started (grader.render.drawer.start), else by two processes forked now
    where forking is safe and nothing else runs in this process (a batch's end: its workers are done), else here."""
    jobs = [(chapter["chapter"], [item for item in statistics["items"] if item["chapter"] == chapter["chapter"]],
             statistics["rules"], statistics["learners"]) for chapter in statistics["chapters"]]
    return dict(zip((job[0] for job in jobs), _drawn(jobs)))


def _drawn(jobs: list[tuple]) -> list[Figure]:
    from grader.render.drawer import drawn_by_started, two_processes
    from grader.system import forkable_now

    drawn = drawn_by_started((__name__, _one.__name__), jobs) if jobs else None  # the one a batch started
    if drawn is not None:
        return drawn
    preload()  # imported once, here, before any fork
    if len(jobs) > 1 and forkable_now():
        try:
            with two_processes() as pool:
                return list(pool.map(_one, jobs))
        except Exception:  # noqa: BLE001, S110  no process could be forked, or one died: drawn here instead
            pass
    return [_one(job) for job in jobs]


def _one(job: tuple) -> Figure:
    try:
        return _figure(*job)
    except Exception as exc:  # noqa: BLE001  a figure never costs the summary
        return Figure("", "", f"This figure could not be drawn ({type(exc).__name__}: {exc}).")


def _short(item: dict) -> str:
    return item["id"].split("/", 1)[1]


class Canvas(NamedTuple):
    """A chapter's figure drawn: the matplotlib Figure, the labels that fit nowhere, the rules' bounds in view."""

    figure: object
    unlabelled: list[str]
    guides: list[str]


def canvas(chapter: str, items: list[dict], rules: dict, learners: int) -> Canvas:
    """The chapter's figure as a matplotlib Figure, drawn: axes fitted to the items' range, the rules' guide lines
    that fall inside it, and each label placed where it overlaps no other text, marker or the legend and stays inside
    the figure (items at one spot share a label; one that fits nowhere is left to the table, and `unlabelled` says
    which)."""
    preload()
    from matplotlib.figure import Figure as MatplotlibFigure

    fig = MatplotlibFigure(figsize=(7.5, 4.6))
    ax = fig.add_subplot()
    placed = [i for i in items if i["facility"] is not None and i["discrimination"] is not None]
    for flagged, colour, marker, label in ((False, REFERENCE, "o", "item"), (True, LEARNER, "^", "flagged item")):
        group = [i for i in placed if bool(i["flags"]) is flagged]
        if group:
            ax.scatter([i["facility"] for i in group], [i["discrimination"] for i in group], s=28, color=colour,
                       marker=marker, label=label, zorder=3)
    x_range = _fitted([i["facility"] for i in placed], 0.0, 1.0)
    y_range = _fitted([i["discrimination"] for i in placed], -1.0, 1.0)
    ax.set(xlim=x_range, ylim=y_range, xlabel="facility (mean share of the item's points)",
           ylabel="discrimination (with the rest of the score)")
    shown = []
    for x in (rules["facility_low"], rules["facility_high"]):
        if x_range[0] < x < x_range[1]:
            ax.axvline(x, color=GUIDE, linestyle=":", linewidth=1)
            shown.append(f"facility {x:g}")
    if y_range[0] < rules["discrimination_low"] < y_range[1]:
        ax.axhline(rules["discrimination_low"], color=GUIDE, linestyle=":", linewidth=1)
        shown.append(f"discrimination {rules['discrimination_low']:g}")
    ax.set_title(f"{chapter}: facility against discrimination ({learners} learners)", loc="left", fontsize=10)
    if placed:
        ax.legend(fontsize=8, loc="lower right", bbox_to_anchor=(1.0, 1.0), ncols=2, frameon=False,
                  borderaxespad=0.2)
    fig.subplots_adjust(left=0.1, right=0.97, bottom=0.12, top=0.9)
    return Canvas(fig, _place_labels(fig, ax, items, placed), shown)


def _fitted(values: list[float], lowest: float, highest: float) -> tuple[float, float]:
    """Axis limits around `values` with a margin (at least a tenth of the scale wide), within lowest and highest
    widened by the margin."""
    if not values:
        return lowest, highest
    low, high = min(values), max(values)
    width = max(high - low, 0.1 * (highest - lowest))
    middle = (low + high) / 2
    low, high = middle - width / 2, middle + width / 2
    if low < lowest:
        low, high = lowest, lowest + width
    if high > highest:
        low, high = highest - width, highest
    margin = 0.08 * width
    return low - margin, high + margin


_OFFSETS = [(dx * r, dy * r) for r in (4, 10, 18) for dx, dy in
            ((1, 0.5), (1, -1.5), (-1, 0.5), (-1, -1.5), (0, 1), (0, -2.5), (1.5, 1), (-1.5, -2.5))]


def _place_labels(fig, ax, items: list[dict], placed: list[dict]) -> list[str]:
    """Label the placed items (by number, a flagged one by its name too), each where its text overlaps nothing
    already drawn and stays inside the figure; items whose markers fall within a few pixels of each other share a
    label. Returns the labels that fit nowhere (their items are in the chapter's table)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.transforms import Bbox

    renderer = FigureCanvasAgg(fig).get_renderer()  # matplotlib's own text extents, as the SVG's text is laid out
    numbers = {id(item): number for number, item in enumerate(items, 1)}
    at = {id(item): ax.transData.transform((item["facility"], item["discrimination"])) for item in placed}
    groups: list[list[dict]] = []
    for item in sorted(placed, key=lambda i: (not i["flags"], numbers[id(i)])):  # flagged ones first
        near = next((g for g in groups if abs(at[id(g[0])] - at[id(item)]).max() < 5), None)
        if near is None:
            groups.append([item])
        else:
            near.append(item)
    taken = [Bbox.from_extents(x - 4, y - 4, x + 4, y + 4) for x, y in at.values()]  # the markers
    taken += [text.get_window_extent(renderer) for text in (ax.title, ax.xaxis.label, ax.yaxis.label)]
    legend = ax.get_legend()
    if legend is not None:
        taken.append(legend.get_window_extent(renderer))
    inside = fig.bbox.padded(-2)
    unlabelled = []
    for group in groups:
        label = ", ".join(f"{numbers[id(i)]} {_short(i)}" if i["flags"] else str(numbers[id(i)]) for i in group)
        flagged = any(i["flags"] for i in group)
        note = ax.annotate(label, (group[0]["facility"], group[0]["discrimination"]), textcoords="offset points",
                           xytext=(0, 0), fontsize=7 if flagged else 6, color="#111827" if flagged else "#374151",
                           annotation_clip=False)
        for offset in _OFFSETS:
            note.set_position(offset)
            box = note.get_window_extent(renderer)
            if inside.contains(box.x0, box.y0) and inside.contains(box.x1, box.y1) and \
                    not any(box.overlaps(other) for other in taken):
                taken.append(box)
                break
        else:
            note.remove()
            unlabelled.append(label)
    return unlabelled


def _figure(chapter: str, items: list[dict], rules: dict, learners: int) -> Figure:
    drawn = canvas(chapter, items, rules, learners)
    placed = [i for i in items if i["facility"] is not None and i["discrimination"] is not None]
    guides = f"dotted lines at the flagging rules' bounds in view ({', '.join(drawn.guides)})" if drawn.guides else \
        "no flagging rule's bound falls in view"
    caption = (f"{chapter}: each item's facility against its discrimination, the axes fitted to the items; {guides}; "
               "flagged items as triangles, with their names; the numbers are those of the chapter's table of items")
    if drawn.unlabelled:
        caption += f"; not labelled where they would overlap: {'; '.join(drawn.unlabelled)}"
    return Figure(svg_uri(drawn.figure), f"{caption}. {_in_numbers(items, placed)}", caption, 750, 460,
                  _in_numbers(items, placed))


def _in_numbers(items: list[dict], placed: list[dict]) -> str:
    """The figure in words: every flagged item with its two numbers, the range of the others."""
    flagged = [i for i in placed if i["flags"]]
    others = [i for i in placed if not i["flags"]]
    said = [f"{len(items)} items"]
    if flagged:
        said.append("flagged: " + "; ".join(f"{_short(i)} (facility {i['facility']:.2f}, discrimination "
                                            f"{i['discrimination']:.2f})" for i in flagged))
    if others:
        said.append(f"the other {len(others)}: facility {min(i['facility'] for i in others):.2f} to "
                    f"{max(i['facility'] for i in others):.2f}, discrimination "
                    f"{min(i['discrimination'] for i in others):.2f} to {max(i['discrimination'] for i in others):.2f}")
    missing = len(items) - len(placed)
    if missing:
        said.append(f"{missing} not placed (every learner got the same points: no discrimination)")
    return "In numbers: " + "; ".join(said) + "."
