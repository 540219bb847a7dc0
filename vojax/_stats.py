"""Statistics from the data alone, shared by the law's bands and the tracker."""

import functools

import numpy as np


def noise_variance(y, order: int = 2) -> float:
    """Measurement-noise variance from the data alone: the median absolute difference of the
    given `order` (2: ``σ̂ = 1.4826·median|y_{k+1} − 2y_k + y_{k−1}| / √6``; white noise:
    Var Δ^k y = C(2k, k) σ²; the median ignores the few large differences of steps and
    ramps). Not from the law's residuals, which carry its tracking error as well. Where most
    differences are exactly zero (an output held flat over most of the record: set to zero
    before a contact, clipped, padded), the median is over the others: a flat stretch has no
    noise to measure, and the median of all would be 0. A constant `y`, or one too short for
    a difference of that order: 0."""
    import math

    dk = np.abs(np.diff(np.asarray(y), order))
    moving = dk[dk != 0]
    if 2 * moving.size < dk.size:  # most exactly zero
        dk = moving
    if dk.size == 0:
        return 0.0
    return float((1.4826 * np.median(dk)) ** 2 / math.comb(2 * order, order))


# lag-1 autocorrelation of the tracker's innovations above which its band, which assumes
# white measurement noise, is not trusted (coloured noise, or a model that misses part of the
# signal): `CORRELATION_Z` standard errors (1/√n) of a white sequence's, but at least
# `CORRELATION_FLOOR` (below it, coloured noise would widen a band by under 11 %) and at most
# `MAX_CORRELATION` (on the calibration suite's records with white noise it stays below 0.23)
MAX_CORRELATION = 0.25
CORRELATION_Z = 3.0
CORRELATION_FLOOR = 0.1


def correlation_limit(samples) -> float:
    """The innovations' lag-1 autocorrelation above which the band is refused, for
    `samples` innovations (`MAX_CORRELATION` when unknown)."""
    if samples is None:
        return MAX_CORRELATION
    z = CORRELATION_Z / np.sqrt(max(int(samples), 1))
    return float(min(MAX_CORRELATION, max(z, CORRELATION_FLOOR)))


def lag1_correlation(e) -> float:
    """Lag-1 autocorrelation of a sequence (its mean removed); NaN when it is constant."""
    e = np.asarray(e, dtype=float)
    e = e - np.mean(e)
    power = float(np.sum(e * e))
    return float(np.sum(e[1:] * e[:-1]) / power) if power > 0 else float("nan")


def prediction_error_correlation(y, y_pred, fitted) -> tuple[float, int]:
    """Lag-1 autocorrelation of the one-step prediction errors ``y − y_pred`` over the `fitted`
    samples (a boolean mask), the first left out (nothing precedes it), and how many errors
    that is: what `correlation_limit` is applied to."""
    errors = (np.asarray(y) - np.asarray(y_pred))[np.asarray(fitted)][1:]
    return lag1_correlation(errors), errors.size


def errors_correlate(y, y_pred, fitted) -> bool:
    """Whether the one-step prediction errors over the `fitted` samples correlate beyond
    `correlation_limit`: the tracker's reason `correlated` (see
    `vojax._diagnostics.diagnose`)."""
    correlation, samples = prediction_error_correlation(y, y_pred, fitted)
    return bool(correlation > correlation_limit(samples))


def delta_stderr(fn, p, cov) -> dict:
    """Standard errors of the named quantities ``fn(p)`` (a dict of scalars) by the delta
    method: ``sqrt(diag(J C Jᵀ))`` with ``J = ∂fn/∂p`` from forward-mode autodiff and ``C`` the
    covariance of ``p``. The Jacobian is compiled once per `fn` and shape of ``p`` when `fn` is
    hashable (a model's bound method is), and traced afresh otherwise."""
    import jax.numpy as jnp

    p = jnp.asarray(p, jnp.result_type(float))
    cov = np.asarray(cov, dtype=float)
    if cov.shape != (p.shape[-1], p.shape[-1]):
        raise ValueError(f"`cov` must have shape {(p.shape[-1],) * 2}, got {cov.shape}.")
    try:
        hash(fn)
        jacobian = _compiled_jacobian()
    except TypeError:  # unhashable: no compiled program to reuse
        jacobian = _jacobian
    jac = np.asarray(jacobian(fn, p))
    names = list(fn(np.asarray(p)))
    # an infinite variance (a coefficient the data do not determine) makes every quantity that
    # depends on it undetermined too, and leaves the others alone
    loose = ~np.isfinite(np.diag(cov))
    finite = np.where(loose[:, None] | loose[None, :], 0.0, cov)
    var = np.einsum("ij,jk,ik->i", jac, finite, jac)
    var = np.where(np.any((np.abs(jac) > 0) & loose[None, :], axis=1), np.inf, var)
    return {k: float(np.sqrt(max(v, 0.0))) for k, v in zip(names, var)}


def _jacobian(fn, p):
    """``∂fn/∂p``, one row per key of ``fn(p)`` in its order."""
    import jax
    import jax.numpy as jnp

    return jax.jacfwd(lambda q: jnp.stack([jnp.asarray(v) for v in fn(q).values()]))(p)


@functools.cache
def _compiled_jacobian():
    """`_jacobian` compiled with `fn` static (made on first use: importing this module does
    not import JAX)."""
    import jax

    return jax.jit(_jacobian, static_argnums=0)
