"""Figures a student can read at the size a notebook shows them.

JupyterLab shows an inline figure at its pixel size (figure inches x dpi), shrunk to the output area when wider, so a
label of s points at `dpi` is s * dpi / 72 screen pixels tall. The lab's rule: every label at least 9 pt as the
screen shows it at 100 % zoom (9 pt = 12 CSS px), in a figure at most MAX_WIDTH_PX wide (JupyterLab's output area
beside the file browser on a 1366-px laptop screen, so nothing is shrunk).

    from armlab.viz.figures import readable, check_readable
    readable()                      # once per notebook: dpi 100, fonts >= 9.5 pt
    fig, ax = plt.subplots(figsize=(8, 3))     # no dpi= argument, widths <= 9 in
    check_readable(fig)             # ValueError naming every label that is too small, and a too-wide figure
"""

from __future__ import annotations

__all__ = ["MIN_LABEL_PX", "MAX_WIDTH_PX", "DPI", "MIN_AXES_PX", "UNIT", "readable", "readability_problems",
           "check_readable", "labelling_problems", "figure_record"]

MIN_LABEL_PX = 12.0     # 9 pt at 100 % zoom (96 px per inch)
MAX_WIDTH_PX = 900
DPI = 100


def readable(dpi: int = DPI) -> dict:
    """Set matplotlib's defaults so that new figures follow the rule: figure.dpi `dpi` and every default font at
    least 9.5 pt (13 px at dpi 100). Returns the settings applied."""
    import matplotlib as mpl

    pt = max(9.5, MIN_LABEL_PX * 72.0 / dpi)
    settings = {"figure.dpi": dpi, "savefig.dpi": "figure", "font.size": max(10.0, pt),
                "axes.titlesize": max(11.0, pt), "axes.labelsize": max(10.0, pt), "xtick.labelsize": pt,
                "ytick.labelsize": pt, "legend.fontsize": pt, "legend.title_fontsize": pt,
                "figure.titlesize": max(12.0, pt)}
    mpl.rcParams.update(settings)
    return settings


def _texts(fig):
    """Every visible, non-empty text of a figure, with what it is."""
    from matplotlib.text import Text

    fig.canvas.draw()       # lays out ticks and legends
    for text in fig.findobj(Text):
        if text.get_visible() and text.get_text().strip() and text.get_figure() is fig:
            yield text


def readability_problems(fig, max_width_px: int = MAX_WIDTH_PX, min_label_px: float = MIN_LABEL_PX) -> list[str]:
    """What is too small in a figure as a notebook shows it: labels under min_label_px screen pixels (after the
    shrinking of a figure wider than max_width_px) and a figure wider than that. Empty when readable."""
    width_px = fig.get_figwidth() * fig.dpi
    shrink = min(1.0, max_width_px / width_px)
    problems = []
    if width_px > max_width_px + 0.5:
        problems.append(f"the figure is {width_px:.0f} px wide (> {max_width_px} px): the notebook shrinks it by "
                        f"{shrink:.2f}; use figsize width <= {max_width_px / fig.dpi:.1f} in at dpi {fig.dpi:g}")
    for text in _texts(fig):
        px = text.get_fontsize() * fig.dpi / 72.0 * shrink
        if px < min_label_px - 1e-9:
            problems.append(f"{text.get_text()[:40]!r} is {text.get_fontsize():g} pt at dpi {fig.dpi:g}: {px:.1f} px "
                            f"on screen (< {min_label_px:g} px = 9 pt)")
    return problems


def check_readable(fig, **limits) -> None:
    """Raise ValueError listing readability_problems(fig) when there are any."""
    problems = readability_problems(fig, **limits)
    if problems:
        raise ValueError("figure not readable at the size a notebook shows it:\n  " + "\n  ".join(problems))


# -- what a figure must say: labels with units, titles clear of the ticks, panels large enough to read ------------
UNIT = r"[(\[][^()\[\]]+[)\]]"      # "(mm)", "[px]", "(deg)", "(count)": a unit in brackets or parentheses
MIN_AXES_PX = (200.0, 120.0)          # a panel's least width and height on screen (px at 100 % zoom)


def _overlap(a, b, tol: float = 1.0) -> bool:
    """Whether two display boxes overlap by more than `tol` px each way."""
    return min(a.x1, b.x1) - max(a.x0, b.x0) > tol and min(a.y1, b.y1) - max(a.y0, b.y0) > tol


def _is_colorbar(ax) -> bool:
    return hasattr(ax, "_colorbar")


def _tick_labels(ax):
    return [t for t in ax.get_xticklabels() + ax.get_yticklabels() if t.get_visible() and t.get_text().strip()]


def labelling_problems(fig) -> list[str]:
    """What a figure leaves unsaid or unreadable, in the lab's rule (empty when none): every visible panel shows its
    axes and has a title (or the figure a suptitle); each axis with tick labels has a label that names a unit in
    brackets or parentheses; a colour bar's label names its unit; no title overlaps a tick label or another title;
    the tick labels of two panels do not overlap; no panel is smaller on screen than MIN_AXES_PX (width, height)
    px."""
    import re

    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    shrink = min(1.0, MAX_WIDTH_PX / (fig.get_figwidth() * fig.dpi))
    problems = []
    panels = [ax for ax in fig.axes if ax.get_visible() and ax.axison]
    problems += [f"a panel without axes ({ax.get_title()[:30]!r}): show its axes with units (px for an image)"
                 for ax in fig.axes if ax.get_visible() and not ax.axison]
    suptitle = fig._suptitle is not None and fig._suptitle.get_text().strip()
    titles = [(ax, t) for ax in fig.axes for t in (ax.title, ax._left_title, ax._right_title)
              if t.get_visible() and t.get_text().strip()]
    for i, ax in enumerate(panels):
        name = f"panel {i + 1}" + (f" ({ax.get_title()[:30]!r})" if ax.get_title() else "")
        if _is_colorbar(ax):
            cb = ax._colorbar
            label = (ax.get_ylabel() if cb.orientation == "vertical" else ax.get_xlabel()) or ax.get_title()
            if not re.search(UNIT, label or ""):
                problems.append(f"{name}: a colour bar without a unit in its label ({label!r})")
            continue
        if not (ax.get_title() or ax.get_title(loc="left") or suptitle):
            problems.append(f"{name}: no title")
        for axis, label, ticks in (("x", ax.get_xlabel(), ax.get_xticklabels()),
                                   ("y", ax.get_ylabel(), ax.get_yticklabels())):
            shown = any(t.get_visible() and t.get_text().strip() for t in ticks)    # a shared axis: its neighbour's
            if shown and not re.search(UNIT, label):
                problems.append(f"{name}: the {axis} label {label!r} names no unit in brackets or parentheses")
        box = ax.get_window_extent(renderer)
        w, h = box.width * shrink, box.height * shrink       # a notebook shows 1 image px as 1 screen px
        if w < MIN_AXES_PX[0] - 0.5 or h < MIN_AXES_PX[1] - 0.5:
            problems.append(f"{name}: {w:.0f} x {h:.0f} px on screen (at least {MIN_AXES_PX[0]:.0f} x "
                            f"{MIN_AXES_PX[1]:.0f} px)")
    ticks = [(t.get_text(), t.get_window_extent(renderer)) for ax in panels for t in _tick_labels(ax)]
    boxes = [(ax, t, t.get_window_extent(renderer)) for ax, t in titles]
    for k, (_, title, box) in enumerate(boxes):
        hit = next((text for text, tick in ticks if _overlap(box, tick)), None)
        if hit is not None:
            problems.append(f"the title {title.get_text()[:30]!r} overlaps the tick label {hit!r}")
        if any(_overlap(box, other) for _, _, other in boxes[k + 1:]):
            problems.append(f"the title {title.get_text()[:30]!r} overlaps another title")
    for a, b in ((a, b) for i, a in enumerate(panels) for b in panels[i + 1:]):
        hit = next(((s.get_text(), t.get_text()) for s in _tick_labels(a) for t in _tick_labels(b)
                    if _overlap(s.get_window_extent(renderer), t.get_window_extent(renderer))), None)
        if hit is not None:
            problems.append(f"the tick labels {hit[0]!r} and {hit[1]!r} of two panels overlap")
            break
    return problems


def figure_record(fig) -> dict:
    """What the notebooks' figure test reads back from a stored figure's output metadata: its size in px (as drawn,
    before a tight crop), and readability_problems and labelling_problems (both empty for a good figure)."""
    return {"width_px": round(fig.get_figwidth() * fig.dpi), "height_px": round(fig.get_figheight() * fig.dpi),
            "problems": readability_problems(fig) + labelling_problems(fig)}
