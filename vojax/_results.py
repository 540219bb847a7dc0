"""What the result objects share: a short summary table, a figure of the order with its band,
and a table of the per-sample columns (the columns of ``identification.csv``)."""

import math

import numpy as np


class Summary(dict):
    """A result's headline numbers: a dict ``{quantity: {"value", "stderr", "note"}}`` that
    prints as a short table (`str`)."""

    def __str__(self):
        width = max((len(k) for k in self), default=8)
        lines = [f"{'quantity':<{width}}  {'value':>12}  {'± 1 SE':>10}  note"]
        for name, row in self.items():
            value, err = row.get("value"), row.get("stderr")
            lines.append(
                f"{name:<{width}}  {_fmt(value):>12}  {_fmt(err):>10}  {row.get('note', '')}".rstrip()
            )
        return "\n".join(lines)

    def _repr_pretty_(self, printer, cycle):  # IPython
        printer.text(str(self))


def _fmt(x):
    if x is None:
        return ""
    if isinstance(x, str):
        return x
    x = float(x)
    if math.isnan(x):
        return "nan"
    if math.isinf(x):
        return "inf"
    return f"{x:.6g}"


def row(value, stderr=None, note=""):
    out = {"value": value if value is None or isinstance(value, str) else float(value)}
    out["stderr"] = None if stderr is None else float(stderr)
    if note:
        out["note"] = note
    return out


def plot_order(times, alpha, lower, upper, *, ax=None, label, xlabel, title=None, color="C3"):
    """The order with its band on `ax` (a new figure's axes if None); returns the axes."""
    if ax is None:
        import matplotlib.pyplot as plt

        _, ax = plt.subplots(figsize=(6.4, 3.2), layout="constrained")
    times = np.asarray(times, dtype=float)
    ax.fill_between(times, np.asarray(lower), np.asarray(upper), color=color, alpha=0.25, lw=0,
                    label="±2σ band")
    ax.plot(times, np.asarray(alpha), color=color, lw=1.4, label=label)
    ax.set(xlabel=xlabel, ylabel="order α (dimensionless)")
    if title:
        ax.set_title(title)
    ax.legend(fontsize=8)
    return ax


def to_dataframe(columns):
    """A pandas DataFrame of the per-sample `columns` (a dict of equal-length arrays)."""
    try:
        import pandas as pd
    except ImportError:
        raise ImportError(
            "to_dataframe needs pandas: pip install 'vojax[pandas]' (or pandas itself)."
        ) from None
    return pd.DataFrame({k: np.asarray(v) for k, v in columns.items()})
