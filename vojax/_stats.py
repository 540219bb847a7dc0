"""Statistics from the data alone, shared by the law's bands and the tracker."""

import numpy as np


def noise_variance(y) -> float:
    """Measurement-noise variance from the data alone: the median absolute second difference,
    ``σ̂ = 1.4826·median|y_{k+1} − 2y_k + y_{k−1}| / √6`` (white noise: Var Δ²y = 6σ²; the
    median ignores the few large differences of steps and ramps). Not from the law's residuals,
    which carry its tracking error as well."""
    d2 = np.diff(np.asarray(y), 2)
    return float((1.4826 * np.median(np.abs(d2))) ** 2 / 6.0)


def delta_stderr(fn, p, cov) -> dict:
    """Standard errors of the named quantities ``fn(p)`` (a dict of scalars) by the delta
    method: ``sqrt(diag(J C Jᵀ))`` with ``J = ∂fn/∂p`` from forward-mode autodiff and ``C`` the
    covariance of ``p``."""
    import jax
    import jax.numpy as jnp

    p = jnp.asarray(p, jnp.result_type(float))
    cov = np.asarray(cov, dtype=float)
    if cov.shape != (p.shape[-1], p.shape[-1]):
        raise ValueError(f"`cov` must have shape {(p.shape[-1],) * 2}, got {cov.shape}.")
    names = list(fn(p))
    jac = np.asarray(jax.jacfwd(lambda q: jnp.stack([jnp.asarray(fn(q)[k]) for k in names]))(p))
    var = np.einsum("ij,jk,ik->i", jac, cov, jac)
    return {k: float(np.sqrt(max(v, 0.0))) for k, v in zip(names, var)}
