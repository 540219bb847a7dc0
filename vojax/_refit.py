"""`refit`: offline batch fit of the order trajectory and the parameters (optimistix)."""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import optimistix as optx
from jaxtyping import Array, Float

from . import _validate as check
from ._identify import check_options
from ._integral import make_memory, scan_memory


class Refit(eqx.Module):
    """What `refit` returns.

    - `order` (N,): the fitted order trajectory; `order_stderr` (N,): its standard error.
    - `p` (n,), `p_stderr` (n,): the fitted parameters and their standard errors.
    - `knots` (K,), `knot_times` (K,): the fitted orders at the knots (K = 1: constant).
    - `y_hat` (N,), `residuals` (N,) = y − y_hat, `sigma`: residual standard deviation.
    - `result`: optimistix's result code (`optx.RESULTS.successful` when it converged),
      `steps`: the solver's steps.
    """

    order: Float[Array, " N"]
    order_stderr: Float[Array, " N"]
    p: Float[Array, " n"]
    p_stderr: Float[Array, " n"]
    knots: Float[Array, " K"]
    knot_times: Float[Array, " K"]
    y_hat: Float[Array, " N"]
    residuals: Float[Array, " N"]
    sigma: Float[Array, ""]
    result: optx.RESULTS
    steps: Array


def _order_curve(raw, num, bounds):
    """Order at every sample: knot values ``bounds[0] + (hi−lo)·sigmoid(raw)``, interpolated
    linearly in the raw (unbounded) variable between knots spread evenly over the record."""
    lo, hi = bounds
    grid = jnp.linspace(0.0, 1.0, num)
    where = jnp.linspace(0.0, 1.0, raw.shape[0]) if raw.shape[0] > 1 else None
    curve = jnp.interp(grid, where, raw) if where is not None else jnp.full((num,), raw[0])
    return lo + (hi - lo) * jax.nn.sigmoid(curve)


def refit(
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
    rtol: float = 1e-10,
    atol: float = 1e-10,
    max_steps: int = 200,
    throw: bool = False,
) -> Refit:
    """Fits ``y − x0 = pᵀ φ(β, t)`` over the whole record by Levenberg–Marquardt.

    The order is a constant (``order="constant"``), a smooth curve through ``K`` knots spread
    evenly over the record (``order=K``, K ≥ 2; linear in a logit variable, so it stays inside
    `order_bounds`), or fixed (``order`` an ``(N,)`` array: then only ``p`` is fitted, which is
    linear least squares). ``p`` is constant. The residuals are differentiated through the
    memory kernels; standard errors come from the Gauss–Newton approximation
    ``σ² (JᵀJ)⁻¹`` with ``σ² = RSS/(N − P)``, and the order's by the delta method.

    **Returns:** a `Refit`.
    """
    bounds = check.interval(order_bounds, "order_bounds")
    u2, y, _, x0, _ = check_options(u, y, dt, None, order0, bounds, memory, rule, x0, None)
    num, width = u2.shape
    big_y = y - x0
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
        return _linear(phi, big_y, fixed, x0, width)

    lo, hi = bounds
    z0 = (order0 - lo) / (hi - lo)
    raw0 = jnp.full((num_knots,), jnp.log(z0 / (1 - z0)))

    def model(theta):
        raw, p = theta[:num_knots], theta[num_knots:]
        beta = _order_curve(raw, num, bounds)
        return scan_memory(mem, u2, beta, False) @ p

    # a start for p: linear least squares at the initial order
    phi0 = scan_memory(mem, u2, _order_curve(raw0, num, bounds), False)
    p0 = jnp.linalg.lstsq(phi0, big_y)[0]
    theta0 = jnp.concatenate([raw0, p0])
    sol = optx.least_squares(
        lambda th, _: model(th) - big_y,
        optx.LevenbergMarquardt(rtol=rtol, atol=atol),
        theta0,
        max_steps=max_steps,
        throw=throw,
    )
    theta = sol.value
    fit = model(theta)
    residuals = big_y - fit
    jac = jax.jacfwd(model)(theta)
    dof = max(num - theta.size, 1)
    sigma2 = jnp.sum(residuals**2) / dof
    cov = sigma2 * jnp.linalg.pinv(jac.T @ jac)
    beta_of = lambda th: _order_curve(th[:num_knots], num, bounds)  # noqa: E731
    gb = jax.jacfwd(beta_of)(theta)
    order_var = jnp.einsum("ni,ij,nj->n", gb, cov, gb)
    knot_times = (
        jnp.linspace(0.0, (num - 1) * float(dt), num_knots) if num_knots > 1 else jnp.zeros(1)
    )
    knot_idx = (
        jnp.round(jnp.linspace(0, num - 1, num_knots)).astype(int)
        if num_knots > 1
        else jnp.zeros(1, int)
    )
    beta = beta_of(theta)
    return Refit(
        order=beta,
        order_stderr=jnp.sqrt(jnp.maximum(order_var, 0.0)),
        p=theta[num_knots:],
        p_stderr=jnp.sqrt(jnp.maximum(jnp.diag(cov)[num_knots:], 0.0)),
        knots=beta[knot_idx],
        knot_times=knot_times,
        y_hat=fit + x0,
        residuals=residuals,
        sigma=jnp.sqrt(sigma2),
        result=sol.result,
        steps=sol.stats["num_steps"],
    )


def _linear(phi, big_y, fixed, x0, width):
    """With the order fixed the model is linear in p: ordinary least squares."""
    p, *_ = jnp.linalg.lstsq(phi, big_y)
    fit = phi @ p
    residuals = big_y - fit
    dof = max(phi.shape[0] - width, 1)
    sigma2 = jnp.sum(residuals**2) / dof
    cov = sigma2 * jnp.linalg.pinv(phi.T @ phi)
    return Refit(
        order=fixed,
        order_stderr=jnp.zeros_like(fixed),
        p=p,
        p_stderr=jnp.sqrt(jnp.diag(cov)),
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
