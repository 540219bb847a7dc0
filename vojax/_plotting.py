"""Figures in the layout of the paper (matplotlib, imported lazily; Agg canvases, not pyplot)."""

import math
from pathlib import Path

from ._io import atomic_path


def _figure(**options):
    """A `matplotlib.figure.Figure` on an Agg canvas, outside pyplot: nothing global changes
    (a notebook's backend and its open figures are left alone), and pyplot is not imported."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(**options)
    FigureCanvasAgg(fig)
    return fig


def _save(fig, path, dpi=110, compress_level=None):
    """Writes `fig` to `path` atomically, in the format its suffix names (PNG by default);
    `compress_level` is zlib's for a PNG (default: Pillow's; 1 gives 5 % larger files and
    0.01–0.02 s less a figure)."""
    fmt = Path(path).suffix.lstrip(".") or "png"
    use = fmt == "png" and compress_level is not None
    extra = {"pil_kwargs": {"compress_level": compress_level}} if use else {}
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=dpi, format=fmt, **extra)


STUDY_FIGURES = ("fig2_order.png", "fig3_output.png", "fig4_parameters.png")


def study_figures(t, truth_alpha, truth_p, x_true, y, result, out_dir, tracker=None) -> list[str]:
    """Writes Figs. 2–4 of the paper (order, output, parameters) as PNG files; returns names.
    `result` is the paper's law, drawn with its ±2σ (the spread over the noise alone, not a
    confidence band); `tracker`, when given, vojax's tracker with its ±2σ band."""
    import numpy as np

    written = []

    def save(fig, name):
        _save(fig, out_dir / name, dpi=120)
        written.append(name)

    def subplots(*shape, figsize, **options):
        fig = _figure(figsize=figsize, layout="constrained")
        return fig, fig.subplots(*shape, **options)

    fig, ax = subplots(figsize=(7, 3.8))
    ax.plot(t, truth_alpha, "k", lw=1.5, label=r"$\alpha^*$")
    ax.fill_between(t, result.alpha_lower, result.alpha_upper, color="C3", alpha=0.25, lw=0,
                    label="law ±2σ (noise only)")
    ax.plot(t, result.alpha, "C3--", lw=1.2, label=r"$\hat\alpha$, paper's law")
    if tracker is not None:
        ax.fill_between(t, tracker.alpha_lower, tracker.alpha_upper, color="C0", alpha=0.2,
                        lw=0, label="tracker ±2σ band")
        ax.plot(t, tracker.alpha, "C0", lw=1.0, label=r"$\hat\alpha$, tracker")
    ax.set(xlabel="t (s)", ylabel="order α", title="Fig. 2: actual and identified order")
    ax.legend(ncols=2 if tracker is not None else 1, fontsize="small")
    save(fig, STUDY_FIGURES[0])

    fig, ax = subplots(figsize=(7, 3.5))
    ax.plot(t, y, color="0.7", lw=0.6, label="measured $x^*+\\nu$")
    ax.plot(t, x_true, "k", lw=1.2, label="$x^*$")
    ax.plot(t, result.y_hat, "C3--", lw=1.0, label=r"$\hat x$, paper's law")
    if tracker is not None:
        ax.plot(t, tracker.y_hat, "C0:", lw=1.0, label=r"$\hat x$, tracker")
    ax.set(xlabel="t (s)", ylabel="output x", title="Fig. 3: actual and identified output")
    ax.legend(ncols=2, fontsize="small")
    save(fig, STUDY_FIGURES[1])

    fig, axes = subplots(2, 1, figsize=(7, 5.5), sharex=True)
    shown = [("paper's law", result, "C3", "--")]
    if tracker is not None:
        shown.append(("tracker", tracker, "C0", "-"))
    for i, ax in enumerate(axes):
        ax.plot(t, truth_p[:, i], "k", lw=1.5, label=f"$p^*_{i + 1}$")
        series = [truth_p[:, i]]
        for name, res, colour, style in shown:
            p, sd = np.asarray(res.p)[:, i], np.asarray(res.p_std)[:, i]
            ax.fill_between(t, p - 2 * sd, p + 2 * sd, color=colour, alpha=0.2, lw=0)
            ax.plot(t, p, colour, ls=style, lw=1.0, label=f"$\\hat p_{i + 1}$, {name} (±2σ)")
            series.append(p)
        _robust_limits(ax, series)
        ax.set_ylabel(f"$p_{i + 1}$")
        ax.legend(fontsize="small")
    axes[0].set_title("Fig. 4: actual and identified parameters")
    axes[1].set_xlabel("t (s)")
    save(fig, STUDY_FIGURES[2])
    return written


SKIP_START = 0.1  # the parameters panel's y-limits leave out this first fraction of a record


def _robust_limits(ax, series):
    """y-limits from the 1st–99th percentiles of each series after its first `SKIP_START`
    (a start-up transient, η = 1/p̂ while p̂ is near 0, would swamp the panel), at least ±1 %
    of the level wide, and plain tick labels: a constant does not become a zoom on its last
    digits with an offset (``1e-9 + 3.19185851e1``)."""
    import numpy as np

    ax.ticklabel_format(axis="y", useOffset=False)
    tails = [np.asarray(v)[int(SKIP_START * len(v)) :] for v in series]
    tails = [v[np.isfinite(v)] for v in tails if np.any(np.isfinite(v))]
    if not tails:
        return
    lo = min(np.percentile(v, 1) for v in tails)
    hi = max(np.percentile(v, 99) for v in tails)
    level = max(abs(lo), abs(hi), 1e-300)
    pad = max(0.15 * (hi - lo), 0.01 * level)
    ax.set_ylim(lo - pad, hi + pad)


# the record figure of this process, drawn again for each record: building its axes and
# ticks anew took half of its 0.28 s (a batch draws one per record)
_RECORD_FIGURE = []


def _record_axes():
    """The record figure and its 2×2 axes, emptied of the last record's artists. A plain
    `Figure` on an Agg canvas, not registered with pyplot (a notebook never shows it)."""
    if not _RECORD_FIGURE:
        from matplotlib.ticker import MaxNLocator

        fig = _figure(figsize=(10, 6.5))
        axes = fig.subplots(2, 2)
        # fixed margins: a constrained layout costs ~0.6 s per figure
        fig.subplots_adjust(left=0.08, right=0.98, bottom=0.08, top=0.91, wspace=0.25, hspace=0.38)
        # at most six ticks an axis, on matplotlib's usual steps: tick labels are most of a
        # figure's text, and text most of its time (0.17 → 0.14 s a figure against the
        # default's eight or nine)
        for ax in axes.flat:
            for axis in (ax.xaxis, ax.yaxis):
                axis.set_major_locator(MaxNLocator(nbins=5, steps=[1, 2, 2.5, 5, 10]))
        _RECORD_FIGURE.append((fig, axes))
    fig, axes = _RECORD_FIGURE[0]
    for ax in axes.flat:
        for artist in [*ax.lines, *ax.collections, *ax.patches, *ax.texts]:
            artist.remove()
        if ax.get_legend() is not None:
            ax.get_legend().remove()
        ax.relim()  # no artists: empty data limits
        ax.set(xlim=(0.0, 1.0), ylim=(0.0, 1.0))  # a new axes' view, where no data sets it
        ax.set_autoscale_on(True)  # the last record's fixed y-limits are released
        ax.set_prop_cycle(None)  # colours from C0 again
    return fig, axes


UNITS = {
    "s": "s", "ms": "ms", "us": "µs", "min": "min", "h": "h",
    "N": "N", "kN": "kN", "mN": "mN", "uN": "µN", "nN": "nN", "pN": "pN",
    "Pa": "Pa", "kPa": "kPa", "MPa": "MPa", "GPa": "GPa", "bar": "bar", "psi": "psi",
    "m": "m", "mm": "mm", "um": "µm", "µm": "µm", "nm": "nm", "cm": "cm",
    "V": "V", "mV": "mV", "K": "K", "C": "°C", "degC": "°C", "pct": "%", "percent": "%",
}


def axis_label(column: str, units=None) -> str:
    """An axis label from a column name whose last ``_`` part is a unit (`UNITS`):
    ``nominal_shear_stress_kPa`` → "nominal shear stress (kPa)", ``x_um`` → "x (µm)"; a unit
    given in `units` ({column: unit}) wins: ``stress`` with ``{"stress": "kPa"}`` → "stress
    (kPa)"; any other name is used as it is."""
    if units and column in units:
        return f"{str(column).replace('_', ' ')} ({units[column]})"
    quantity, _, unit = str(column).rpartition("_")
    if quantity and unit in UNITS:
        return f"{quantity.replace('_', ' ')} ({UNITS[unit]})"
    return str(column)


def first_sentence(text: str, limit: int = 110) -> str:
    """The first sentence of a diagnostic message, cut at `limit` characters (a title)."""
    text = " ".join(str(text).split())
    end = text.find(". ")
    text = text if end < 0 else text[: end + 1]
    return text if len(text) <= limit else text[: limit - 1].rstrip() + "…"


def warm_record_figure() -> None:
    """Builds this process's record figure and draws it once (imports, fonts, ticks): a batch's
    figure workers do it on starting, while the batch compiles."""
    fig, _ = _record_axes()
    fig.canvas.draw()


def record_figure(columns, summary, inputs, path) -> None:
    """The layout of the paper's Figs. 7–8: output and identified output, input, order with
    its ±2σ band, parameters; axes labelled with the file's column names (their units)."""
    t = columns["time"]
    tracker = "kalman" if "kalman" in summary else "gradient" if "gradient" in summary else None
    kind = {"gradient": "paper's law", "kalman": "tracker"}.get(tracker, "identified")
    time_column = summary.get("time_column", "t")
    units = summary.get("units") or {}
    time_unit = units.get(time_column) or UNITS.get(time_column.rpartition("_")[2])
    if not time_column.rpartition("_")[0] and time_column not in units:
        time_unit = None
    offset = summary.get("time_offset") or 0.0
    time_label = f"time ({time_unit or time_column}, from the first sample" + (
        f", at {offset:g} in the file)" if offset else ")")
    fig, axes = _record_axes()
    ax = axes[0, 0]
    ax.plot(t, columns["y"], "k", lw=1.2, label="measured")
    if "y_hat" in columns:
        ax.plot(t, columns["y_hat"], "C3--", lw=1.0, label=kind)
    if "refit_y_hat" in columns:
        ax.plot(t, columns["refit_y_hat"], "C0:", lw=1.2, label="refit")
    out = axis_label(summary["output_column"], units)
    if summary.get("length"):
        out = f"{out} / {summary['length']:g}"
    ax.set(title="output", xlabel=time_label, ylabel=out)
    ax.legend()
    ax = axes[0, 1]
    for i, name in enumerate(summary["input_columns"]):
        ax.plot(t, inputs[:, i], label=axis_label(name, units))
    ax.set(title="input", xlabel=time_label,
           ylabel=", ".join(axis_label(c, units) for c in summary["input_columns"]))
    ax.legend()
    ax = axes[1, 0]
    if "alpha" in columns:
        if "alpha_lower" in columns:
            ax.fill_between(
                t, columns["alpha_lower"], columns["alpha_upper"], color="C3", alpha=0.2,
                lw=0, label="±2σ band",
            )
        ax.plot(t, columns["alpha"], "C3", label=kind)
    if "refit_alpha" in columns:
        if "refit_alpha_lower" in columns:
            ax.fill_between(
                t, columns["refit_alpha_lower"], columns["refit_alpha_upper"], color="C0",
                alpha=0.15, lw=0, label="refit 95 %",
            )
        ax.plot(t, columns["refit_alpha"], "C0:", label="refit")
    ax.set(title="identified order", xlabel=time_label, ylabel="order α (dimensionless)")
    if ax.get_legend_handles_labels()[0]:
        ax.legend()
    _parameter_panel(axes[1, 1], t, columns, summary, time_label)
    verdict = []
    part = summary.get(tracker) if tracker else None
    if part is not None and "identified" in part:
        verdict.append("order identified" if part["identified"] else "order not identified")
    if summary.get("disagreement"):
        verdict.append("the estimators' bands are disjoint")
    title = f"{summary['record']} — {summary['model']}"
    title += f" ({'; '.join(verdict)})" if verdict else ""
    afm = summary.get("afm") or {}
    if afm.get("youngs_modulus_Pa") is not None:  # nanite's Hertz fit of the loading
        title += (f"; E = {afm['youngs_modulus_Pa']:.4g} ± {afm['youngs_modulus_stderr_Pa']:.2g}"
                  f" Pa (Hertz, {afm['tip']})")
    reason = first_sentence(part.get("message", "")) if part and not part.get("identified", True) else ""
    fig.suptitle(title + (f"\n{reason}" if reason else ""))
    _save(fig, path, compress_level=1)  # a batch draws one a record: the faster zlib level


def _parameter_panel(ax, t, columns, summary, time_label):
    """The tracker's or the law's parameters over time, and the refit's constants with their
    ±2 SE bands; y-limits robust to the start's transient."""
    shown = [name for name in summary["parameter_names"] if name in columns]
    series = [columns[name] for name in shown]
    for i, name in enumerate(shown):
        ax.plot(t, columns[name], f"C{i}", label=name)
    refit = summary.get("refit")
    if refit:
        # the refit's constant parameters with their ±2 SE (delta method) as shaded bands
        # (an infinite error, a parameter the data do not determine, draws no band)
        for i, (name, value) in enumerate(refit["parameters"].items()):
            if value is None or not math.isfinite(value):  # undetermined: nothing to draw
                continue
            se = refit["parameters_stderr"].get(name)
            finite = se is not None and math.isfinite(se)
            ax.axhline(value, color=f"C{i}", ls=":", lw=1.2, label=f"{name} (refit)")
            if finite:
                ax.axhspan(value - 2 * se, value + 2 * se, color=f"C{i}", alpha=0.12, lw=0)
            series.append([value - 2 * se, value + 2 * se] if finite else [value])
    _robust_limits(ax, series)
    if not shown:  # only the refit's constants: the panel still spans the record's time
        ax.set_xlim(t[0], t[-1])
    names = shown or list((refit or {}).get("parameters", {}))
    ax.set(
        title=f"parameters (y-limits after the first {SKIP_START:.0%})",
        xlabel=time_label,
        ylabel=", ".join(names) or "parameters",
    )
    if ax.get_legend_handles_labels()[0]:
        ax.legend()


def overview_figure(rows, path, failed=0) -> None:
    """The batch at a glance, from the rows of ``summary.csv``: each record's order with its
    band (the tracker's or law's final order ±2σ, the refit's interval), and the distributions
    of the orders and of the fits' NRMSE."""
    import numpy as np

    def column(key):
        return np.array([float(r[key]) if r.get(key) is not None else np.nan for r in rows])

    names = [r["record"] for r in rows]
    index = np.arange(len(rows))
    fig = _figure(figsize=(13, 3.8), layout="constrained")
    axes = fig.subplots(1, 3)
    ax = axes[0]
    series = []
    tracker = next(
        (m for m in ("kalman", "gradient") if any(f"{m}_alpha_final" in r for r in rows)), None
    )
    unidentified = 0
    if tracker is not None:
        a, sd = column(f"{tracker}_alpha_final"), column(f"{tracker}_alpha_final_std")
        known = np.array([str(r.get(f"{tracker}_identified")) == "True" for r in rows])
        if tracker == "gradient":  # the law never identifies: one kind of marker
            known[:] = True
        for mask, face, label in ((known, "C3", "final order ±2σ"),
                                  (~known, "none", "not identified")):
            if mask.any():
                ax.errorbar(index[mask] - 0.15, a[mask], yerr=2 * sd[mask], fmt="o", ms=4,
                            color="C3", mfc=face, label=label)
        unidentified = int((~known).sum())
        series.append(("final order", a, "C3"))
    if any("refit_order" in r for r in rows):
        q, lo, hi = column("refit_order"), column("refit_order_lower"), column("refit_order_upper")
        ax.errorbar(index + 0.15, q, yerr=[q - lo, hi - q], fmt="s", ms=3, color="C0", label="refit 95 %")
        series.append(("refit order", q, "C0"))
    title = f"{len(rows)} records"
    if tracker is not None and unidentified:
        title += f", {unidentified} not identified"
    if failed:
        title += f", {failed} failed (failures.csv)"
    ax.set(xlabel="record (sorted by name; see summary.csv)", ylabel="order q (dimensionless)",
           title=title, ylim=(0, 1))
    from matplotlib.ticker import MaxNLocator

    ax.xaxis.set_major_locator(MaxNLocator(integer=True))
    if len(rows) <= 12:
        ax.set_xticks(index, names, rotation=45, ha="right", fontsize=7)
    ax.legend(fontsize=8)
    ax = axes[1]
    for label, values, color in series:
        finite = values[np.isfinite(values)]
        # bins over the orders found (not the whole 0–1), so that close orders are told apart
        span = (max(0.0, finite.min() - 0.02), min(1.0, finite.max() + 0.02)) if finite.size else (0, 1)
        ax.hist(finite, bins=20, range=span, alpha=0.5, color=color, label=label)
    ax.set(xlabel="order q (dimensionless)", ylabel="records", title="orders")
    if series:
        ax.legend(fontsize=8)
    ax = axes[2]
    fits = [(column(k), label, c) for k, label, c in (
        (f"{tracker}_nrmse", "order tracking", "C3"), ("refit_nrmse", "refit", "C0"),
    ) if any(k in r for r in rows)]
    top = max([float(np.nanmax(v)) for v, _, _ in fits if np.any(np.isfinite(v))] or [1.0])
    for values, label, color in fits:
        ax.hist(values[np.isfinite(values)], bins=20, range=(0, 1.05 * top or 1.0), alpha=0.5,
                color=color, label=label)
    ax.set(xlabel="NRMSE of the fit (RMS error / range of the output)", ylabel="records",
           title="fit quality")
    if ax.get_legend_handles_labels()[0]:
        ax.legend(fontsize=8)
    _save(fig, path)
