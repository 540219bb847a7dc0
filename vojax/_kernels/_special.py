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
