"""Least squares with forgetting factor, eq. (23) in the exact discrete form of docs/method.md §3."""

import equinox as eqx
import jax.numpy as jnp
from jax.scipy.linalg import cho_factor, cho_solve
from jaxtyping import Array, Float

UNROLL_UP_TO = 6  # inputs; beyond, LAPACK's Cholesky (its call overhead dominates small n)


def cholesky_solve(a, b):
    """Solves ``a x = b`` for symmetric positive definite ``a`` through its Cholesky factor.

    For the few inputs of a constitutive law the factorisation is unrolled into scalar
    operations that XLA fuses into the scan step; a LAPACK call per sample costs more than the
    arithmetic.
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


class LSFFState(eqx.Module):
    information: Float[Array, "n n"]  # R_k
    moment: Float[Array, " n"]  # Q_k
    # 0 before the first sample, 1 after; a float so that jax.jvp can carry a (zero) tangent
    started: Float[Array, ""]


class LSFF(eqx.Module):
    """``R_k = f R_{k−1} + h φ_k φ_kᵀ``, ``Q_k = f Q_{k−1} + h y_k φ_k``, ``p_k = R_k⁻¹ Q_k``.

    ``f = e^{−λh}``; ``R`` starts from ``R_0`` (the identity unless given: ``P(0) = I`` in eq. 29)
    and is never inverted: ``p`` is solved from the Cholesky factor of ``R``. The recursion is
    algebraically the batch solution (23) on the sample grid.

    **Arguments:** `lam` (λ > 0), `dt` (h), `r0` (``R_0``, symmetric positive definite, or None).
    """

    lam: Float[Array, ""]
    dt: Float[Array, ""]
    r0: Float[Array, "n n"] | None = None

    def init(self, num_inputs: int) -> LSFFState:
        dtype = jnp.asarray(self.dt).dtype
        r0 = jnp.eye(num_inputs, dtype=dtype) if self.r0 is None else self.r0
        return LSFFState(r0, jnp.zeros((num_inputs,), dtype), jnp.zeros((), dtype))

    def step(self, state: LSFFState, phi, y, h=None):
        """Returns ``(new_state, p_k)`` after the sample ``(φ_k, y_k)``; ``h`` is the step
        ending at the sample (default `dt`; on a non-uniform grid, the local step)."""
        h = self.dt if h is None else h
        f = jnp.where(state.started > 0, jnp.exp(-self.lam * h), 1.0)
        information = f * state.information + h * jnp.outer(phi, phi)
        moment = f * state.moment + h * y * phi
        p = cholesky_solve(information, moment)
        return LSFFState(information, moment, jnp.ones_like(state.started)), p
