"""Statistics from the data alone, shared by the law's bands and the tracker."""

import functools

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
