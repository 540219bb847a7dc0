"""Pieces the record figure and `Identification.plot` share: the time axis (a log axis for a
log-spaced clock), plain tick labels on constant signals, the residual panel, the parameters'
units, and the verdict's title and caption."""

import textwrap

import numpy as np

from ._plotting import unit_of

# a clock whose steps at its end are this many times those at its start is drawn on a
# (symmetric) log time axis: on a linear one a 1 s ramp of a 60 s log-spaced record vanishes
LOG_CLOCK = 30.0
# a caption line: its characters per inch of the figure's width at 9 pt, and its height in
# inches
CAPTION_CHARS, CAPTION_LINE = 14.5, 0.19
# inches around the panels: above (the figure's title and the top panels' titles), left (tick
# labels and the y-label), right
TOP, LEFT, RIGHT = 0.8, 0.8, 0.2
# a series whose range is below this fraction of its level is drawn within ±1 % of the level
# (a constant 500 Pa with float jitter is not a zoom on its last digits)
FLAT = 1e-3

_NAMES = {"eta": "η", "E0": "E₀", "E1": "E₁"}


def log_clock(t) -> bool:
    """Whether the sample times `t` are log-spaced: the median step of their last quarter
    `LOG_CLOCK` times that of their first (a gap or two in a uniform clock is not)."""
    steps = np.diff(np.asarray(t, dtype=float))
    if steps.size < 8 or not np.all(steps > 0):
        return False
    quarter = steps.size // 4
    return bool(np.median(steps[-quarter:]) > LOG_CLOCK * np.median(steps[:quarter]))


def set_time_axis(ax, t) -> None:
    """A symmetric-log time axis for a log-spaced clock (linear below its first step, so that
    the first sample at 0 is drawn), else at most six ticks on the (linear) axis: a reused
    figure's axes are linear again before a record is drawn."""
    from matplotlib.ticker import MaxNLocator

    t = np.asarray(t, dtype=float)
    if log_clock(t):
        ax.set_xscale("symlog", linthresh=float(t[1] - t[0]), linscale=0.3)
        ax.set_xlim(t[0], t[-1])  # no margin: below 0 a symmetric-log axis draws −10ⁿ decades
    else:
        ax.xaxis.set_major_locator(MaxNLocator(nbins=5, steps=[1, 2, 2.5, 5, 10]))


def time_label(summary) -> str:
    """The time axes' label: the clock's unit (or the column's name), from the first sample,
    and where that sample lies in the file."""
    column = summary.get("time_column", "t")
    unit = unit_of(column, summary.get("units"))
    offset = summary.get("time_offset") or 0.0
    return f"time ({unit or column}, from the first sample" + (
        f", at {offset:g} in the file)" if offset else ")")


def parameter_label(name: str, summary) -> str:
    """A parameter's name with its unit, from the units of the record's columns (a column's
    name stands for its unit where it has none): for ``σ = η D^α ε`` (x = ε, u = σ) η is in
    σ·t^α/ε, the springs (k, E, E₀, E₁) in σ/ε; a linear model's ``p_j`` in x/(u_j·t^α). A
    strain (divided by a length, ``--length``, or a column named so with no unit) is
    dimensionless; a force divided by an area (``--area``) is that column's unit per area."""
    units = summary.get("units") or {}
    time = unit_of(summary.get("time_column", "t"), units) or summary.get("time_column", "t")
    output = summary["output_column"]
    # a strain (divided by a length, or a column named so without a unit) is dimensionless
    out = None if summary.get("length") else unit_of(output, units) or (
        None if "strain" in str(output).lower() else output)
    out = None if out == "1" else out  # a unit of 1: dimensionless
    tau = f"{time}$^{{\\alpha}}$"
    if name.startswith("p_") and summary.get("model") == "linear":
        column = name[2:]
        inp = unit_of(column, units) or column
        return f"{name} ({out or '1'}/({inp}·{tau}))"
    (column,) = summary["input_columns"][:1] or ["u"]
    stress = unit_of(column, units) or column
    if summary.get("area"):
        stress = f"{stress}/area"
    per = f"/{out}" if out else ""
    unit = f"{stress}·{tau}{per}" if name == "eta" else f"{stress}{per}"
    return f"{_NAMES.get(name, name)} ({unit})"


def plain_y(ax, series) -> None:
    """A series flat to `FLAT` of its level drawn within ±1 % of it with plain tick labels,
    not as a zoom on its rounding with an offset (``1e-5+5e2``); others with matplotlib's
    usual labels (an offset where a real variation sits on a large level)."""
    values = np.concatenate([np.ravel(np.asarray(v, dtype=float)) for v in series])
    values = values[np.isfinite(values)]
    lo, hi = (float(values.min()), float(values.max())) if values.size else (0.0, 0.0)
    level = max(abs(lo), abs(hi))
    flat = level > 0 and hi - lo < FLAT * level
    ax.ticklabel_format(axis="y", useOffset=not flat)  # set each time: the figure is reused
    if flat:
        middle = 0.5 * (lo + hi)
        ax.set_ylim(middle - 0.01 * level, middle + 0.01 * level)


def residual_panel(ax, t, y, fits, label) -> None:
    """The measured output minus each fit, with its RMS in the legend."""
    y = np.asarray(y, dtype=float)
    ax.axhline(0.0, color="0.6", lw=0.8)
    for name, fit, colour in fits:
        r = y - np.asarray(fit, dtype=float)
        rms = float(np.sqrt(np.nanmean(r**2)))
        ax.plot(t, r, color=colour, lw=0.9, label=f"{name} (RMS {rms:.3g})")
    ax.set(title="residuals (measured − fit)", xlabel=label, ylabel="residual")
    ax.ticklabel_format(axis="y", useOffset=False)
    if fits:
        ax.legend(fontsize=8)


def verdict_of(part) -> str | None:
    """The verdict in its three words (identified, conditional, not identified), or None."""
    if not part:
        return None
    if part.get("verdict"):
        return part["verdict"]
    if "identified" in part:
        return "identified" if part["identified"] else "not identified"
    return None


def verdict_title(summary, part) -> str:
    """One line: the record, the model and the verdict."""
    title = f"{summary['record']} — {summary['model']}"
    verdict = verdict_of(part)
    if verdict:
        title += f": order {verdict}"
    if summary.get("disagreement"):
        title += "; the estimators disagree"
    return title


def _assumed(part) -> str:
    """What the tracker's answer assumes, as stated (or by default)."""
    model = part.get("parameter_model")
    if model in ("constant",):
        said = "parameters stated constant"
    elif isinstance(model, (int, float)):
        said = f"parameters stated to drift less than {100 * model:.0f} % over the test"
    elif model is None:
        return ""
    else:
        said = "parameters free to drift (the default)"
    offset = part.get("offset_model")
    if offset:
        said += "; output offset " + ("given" if offset == "known" else "estimated")
    return said


def caption_lines(summary, part, kind) -> list[str]:
    """The caption's sentences: the answer and its band, what it assumes, why (the finding in
    full), the refit's order, the estimators' disagreement, the AFM modulus."""
    lines = []
    if part:
        answer = part.get("answer") or verdict_of(part) or ""
        assumed = _assumed(part)
        lines.append(f"{kind.capitalize()} — {answer}" + (f" ({assumed})." if assumed else "."))
        finding = part.get("finding") or (part.get("message") or "").split(". ")[0]
        if finding:
            lines.append("Why: " + finding.rstrip(".") + ".")
    refit = summary.get("refit")
    if refit and refit.get("order") is not None:
        lines.append(f"Refit (constant order): q = {refit['order']:.3g}, 95 % "
                     f"[{refit['order_lower']:.3g}, {refit['order_upper']:.3g}].")
    if summary.get("disagreement"):
        lines.append(summary["disagreement"].rstrip(".") + ".")
    afm = summary.get("afm") or {}
    if afm.get("youngs_modulus_Pa") is not None:  # nanite's Hertz fit of the loading
        lines.append(f"E = {afm['youngs_modulus_Pa']:.4g} ± {afm['youngs_modulus_stderr_Pa']:.2g}"
                     f" Pa (Hertz fit of the approach, {afm['tip']}).")
    return lines


def caption(fig, summary, part, kind, panels_height) -> list[str]:
    """Writes the caption below the panels, every line wrapped and none cut: the figure grows
    by the caption's height, the panels keep theirs. Returns the wrapped lines."""
    width = float(fig.get_size_inches()[0])
    lines = [w for line in caption_lines(summary, part, kind)
             for w in textwrap.wrap(line, int(CAPTION_CHARS * width), subsequent_indent="  ")]
    extra = CAPTION_LINE * len(lines) + (0.1 if lines else 0.0)
    height = panels_height + extra
    fig.set_size_inches(width, height)
    fig.subplots_adjust(left=LEFT / width, right=1 - RIGHT / width, top=1 - TOP / height,
                        bottom=(extra + 0.55) / height, wspace=0.25, hspace=0.55)
    if lines:
        fig.text(0.015, (extra - 0.02) / height, "\n".join(lines), ha="left", va="top",
                 fontsize=9, linespacing=1.3)
    return lines
