"""`Identification`: what `identify` returns, with its summary, plot and table."""

import equinox as eqx
import numpy as np
from jaxtyping import Array, Float

from . import _validate as check
from ._diagnostics import Diagnostics


def stated_drift(parameters) -> float:
    """The largest relative drift of the parameters that `parameters` states: "constant" 0,
    "free" (or "drifting") ∞, a number itself."""
    if parameters == "constant":
        return 0.0
    if parameters in ("free", "drifting"):
        return np.inf
    return float(parameters)


class Conditional(eqx.Module):
    """The conditional answer of the tracker: the order `alpha` (N,) with its ±2σ band
    `alpha_lower`, `alpha_upper` and `alpha_std`, which hold while the parameters drift less
    than `diagnostics.breakdown_drift` over the record (relative: (max − min)/|mean|); beyond
    that an order outside the band explains the data as well."""

    alpha: Float[Array, " N"]
    alpha_lower: Float[Array, " N"]
    alpha_upper: Float[Array, " N"]
    alpha_std: Float[Array, " N"]


class Identification(eqx.Module):
    """What `identify` returns: the estimates at every sample, their bands and the settings.

    - `alpha` (N,): the identified order α̂; `alpha_std` (N,): its standard deviation;
      `alpha_lower`, `alpha_upper` (N,): the ±2σ band (for ``method="kalman"`` taken on the
      unbounded scale and mapped back, so it stays inside `alpha_bounds`).
    - `p` (N, n): the identified parameters p̂; `p_std` (N, n): their standard deviations.
    - `x0`, `x0_std`: the output offset x(0) used (``"gradient"``) or estimated (``"kalman"``).
    - `y_hat` (N,): the identified output x0 + p̂ᵀφ(α̂, t) (eq. 25).
    - `y` (N,): the measured output the estimates were fitted to (for `plot`'s residuals).
    - `y_pred` (N,): the a-priori prediction, made before y_k is used (for a long record
      fitted as block means, `diagnostics.block` > 1: the blocks' predictions, linear
      between block times).
    - `dp` (N, n): ∂p/∂β along a uniform order shift (26), and `Lambda` (N,): Λ of eq. (30);
      ``None`` for ``method="kalman"``.
    - `method`, `diagnostics` (`Diagnostics`), and the settings used: `gamma`, `lam`, `alpha0`,
      `dt` (the median step when the samples came with times `t`), `alpha_bounds`, `memory`
      (for ``"kalman"``, `gamma` and `lam` are NaN and `diagnostics`/`tuning` say what was
      chosen, and `parameters` whether the parameters were let drift).

    For ``method="gradient"`` the band is the law's spread over realisations of the
    measurement noise, by the delta method through its own recursion (see
    `vojax._adaptive._bands`); it does not include the law's tracking bias. For
    ``method="kalman"`` it is the posterior of the tracker's random-walk model, mixed over
    the explanations its evidence leaves open and widened to cover every explanation that
    fits the data (with ``parameters="drifting"``, those with a drifting parameter too).
    """

    alpha: Float[Array, " N"]
    alpha_std: Float[Array, " N"]
    alpha_lower: Float[Array, " N"]
    alpha_upper: Float[Array, " N"]
    p: Float[Array, "N n"]
    p_std: Float[Array, "N n"]
    y_hat: Float[Array, " N"]
    y_pred: Float[Array, " N"]
    x0: Float[Array, ""]
    x0_std: Float[Array, ""]
    dp: Float[Array, "N n"] | None
    Lambda: Float[Array, " N"] | None
    gamma: Float[Array, ""]
    lam: Float[Array, ""]
    alpha0: Float[Array, ""]
    dt: Float[Array, ""]
    alpha_bounds: tuple[float, float] = eqx.field(static=True)
    memory: str = eqx.field(static=True)
    method: str = eqx.field(static=True)
    diagnostics: Diagnostics = eqx.field(static=True)
    tuning: object = eqx.field(static=True, default=None)
    # the tracker's `parameters` statement ("free", "constant", or a drift bound, a number;
    # `stated_drift` reads it); None for the law
    parameters: str | float | None = eqx.field(static=True, default=None)
    # the tracker's conditional answer (see `Conditional`); None for the law
    conditional: Conditional | None = None
    # the samples fitted, ``(first, stop)``: from the first fitted sample to one past the last
    # (a fit window or a mask, `identify(..., window=, mask=)`); None: every sample. The
    # summary and the verdict line speak of this range.
    fitted: tuple[int, int] | None = eqx.field(static=True, default=None)
    # the measured output (N,) the estimates were fitted to; None where it was not kept
    y: Float[Array, " N"] | None = None

    def _fitted(self, a):
        """`a` (N, …) over the fitted samples."""
        a = np.asarray(a)
        return a if self.fitted is None else a[slice(*self.fitted)]

    def summary(self, names=None):
        """The headline numbers as a `vojax.Summary` (a dict that prints as a table): the final
        order with its standard deviation, the order's median over the second half, the band's
        half-width, each parameter's final value (named by `names`, default ``p1``, ``p2``…),
        the offset, and the verdict with its reason; with a fit window or a mask, over the
        fitted samples (`fitted`)."""
        from ._results import Summary, parameter_names, row

        alpha, std = self._fitted(self.alpha), self._fitted(self.alpha_std)
        half = alpha.shape[0] // 2
        out = Summary()
        out["order (final)"] = row(alpha[-1], std[-1])
        out["order (median, second half)"] = row(np.median(alpha[half:]))
        out["band half-width (median)"] = row(self.diagnostics.band_halfwidth)
        p, p_std = self._fitted(self.p), self._fitted(self.p_std)
        names = parameter_names(names, p.shape[1])
        for j, name in enumerate(names):
            out[f"{name} (final)"] = row(p[-1, j], p_std[-1, j])
        out["x0"] = row(self.x0, self.x0_std)
        still = [
            name.split()[0].replace("_", " ") for name in self.diagnostics.at_edge
            if name.endswith("(lower edge)")
        ]
        note = self.diagnostics.message or (
            f"no {' or '.join(still)} found (tuned to its lower edge)" if still else ""
        )
        d = self.diagnostics
        out["identified"] = row("yes" if d.identified else "no", None, note)
        out["verdict"] = row(d.verdict, None, self.verdict_line())
        if np.isfinite(d.breakdown_drift) or np.isfinite(d.conditional_halfwidth):
            out["conditional band half-width"] = row(d.conditional_halfwidth)
            out["breakdown drift"] = row(d.breakdown_drift)
        other = self._clock_apart()
        if other is not None:
            out["order, parameters constant in the data's unit"] = row(
                other, None, "outside the band: the parameters' unit of time decides the order")
        return out

    def _clock_apart(self):
        """`diagnostics.clock_order` where it lies outside the band (its edges' medians over
        the second half): an account the band does not cover; else None."""
        d = self.diagnostics
        if not np.isfinite(d.clock_order):
            return None
        half = self._fitted(self.alpha).shape[0] // 2
        lo, hi = (float(np.median(self._fitted(a)[half:]))
                  for a in (self.alpha_lower, self.alpha_upper))
        return d.clock_order if not lo <= d.clock_order <= hi else None

    def verdict_line(self) -> str:
        """The verdict and the answer in one line: the order over the second half (its first
        and last values there) with the band's half-width, and how far it holds, e.g.
        "conditional: α 0.31 → 0.42 ± 0.02 if the parameters drift less than 12 % over the
        test; beyond that a drifting parameter explains the data as well". An answer
        identified under stated parameters (constant, or a drift bound) says how far the
        statement carries where the breakdown drift is finite and beyond the stated bound
        (where it is within, the band covers what drifts so far): "identified: α 0.31 → 0.42 ±
        0.02 with the parameters constant, as stated; with a drift of 1.5 % over the test an
        order outside the band fits as well"."""
        d = self.diagnostics
        if d.verdict == "conditional" and self.conditional is not None:
            alpha, width = self._fitted(self.conditional.alpha), d.conditional_halfwidth
        else:
            alpha, width = self._fitted(self.alpha), d.band_halfwidth
        half = alpha.shape[0] // 2
        head = f"{d.verdict}: α {alpha[half]:.2f} → {alpha[-1]:.2f} ± {width:.2g}"
        if d.verdict == "identified":
            bound = np.inf if self.parameters is None else stated_drift(self.parameters)
            stated = bool(np.isfinite(bound))
            held = ("" if not stated else " with the parameters constant, as stated"
                    if bound == 0 else
                    f" with the parameters drifting less than {100 * self.parameters:.0f} %, "
                    "as stated")
            other = self._clock_apart()
            clock = "" if other is None else (
                f" (over the record's span; constant in the data's unit of time instead, "
                f"α {other:.2f})")
            # how far the statement carries: the drift beyond it with which an order outside
            # the band fits as well (none found: nothing said, no promise made; within a
            # stated bound the band already covers the explanations that drift so far)
            reach = (f"; with a drift of {100 * d.breakdown_drift:.2g} % over the test an "
                     "order outside the band fits as well"
                     if bound < d.breakdown_drift < np.inf else "")
            return head + held + clock + reach
        if d.verdict != "conditional":
            return head
        if not np.isfinite(d.breakdown_drift):  # no drift tried left the conditional band
            return (f"{head} however the parameters drift (no drift tried moves the order "
                    "outside it); the tuned fit's other alternatives widen it to "
                    f"± {d.band_halfwidth:.2g}")
        return (f"{head} if the parameters drift less than {100 * d.breakdown_drift:.0f} % "
                "over the test; beyond that a drifting parameter explains the data as well")

    def plot(self, ax=None, *, t=None):
        """The identification at a glance against `t` (the sample times; default ``k·dt``).

        Without `ax`: a figure of three panels, the measured output with the identified fit
        ŷ, the residuals y − ŷ, and the order with its ±2σ band (the conditional band where
        the verdict is conditional, the fit window shaded), titled with the verdict and
        captioned with the answer, what it assumes and why, in full. With `ax`: the order
        panel alone, on that axes. Returns the order's Axes (its figure: ``ax.figure``)."""
        n = np.asarray(self.alpha).shape[0]
        times = float(self.dt) * np.arange(n) if t is None else check.reals(t, "t")
        if times.shape != (n,):
            raise ValueError(f"`t` must have shape ({n},), got {times.shape}.")
        if ax is None:
            from ._plotting_record import identification_figure

            return identification_figure(self, times)
        return self._plot_order(ax, times)

    def _plot_order(self, ax, times):
        """The order with its ±2σ band on `ax`, titled with the verdict (see `plot`)."""
        from ._results import plot_order

        name = {"kalman": "tracker", "gradient": "paper's law"}.get(self.method, self.method)
        ax = plot_order(
            times, self.alpha, self.alpha_lower, self.alpha_upper, ax=ax, label=name,
            xlabel="time (from the first sample)", title=f"order: {self.diagnostics.verdict}",
        )
        if self.fitted is not None:  # the fit window, shaded
            ax.axvspan(times[self.fitted[0]], times[self.fitted[1] - 1], color="0.92", zorder=0,
                       label="fit window")
            ax.legend(fontsize=8)
        if self.conditional is not None and self.diagnostics.verdict == "conditional":
            c = self.conditional
            ax.fill_between(times, np.asarray(c.alpha_lower), np.asarray(c.alpha_upper),
                            color="C0", alpha=0.3, lw=0,
                            label=_reach_label(self.diagnostics.breakdown_drift))
            ax.legend(fontsize=8)
        return ax

    def to_dataframe(self, t=None, names=None):
        """The per-sample columns (``alpha`` with ``alpha_std`` and its band, each parameter
        and its standard deviation, ``y_hat``, ``y_pred``; ``time`` if `t` is given) as a
        pandas DataFrame (needs the optional pandas)."""
        from ._results import dataframe_time, parameter_names, to_dataframe

        p, p_std = np.asarray(self.p), np.asarray(self.p_std)
        names = parameter_names(names, p.shape[1])
        columns = dataframe_time(t, p.shape[0])
        columns.update(
            alpha=self.alpha, alpha_std=self.alpha_std, alpha_lower=self.alpha_lower,
            alpha_upper=self.alpha_upper,
        )
        if self.conditional is not None:
            c = self.conditional
            columns.update(alpha_conditional=c.alpha, alpha_conditional_lower=c.alpha_lower,
                           alpha_conditional_upper=c.alpha_upper)
        for j, name in enumerate(names):
            columns[name] = p[:, j]
            columns[f"{name}_std"] = p_std[:, j]
        columns.update(y_hat=self.y_hat, y_pred=self.y_pred)
        return to_dataframe(columns)


def _reach_label(breakdown_drift) -> str:
    """The conditional band's legend label: the drift it holds below, or every drift tried."""
    if not np.isfinite(breakdown_drift):
        return "any drift tried"
    return f"if drift < {100 * breakdown_drift:.0f} %"
