"""`refit`: offline batch fit of the order trajectory and the parameters (optimistix)."""

from typing import TYPE_CHECKING

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from . import _validate as check
from ._validate import check_options
from ._integral import make_memory, order_map, scan_memory

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
        from ._results import Summary, row

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
        names = list(names) if names is not None else [f"p{j + 1}" for j in range(p.size)]
        if len(names) != p.size:
            raise ValueError(f"`names` must name the {p.size} coefficients, got {len(names)}.")
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
        times = np.arange(n) if t is None else np.asarray(t, dtype=float)
        if times.shape != (n,):
            raise ValueError(f"`t` must have shape ({n},), got {times.shape}.")
        return plot_order(
            times, self.order, self.order_lower, self.order_upper, ax=ax, label="refit",
            xlabel="sample" if t is None else "time", color="C0",
        )

    def to_dataframe(self, t=None):
        """The per-sample columns (``order``, its interval, ``y_hat``, ``residuals``; ``time``
        if `t` is given) as a pandas DataFrame (needs the optional pandas)."""
        from ._results import to_dataframe

        columns = {} if t is None else {"time": np.asarray(t, dtype=float)}
        columns.update(
            order=self.order, order_lower=self.order_lower, order_upper=self.order_upper,
            y_hat=self.y_hat, residuals=self.residuals,
        )
        return to_dataframe(columns)


TRACES = {"fit": 0}
# a direction of the column-scaled Jacobian whose singular value is below this fraction of the
# largest is not determined by the data: the coefficients along it get an infinite variance
UNDETERMINED_RCOND = 1e-10
# a fitted coefficient whose contribution to the weighted fit (|p_j|·‖column j‖) is below this
# fraction of ‖y‖ is reported as exactly 0: it is rounding, not a measurement
ROUNDING = 1e-12
# a constant-order fit with fewer direct regressors than this runs padded to it (zero columns,
# held at 0), so that the laws with and without a spring in series share a compiled program
PAD_DIRECT = 1


def _gauss_newton(jac, free):
    """``(JᵀJ)⁻¹`` from the SVD of the Jacobian with unit columns (unit-free; the normal
    matrix, which squares the condition number, is never formed), and which parameters the
    data do not determine: those with weight on a direction whose singular value is below
    `UNDETERMINED_RCOND` of the largest, or whose column is 0. Their variance is returned as
    ``inf`` (and their covariances 0): a pseudo-inverse would report 0 there, the most
    confident number for the least determined parameter. Parameters with ``free = 0`` are held
    (variance 0). The residual variance's degrees of freedom count the determined ones
    only (N − rank J)."""
    aug = jnp.concatenate([jac, jnp.diag(1.0 - free)], axis=0)  # held: a unit row, no effect
    norms = jnp.linalg.norm(aug, axis=0)
    scale = jnp.where(norms > 0, 1.0 / jnp.where(norms > 0, norms, 1.0), 0.0)
    _, s, vt = jnp.linalg.svd(aug * scale, full_matrices=False)
    kept = s > UNDETERMINED_RCOND * s[0]
    inv_s2 = jnp.where(kept, 1.0 / jnp.where(kept, s, 1.0) ** 2, 0.0)
    cov = scale[:, None] * ((vt.T * inv_s2) @ vt) * scale[None, :]
    loose = jnp.any((jnp.abs(vt.T) > 1e-6) & ~kept[None, :], axis=1) | (norms == 0)
    loose = loose & (free > 0)
    cov = jnp.where(loose[:, None] | loose[None, :], 0.0, cov) * jnp.outer(free, free)
    return cov + jnp.diag(jnp.where(loose, jnp.inf, 0.0)), loose


def _knot_places(num_knots):
    """Knots at the centres of K equal parts of the record (as fractions of its length): none at
    t = 0, where Φ = 0 says nothing about the order."""
    return (jnp.arange(num_knots, dtype=jnp.result_type(float)) + 0.5) / num_knots


def _raw_curve(raw, num, span=None):
    """The unbounded order at every sample: linear between knots, constant beyond the end ones.
    The knots spread over the first `span` samples (default all; later ones are padding)."""
    span = num if span is None else span
    grid = jnp.arange(num, dtype=raw.dtype) / jnp.maximum(jnp.asarray(span, raw.dtype) - 1, 1.0)
    if raw.shape[0] == 1:
        return jnp.full((num,), raw[0])
    return jnp.interp(grid, _knot_places(raw.shape[0]), raw)


def _order_curve(raw, num, bounds, span=None):
    """Order at every sample: ``bounds[0] + (hi−lo)·sigmoid(curve)`` of `_raw_curve`."""
    lo, hi = bounds
    return lo + (hi - lo) * jax.nn.sigmoid(_raw_curve(raw, num, span))


def _weights(num, mask, weights, window, relative, times, y):
    """The weight of each sample's squared residual (NumPy): the product of the mask, the
    user's weights, the fit window and, for relative residuals, ``1/y²``."""
    from ._validate import check_mask

    w = np.ones(num)
    if mask is not None:
        w = w * check_mask(mask, num, 0)
    if weights is not None:
        arr = np.asarray(check.float_array(weights, "weights"))
        if arr.shape != (num,):
            raise ValueError(f"`weights` must have shape ({num},), got shape {arr.shape}.")
        if not np.all(np.isfinite(arr)) or np.any(arr < 0):
            raise ValueError("`weights` must be finite and non-negative.")
        w = w * arr
    if window is not None:
        try:
            lo, hi = (float(v) for v in window)
        except (TypeError, ValueError):
            raise TypeError(f"`window` must be a pair of times (from, to), got {window!r}.") from None
        if not lo < hi:
            raise ValueError(f"`window` must satisfy from < to, got ({lo}, {hi}).")
        w = w * ((times >= lo) & (times <= hi))
    if relative:
        y = np.asarray(y)
        zero = (w > 0) & (y == 0)
        if np.any(zero):
            raise ValueError(
                f"relative residuals divide by y, which is 0 at fitted sample {int(np.argmax(zero))}; "
                "leave that sample out (`window`, `mask`) or use absolute residuals."
            )
        w = w / np.where(w > 0, y, 1.0) ** 2
    return w


def _signs(p_signs, count):
    if p_signs is None:
        return np.zeros(count)
    arr = np.asarray(p_signs, dtype=float)
    if arr.shape != (count,) or not np.all(np.isin(arr, (-1.0, 0.0, 1.0))):
        raise ValueError(
            f"`p_signs` must hold {count} values of +1 (≥ 0), −1 (≤ 0) or 0 (free), one per "
            f"coefficient, got {p_signs!r}."
        )
    return arr


def refit(
    u,
    y,
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
) -> Refit:
    """Fits ``y = x0 + pᵀ φ(β, t) + cᵀ v`` over a record by Levenberg–Marquardt.

    The samples lie at ``t_k = k·dt`` or at the strictly increasing times `t` (log-spaced,
    irregular; exactly one of the two). ``φ`` integrates the inputs `u` (N, n) from the start of
    the test; the optional `direct` regressors ``v`` (N, m) enter as they are (order 0: the
    spring of a fractional Maxwell model, `vojax.FractionalMaxwell`).

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

    **Returns:** a `Refit`; ``p`` holds the coefficients of `u` then of `direct`.
    """
    bounds = check.interval(order_bounds, "order_bounds")
    estimate = isinstance(x0, str)
    if estimate and x0 != "estimate":
        raise ValueError(f"`x0` must be 'estimate', None (y[0]) or a number, got {x0!r}.")
    if origin is not None and x0 is None:
        raise ValueError("with `origin`, `x0` is the output at the origin: 'estimate' it or give it.")
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
    grid = t
    if origin is not None:
        origin = float(np.asarray(check.float_array(origin, "origin")))
        if not np.isfinite(origin) or origin >= times[0]:
            raise ValueError(
                f"`origin` must be a finite time before the first sample ({times[0]:g}), got {origin}."
            )
        # the step load: one more sample at the origin, the inputs held at their first values
        grid = np.concatenate([[origin], times])
        u2 = jnp.concatenate([u2[:1], u2])
        v = np.concatenate([v[:1], v])
        y = jnp.concatenate([y[:1], y])
        w = np.concatenate([[0.0], w])
    n_all = u2.shape[0]
    mem = make_memory(
        memory, dt if grid is None else None, n_all, rule=rule, order_range=bounds, times=grid
    )
    big_y = y - x0  # with an estimated offset, x0 = y[0] + the fitted correction
    sw = jnp.asarray(np.sqrt(w), u2.dtype)
    v = jnp.asarray(v, u2.dtype)
    trim = slice(1, None) if origin is not None else slice(None)

    if isinstance(order, str):
        if order != "constant":
            raise ValueError(
                f"`order` must be 'constant', a number of knots ≥ 2, or an (N,) array, got {order!r}."
            )
        num_knots = 1
    elif isinstance(order, (int, np.integer)) and not isinstance(order, bool):
        if order < 1 or order > num // 2:
            raise ValueError(
                f"`order` as a number of knots must be in [1, {num // 2}], got {order}."
            )
        num_knots = int(order)
    else:
        fixed = check.order(order, num, bounds=bounds, closed=True)
        if origin is not None:
            fixed = jnp.concatenate([fixed[:1], fixed])
        phi = scan_memory(mem, u2, fixed, False)
        fit = _linear(phi, v, big_y, fixed, x0, width, estimate, sw, signs)
        return jax.tree_util.tree_map(
            lambda a: a[trim] if getattr(a, "shape", ()) and a.shape[0] == n_all else a, fit
        )

    # a constant-order fit with fewer direct regressors than PAD_DIRECT is padded with zero
    # columns whose coefficients are held at 0 (they cost no scan of the memory): the
    # springpot shares the Maxwell law's compiled program, the Kelvin–Voigt law the Zener's
    # (`compare` fits all four); a fit on knots is a program of its own anyway, not padded
    deep = max(v.shape[1], PAD_DIRECT) if num_knots == 1 else v.shape[1]
    v_pad = jnp.concatenate([v, jnp.zeros((n_all, deep - v.shape[1]), v.dtype)], axis=1)
    count = signs.size  # the coefficients that are not padding come first
    active = np.ones(count)
    while True:
        out = _fit(
            mem, u2, v_pad, big_y, sw, jnp.asarray(np.pad(active, (0, width + deep - count))),
            jnp.asarray(order0, big_y.dtype), num_knots, bounds, estimate,
            jnp.asarray(rtol, big_y.dtype), jnp.asarray(atol, big_y.dtype), max_steps, throw,
        )
        out["p"], out["p_stderr"] = out["p"][:count], out["p_stderr"][:count]
        out["p_cov"] = out["p_cov"][:count, :count]
        se = np.maximum(np.asarray(out["p_stderr"]), np.finfo(float).tiny)
        if not _hold_worst(active, signs, np.asarray(out["p"]), se):
            break
    offset = out.pop("offset")
    fit = out.pop("fit")
    span = float(out.pop("span"))
    knots = out["knots"]
    margin = 1e-3 * (bounds[1] - bounds[0])
    places = np.asarray(_knot_places(num_knots)) * (span - 1)
    all_times = times if grid is None or origin is None else np.asarray(grid)
    out = {k: (a[trim] if k in ("order", "order_stderr", "order_lower", "order_upper",
                                "residuals") else a) for k, a in out.items()}
    return Refit(
        **out,
        x0=x0 + offset if estimate else x0,
        knot_times=(
            jnp.asarray(np.interp(places, np.arange(n_all), all_times))
            if num_knots > 1 else jnp.zeros(1)
        ),
        y_hat=(fit + x0)[trim],
        p_at_bound=tuple(bool(a == 0) for a in active),
        at_bound=bool(jnp.any((knots < bounds[0] + margin) | (knots > bounds[1] - margin))),
    )


def _hold_worst(active, signs, coefficients, scale) -> bool:
    """One step of the sign constraints' active set: the coefficient furthest on the wrong side
    of its sign (in units of `scale`) is held at 0, its bound (``active`` is updated in place).
    Returns False when every sign holds."""
    count = signs.size
    broken = (active[:count] > 0) & (signs * coefficients < 0)
    if not broken.any():
        return False
    active[int(np.argmax(np.where(broken, -signs * coefficients / scale, -np.inf)))] = 0.0
    return True


def _zero_rounding(p, columns, big_y, sw):
    """``p`` with 0 for each coefficient whose whole contribution to the weighted fit,
    ``|p_j|·‖column j‖``, is below `ROUNDING` of ``‖y‖``: the sign of a rounding error differs
    between machines, and 1/p of a model would be ±1e16 on one and a failure on another."""
    size = jnp.linalg.norm(big_y * sw)
    noise = jnp.abs(p) * jnp.linalg.norm(columns * sw[:, None], axis=0) <= ROUNDING * size
    return jnp.where(noise, 0.0, p)


def _direct_regressors(direct, num):
    if direct is None:
        return np.zeros((num, 0))
    v = np.asarray(check.samples(direct, "direct"))
    v = v[:, None] if v.ndim == 1 else v
    if v.shape[0] != num:
        raise ValueError(
            f"`direct` must have {num} samples like `u`, got shape {v.shape}."
        )
    return v


@eqx.filter_jit
def _fit(
    mem, u2, v, big_y, sw, active, order0, num_knots, bounds, estimate, rtol, atol, max_steps,
    throw,
):
    """The Levenberg–Marquardt fit and its Gauss–Newton errors, compiled once per shape and
    static setting (numbers are arrays, the model is built inside: no retracing). ``sw`` is the
    square root of each sample's weight; coefficients with ``active = 0`` are held at 0."""
    import optimistix as optx

    TRACES["fit"] += 1  # runs only while tracing
    num, width = u2.shape
    count = active.shape[0]  # coefficients: of the integrated inputs, then of `direct`
    # up to the last fitted sample (as a float: it scales the knots' grid)
    span = (jnp.max(jnp.where(sw > 0, jnp.arange(num), 0)) + 1).astype(sw.dtype)
    lo, hi = bounds
    z0 = (order0 - lo) / (hi - lo)
    raw0 = jnp.full((num_knots,), jnp.log(z0 / (1 - z0)))
    keep = jnp.concatenate([active, jnp.ones((1,), sw.dtype)]) if estimate else active

    def design(phi):  # regressors of the linear part: Φ, the direct ones and (estimated) 1
        parts = [phi, v] + ([jnp.ones((num, 1), phi.dtype)] if estimate else [])
        return jnp.concatenate(parts, 1) * keep

    phi_of = order_map(mem, u2)  # the order-free history, once, outside the solver's loop

    def model(theta):
        raw, p = theta[:num_knots], theta[num_knots:]
        beta = _order_curve(raw, num, bounds, span)
        return design(phi_of(beta)) @ p

    # a start for p: linear least squares at the initial order (0 for held coefficients)
    phi0 = design(phi_of(_order_curve(raw0, num, bounds, span)))
    p0 = jnp.linalg.lstsq(phi0 * sw[:, None], big_y * sw)[0]
    # the solver sees the residuals in units of the data's RMS and each coefficient in units
    # of (that RMS / its regressor's RMS), so that its tolerances mean the same in any units
    # (in metres and newtons an AFM record's residuals are ~1e-10: below an absolute
    # tolerance of 1e-10 the solver stopped at its start)
    fitted = jnp.maximum(jnp.sum(sw > 0), 1).astype(sw.dtype)
    y_scale = jnp.sqrt(jnp.sum((sw * big_y) ** 2) / fitted)
    y_scale = jnp.where(y_scale > 0, y_scale, 1.0)
    col = jnp.sqrt(jnp.sum((phi0 * sw[:, None]) ** 2, axis=0) / fitted)
    p_unit = y_scale / jnp.where(col > 0, col, y_scale)
    sol = optx.least_squares(
        lambda th, _: (model(jnp.concatenate([th[:num_knots], th[num_knots:] * p_unit])) - big_y)
        * sw / y_scale,
        optx.LevenbergMarquardt(rtol=rtol, atol=atol),
        jnp.concatenate([raw0, p0 / p_unit]),
        max_steps=max_steps,
        throw=throw,
    )
    theta = jnp.concatenate([sol.value[:num_knots], sol.value[num_knots:] * p_unit])
    fit = model(theta)
    residuals = big_y - fit
    # the Jacobian by the chain rule: ∂ŷ/∂p = the design, ∂ŷ_k/∂raw_i = (∂Φ_k/∂b · p) ∂β_k/∂raw_i
    # (one readout with its order sensitivity, no Jacobian traced through the memory)
    raw_t, p_t = theta[:num_knots], theta[num_knots:]
    phi_t, dphi_t = phi_of(_order_curve(raw_t, num, bounds, span), True)
    dbeta = jax.jacfwd(lambda r: _order_curve(r, num, bounds, span))(raw_t)
    jac = jnp.concatenate(
        [(dphi_t @ (p_t[:width] * active[:width]))[:, None] * dbeta, design(phi_t)], axis=1
    ) * sw[:, None]
    free = jnp.concatenate([jnp.ones((num_knots,), sw.dtype), keep])
    inverse, loose = _gauss_newton(jac, free)
    determined = jnp.sum(free) - jnp.sum(loose, dtype=sw.dtype)
    dof = jnp.maximum(jnp.sum(sw > 0, dtype=sw.dtype) - determined, 1.0)
    sigma2 = jnp.sum((sw * residuals) ** 2) / dof
    cov = sigma2 * inverse
    raw_of = lambda th: _raw_curve(th[:num_knots], num, span)  # noqa: E731
    graw = jax.jacfwd(raw_of)(theta)
    finite = jnp.where(loose[:, None] | loose[None, :], 0.0, cov)
    raw_sd = jnp.sqrt(jnp.maximum(jnp.einsum("ni,ij,nj->n", graw, finite, graw), 0.0))
    # a sample whose order depends on an undetermined knot: an infinite error, the band the range
    raw_sd = jnp.where(jnp.any((jnp.abs(graw) > 0) & loose[None, :], axis=1), jnp.inf, raw_sd)
    raw = raw_of(theta)
    slope = (hi - lo) * jax.nn.sigmoid(raw) * (1 - jax.nn.sigmoid(raw))
    pc = cov[num_knots : num_knots + count, num_knots : num_knots + count]
    theta = theta.at[num_knots:].set(_zero_rounding(theta[num_knots:], design(phi_t), big_y, sw))
    return dict(
        order=_order_curve(theta[:num_knots], num, bounds, span),
        order_stderr=slope * raw_sd,
        order_lower=lo + (hi - lo) * jax.nn.sigmoid(raw - 2 * raw_sd),
        order_upper=lo + (hi - lo) * jax.nn.sigmoid(raw + 2 * raw_sd),
        p=theta[num_knots : num_knots + count] * active,
        p_stderr=jnp.sqrt(jnp.maximum(jnp.diag(pc), 0.0)),
        p_cov=pc,
        offset=theta[-1] if estimate else jnp.zeros((), theta.dtype),
        x0_stderr=jnp.sqrt(jnp.maximum(cov[-1, -1], 0.0)) if estimate else jnp.zeros(()),
        knots=lo + (hi - lo) * jax.nn.sigmoid(theta[:num_knots]),
        knots_stderr=jnp.where(
            loose[:num_knots],
            jnp.inf,
            (hi - lo) * jax.nn.sigmoid(theta[:num_knots]) * (1 - jax.nn.sigmoid(theta[:num_knots]))
            * jnp.sqrt(jnp.maximum(jnp.diag(cov)[:num_knots], 0.0)),
        ),
        fit=fit,
        residuals=residuals,
        sigma=jnp.sqrt(sigma2),
        result=sol.result,
        steps=sol.stats["num_steps"],
        span=span,
    )


def _linear(phi, v, big_y, fixed, x0, width, estimate, sw, signs):
    """With the order fixed the model is linear in the coefficients (and the offset): weighted
    least squares, with the sign constraints by the same active set as `refit`."""
    import optimistix as optx

    parts = [phi, v] + ([jnp.ones((phi.shape[0], 1), phi.dtype)] if estimate else [])
    full = jnp.concatenate(parts, 1)
    count = signs.size
    active = np.ones(full.shape[1])
    while True:
        a = full * jnp.asarray(active)
        p = jnp.linalg.lstsq(a * sw[:, None], big_y * sw)[0] * jnp.asarray(active)
        # ranked in standard errors (σ² is common to all and drops out): in magnitudes the
        # choice would depend on each input's unit
        inverse, _ = _gauss_newton(a * sw[:, None], jnp.asarray(active))
        scale = np.sqrt(np.maximum(np.diag(np.asarray(inverse))[:count], np.finfo(float).tiny))
        if not _hold_worst(active, signs, np.asarray(p[:count]), scale):
            break
    p = _zero_rounding(p, full, big_y, sw)
    fit = full @ p
    residuals = big_y - fit
    inverse, loose = _gauss_newton(a * sw[:, None], jnp.asarray(active))
    determined = float(np.sum(active)) - jnp.sum(loose, dtype=sw.dtype)
    dof = jnp.maximum(jnp.sum(sw > 0, dtype=sw.dtype) - determined, 1.0)
    sigma2 = jnp.sum((sw * residuals) ** 2) / dof
    cov = sigma2 * inverse
    zero = jnp.zeros_like(fixed)
    return Refit(
        order=fixed,
        order_stderr=zero,
        order_lower=fixed,
        order_upper=fixed,
        p=p[:count],
        p_stderr=jnp.sqrt(jnp.diag(cov)[:count]),
        p_cov=cov[:count, :count],
        x0=x0 + (p[-1] if estimate else 0.0),
        x0_stderr=jnp.sqrt(cov[-1, -1]) if estimate else jnp.zeros(()),
        knots=fixed[:0],
        knots_stderr=fixed[:0],
        knot_times=fixed[:0],
        y_hat=fit + x0,
        residuals=residuals,
        sigma=jnp.sqrt(sigma2),
        result=optx.RESULTS.successful,
        steps=jnp.asarray(0),
        p_at_bound=tuple(bool(a == 0) for a in active[:count]),
    )


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
):
    """Second opinion on `refit`: the same model and objective, ``½‖y − x0 − pᵀφ‖²``, by
    jaxopt's box-constrained L-BFGS-B, with the knot orders themselves bounded by
    `order_bounds` (no logit). Needs the optional extra ``vojax[jaxopt]``.

    **Returns:** ``(order (N,), p (n,))``.
    """
    try:
        import warnings

        with warnings.catch_warnings():
            warnings.filterwarnings("ignore", "JAXopt is no longer maintained", DeprecationWarning)
            import jaxopt
    except ImportError:  # pragma: no cover - depends on the environment
        raise ImportError("refit_lbfgsb needs jaxopt: pip install 'vojax[jaxopt]'.") from None
    bounds = check.interval(order_bounds, "order_bounds")
    u2, y, _, x0, _ = check_options(u, y, dt, None, order0, bounds, memory, rule, x0, None)
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
    theta = solver.run(theta0, bounds=(lower, upper)).params
    z = (theta[:num_knots] - lo) / (hi - lo)
    return _order_curve(jnp.log(z / (1 - z)), num, bounds), theta[num_knots:]
