"""Least squares with forgetting factor, eq. (23) in the exact discrete form of docs/method.md §3."""

import equinox as eqx
import jax.numpy as jnp
from jaxtyping import Array, Float

from .._linalg import cholesky_solve


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
