"""`Refit`: what `refit` returns, with its summary, plot and table."""


from typing import TYPE_CHECKING

import equinox as eqx
import numpy as np
from jaxtyping import Array, Float

from . import _validate as check

if TYPE_CHECKING:  # imported where it is used: 0.07 s of `import vojax`
    import optimistix


class Refit(eqx.Module):
    """What `refit` returns.

    - `order` (N,): the fitted order trajectory; `order_stderr` (N,): its standard error (delta
      method); `order_lower`, `order_upper` (N,): the ±2σ Wald interval taken on the unbounded
      (logistic) scale and mapped back, so it stays inside the bounds and keeps its meaning
      near them; `at_bound`: a knot lies within 0.1 % of the range of a bound (then the interval
      is one-sided in effect and the standard error small by construction: do not trust it).
    - `p` (n + m,), `p_stderr`, `p_cov` (n + m, n + m): the fitted coefficients of the
      integrated inputs and then of the `direct` regressors, their standard errors and
      covariance; `p_at_bound`: which coefficients were held at 0 by `p_signs` (error 0).
    - A standard error (and variance) is ``inf`` where the data do not determine the quantity:
      the Jacobian scaled to unit columns has a singular value below 1e-10 of its largest
      along it (e.g. a hold phase of constant output with the offset estimated). The order's
      interval then spans `order_bounds`.
    - `x0`, `x0_stderr`: the output offset (at `origin` when given), estimated unless given
      (then its error is 0).
    - `knots` (K,), `knots_stderr` (K,), `knot_times` (K,): the fitted orders at the knots
      (K = 1: constant), their standard errors (delta method; ``inf`` where undetermined) and
      their times.
    - `y_hat` (N,), `residuals` (N,) = y − y_hat, `sigma`: residual standard deviation.
    - `result`: optimistix's result code (`optx.RESULTS.successful` when it converged),
      `steps`: the solver's steps.
    - `residual_correlation`: the lag-1 autocorrelation ρ of the fitted residuals; every
      standard error, covariance and interval above is inflated by `error_inflation`
      ``√((1 + ρ)/(1 − ρ))`` where ρ exceeds a white sequence's two standard errors
      (``2/√n``): residuals correlated as AR(1) noise, or a model that misses a slow part of
      the signal, so that the samples tell less than their number.
    """

    order: Float[Array, " N"]
    order_stderr: Float[Array, " N"]
    order_lower: Float[Array, " N"]
    order_upper: Float[Array, " N"]
    p: Float[Array, " n"]
    p_stderr: Float[Array, " n"]
    p_cov: Float[Array, "n n"]
    x0: Float[Array, ""]
    x0_stderr: Float[Array, ""]
    knots: Float[Array, " K"]
    knots_stderr: Float[Array, " K"]
    knot_times: Float[Array, " K"]
    y_hat: Float[Array, " N"]
    residuals: Float[Array, " N"]
    sigma: Float[Array, ""]
    result: "optimistix.RESULTS"
    steps: Array
    p_at_bound: tuple[bool, ...] = eqx.field(static=True, default=())
    at_bound: bool = eqx.field(static=True, default=False)
    residual_correlation: float = eqx.field(static=True, default=float("nan"))
    error_inflation: float = eqx.field(static=True, default=1.0)

    @property
    def constant(self) -> bool:
        """Whether the fitted order is one number (``order="constant"``, or a fixed constant)."""
        order = np.asarray(self.order)
        return bool(order.size and np.all(order == order[0]))

    def _constant_or_raise(self):
        if not self.constant:
            raise ValueError(
                f"the order varies along the record ({np.asarray(self.knots).size} knots): read "
                "`order` (per sample), or `knots` at `knot_times`."
            )

    @property
    def order_value(self) -> float:
        """The order as a number, where it is constant; `ValueError` where it varies."""
        self._constant_or_raise()
        return float(np.asarray(self.order)[0])

    @property
    def order_value_stderr(self) -> float:
        """The constant order's standard error; `ValueError` where the order varies."""
        self._constant_or_raise()
        return float(np.asarray(self.order_stderr)[0])

    def summary(self, names=None):
        """The headline numbers as a `vojax.Summary` (a dict that prints as a table): the
        order (or its knots), each coefficient (named by `names`, default ``p1``, ``p2``…)
        with its standard error, the offset, the residual σ and whether it converged."""
        from ._results import Summary, parameter_names, row

        out = Summary()
        if self.constant:
            note = "at a bound: the interval is not meaningful" if self.at_bound else ""
            out["order"] = row(self.order_value, self.order_value_stderr, note)
        else:
            knots = np.asarray(self.knots)
            ses = np.asarray(self.knots_stderr)
            for k, (q, se, tk) in enumerate(zip(knots, ses, np.asarray(self.knot_times))):
                out[f"order at knot {k + 1} (t = {float(tk):.4g})"] = row(q, se)
        p, se = np.asarray(self.p), np.asarray(self.p_stderr)
        names = parameter_names(names, p.size)
        for j, name in enumerate(names):
            held = bool(self.p_at_bound[j]) if j < len(self.p_at_bound) else False
            out[name] = row(p[j], se[j], "held at 0 by its sign" if held else "")
        out["x0"] = row(self.x0, self.x0_stderr)
        out["residual sigma"] = row(self.sigma)
        import optimistix as optx

        out["converged"] = row("yes" if self.result == optx.RESULTS.successful else "no")
        return out

    def plot(self, ax=None, *, t=None):
        """The fitted order with its ±2σ interval against `t` (the sample times; default the
        sample index). Returns the matplotlib Axes."""
        from ._results import plot_order

        n = np.asarray(self.order).size
        times = np.arange(n) if t is None else check.reals(t, "t")
        if times.shape != (n,):
            raise ValueError(f"`t` must have shape ({n},), got {times.shape}.")
        return plot_order(
            times, self.order, self.order_lower, self.order_upper, ax=ax, label="refit",
            xlabel="sample" if t is None else "time", color="C0",
        )

    def to_dataframe(self, t=None):
        """The per-sample columns (``order``, its interval, ``y_hat``, ``residuals``; ``time``
        if `t` is given) as a pandas DataFrame (needs the optional pandas)."""
        from ._results import dataframe_time, to_dataframe

        columns = dataframe_time(t, np.asarray(self.order).shape[0])
        columns.update(
            order=self.order, order_lower=self.order_lower, order_upper=self.order_upper,
            y_hat=self.y_hat, residuals=self.residuals,
        )
        return to_dataframe(columns)


class RefitWarning(UserWarning):
    """A refit whose answer needs care: it did not converge, its order sits at a bound, or its
    residuals are strongly correlated (the model misses part of the signal)."""
