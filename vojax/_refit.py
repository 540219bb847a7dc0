"""`refit`: offline batch fit of the order trajectory and the parameters (optimistix)."""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import optimistix as optx
from jaxtyping import Array, Float

from . import _validate as check
from ._identify import check_options
from ._integral import make_memory, order_map, scan_memory


class Refit(eqx.Module):
    """What `refit` returns.

    - `order` (N,): the fitted order trajectory; `order_stderr` (N,): its standard error (delta
      method); `order_lower`, `order_upper` (N,): the ±2σ Wald interval taken on the unbounded
      (logistic) scale and mapped back, so it stays inside the bounds and keeps its meaning
      near them; `at_bound`: a knot lies within 0.1 % of the range of a bound (then the interval
      is one-sided in effect and the standard error small by construction: do not trust it).
    - `p` (n,), `p_stderr` (n,), `p_cov` (n, n): the fitted parameters, their standard errors
      and covariance.
    - `x0`, `x0_stderr`: the output offset, estimated unless given (then its error is 0).
    - `knots` (K,), `knot_times` (K,): the fitted orders at the knots (K = 1: constant).
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
    knot_times: Float[Array, " K"]
    y_hat: Float[Array, " N"]
    residuals: Float[Array, " N"]
    sigma: Float[Array, ""]
    result: optx.RESULTS
    steps: Array
    at_bound: bool = eqx.field(static=True, default=False)


TRACES = {"fit": 0}


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


def refit(
    u,
    y,
    dt,
    *,
    order="constant",
    order_bounds=(0.01, 0.99),
    order0=0.5,
    x0="estimate",
    memory: str = "exponential",
    rule: str = "trapezoid",
    rtol: float = 1e-10,
    atol: float = 1e-10,
    max_steps: int = 200,
    throw: bool = False,
    mask=None,
) -> Refit:
    """Fits ``y = x0 + pᵀ φ(β, t)`` over the whole record by Levenberg–Marquardt.

    The offset ``x0 = x(0)`` is estimated with the rest (``x0="estimate"``, the default), taken
    as ``y[0]`` (``None``) or fixed (a number).

    The order is a constant (``order="constant"``), a smooth curve through ``K`` knots spread
    evenly over the record (``order=K``, K ≥ 2; linear in a logit variable, so it stays inside
    `order_bounds`), or fixed (``order`` an ``(N,)`` array: then only ``p`` is fitted, which is
    linear least squares). ``p`` is constant. The residuals are differentiated through the
    memory kernels; standard errors come from the Gauss–Newton approximation
    ``σ² (JᵀJ)⁻¹`` with ``σ² = RSS/(N − P)``, and the order's by the delta method.

    `mask` (an ``(N,)`` array of 0 and 1, default all 1): samples with 0 do not enter the fit
    (their residuals are dropped; the degrees of freedom count the fitted samples only).

    **Returns:** a `Refit`.
    """
    bounds = check.interval(order_bounds, "order_bounds")
    estimate = isinstance(x0, str)
    if estimate and x0 != "estimate":
        raise ValueError(f"`x0` must be 'estimate', None (y[0]) or a number, got {x0!r}.")
    u2, y, _, x0, _ = check_options(
        u, y, dt, None, order0, bounds, memory, rule, None if estimate else x0, None
    )
    num, width = u2.shape
    from ._identify import check_mask

    w = jnp.asarray(
        np.ones(num) if mask is None else check_mask(mask, num, width), u2.dtype
    )
    big_y = y - x0  # with an estimated offset, x0 = y[0] + the fitted correction
    mem = make_memory(memory, dt, num, rule=rule, order_range=bounds)

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
        phi = scan_memory(mem, u2, fixed, False)
        return _linear(phi, big_y, fixed, x0, width, estimate, w)

    out = _fit(
        mem, u2, big_y, w, jnp.asarray(order0, big_y.dtype), num_knots, bounds, estimate,
        jnp.asarray(rtol, big_y.dtype), jnp.asarray(atol, big_y.dtype), max_steps, throw,
    )
    offset = out.pop("offset")
    fit = out.pop("fit")
    span = out.pop("span")
    knots = out["knots"]
    margin = 1e-3 * (bounds[1] - bounds[0])
    places = _knot_places(num_knots) if num_knots > 1 else jnp.zeros(1)
    return Refit(
        **out,
        x0=x0 + offset if estimate else x0,
        knot_times=places * (span - 1) * float(dt) if num_knots > 1 else jnp.zeros(1),
        y_hat=fit + x0,
        at_bound=bool(jnp.any((knots < bounds[0] + margin) | (knots > bounds[1] - margin))),
    )


@eqx.filter_jit
def _fit(mem, u2, big_y, w, order0, num_knots, bounds, estimate, rtol, atol, max_steps, throw):
    """The Levenberg–Marquardt fit and its Gauss–Newton errors, compiled once per shape and
    static setting (numbers are arrays, the model is built inside: no retracing)."""
    TRACES["fit"] += 1  # runs only while tracing
    num, width = u2.shape
    # up to the last fitted sample (as a float: it scales the knots' grid)
    span = (jnp.max(jnp.where(w > 0, jnp.arange(num), 0)) + 1).astype(w.dtype)
    lo, hi = bounds
    z0 = (order0 - lo) / (hi - lo)
    raw0 = jnp.full((num_knots,), jnp.log(z0 / (1 - z0)))

    def design(phi):  # regressors of the linear part: Φ and, for an estimated offset, 1
        return jnp.concatenate([phi, jnp.ones((num, 1), phi.dtype)], 1) if estimate else phi

    phi_of = order_map(mem, u2)  # the order-free history, once, outside the solver's loop

    def model(theta):
        raw, p = theta[:num_knots], theta[num_knots:]
        beta = _order_curve(raw, num, bounds, span)
        return design(phi_of(beta)) @ p

    # a start for p: linear least squares at the initial order
    phi0 = design(phi_of(_order_curve(raw0, num, bounds, span)))
    p0 = jnp.linalg.lstsq(phi0 * w[:, None], big_y * w)[0]
    theta0 = jnp.concatenate([raw0, p0])
    sol = optx.least_squares(
        lambda th, _: (model(th) - big_y) * w,
        optx.LevenbergMarquardt(rtol=rtol, atol=atol),
        theta0,
        max_steps=max_steps,
        throw=throw,
    )
    theta = sol.value
    fit = model(theta)
    residuals = big_y - fit
    # the Jacobian by the chain rule: ∂ŷ/∂p = the design, ∂ŷ_k/∂raw_i = (∂Φ_k/∂b · p) ∂β_k/∂raw_i
    # (one readout with its order sensitivity, no Jacobian traced through the memory)
    raw_t, p_t = theta[:num_knots], theta[num_knots:]
    phi_t, dphi_t = phi_of(_order_curve(raw_t, num, bounds, span), True)
    dbeta = jax.jacfwd(lambda r: _order_curve(r, num, bounds, span))(raw_t)
    jac = jnp.concatenate(
        [(dphi_t @ p_t[:width])[:, None] * dbeta, design(phi_t)], axis=1
    ) * w[:, None]
    dof = jnp.maximum(jnp.sum(w) - theta.size, 1.0)
    sigma2 = jnp.sum(w * residuals**2) / dof
    cov = sigma2 * jnp.linalg.pinv(jac.T @ jac)
    raw_of = lambda th: _raw_curve(th[:num_knots], num, span)  # noqa: E731
    graw = jax.jacfwd(raw_of)(theta)
    raw_sd = jnp.sqrt(jnp.maximum(jnp.einsum("ni,ij,nj->n", graw, cov, graw), 0.0))
    raw = raw_of(theta)
    slope = (hi - lo) * jax.nn.sigmoid(raw) * (1 - jax.nn.sigmoid(raw))
    pc = cov[num_knots : num_knots + width, num_knots : num_knots + width]
    return dict(
        order=_order_curve(theta[:num_knots], num, bounds, span),
        order_stderr=slope * raw_sd,
        order_lower=lo + (hi - lo) * jax.nn.sigmoid(raw - 2 * raw_sd),
        order_upper=lo + (hi - lo) * jax.nn.sigmoid(raw + 2 * raw_sd),
        p=theta[num_knots : num_knots + width],
        p_stderr=jnp.sqrt(jnp.maximum(jnp.diag(pc), 0.0)),
        p_cov=pc,
        offset=theta[-1] if estimate else jnp.zeros((), theta.dtype),
        x0_stderr=jnp.sqrt(jnp.maximum(cov[-1, -1], 0.0)) if estimate else jnp.zeros(()),
        knots=lo + (hi - lo) * jax.nn.sigmoid(theta[:num_knots]),
        fit=fit,
        residuals=residuals,
        sigma=jnp.sqrt(sigma2),
        result=sol.result,
        steps=sol.stats["num_steps"],
        span=span,
    )


def _linear(phi, big_y, fixed, x0, width, estimate, w):
    """With the order fixed the model is linear in p (and the offset): ordinary least squares."""
    if estimate:
        phi = jnp.concatenate([phi, jnp.ones((phi.shape[0], 1), phi.dtype)], 1)
    p, *_ = jnp.linalg.lstsq(phi * w[:, None], big_y * w)
    fit = phi @ p
    residuals = big_y - fit
    dof = jnp.maximum(jnp.sum(w) - phi.shape[1], 1.0)
    sigma2 = jnp.sum(w * residuals**2) / dof
    cov = sigma2 * jnp.linalg.pinv((phi * w[:, None]).T @ phi)
    zero = jnp.zeros_like(fixed)
    return Refit(
        order=fixed,
        order_stderr=zero,
        order_lower=fixed,
        order_upper=fixed,
        p=p[:width],
        p_stderr=jnp.sqrt(jnp.diag(cov)[:width]),
        p_cov=cov[:width, :width],
        x0=x0 + (p[-1] if estimate else 0.0),
        x0_stderr=jnp.sqrt(cov[-1, -1]) if estimate else jnp.zeros(()),
        knots=fixed[:0],
        knot_times=fixed[:0],
        y_hat=fit + x0,
        residuals=residuals,
        sigma=jnp.sqrt(sigma2),
        result=optx.RESULTS.successful,
        steps=jnp.asarray(0),
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
