"""Theorem 1: the order law and LSFF composed, with ``∂p/∂β`` by forward-mode autodiff."""

import equinox as eqx
import jax
import jax.numpy as jnp
from jaxtyping import Array, Float

from .._kernels import AbstractMemory
from ._lsff import LSFF, LSFFState
from ._order import OrderGradient


class LawState(eqx.Module):
    memory: eqx.Module
    lsff: LSFFState
    # tangent of the LSFF state along a uniform shift of the order history: (dR_k, dQ_k)
    lsff_tangent: LSFFState
    alpha: Float[Array, ""]
    p: Float[Array, " n"]  # p_{k−1}, for the a-priori prediction


class LawOutput(eqx.Module):
    alpha: Float[Array, ""]  # α̂_k, the order used at sample k
    p: Float[Array, " n"]  # p̂_k = p(α̂, t_k)
    dp: Float[Array, " n"]  # ∂p/∂β (26)
    y_hat: Float[Array, ""]  # p̂_kᵀ φ_k (a posteriori, eq. 25)
    y_pred: Float[Array, ""]  # p̂_{k−1}ᵀ φ_k (a priori: before y_k is used)
    Lambda: Float[Array, ""]  # Λ_k (30)
    phi: Float[Array, " n"]  # φ(α̂_k, t_k)


class AdaptiveLaw(eqx.Module):
    """The adaptive order/parameter law (29)–(30), one sample per `step`.

    ``φ_k`` and ``∂φ_k/∂β`` come from the memory at the current order ``α̂_k``; the LSFF step is
    differentiated with ``jax.jvp`` along the uniform order shift, its tangent ``(dR, dQ)``
    carried in the state, which yields ``∂p/∂β`` exactly as the corrected (26) of docs/method.md §3.

    Streaming use, one sample at a time (``Y = y − x0``, Remark 4)::

        law = AdaptiveLaw(memory, LSFF(lam, dt), OrderGradient(gamma, dt, alpha0, bounds))
        state = law.init(num_inputs)
        step = eqx.filter_jit(law.step)
        for u_k, y_k in stream:
            state, out = step(state, u_k, y_k - x0)   # out.alpha, out.p, out.y_hat + x0, …
    """

    memory: AbstractMemory
    lsff: LSFF
    order: OrderGradient

    def init(self, num_inputs: int) -> LawState:
        lsff = self.lsff.init(num_inputs)
        tangent = jax.tree_util.tree_map(jnp.zeros_like, lsff)
        return LawState(
            self.memory.init(num_inputs),
            lsff,
            tangent,
            self.order.init(),
            jnp.zeros((num_inputs,), lsff.moment.dtype),
        )

    def step(self, state: LawState, u_k, y_k):
        alpha = state.alpha
        h = self.memory.step_size(state.memory)  # the local step on a non-uniform grid
        memory, (phi, dphi) = self.memory.step(state.memory, u_k, alpha)
        (lsff, p), (lsff_tangent, dp) = jax.jvp(
            lambda s, ph: self.lsff.step(s, ph, y_k, h),
            (state.lsff, phi),
            (state.lsff_tangent, dphi),
        )
        y_hat = jnp.dot(p, phi)
        lam_k = jnp.dot(p, dphi) + jnp.dot(dp, phi)  # Λ of eq. (30)
        alpha_next = self.order.step(alpha, lam_k, y_k - y_hat, h)
        out = LawOutput(alpha, p, dp, y_hat, jnp.dot(state.p, phi), lam_k, phi)
        return LawState(memory, lsff, lsff_tangent, alpha_next, p), out
