"""Small dense linear algebra written for the inside of a scan over samples."""

import jax.numpy as jnp
from jax.scipy.linalg import cho_factor, cho_solve

UNROLL_UP_TO = 6  # unknowns; beyond, LAPACK's Cholesky (its call overhead dominates small n)


def cholesky_solve(a, b):
    """Solves ``a x = b`` for symmetric positive definite ``a`` (n, n), ``b`` (n,) or (n, m),
    through its Cholesky factor.

    For the few unknowns of a constitutive law (LSFF's n inputs, the tracker's n + 2 states)
    the factorisation is unrolled into scalar operations that XLA fuses into the scan step; a
    LAPACK call per sample costs more than the arithmetic (the tracker's filter and smoother:
    7 µs against 0.4 µs a sample at n + 2 = 4).
    """
    n = a.shape[0]
    if n > UNROLL_UP_TO:
        return cho_solve(cho_factor(a, lower=True), b)
    low = [[None] * n for _ in range(n)]
    for j in range(n):
        low[j][j] = jnp.sqrt(a[j, j] - sum(low[j][k] ** 2 for k in range(j)))
        for i in range(j + 1, n):
            low[i][j] = (a[i, j] - sum(low[i][k] * low[j][k] for k in range(j))) / low[j][j]
    z = []
    for i in range(n):
        z.append((b[i] - sum(low[i][k] * z[k] for k in range(i))) / low[i][i])
    x = [None] * n
    for i in reversed(range(n)):
        x[i] = (z[i] - sum(low[k][i] * x[k] for k in range(i + 1, n))) / low[i][i]
    return jnp.stack(x)
