"""The class summary's figure per chapter: each item's facility against its discrimination, items labelled (by their
number in the chapter's table; a flagged one by its name too), the flagging rules as guide lines; drawn by matplotlib as the HTML report's figures are (grader.render.figures: an SVG
data URI with a text alternative that says the same in numbers). It reads only the numbers grader.course.statistics
computed."""

from __future__ import annotations

from grader.render.figures import GUIDE, LEARNER, REFERENCE, Figure, preload, svg_uri


def figures(statistics: dict) -> dict[str, Figure]:
    """Per chapter, its facility-discrimination figure (a figure that cannot be drawn is a caption saying so);
    drawn by the drawing process the batch started (grader.render.drawer.start), else by two processes forked now
    where forking is safe and nothing else runs in this process (a batch's end: its workers are done), else here."""
    jobs = [(chapter["chapter"], [item for item in statistics["items"] if item["chapter"] == chapter["chapter"]],
             statistics["rules"], statistics["learners"]) for chapter in statistics["chapters"]]
    return dict(zip((job[0] for job in jobs), _drawn(jobs)))


def _drawn(jobs: list[tuple]) -> list[Figure]:
    from grader.render.drawer import drawn_by_started, forkable, two_processes

    drawn = drawn_by_started((__name__, _one.__name__), jobs) if jobs else None  # the one a batch started
    if drawn is not None:
        return drawn
    preload()  # imported once, here, before any fork
    if len(jobs) > 1 and forkable():
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


def _figure(chapter: str, items: list[dict], rules: dict, learners: int) -> Figure:
    preload()
    from matplotlib.figure import Figure as Canvas

    fig = Canvas(figsize=(7.5, 4.6))
    ax = fig.add_subplot()
    placed = [i for i in items if i["facility"] is not None and i["discrimination"] is not None]
    for flagged, colour, marker, label in ((False, REFERENCE, "o", "item"), (True, LEARNER, "^", "flagged item")):
        group = [i for i in placed if bool(i["flags"]) is flagged]
        if group:
            ax.scatter([i["facility"] for i in group], [i["discrimination"] for i in group], s=28, color=colour,
                       marker=marker, label=label, zorder=3)
    for number, item in enumerate(items, 1):  # by number (the chapter's table has them), flagged ones by name too
        if item in placed:
            label = f"{number} {_short(item)}" if item["flags"] else str(number)
            ax.annotate(label, (item["facility"], item["discrimination"]), xytext=(3, 2), textcoords="offset points",
                        fontsize=7 if item["flags"] else 6, color="#111827" if item["flags"] else "#374151")
    for x in (rules["facility_low"], rules["facility_high"]):
        ax.axvline(x, color=GUIDE, linestyle=":", linewidth=1)
    ax.axhline(rules["discrimination_low"], color=GUIDE, linestyle=":", linewidth=1)
    low = min([-0.1] + [i["discrimination"] for i in placed])
    high = max([0.5] + [i["discrimination"] for i in placed])
    ax.set(xlim=(-0.02, 1.05), ylim=(low - 0.05, min(1.0, high + 0.1)), xlabel="facility (mean share of the item's points)",
           ylabel="discrimination (with the rest of the score)",
           title=f"{chapter}: facility against discrimination ({learners} learners)")
    ax.legend(fontsize=8, loc="upper left")
    fig.subplots_adjust(left=0.1, right=0.97, bottom=0.12, top=0.92)
    caption = (f"{chapter}: each item's facility against its discrimination; dotted lines at the flagging rules "
               f"(facility {rules['facility_low']:g} and {rules['facility_high']:g}, discrimination "
               f"{rules['discrimination_low']:g}); flagged items as triangles, with their names; the numbers are "
               "those of the chapter's table of items")
    return Figure(svg_uri(fig), f"{caption}. {_in_numbers(items, placed)}", caption, 750, 460,
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
