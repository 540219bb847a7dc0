"""The order-gradient law of eq. (29): ``α̂_{k+1} = Π[α̂_k + h γ Λ_k (y_k − ŷ_k)]``."""

import equinox as eqx
import jax.numpy as jnp
from jaxtyping import Array, Float


class OrderGradient(eqx.Module):
    """Gradient law for the order with projection ``Π`` onto ``[α_min, α_max] ⊂ (0, 1)``.

    **Arguments:** `gamma` (γ > 0), `dt` (h), `alpha0` (α̂(0)), `bounds` (α_min, α_max).
    """

    gamma: Float[Array, ""]
    dt: Float[Array, ""]
    alpha0: Float[Array, ""]
    bounds: tuple[float, float] = eqx.field(static=True)

    def init(self) -> Float[Array, ""]:
        return jnp.asarray(self.alpha0)

    def step(self, alpha, sensitivity, error, h=None):
        """``Λ_k`` (30) and the output error ``y_k − ŷ_k`` → ``α̂_{k+1}``; ``h`` the step
        (default `dt`; on a non-uniform grid, the step ending at sample k: known online)."""
        lo, hi = self.bounds
        h = self.dt if h is None else h
        return jnp.clip(alpha + h * self.gamma * sensitivity * error, lo, hi)
