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

__all__ = ["MIN_LABEL_PX", "MAX_WIDTH_PX", "DPI", "readable", "readability_problems", "check_readable"]

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
