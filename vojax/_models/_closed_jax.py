"""``E_{α,β}(−x)`` in JAX: traced and differentiable in the order α and the argument x, for a
refit of a closed form (e.g. a relaxation modulus) by gradient.

The three regions and formulas are those of the NumPy function (`vojax._models._closed`):
the power series for ``x ≤ 0.5``, the asymptotic series for ``x ≥ 10⁴``, and between them the
integral of the bounded, positive angle θ(w). Where the NumPy function places its panels with
Python control flow, this one uses a fixed number of them: the panels graded towards w = 0,
and always the panels graded about the steep rise of θ near ``w_c`` (for α ≤ 1/2, where θ has
no steep rise, at a nominal ``w_c = 1``; more panels cost time, not accuracy). Each region is
evaluated at every x on a safe stand-in where x lies outside it, so that no NaN reaches a
gradient through `jnp.where`.
"""

import functools

import jax
import jax.numpy as jnp
import numpy as np
from jax.scipy.special import gammaln

from ._closed import (
    ASYMPTOTIC_LIMIT,
    GRADING,
    NODES,
    SERIES_LIMIT,
    W_MAX,
    check_alpha,
    check_argument,
    ramp_weight,
)

_GL_X, _GL_W = np.polynomial.legendre.leggauss(NODES)
_SERIES_TERMS = 80
_ASYMPTOTIC_TERMS = 12


def mittag_leffler_jax(alpha, x, beta=1):
    """``E_{α,β}(−x)`` for ``0 < α < 1`` and x ≥ 0, β = 1 or 2, in JAX: `alpha` (a scalar)
    and `x` (an array) may be traced, and `jax.grad` differentiates through both. Agrees with
    `vojax.mittag_leffler` to a few units of rounding (2e-15 relative measured over α
    0.05–0.99, x 0–1e6) in double precision (enable it:
    ``jax.config.update("jax_enable_x64", True)``; single precision gives single's digits). ``E_{α,β+α}(−x) = (1/Γ(β) − E_{α,β}(−x))/x``
    gives β = 1 + α and 2 + α. `beta` is a Python number (it chooses the formula); the order
    and the argument are checked only where they are concrete (a traced value is the
    caller's to keep in range; out of range gives NaN)."""
    if (isinstance(beta, bool) or not isinstance(beta, (int, float, np.integer, np.floating))
            or beta not in (1, 2)):
        raise ValueError(f"beta must be 1 or 2, got {beta!r}.")
    if not isinstance(alpha, jax.core.Tracer):
        a = np.asarray(alpha)
        check_alpha(float(a) if a.ndim == 0 and a.dtype.kind in "iuf" else alpha,
                    upper_open=True)
    if not isinstance(x, jax.core.Tracer):
        check_argument(x)
    alpha = jnp.asarray(alpha, dtype=jnp.result_type(float))
    return _evaluate(alpha, jnp.asarray(x, dtype=alpha.dtype), float(beta))


@functools.partial(jax.jit, static_argnums=2)
def _evaluate(alpha, x, beta):
    series = x <= SERIES_LIMIT
    asymptotic = x >= ASYMPTOTIC_LIMIT
    x_s = jnp.where(series, x, 0.0)
    x_a = jnp.where(asymptotic, x, ASYMPTOTIC_LIMIT)
    x_m = jnp.where(series | asymptotic, 1.0, x)
    middle = jax.vmap(lambda xi: _integral(alpha, xi, beta))(x_m.ravel()).reshape(x.shape)
    return jnp.where(series, _series(alpha, x_s, beta),
                     jnp.where(asymptotic, _asymptotic(alpha, x_a, beta), middle))


def _rgamma(z):
    """1/Γ(z), by reflection below 1/2 with sin(πz) from z's distance to the nearest integer
    (exact), as the NumPy function does."""
    n = jnp.round(z)
    sign = jnp.where(jnp.mod(n, 2) == 0, 1.0, -1.0)
    low = sign * jnp.sin(jnp.pi * (z - n)) * jnp.exp(gammaln(1.0 - jnp.minimum(z, 0.5))) / jnp.pi
    return jnp.where(z >= 0.5, jnp.exp(-gammaln(jnp.maximum(z, 0.5))), low)


def _series(alpha, x, beta):
    k = jnp.arange(_SERIES_TERMS, dtype=x.dtype)
    coef = _rgamma(alpha * k + beta)
    return jnp.sum((-x[..., None]) ** k * coef, axis=-1)


def _asymptotic(alpha, x, beta):
    k = jnp.arange(1, _ASYMPTOTIC_TERMS + 1, dtype=x.dtype)
    coef = _rgamma(beta - alpha * k)
    return -jnp.sum((-1.0 / x[..., None]) ** k * coef, axis=-1)


def _nodes(points, end):
    """Gauss–Legendre nodes and weights of the panels between the sorted `points` clipped to
    [0, end] (repeated points: panels of zero width, weight 0)."""
    b = jnp.sort(jnp.clip(points, 0.0, end))
    lo, hi = b[:-1, None], b[1:, None]
    return (0.5 * (hi - lo) * _GL_X + 0.5 * (hi + lo)).ravel(), (0.5 * (hi - lo) * _GL_W).ravel()


def gamma_jax(z):
    """Γ(z) for z > 0 in JAX (the laws' closed forms' Γ(1 ± q))."""
    return jnp.exp(gammaln(z))


def rotate_jax(omega, q, p):
    """``((iω)^q, p)`` in JAX for `complex_modulus`: ``ω^q e^{iπq/2}``, and the parameters
    made complex explicitly (JAX's strict promotion refuses ``1j * ω``)."""
    w = omega**q
    s = jax.lax.complex(w * jnp.cos(jnp.pi * q / 2), w * jnp.sin(jnp.pi * q / 2))
    return s, {k: jnp.asarray(v).astype(s.dtype) for k, v in p.items()}


def _power(w, alpha):
    """``w^α`` for w ≥ 0, 0 at w = 0 with a finite gradient in α (the nodes of a panel of zero
    width sit at its end, which may be 0; their weight is 0, and 0 · NaN would still be NaN)."""
    positive = w > 0
    return jnp.where(positive, jnp.where(positive, w, 1.0) ** alpha, 0.0)


def _integral(alpha, x, beta):
    """``E_{α,β}(−x)`` for β = 1 or 2 at one x between the series (see the module)."""
    upper = alpha > 0.5
    # sin απ and cos απ from 1 − α above 1/2 (exact there), as the NumPy function does
    s = jnp.where(upper, jnp.sin((1 - alpha) * jnp.pi), jnp.sin(alpha * jnp.pi))
    c = jnp.where(upper, -jnp.cos((1 - alpha) * jnp.pi), jnp.cos(alpha * jnp.pi))
    halves = 2.0 ** -np.arange(GRADING + 1)
    graded = 2.0 ** np.arange(-GRADING, 11)
    steep = c < 0
    neg_c = jnp.where(steep, -c, 1.0)
    wc = jnp.where(steep, (x / neg_c) ** (1.0 / alpha), 1.0)
    width = jnp.maximum(s / neg_c / alpha, 1e-17) * wc
    rise = jnp.concatenate([wc[None], wc - width * 2**20 * halves, wc + width * 2**20 * halves])
    points = jnp.concatenate([jnp.zeros(1), jnp.asarray(graded), rise])
    w, weight = _nodes(points, W_MAX)
    wa = _power(w, alpha)
    theta = jnp.arctan2(s * wa, x + c * wa)
    if beta == 1.0:
        total = jnp.sum(weight * jnp.exp(-w) * theta)
    else:  # the weight (1 − e^{−w}(1 + w))/w², then the tail beyond W_MAX in v = 1/w
        total = jnp.sum(weight * ramp_weight(w, jnp) * theta)
        far = jnp.where(rise > W_MAX, 1.0 / jnp.maximum(rise, W_MAX), 0.0)
        tail = jnp.concatenate([jnp.zeros(1), jnp.asarray(graded / W_MAX**2), far])
        v, weight = _nodes(tail, 1.0 / W_MAX)
        total += jnp.sum(weight * jnp.arctan2(s, x * _power(v, alpha) + c))
    return total / (alpha * jnp.pi)
