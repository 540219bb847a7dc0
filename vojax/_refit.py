"""`refit`: offline batch fit of the order trajectory and the parameters (optimistix)."""

from typing import TYPE_CHECKING

import jax
import jax.numpy as jnp
import numpy as np

from . import _validate as check
from ._integral import make_memory, scan_memory
from ._refit_inputs import (
    BOUND_MARGIN,
    _check_x0,
    _direct_regressors,
    _from_origin,
    _num_knots,
    _signs,
    _start,
    _weights,
)
from ._validate import check_options
from ._xla import spare_mappings

if TYPE_CHECKING:  # imported where it is used: 0.07 s of `import vojax`
    pass
from ._refit_active import _settled_fit as _settled_fit
from ._refit_result import Refit as Refit
from ._refit_result import RefitWarning as RefitWarning
from ._refit_solve import ROUNDING as ROUNDING
from ._refit_solve import TRACES as TRACES
from ._refit_solve import UNDETERMINED_RCOND as UNDETERMINED_RCOND
from ._refit_solve import _fit as _fit
from ._refit_solve import _gauss_newton as _gauss_newton
from ._refit_solve import _hold_worst as _hold_worst
from ._refit_solve import _knot_places as _knot_places
from ._refit_solve import _linear as _linear
from ._refit_solve import _order_curve as _order_curve
from ._refit_solve import _raw_curve as _raw_curve
from ._refit_solve import _zero_rounding as _zero_rounding


def refit(
    u,
    y=None,
    dt=None,
    *,
    t=None,
    order="constant",
    order_bounds=(0.01, 0.99),
    order0=0.5,
    x0="estimate",
    direct=None,
    weights=None,
    window=None,
    relative: bool = False,
    origin=None,
    p_signs=None,
    memory: str = "exponential",
    rule: str = "trapezoid",
    rtol: float = 1e-10,
    atol: float = 1e-10,
    max_steps: int = 200,
    throw: bool = False,
    mask=None,
    warn: bool = True,
) -> Refit:
    """Fits ``y = x0 + pᵀ φ(β, t) + cᵀ v`` over a record by Levenberg–Marquardt.

    The samples lie at ``t_k = k·dt`` or at the strictly increasing times `t` (log-spaced,
    irregular; exactly one of the two). Or `u` is a `Record` (`vojax.load_records`) given
    alone, ``refit(record)``: its inputs, output and own clock. ``φ`` integrates the inputs
    `u` (N, n) from the start of the test; the optional `direct` regressors ``v`` (N, m)
    enter as they are (order 0: the spring of a fractional Maxwell model,
    `vojax.FractionalMaxwell`).

    The offset ``x0`` (the output at the start) is estimated with the rest (``x0="estimate"``,
    the default), taken as ``y[0]`` (``None``) or fixed (a number).

    The order is a constant (``order="constant"``), a smooth curve through ``K`` knots spread
    evenly over the samples (``order=K``, K ≥ 2; on a log-spaced grid, evenly in log time;
    linear in a logit variable, so it stays inside `order_bounds`), or fixed (``order`` an
    ``(N,)`` array: then the fit is linear least squares). The coefficients are constant.
    Standard errors come from the Gauss–Newton approximation ``σ² (JᵀWJ)⁻¹``,
    ``σ² = Σ w r²/(N_fit − P)``, and the order's by the delta method through the logistic
    map of the knots.

    **What is fitted** (the whole input history drives the model either way):

    - `window` ``(from, to)``: only samples with ``from ≤ t_k ≤ to`` enter the objective and the
      statistics, e.g. the hold phase of a ramp–hold test;
    - `weights` (N,), ≥ 0: each squared residual is multiplied by its weight;
    - `relative`: residuals relative to the data, ``(y − ŷ)/y`` (weights ``1/y²``), for data
      spanning decades (to first order the residuals of ``ln y``); `y` must not be 0 where fitted;
    - `mask` (N,) of 0 and 1: samples with 0 are left out (the batch's padding).

    **Start of the test:** `origin` ``T0`` before the first sample (``T0 < t_0``, or ``< 0`` with
    `dt`) says the test started there with the inputs held at their first values (a step load
    at ``T0``): the integral starts at ``T0`` and ``x0`` is the output at ``T0`` (estimated or
    given). For another loading history before the first sample, give those samples in `u`,
    `t` and leave them out of the fit with `window`.

    **Signs:** `p_signs` (n + m,) of +1 (the coefficient is ≥ 0), −1 (≤ 0) or 0 (free) keeps
    physical parameters physical (`vojax.KelvinVoigt().p_signs`: η > 0, k ≥ 0). A coefficient
    whose free fit breaks its sign is fixed at 0, the bound, and the rest refitted (an active
    set, one coefficient at a time); `Refit.p_at_bound` says which, with standard error 0.

    **Restarts:** a fit that did not converge from `order0`, or whose active set held every
    input's coefficient at 0 (the order then moves nothing and the solver stops where it
    started), is run again from the orders at 10, 30, 50, 70 and 90 % of `order_bounds`; the
    converged fit with the least (weighted) sum of squares is returned, so the answer does not
    depend on the start. A constant order is then checked against its profile (the sum of
    squares with the coefficients refitted at each order, at 17 orders over `order_bounds`,
    narrowed around each other basin): where the profile fits better, the fit is run again
    from there (Levenberg–Marquardt stops at its start where the profile is flat, and in the
    basin of its start where the profile has two minima).

    **Errors under correlated residuals:** the Gauss–Newton errors assume independent
    residuals; where they are correlated (lag-1 ρ above ``2/√n``) every error is inflated by
    ``√((1 + ρ)/(1 − ρ))`` (`Refit.error_inflation`). With `warn`, a `RefitWarning` says when
    the fit did not converge, sits at a bound or has residuals correlated above 0.5.

    **Returns:** a `Refit`; ``p`` holds the coefficients of `u` then of `direct`.
    """
    u, y, dt, t = check.record_arguments(u, y, dt, t, call="refit")
    spare_mappings()  # a long process (a batch, `compare`'s models) never reaches the cap
    bounds = check.interval(order_bounds, "order_bounds")
    estimate = _check_x0(x0, origin)
    order0 = _start(order0, bounds)
    max_steps = check.count(max_steps, "max_steps", 1, 100_000)
    rtol, atol = (float(check.positive(v, name)) for v, name in ((rtol, "rtol"), (atol, "atol")))
    throw, warn = check.flag(throw, "throw"), check.flag(warn, "warn")
    u2, y, _, x0, _ = check_options(
        u, y, dt, None, order0, bounds, memory, rule, None if estimate else x0, None, t=t
    )
    num, width = u2.shape
    times = np.asarray(t) if t is not None else float(dt) * np.arange(num)
    v = _direct_regressors(direct, num)
    w = _weights(num, mask, weights, window, relative, times, y)
    signs = _signs(p_signs, width + v.shape[1])
    if np.count_nonzero(w) < width + v.shape[1] + 3:
        raise ValueError(
            f"{np.count_nonzero(w)} samples have a non-zero weight; the fit needs at least "
            f"{width + v.shape[1] + 3}."
        )
    grid, u2, v, y, w = _from_origin(origin, t, times, u2, v, y, w)
    n_all = u2.shape[0]
    mem = make_memory(
        memory, dt if grid is None else None, n_all, rule=rule, order_range=bounds, times=grid
    )
    # with an estimated offset, x0 = y[0] + the fitted correction (on the host: an eager JAX
    # operation compiles a program of its own)
    big_y = jnp.asarray(np.asarray(y) - np.asarray(x0), u2.dtype)
    sw = jnp.asarray(np.sqrt(w), u2.dtype)
    v = jnp.asarray(v, u2.dtype)
    trim = slice(1, None) if origin is not None else slice(None)

    num_knots = _num_knots(order, num)
    if num_knots is None:
        fixed = check.order(order, num, bounds=bounds, closed=True)
        if origin is not None:
            fixed = jnp.concatenate([fixed[:1], fixed])
        phi = scan_memory(mem, u2, fixed, False)
        fit = _linear(phi, v, big_y, fixed, x0, width, estimate, sw, signs)
        return jax.tree_util.tree_map(
            lambda a: a[trim] if getattr(a, "shape", ()) and a.shape[0] == n_all else a, fit
        )

    solver = dict(order0=order0, bounds=bounds, estimate=estimate, rtol=rtol, atol=atol,
                  max_steps=max_steps, throw=throw)
    out, active = _settled_fit(mem, u2, v, big_y, sw, signs, num_knots, solver)
    all_times = times if grid is None or origin is None else np.asarray(grid)
    return _result(out, active, x0, estimate, trim, np.asarray(sw), bounds, all_times, warn)



def _result(out, active, x0, estimate, trim, sw, bounds, all_times, warn):
    """The `Refit` from the solver's dictionary: the samples before the origin trimmed, the
    errors inflated for correlated residuals, the knots' times, the warnings."""
    offset = out.pop("offset")
    out.pop("profile", None)
    fit = out.pop("fit")
    span = float(out.pop("span"))
    knots = out["knots"]
    margin = BOUND_MARGIN * (bounds[1] - bounds[0])
    num_knots = knots.shape[0]
    places = np.asarray(_knot_places(num_knots)) * (span - 1)
    out = {k: (a[trim] if k in ("order", "order_stderr", "order_lower", "order_upper",
                                "residuals") else a) for k, a in out.items()}
    rho, inflation = _residual_inflation(np.asarray(out["residuals"]), sw[trim])
    out = _inflated(out, inflation, bounds)
    at_bound = bool(np.any((knots < bounds[0] + margin) | (knots > bounds[1] - margin)))
    if warn:
        _warn(out["result"], at_bound, rho)
    x0 = np.asarray(x0)
    arrays = dict(
        out,
        x0=x0 + offset if estimate else x0,
        knot_times=(np.interp(places, np.arange(all_times.size), all_times)
                    if num_knots > 1 else np.zeros(1)),
        y_hat=(fit + x0)[trim],
    )
    return Refit(
        **{k: (a if k == "result" else jax.device_put(np.asarray(a))) for k, a in arrays.items()},
        residual_correlation=rho,
        error_inflation=inflation,
        p_at_bound=tuple(bool(a == 0) for a in active),
        at_bound=at_bound,
    )


# the residuals' lag-1 correlation above which the refit warns that its model misses part of
# the signal (its intervals are inflated for any positive correlation); and the largest
# correlation the inflation takes (×14)
CORRELATED_RESIDUALS = 0.5


MAX_RESIDUAL_CORRELATION = 0.99


def _residual_inflation(residuals, sw):
    """ρ, the lag-1 autocorrelation of the fitted residuals (NaN for fewer than 4), and the
    factor ``√((1 + ρ)/(1 − ρ))`` on the standard errors: 1 where ρ is within two standard
    errors of a white sequence's, ``2/√n`` (independent residuals, as the errors assume)."""
    from ._stats import lag1_correlation

    fitted = residuals[np.asarray(sw) > 0]
    if fitted.size < 4:
        return float("nan"), 1.0
    rho = lag1_correlation(fitted)
    if not np.isfinite(rho) or rho <= 2.0 / np.sqrt(fitted.size):
        return float(rho), 1.0
    r = min(rho, MAX_RESIDUAL_CORRELATION)
    return float(rho), float(np.sqrt((1 + r) / (1 - r)))


def _inflated(out, factor, bounds):
    """The fit's errors × `factor` (covariances × factor²), the order's interval widened on
    its logistic scale (where the ±2σ Wald interval is taken)."""
    if factor == 1.0:
        return out
    lo, hi = bounds
    out = dict(out)
    order, sd = np.asarray(out["order"]), np.asarray(out["order_stderr"])
    z = np.clip((order - lo) / (hi - lo), 1e-300, 1 - 1e-16)
    raw, slope = np.log(z) - np.log1p(-z), (hi - lo) * z * (1 - z)
    raw_sd = factor * sd / np.maximum(slope, 1e-300)
    sig = lambda x: 0.5 * (1.0 + np.tanh(x / 2))  # noqa: E731  (no overflow at the bounds)
    out["order_lower"] = lo + (hi - lo) * sig(raw - 2 * raw_sd)
    out["order_upper"] = lo + (hi - lo) * sig(raw + 2 * raw_sd)
    for key in ("order_stderr", "p_stderr", "x0_stderr", "knots_stderr"):
        out[key] = out[key] * factor
    out["p_cov"] = out["p_cov"] * factor**2
    return out


def _warn(result, at_bound, rho):
    import warnings

    import optimistix as optx

    problems = []
    if not bool(result == optx.RESULTS.successful):
        problems.append("the fit did not converge (more `max_steps`, another `order0`)")
    if at_bound:
        problems.append("the order sits at a bound of `order_bounds`: its interval is "
                        "one-sided and its standard error is not meaningful")
    if np.isfinite(rho) and rho > CORRELATED_RESIDUALS:
        problems.append(f"the residuals are correlated (lag-1 {rho:.2f}): the model misses "
                        "part of the signal (compare models with vojax.compare, another "
                        "--model); the errors are inflated for it")
    if problems:
        warnings.warn(f"vojax.refit: {'; '.join(problems)}.", RefitWarning, stacklevel=3)


def refit_lbfgsb(
    u,
    y,
    dt,
    *,
    order="constant",
    order_bounds=(0.01, 0.99),
    order0=0.5,
    x0=None,
    memory: str = "exponential",
    rule: str = "trapezoid",
    max_steps: int = 500,
    tol: float = 1e-12,
    warn: bool = True,
):
    """Second opinion on `refit`: the same model and objective, ``½‖y − x0 − pᵀφ‖²``, by
    jaxopt's box-constrained L-BFGS-B, with the knot orders themselves bounded by
    `order_bounds` (no logit). Needs the optional extra ``vojax[jaxopt]``.

    **Returns:** ``(order (N,), p (n,))``. With `warn`, a `RefitWarning` says when the
    solver stopped before its projected gradient's norm fell below `tol` (after `max_steps`
    steps or a failed line search): the answer is then where it stopped, not a minimum.

    **Raises:** `ValueError` for an argument out of range, or where the solver reaches no
    finite answer.
    """
    try:
        import warnings

        with warnings.catch_warnings():
            warnings.filterwarnings("ignore", "JAXopt is no longer maintained", DeprecationWarning)
            import jaxopt
    except ImportError:  # pragma: no cover - depends on the environment
        raise ImportError("refit_lbfgsb needs jaxopt: pip install 'vojax[jaxopt]'.") from None
    bounds = check.interval(order_bounds, "order_bounds")
    order0 = _start(order0, bounds)
    u2, y, _, x0, _ = check_options(u, y, dt, None, order0, bounds, memory, rule, x0, None)
    max_steps, tol = (check.count(max_steps, "max_steps", 1, 100_000),
                      float(check.positive(tol, "tol")))
    warn = check.flag(warn, "warn")
    num, width = u2.shape
    if order == "constant":
        num_knots = 1
    elif isinstance(order, (int, np.integer)) and 1 <= order <= num // 2:
        num_knots = int(order)
    else:
        raise ValueError(
            f"`order` must be 'constant' or a number of knots in [1, {num // 2}], got {order!r}."
        )
    lo, hi = bounds
    mem = make_memory(memory, dt, num, rule=rule, order_range=bounds)
    big_y = y - x0

    def objective(theta):
        z = (theta[:num_knots] - lo) / (hi - lo)
        beta = _order_curve(jnp.log(z / (1 - z)), num, bounds)
        r = scan_memory(mem, u2, beta, False) @ theta[num_knots:] - big_y
        return 0.5 * jnp.sum(r**2)

    eps = 1e-9
    lower = jnp.concatenate([jnp.full(num_knots, lo + eps), jnp.full(width, -jnp.inf)])
    upper = jnp.concatenate([jnp.full(num_knots, hi - eps), jnp.full(width, jnp.inf)])
    phi0 = scan_memory(mem, u2, jnp.full((num,), float(order0)), False)
    theta0 = jnp.concatenate([jnp.full(num_knots, float(order0)), jnp.linalg.lstsq(phi0, big_y)[0]])
    solver = jaxopt.LBFGSB(fun=objective, maxiter=max_steps, tol=tol)
    theta, state = solver.run(theta0, bounds=(lower, upper))
    if not np.all(np.isfinite(np.asarray(theta))):
        raise ValueError("refit_lbfgsb reached no finite answer on these data (L-BFGS-B "
                         "stepped out of float64's range): use vojax.refit, or other units.")
    error = float(state.error)
    if warn and not error <= tol:  # (`warnings` imported with jaxopt above)
        why = ("its line search failed" if bool(getattr(state, "failed_linesearch", False))
               else f"it took all {max_steps} of `max_steps`")
        warnings.warn(f"vojax.refit_lbfgsb: the fit did not converge ({why} with the projected "
                      f"gradient's norm at {error:.3g}, above `tol` {tol:.3g}): the answer is "
                      "where it stopped (more `max_steps`, data in other units, or vojax.refit).",
                      RefitWarning, stacklevel=2)
    z = (theta[:num_knots] - lo) / (hi - lo)
    return _order_curve(jnp.log(z / (1 - z)), num, bounds), theta[num_knots:]
