"""The band of the paper's law: the spread of its estimates over realisations of the
measurement noise, by the delta method through the law's own recursion.

The law is a deterministic map from the measurements to the estimates. Linearised about the
realised trajectory, white measurement noise of variance σ² propagates through it exactly as
through a linear system: with ``s_k`` the part of the law's state that depends on the
measurements (LSFF's R, Q and their order tangents, α̂, p̂) and ``A_k = ∂s_k/∂s_{k−1}``,
``b_k = ∂s_k/∂y_k`` (forward-mode autodiff of one step),

    Σ_k = A_k Σ_{k−1} A_kᵀ + σ² b_k b_kᵀ,

and the covariance of any output is read off with its Jacobian. This is the law's sampling
spread, checked against Monte Carlo in the tests. It does **not** include the law's tracking
bias (the lag of a gradient law behind a moving order, or an order held by its start α̂(0)
where the data do not determine it): compare with ``method="kalman"``, whose band does.

At some gains the law is unstable: a change of the data in its last digits changes the order
by 1e-2 a few thousand samples later, and Σ grows geometrically. Σ is carried as
``e^s Σ̃`` with ``max |Σ̃|`` renormalised to 1 whenever it passes `RESCALE`, so that the
recursion never overflows to NaN; a variance beyond the float range comes out as ``inf``.
"""

import equinox as eqx
import jax
import jax.numpy as jnp
from jax import lax
from jax.flatten_util import ravel_pytree

RESCALE = 1e100  # Σ̃ is renormalised when its largest entry passes this


@eqx.filter_jit
def law_covariance(law, u, big_y, sigma2, rescale=RESCALE):
    """Variances of α̂ (N,) and p̂ (N, n) of ``law`` run over ``u`` (N, n), ``big_y`` (N,);
    Σ̃ is renormalised when its largest entry passes `rescale`."""
    state0 = law.init(u.shape[1])
    free0 = (state0.lsff, state0.lsff_tangent, state0.alpha, state0.p)
    flat0, unravel = ravel_pytree(free0)
    dim = flat0.shape[0]

    def one(flat, memory, u_k, y_k):
        lsff, tangent, alpha, p = unravel(flat)
        state = eqx.tree_at(lambda s: (s.lsff, s.lsff_tangent, s.alpha, s.p), state0, (lsff, tangent, alpha, p))
        state = eqx.tree_at(lambda s: s.memory, state, memory)
        new, out = law.step(state, u_k, y_k)
        flat_new, _ = ravel_pytree((new.lsff, new.lsff_tangent, new.alpha, new.p))
        return flat_new, (flat_new, out.p, new.memory)

    def body(carry, x):
        flat, memory, cov, log_scale = carry
        u_k, y_k = x
        def f(v, yy):  # the outputs to differentiate, and the step's primal results as aux
            _, (flat_new, p, memory_new) = one(v, memory, u_k, yy)
            return (flat_new, p), (flat_new, memory_new)

        jacobians, (flat_new, memory_new) = jax.jacfwd(f, argnums=(0, 1), has_aux=True)(flat, y_k)
        (jv_state, jy_state), (jv_p, jy_p) = jacobians
        # Σ = e^s Σ̃: the noise enters Σ̃ scaled by e^{−s}
        shrink = jnp.exp(-log_scale)
        cov_new = jv_state @ cov @ jv_state.T + sigma2 * shrink * jnp.outer(jy_state, jy_state)
        var_p = unscaled(jnp.einsum("ij,jk,ik->i", jv_p, cov, jv_p), log_scale) + sigma2 * jy_p**2
        # α̂_k (the order used at sample k) is part of the state before the step
        alpha_index = dim - u.shape[1] - 1
        var_alpha = unscaled(cov[alpha_index, alpha_index], log_scale)
        cov_new = 0.5 * (cov_new + cov_new.T)
        big = jnp.max(jnp.abs(cov_new))
        renorm = jnp.isfinite(big) & (big > rescale)
        cov_new = jnp.where(renorm, cov_new / jnp.where(renorm, big, 1.0), cov_new)
        log_scale = log_scale + jnp.where(renorm, jnp.log(jnp.where(renorm, big, 1.0)), 0.0)
        return (flat_new, memory_new, cov_new, log_scale), (var_alpha, var_p)

    start = (flat0, state0.memory, jnp.zeros((dim, dim), flat0.dtype), jnp.zeros((), flat0.dtype))
    _, (var_alpha, var_p) = lax.scan(jax.checkpoint(body), start, (u, big_y))
    return var_alpha, var_p


def unscaled(v, log_scale):
    """``e^s · v`` for variances ``v ≥ 0`` (rounding may leave them slightly negative), ``inf``
    beyond the float range; ``0 · e^s`` stays 0, and a NaN stays NaN (never hidden as 0)."""
    v = jnp.maximum(v, 0.0)
    out = jnp.where(v > 0, jnp.exp(jnp.log(jnp.where(v > 0, v, 1.0)) + log_scale), 0.0)
    return jnp.where(jnp.isnan(v), v, out)
