"""IPython startup code that tools/build-notebook runs in the kernel that executes a notebook: every matplotlib figure
the notebook shows is stored with, in its output's metadata ("image/png" -> "armlab_figure"), the record
armlab.viz.figures.figure_record makes of it (its size and the problems of its labels, units, titles and panels), so
that tests/test_notebook_figures.py checks every figure a notebook made without running the notebook again.

It wraps the PNG formatter the inline backend registers for matplotlib figures (IPython lets a formatter return
(data, metadata)), before every cell and again before the figures of a cell are flushed.
"""


def _armlab_record_figures() -> None:
    from IPython import get_ipython

    ip = get_ipython()
    if ip is None:
        return
    fmt = ip.display_formatter.formatters["image/png"]

    def wrap(*_):
        from matplotlib.figure import Figure

        printer = fmt.type_printers.get(Figure)
        if printer is None or getattr(printer, "armlab_recording", False):
            return

        def record(fig, _printer=printer):
            from armlab.viz.figures import figure_record

            return _printer(fig), {"armlab_figure": figure_record(fig)}

        record.armlab_recording = True
        fmt.for_type(Figure, record)

    ip.events.register("pre_run_cell", wrap)
    ip.events.register("post_execute", wrap)


_armlab_record_figures()
del _armlab_record_figures
