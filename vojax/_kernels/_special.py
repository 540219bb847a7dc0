"""Host-side Γ and ψ for the mode design and the NumPy reference (no SciPy dependency)."""

import math

import numpy as np


def _digamma_scalar(x: float) -> float:
    acc = 0.0
    while x < 8.0:
        acc -= 1.0 / x
        x += 1.0
    inv2 = 1.0 / (x * x)
    series = inv2 * (1 / 12 - inv2 * (1 / 120 - inv2 * (1 / 252 - inv2 * (1 / 240 - inv2 / 132))))
    return acc + math.log(x) - 0.5 / x - series


def digamma(x):
    """ψ(x) for x > 0, elementwise, by recurrence to x ≥ 8 and the asymptotic series."""
    return np.vectorize(_digamma_scalar, otypes=[float])(x)


def lgamma(x):
    """ln Γ(x) for x > 0, elementwise."""
    return np.vectorize(math.lgamma, otypes=[float])(x)


def _chebyshev_lgamma1p(count: int = 256, terms: int = 23) -> np.ndarray:
    """Chebyshev coefficients of ``ln Γ(1 + b)`` on ``b ∈ [0, 1]`` (variable ``t = 2b − 1``).

    Interpolated at ``count`` Chebyshev points from `math.lgamma` (correct to an ulp). They fall
    by about 6× a term, to 1e-17 at term 21, below which the interpolation's rounding (~1e-17)
    would dominate: the series is cut after `terms` terms.
    """
    theta = np.pi * (np.arange(count) + 0.5) / count
    values = lgamma(1.0 + (np.cos(theta) + 1.0) / 2.0)
    coefficients = 2.0 / count * np.cos(np.outer(np.arange(terms), theta)) @ values
    coefficients[0] /= 2.0
    return coefficients


LGAMMA1P_CHEBYSHEV = _chebyshev_lgamma1p()
