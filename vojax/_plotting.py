"""Figures in the layout of the paper (matplotlib, imported lazily, Agg backend)."""

import math
from pathlib import Path

from ._io import atomic_path


def _pyplot():
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    return plt


def study_figures(t, truth_alpha, truth_p, x_true, y, result, out_dir) -> list[str]:
    """Writes Figs. 2–4 of the paper (order, output, parameters) as PNG files; returns names."""
    plt = _pyplot()
    written = []

    def save(fig, name):
        with atomic_path(out_dir / name) as tmp:
            fig.savefig(tmp, dpi=120, format="png")
        plt.close(fig)
        written.append(name)

    fig, ax = plt.subplots(figsize=(7, 3.5), layout="constrained")
    ax.plot(t, truth_alpha, "k", lw=1.5, label=r"$\alpha^*$")
    ax.plot(t, result.alpha, "C3--", lw=1.2, label=r"$\hat\alpha$")
    ax.set(xlabel="t (s)", ylabel="order", title="Fig. 2: actual and identified order")
    ax.legend()
    save(fig, "fig2_order.png")

    fig, ax = plt.subplots(figsize=(7, 3.5), layout="constrained")
    ax.plot(t, y, color="0.7", lw=0.6, label="measured $x^*+\\nu$")
    ax.plot(t, x_true, "k", lw=1.2, label="$x^*$")
    ax.plot(t, result.y_hat, "C3--", lw=1.0, label=r"$\hat x$")
    ax.set(xlabel="t (s)", ylabel="output", title="Fig. 3: actual and identified output")
    ax.legend(ncols=3)
    save(fig, "fig3_output.png")

    fig, axes = plt.subplots(2, 1, figsize=(7, 5), sharex=True, layout="constrained")
    for i, ax in enumerate(axes):
        ax.plot(t, truth_p[:, i], "k", lw=1.5, label=f"$p^*_{i + 1}$")
        ax.plot(t, result.p[:, i], "C3--", lw=1.0, label=f"$\\hat p_{i + 1}$")
        ax.legend()
    axes[0].set_title("Fig. 4: actual and identified parameters")
    axes[1].set_xlabel("t (s)")
    save(fig, "fig4_parameters.png")
    return written


def _robust_limits(ax, series):
    """y-limits from the 1st–99th percentiles of the second half of each series, so that a
    start-up transient does not swamp the panel."""
    import numpy as np

    tails = [np.asarray(v)[len(v) // 2 :] for v in series]
    tails = [v[np.isfinite(v)] for v in tails if np.any(np.isfinite(v))]
    if not tails:
        return
    lo = min(np.percentile(v, 1) for v in tails)
    hi = max(np.percentile(v, 99) for v in tails)
    pad = 0.15 * (hi - lo) if hi > lo else 0.1 * max(abs(hi), 1e-300)
    ax.set_ylim(lo - pad, hi + pad)


def record_figure(columns, summary, inputs, path) -> None:
    """The layout of the paper's Figs. 7–8: output and identified output, input, order with
    its ±2σ band, parameters; axes labelled with the file's column names (their units)."""
    plt = _pyplot()
    t = columns["time"]
    kind = (summary.get("adaptive") or {}).get("method", summary.get("method", "identified"))
    kind = {"gradient": "paper's law", "kalman": "tracker"}.get(kind, kind)
    time_label = f"time ({summary.get('time_column', 't')}, from the first sample)"
    # fixed margins: a constrained layout costs ~0.6 s per figure, most of a batch's time
    fig, axes = plt.subplots(2, 2, figsize=(10, 6.5))
    fig.subplots_adjust(left=0.08, right=0.98, bottom=0.08, top=0.91, wspace=0.25, hspace=0.38)
    ax = axes[0, 0]
    ax.plot(t, columns["y"], "k", lw=1.2, label="measured")
    if "y_hat" in columns:
        ax.plot(t, columns["y_hat"], "C3--", lw=1.0, label=kind)
    if "refit_y_hat" in columns:
        ax.plot(t, columns["refit_y_hat"], "C0:", lw=1.2, label="refit")
    out = summary["output_column"]
    if summary.get("length"):
        out = f"{out} / {summary['length']:g}"
    ax.set(title="output", xlabel=time_label, ylabel=out)
    ax.legend()
    ax = axes[0, 1]
    for i, name in enumerate(summary["input_columns"]):
        ax.plot(t, inputs[:, i], label=name)
    ax.set(title="input", xlabel=time_label, ylabel=", ".join(summary["input_columns"]))
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
    ax.legend()
    ax = axes[1, 1]
    shown = [name for name in summary["parameter_names"] if name in columns]
    series = [columns[name] for name in shown]
    for i, name in enumerate(shown):
        ax.plot(t, columns[name], f"C{i}", label=name)
    refit = summary.get("refit")
    if refit:
        # the refit's constant parameters with their ±2 SE (delta method) as shaded bands
        # (an infinite error, a parameter the data do not determine, draws no band)
        for i, (name, value) in enumerate(refit["parameters"].items()):
            se = refit["parameters_stderr"].get(name)
            finite = se is not None and math.isfinite(se)
            ax.axhline(value, color=f"C{i}", ls=":", lw=1.2, label=f"{name} (refit)")
            if finite:
                ax.axhspan(value - 2 * se, value + 2 * se, color=f"C{i}", alpha=0.12, lw=0)
            series.append([value - 2 * se, value + 2 * se] if finite else [value])
    _robust_limits(ax, series)
    ax.set(
        title="parameters (y-limits from the 2nd half)",
        xlabel=time_label,
        ylabel="value (units of the fitted columns)",
    )
    if ax.get_legend_handles_labels()[0]:
        ax.legend()
    fig.suptitle(f"{summary['record']} — {summary['model']}")
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=110, format=Path(path).suffix.lstrip(".") or "png")
    plt.close(fig)


def overview_figure(rows, path) -> None:
    """The batch at a glance, from the rows of ``summary.csv``: each record's order with its
    band (the tracker's or law's final order ±2σ, the refit's interval), and the distributions
    of the orders and of the fits' NRMSE."""
    import numpy as np

    plt = _pyplot()

    def column(key):
        return np.array([float(r[key]) if r.get(key) is not None else np.nan for r in rows])

    names = [r["record"] for r in rows]
    index = np.arange(len(rows))
    fig, axes = plt.subplots(1, 3, figsize=(13, 3.8), layout="constrained")
    ax = axes[0]
    series = []
    if any("adaptive_alpha_final" in r for r in rows):
        a, sd = column("adaptive_alpha_final"), column("adaptive_alpha_final_std")
        ax.errorbar(index - 0.15, a, yerr=2 * sd, fmt="o", ms=3, color="C3", label="final order ±2σ")
        series.append(("final order", a, "C3"))
    if any("refit_order" in r for r in rows):
        q, lo, hi = column("refit_order"), column("refit_order_lower"), column("refit_order_upper")
        ax.errorbar(index + 0.15, q, yerr=[q - lo, hi - q], fmt="s", ms=3, color="C0", label="refit 95 %")
        series.append(("refit order", q, "C0"))
    ax.set(xlabel="record (sorted by name; see summary.csv)", ylabel="order q (dimensionless)",
           title=f"{len(rows)} records", ylim=(0, 1))
    if len(rows) <= 12:
        ax.set_xticks(index, names, rotation=45, ha="right", fontsize=7)
    ax.legend(fontsize=8)
    ax = axes[1]
    for label, values, color in series:
        ax.hist(values[np.isfinite(values)], bins=20, range=(0, 1), alpha=0.5, color=color, label=label)
    ax.set(xlabel="order q (dimensionless)", ylabel="records", title="orders")
    if series:
        ax.legend(fontsize=8)
    ax = axes[2]
    fits = [(column(k), label, c) for k, label, c in (
        ("adaptive_nrmse", "order tracking", "C3"), ("refit_nrmse", "refit", "C0"),
    ) if any(k in r for r in rows)]
    top = max([float(np.nanmax(v)) for v, _, _ in fits if np.any(np.isfinite(v))] or [1.0])
    for values, label, color in fits:
        ax.hist(values[np.isfinite(values)], bins=20, range=(0, 1.05 * top or 1.0), alpha=0.5,
                color=color, label=label)
    ax.set(xlabel="NRMSE of the fit (RMS error / range of the output)", ylabel="records",
           title="fit quality")
    if ax.get_legend_handles_labels()[0]:
        ax.legend(fontsize=8)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=110, format=Path(path).suffix.lstrip(".") or "png")
    plt.close(fig)
