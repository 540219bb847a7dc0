"""The record figure of `vojax identify` and `vojax batch`: the output with the fit and its
residuals, the input, the order with its band, the parameters in their units, and the verdict
with what it assumes in a caption that is wrapped, never cut (matplotlib, imported lazily)."""

import math

import numpy as np

from ._plotting import SKIP_START, _figure, _robust_limits, _save, axis_label
from ._plotting_parts import (
    caption,
    parameter_label,
    plain_y,
    residual_panel,
    set_time_axis,
    time_label,
    verdict_title,
)

# the record figure of this process, drawn again for each record: building its axes and
# ticks anew took half of its 0.28 s (a batch draws one per record)
_RECORD_FIGURE = []

# the figure's size in inches, and the height of its panels' block (the caption's lines go
# below it, the figure growing by their height)
WIDTH, PANELS_HEIGHT = 10.0, 7.4


def _record_axes():
    """The record figure and its five axes (output, residuals, input, order, parameters),
    emptied of the last record's artists. A plain `Figure` on an Agg canvas, not registered
    with pyplot (a notebook never shows it)."""
    if not _RECORD_FIGURE:
        from matplotlib.ticker import MaxNLocator

        fig = _figure(figsize=(WIDTH, PANELS_HEIGHT))
        grid = fig.add_gridspec(3, 2, height_ratios=[2.0, 1.0, 2.0])
        out = fig.add_subplot(grid[0, 0])
        axes = {
            "output": out,
            "residuals": fig.add_subplot(grid[1, 0], sharex=out),
            "input": fig.add_subplot(grid[0:2, 1]),
            "order": fig.add_subplot(grid[2, 0]),
            "parameters": fig.add_subplot(grid[2, 1]),
        }
        # at most six ticks on a y-axis (`set_time_axis` caps the time axes): tick labels
        # are most of a figure's text, and text most of its time
        for ax in axes.values():
            ax.yaxis.set_major_locator(MaxNLocator(nbins=5, steps=[1, 2, 2.5, 5, 10]))
        _RECORD_FIGURE.append((fig, axes))
    fig, axes = _RECORD_FIGURE[0]
    for ax in axes.values():
        for artist in [*ax.lines, *ax.collections, *ax.patches, *ax.texts]:
            artist.remove()
        if ax.get_legend() is not None:
            ax.get_legend().remove()
        ax.relim()  # no artists: empty data limits
        # a linear time axis again before anything is drawn: under the last record's
        # symmetric-log scale, a line spanning the axes (a refit's constant) falls below its
        # threshold, which matplotlib 3.7 warns of
        ax.set_xscale("linear")
        ax.set(xlim=(0.0, 1.0), ylim=(0.0, 1.0))  # a new axes' view, where no data sets it
        ax.set_autoscale_on(True)  # the last record's fixed y-limits are released
        ax.set_prop_cycle(None)  # colours from C0 again
    for text in [t for t in fig.texts if t is not fig._suptitle]:  # the last caption
        text.remove()
    return fig, axes


def warm_record_figure() -> None:
    """Builds this process's record figure and draws it once (imports, fonts, ticks): a batch's
    figure workers do it on starting, while the batch compiles."""
    fig, _ = _record_axes()
    fig.canvas.draw()


def record_figure(columns, summary, inputs, path) -> None:
    """The record at a glance: the measured output with the estimators' fits, their residuals
    below, the input, the order with its ±2σ band, the parameters with their units; titled
    with the verdict and captioned with the answer, what it assumes and why, wrapped in full.
    Axes are labelled with the file's column names (their units); a log-spaced clock is drawn
    on a log time axis."""
    t = np.asarray(columns["time"], dtype=float)
    tracker = "kalman" if "kalman" in summary else "gradient" if "gradient" in summary else None
    kind = {"gradient": "paper's law", "kalman": "tracker"}.get(tracker, "identified")
    label = time_label(summary)
    units = summary.get("units") or {}
    fig, axes = _record_axes()
    ax = axes["output"]
    ax.plot(t, columns["y"], "k", lw=1.2, label="measured")
    fits = []
    if "y_hat" in columns:
        ax.plot(t, columns["y_hat"], "C3--", lw=1.0, label=kind)
        fits.append((kind, columns["y_hat"], "C3"))
    if "refit_y_hat" in columns:
        ax.plot(t, columns["refit_y_hat"], "C0:", lw=1.2, label="refit")
        fits.append(("refit", columns["refit_y_hat"], "C0"))
    out = axis_label(summary["output_column"], units)
    if summary.get("length"):
        out = f"{out} / {summary['length']:g}"
    ax.set(title="output and fit", ylabel=out)
    ax.tick_params(labelbottom=False)
    plain_y(ax, [columns["y"]])
    ax.legend(fontsize=8)
    residual_panel(axes["residuals"], t, columns["y"], fits, label)
    ax = axes["input"]
    for i, name in enumerate(summary["input_columns"]):
        ax.plot(t, inputs[:, i], label=axis_label(name, units))
    ax.set(title="input", xlabel=label,
           ylabel=", ".join(axis_label(c, units) for c in summary["input_columns"]))
    plain_y(ax, [inputs[:, i] for i in range(inputs.shape[1])])
    ax.legend(fontsize=8)
    _order_panel(axes["order"], t, columns, kind, label)
    _parameter_panel(axes["parameters"], t, columns, summary, label)
    for ax in axes.values():
        set_time_axis(ax, t)
    part = summary.get(tracker) if tracker else None
    fig.suptitle(verdict_title(summary, part), fontsize=12)
    caption(fig, summary, part, kind, PANELS_HEIGHT)
    _save(fig, path, compress_level=1)  # a batch draws one a record: the faster zlib level


def _order_panel(ax, t, columns, kind, label):
    """The tracker's or law's order with its ±2σ band, and the refit's with its 95 %."""
    if "alpha" in columns:
        if "alpha_lower" in columns:
            ax.fill_between(t, columns["alpha_lower"], columns["alpha_upper"], color="C3",
                            alpha=0.2, lw=0, label="±2σ band")
        ax.plot(t, columns["alpha"], "C3", label=kind)
    if "refit_alpha" in columns:
        if "refit_alpha_lower" in columns:
            ax.fill_between(t, columns["refit_alpha_lower"], columns["refit_alpha_upper"],
                            color="C0", alpha=0.15, lw=0, label="refit 95 %")
        ax.plot(t, columns["refit_alpha"], "C0:", label="refit")
    ax.set(title="identified order", xlabel=label, ylabel="order α (dimensionless)")
    if ax.get_legend_handles_labels()[0]:
        ax.legend(fontsize=8)


def _parameter_panel(ax, t, columns, summary, label):
    """The tracker's or the law's parameters over time, and the refit's constants with their
    ±2 SE bands, each labelled with its unit; y-limits robust to the start's transient."""
    shown = [name for name in summary["parameter_names"] if name in columns]
    series = [columns[name] for name in shown]
    for i, name in enumerate(shown):
        ax.plot(t, columns[name], f"C{i}", label=parameter_label(name, summary))
    refit = summary.get("refit")
    if refit:
        # the refit's constant parameters with their ±2 SE (delta method) as shaded bands
        # (an infinite error, a parameter the data do not determine, draws no band)
        for i, (name, value) in enumerate(refit["parameters"].items()):
            if value is None or not math.isfinite(value):  # undetermined: nothing to draw
                continue
            se = refit["parameters_stderr"].get(name)
            finite = se is not None and math.isfinite(se)
            ax.axhline(value, color=f"C{i}", ls=":", lw=1.2,
                       label=f"{parameter_label(name, summary)}, refit")
            if finite:
                ax.axhspan(value - 2 * se, value + 2 * se, color=f"C{i}", alpha=0.12, lw=0)
            series.append([value - 2 * se, value + 2 * se] if finite else [value])
    _robust_limits(ax, series)
    if not shown:  # only the refit's constants: the panel still spans the record's time
        ax.set_xlim(t[0], t[-1])
    names = shown or list((refit or {}).get("parameters", {}))
    ax.set(title=f"parameters (y-limits after the first {SKIP_START:.0%})", xlabel=label,
           ylabel=parameter_label(names[0], summary) if len(names) == 1 else
           "parameters (units in the legend)" if names else "parameters")
    if ax.get_legend_handles_labels()[0]:
        ax.legend(fontsize=8)


def identification_figure(res, times):
    """`Identification.plot`'s figure (on pyplot, so that a notebook shows it): the measured
    output with the fit, the residuals and the order with its band, the verdict as title and
    caption (as the record figure's). Returns the order's Axes."""
    import matplotlib.pyplot as plt

    name = {"kalman": "tracker", "gradient": "paper's law"}.get(res.method, res.method)
    fig, (out, resid, order) = plt.subplots(
        3, 1, figsize=(8.0, 6.6), sharex=True, height_ratios=[2.0, 1.0, 2.0]
    )
    y_hat = np.asarray(res.y_hat)
    shown = [y_hat]
    if res.y is not None:
        out.plot(times, np.asarray(res.y), "k", lw=1.2, label="measured")
        shown.append(np.asarray(res.y))
        residual_panel(resid, times, res.y, [(name, y_hat, "C3")], "")
    else:
        resid.set(title="residuals: the measured output was not kept")
    out.plot(times, y_hat, "C3--", lw=1.0, label=f"{name}'s fit")
    out.set(title="output and fit", ylabel="output x")
    plain_y(out, shown)
    out.legend(fontsize=8)
    res._plot_order(order, times)
    for ax in (out, resid, order):
        set_time_axis(ax, times)
    d = res.diagnostics
    part = {"verdict": d.verdict, "answer": res.verdict_line(), "finding": d.finding}
    if res.method == "kalman":
        part["parameter_model"] = "free" if res.parameters == "drifting" else res.parameters
        part["offset_model"] = "known" if float(res.x0_std) == 0.0 else "estimated"
    fig.suptitle(f"order {d.verdict}", fontsize=12)
    caption(fig, {}, part, name, 6.6)
    return order
