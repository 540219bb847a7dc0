"""Figures in the layout of the paper (matplotlib, imported lazily; Agg canvases, not pyplot)."""

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
    `compress_level` is zlib's for a PNG (default: Pillow's; 1, the batch's, writes slightly
    larger files faster)."""
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

    # Fig. 3: the three outputs agree to the noise's scale, so their errors are drawn below
    # (on one panel they are one curve); legends above the panels, hiding no data
    fig, (ax, err) = subplots(2, 1, figsize=(7, 5.2), sharex=True, height_ratios=[2.0, 1.0])
    ax.plot(t, y, color="0.7", lw=0.6, label="measured $x^*+\\nu$")
    ax.plot(t, x_true, "k", lw=1.2, label="$x^*$")
    ax.plot(t, result.y_hat, "C3--", lw=1.0, label=r"$\hat x$, paper's law")
    err.axhline(0.0, color="k", lw=1.0)
    err.plot(t, np.asarray(result.y_hat) - x_true, "C3", lw=0.8, label=r"$\hat x - x^*$, paper's law")
    if tracker is not None:
        ax.plot(t, tracker.y_hat, "C0:", lw=1.0, label=r"$\hat x$, tracker")
        err.plot(t, np.asarray(tracker.y_hat) - x_true, "C0", lw=0.8,
                 label=r"$\hat x - x^*$, tracker")
    ax.set(ylabel="output x", title="Fig. 3: actual and identified output")
    err.set(xlabel="t (s)", ylabel=f"error of $\\hat x$\n(y-limits after {SKIP_START:.0%})")
    _robust_limits(err, [np.asarray(result.y_hat) - x_true] + (
        [] if tracker is None else [np.asarray(tracker.y_hat) - x_true]), percentiles=(0, 100))
    for a in (ax, err):
        a.legend(ncols=4 if a is ax else 2, fontsize="small", loc="lower left",
                 bbox_to_anchor=(0.0, 1.0 if a is err else 1.08), frameon=False)
    save(fig, STUDY_FIGURES[1])

    # Fig. 4: every estimate after the start's transient in view (none clipped), the legends
    # beside the panels
    fig, axes = subplots(2, 1, figsize=(8.2, 5.5), sharex=True)
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
        _robust_limits(ax, series, percentiles=(0, 100))
        ax.set_ylabel(f"$p_{i + 1}$")
        ax.legend(fontsize="small", loc="upper left", bbox_to_anchor=(1.01, 1.0))
    axes[0].set_title(f"Fig. 4: actual and identified parameters (y-limits after the first "
                      f"{SKIP_START:.0%})")
    axes[1].set_xlabel("t (s)")
    save(fig, STUDY_FIGURES[2])
    return written


SKIP_START = 0.1  # the parameters panel's y-limits leave out this first fraction of a record


def _robust_limits(ax, series, percentiles=(1, 99)):
    """y-limits from the `percentiles` of each series after its first `SKIP_START` (a
    start-up transient, η = 1/p̂ while p̂ is near 0, would swamp the panel; ``(0, 100)``: all
    of the rest in view), at least ±1 % of the level wide, and plain tick labels: a constant
    does not become a zoom on its last digits with an offset (``1e-9 + 3.19185851e1``)."""
    import numpy as np

    ax.ticklabel_format(axis="y", useOffset=False)
    tails = [np.asarray(v)[int(SKIP_START * len(v)) :] for v in series]
    tails = [v[np.isfinite(v)] for v in tails if np.any(np.isfinite(v))]
    if not tails:
        return
    lo = min(np.percentile(v, percentiles[0]) for v in tails)
    hi = max(np.percentile(v, percentiles[1]) for v in tails)
    level = max(abs(lo), abs(hi), 1e-300)
    pad = max(0.15 * (hi - lo), 0.01 * level)
    ax.set_ylim(lo - pad, hi + pad)


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
    unit = unit_of(column, units)
    if unit is None:
        return str(column)
    quantity = str(column) if units and column in units else str(column).rpartition("_")[0]
    return f"{quantity.replace('_', ' ')} ({unit})"


def unit_of(column: str, units=None) -> str | None:
    """The unit of a column: given in `units` ({column: unit}) or its name's last ``_`` part
    when that is a unit (`UNITS`); None if neither."""
    if units and column in units:
        return units[column]
    quantity, _, unit = str(column).rpartition("_")
    return UNITS[unit] if quantity and unit in UNITS else None


# the tracker's median NRMSE below this fraction of the refit's: its drifting parameters, not
# its order, absorb the misfit, and the overview says so
ABSORBED = 0.5


def _absorbed_note(rows, tracker) -> str:
    """A sentence for the fit panel where the tracker fits far closer than the refit (its
    median NRMSE below `ABSORBED` of the refit's on the records that have both), else ``""``."""
    import numpy as np

    if tracker != "kalman":  # the paper's law holds its parameters by its own gains
        return ""
    pairs = [(float(r["kalman_nrmse"]), float(r["refit_nrmse"])) for r in rows
             if r.get("kalman_nrmse") is not None and r.get("refit_nrmse") is not None]
    pairs = np.array([p for p in pairs if all(np.isfinite(p))]).reshape(-1, 2)
    if not pairs.size or not np.median(pairs[:, 0]) < ABSORBED * np.median(pairs[:, 1]):
        return ""
    return (f"the tracker's NRMSE (median {np.median(pairs[:, 0]):.2g}) is below the refit's "
            f"({np.median(pairs[:, 1]):.2g}) because its parameters drift with the data: a "
            "close fit is no evidence for its order")


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
    finite = [v[np.isfinite(v)] for _, v, _ in series]
    if finite and any(v.size for v in finite):
        # bins over the orders found (not the whole 0–1), so that close orders are told
        # apart; the estimators' bars side by side, none hiding another's
        every = np.concatenate(finite)
        span = (max(0.0, every.min() - 0.02), min(1.0, every.max() + 0.02))
        ax.hist(finite, bins=20, range=span, color=[c for _, _, c in series],
                label=[label for label, _, _ in series])
        ax.legend(fontsize=8)
    ax.set(xlabel="order q (dimensionless)", ylabel="records", title="orders")
    ax = axes[2]
    fits = [(column(k), label, c) for k, label, c in (
        (f"{tracker}_nrmse", "order tracking", "C3"), ("refit_nrmse", "refit", "C0"),
    ) if any(k in r for r in rows)]
    fits = [(v[np.isfinite(v)], label, c) for v, label, c in fits]
    fits = [f for f in fits if f[0].size]
    if fits:
        top = max(float(v.max()) for v, _, _ in fits)
        ax.hist([v for v, _, _ in fits], bins=20, range=(0, 1.05 * top or 1.0),
                color=[c for _, _, c in fits], label=[label for _, label, c in fits])
        ax.legend(fontsize=8)
    ax.set(xlabel="NRMSE of the fit (RMS error / range of the output)", ylabel="records",
           title="fit quality")
    note = _absorbed_note(rows, tracker)
    if note:
        import textwrap

        ax.text(0.97, 0.75, textwrap.fill(note, 44), transform=ax.transAxes, ha="right",
                va="top", fontsize=7, bbox={"facecolor": "white", "alpha": 0.8, "lw": 0})
    for ax in axes[1:]:
        ax.yaxis.set_major_locator(MaxNLocator(integer=True))  # counts of records
    _save(fig, path)
