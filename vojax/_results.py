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


def dataframe_time(t, num):
    """The `time` column of a result's DataFrame: `t` as ``(num,)`` finite floats."""
    if t is None:
        return {}
    try:
        times = np.asarray(t, dtype=float)
    except (TypeError, ValueError):
        raise TypeError(f"`t` must be an array of {num} times, got {type(t).__name__}.") from None
    if times.shape != (num,) or not np.all(np.isfinite(times)):
        raise ValueError(
            f"`t` must be {num} finite times, one per sample, got shape {times.shape}."
        )
    return {"time": times}


def parameter_names(names, count):
    """The names of a result's `count` parameters: ``p1, p2, …`` by default, or `names`, as
    many distinct strings."""
    if names is None:
        return [f"p{j + 1}" for j in range(count)]
    try:
        names = [names] if isinstance(names, str) else list(names)
    except TypeError:
        raise TypeError(f"`names` must be {count} non-empty strings, one per parameter, got "
                        f"{names!r}.") from None
    if len(names) != count or not all(isinstance(n, str) and n for n in names):
        raise ValueError(f"`names` must be {count} non-empty strings, one per parameter, got "
                         f"{names!r}.")
    if len(set(names)) != count:
        raise ValueError(f"`names` must be distinct, got {names!r}.")
    return names


def to_dataframe(columns):
    """A pandas DataFrame of the per-sample `columns` (a dict of equal-length arrays)."""
    try:
        import pandas as pd
    except ImportError:
        raise ImportError(
            "to_dataframe needs pandas: pip install 'vojax[pandas]' (or pandas itself)."
        ) from None
    return pd.DataFrame({k: np.asarray(v) for k, v in columns.items()})
