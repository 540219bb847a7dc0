"""The refit's compiled solve: Levenberg–Marquardt (optimistix) over the order's knots
and the coefficients, and its Gauss–Newton errors; the linear fit at a fixed order."""


from typing import TYPE_CHECKING

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from ._integral import order_map
from ._refit_profile import _profile_orders, _reductions

if TYPE_CHECKING:  # imported where it is used: 0.07 s of `import vojax`
    pass


from ._refit_result import Refit

TRACES = {"fit": 0}

# a direction of the column-scaled Jacobian whose singular value is below this fraction of the
# largest is not determined by the data: the coefficients along it get an infinite variance
UNDETERMINED_RCOND = 1e-10

# a fitted coefficient whose contribution to the weighted fit (|p_j|·‖column j‖) is below this
# fraction of ‖y‖ is reported as exactly 0: it is rounding, not a measurement
ROUNDING = 1e-12


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
    # NumPy (a constant under tracing): an eager JAX operation compiles a program of its own
    return (np.arange(num_knots, dtype=jnp.result_type(float)) + 0.5) / num_knots


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
    y_scale, p_unit = _solver_units(sw, big_y, phi0)
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
    by_order = (dphi_t @ (p_t[:width] * active[:width]))[:, None] * dbeta
    jac = jnp.concatenate([by_order, design(phi_t)], axis=1) * sw[:, None]
    free = jnp.concatenate([jnp.ones((num_knots,), sw.dtype), keep])
    inverse, loose = _gauss_newton(jac, free)
    determined = jnp.sum(free) - jnp.sum(loose, dtype=sw.dtype)
    dof = jnp.maximum(jnp.sum(sw > 0, dtype=sw.dtype) - determined, 1.0)
    sigma2 = jnp.sum((sw * residuals) ** 2) / dof
    cov = sigma2 * inverse
    raw, raw_sd = _raw_order_errors(theta, cov, loose, num_knots, num, span)
    slope = (hi - lo) * jax.nn.sigmoid(raw) * (1 - jax.nn.sigmoid(raw))
    pc = cov[num_knots : num_knots + count, num_knots : num_knots + count]
    theta = theta.at[num_knots:].set(_zero_rounding(theta[num_knots:], design(phi_t), big_y, sw))
    knot_z = jax.nn.sigmoid(theta[:num_knots])
    knots_sd = (hi - lo) * knot_z * (1 - knot_z) * jnp.sqrt(jnp.maximum(jnp.diag(cov)[:num_knots], 0))
    # a constant order's profile at a grid of orders, with the fit (its order map shared)
    profile = (_reductions(phi_of, v, big_y, sw, _profile_orders(bounds), estimate)
               if num_knots == 1 else ())
    return dict(
        profile=profile,
        order=_order_curve(theta[:num_knots], num, bounds, span),
        order_stderr=slope * raw_sd,
        order_lower=lo + (hi - lo) * jax.nn.sigmoid(raw - 2 * raw_sd),
        order_upper=lo + (hi - lo) * jax.nn.sigmoid(raw + 2 * raw_sd),
        p=theta[num_knots : num_knots + count] * active,
        p_stderr=jnp.sqrt(jnp.maximum(jnp.diag(pc), 0.0)),
        p_cov=pc,
        offset=theta[-1] if estimate else jnp.zeros((), theta.dtype),
        x0_stderr=jnp.sqrt(jnp.maximum(cov[-1, -1], 0.0)) if estimate else jnp.zeros(()),
        knots=lo + (hi - lo) * knot_z,
        knots_stderr=jnp.where(loose[:num_knots], jnp.inf, knots_sd),
        fit=fit,
        residuals=residuals,
        sigma=jnp.sqrt(sigma2),
        result=sol.result,
        steps=sol.stats["num_steps"],
        span=span,
    )


def _solver_units(sw, big_y, phi0):
    """The solver sees the residuals in units of the data's RMS and each coefficient in units
    of (that RMS / its regressor's RMS), so that its tolerances mean the same in any units (in
    metres and newtons an AFM record's residuals are ~1e-10: below an absolute tolerance of
    1e-10 the solver stopped at its start). Returns the two units."""
    fitted = jnp.maximum(jnp.sum(sw > 0), 1).astype(sw.dtype)
    y_scale = jnp.sqrt(jnp.sum((sw * big_y) ** 2) / fitted)
    y_scale = jnp.where(y_scale > 0, y_scale, 1.0)
    col = jnp.sqrt(jnp.sum((phi0 * sw[:, None]) ** 2, axis=0) / fitted)
    return y_scale, y_scale / jnp.where(col > 0, col, y_scale)


def _raw_order_errors(theta, cov, loose, num_knots, num, span):
    """The unbounded order at every sample and its standard error by the delta method; a
    sample whose order depends on an undetermined knot gets an infinite error (its band: the
    range)."""
    raw_of = lambda th: _raw_curve(th[:num_knots], num, span)  # noqa: E731
    graw = jax.jacfwd(raw_of)(theta)
    finite = jnp.where(loose[:, None] | loose[None, :], 0.0, cov)
    raw_sd = jnp.sqrt(jnp.maximum(jnp.einsum("ni,ij,nj->n", graw, finite, graw), 0.0))
    raw_sd = jnp.where(jnp.any((jnp.abs(graw) > 0) & loose[None, :], axis=1), jnp.inf, raw_sd)
    return raw_of(theta), raw_sd


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


def _zero_rounding(p, columns, big_y, sw):
    """``p`` with 0 for each coefficient whose whole contribution to the weighted fit,
    ``|p_j|·‖column j‖``, is below `ROUNDING` of ``‖y‖``: the sign of a rounding error differs
    between machines, and 1/p of a model would be ±1e16 on one and a failure on another."""
    size = jnp.linalg.norm(big_y * sw)
    noise = jnp.abs(p) * jnp.linalg.norm(columns * sw[:, None], axis=0) <= ROUNDING * size
    return jnp.where(noise, 0.0, p)


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
