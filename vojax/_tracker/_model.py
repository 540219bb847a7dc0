"""The tracker's state-space model of eq. (12) with a random-walk order and parameters.

State ``θ_k = [β_k, p_k (n), c]``: the order through an unbounded (logistic) coordinate,
``α_k = lo + (hi − lo)·sigmoid(β_k)``, the parameters of eq. (11) and the output offset
``c = x(0)``. All three are in normalised units (see `_scaling`):

    θ_{k+1} = θ_k + w_k,   w_k ~ N(0, diag(q_β, q_p·1, 0) · (t_{k+1} − t_k)/T)
    y_k     = c + p_kᵀ Φ(α_k, t_k) + v_k,   v_k ~ N(0, r)

The order enters only at the evaluation time, so the measurement at sample k depends on
``β_k`` through ``Φ(α_k, t_k)`` alone; its linearisation needs ``Φ`` and ``∂Φ/∂b`` at one order
per sample, which one scan of a memory kernel gives for a whole trajectory.
"""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float


def order_of(beta, bounds):
    """``α = lo + (hi − lo)·sigmoid(β)`` and ``dα/dβ``."""
    lo, hi = bounds
    s = jax.nn.sigmoid(beta)
    return lo + (hi - lo) * s, (hi - lo) * s * (1.0 - s)


def order_of_np(beta, bounds):
    """`order_of` in NumPy: for the host-side steps before and after the compiled programs
    (an eager JAX operation compiles a program of its own on the first call)."""
    lo, hi = bounds
    s = 1.0 / (1.0 + np.exp(-np.asarray(beta, dtype=float)))
    return lo + (hi - lo) * s, (hi - lo) * s * (1.0 - s)


def beta_of_np(alpha, bounds):
    """`beta_of` in NumPy."""
    lo, hi = bounds
    z = (np.asarray(alpha, dtype=float) - lo) / (hi - lo)
    return np.log(z) - np.log1p(-z)


def beta_of(alpha, bounds):
    """The inverse of `order_of`."""
    lo, hi = bounds
    z = (alpha - lo) / (hi - lo)
    return jnp.log(z) - jnp.log1p(-z)


class Hyper(eqx.Module):
    """Noise intensities in normalised units, as logarithms (so that they can be optimised
    freely): ``log_q_order`` (variance of the change of β over the whole record),
    ``log_q_params`` (variance of the change of each normalised parameter over the record),
    ``log_r`` (measurement variance of the normalised output)."""

    log_q_order: Float[Array, ""]
    log_q_params: Float[Array, ""]
    log_r: Float[Array, ""]

    def process(self, steps, horizon, n):
        """Process variances ``q`` (N, n + 2) for the steps ``t_{k+1} − t_k`` (N,)."""
        frac = steps / horizon
        qo = jnp.exp(self.log_q_order) * frac
        qp = jnp.exp(self.log_q_params) * frac
        return jnp.concatenate(
            [qo[:, None], jnp.broadcast_to(qp[:, None], (frac.shape[0], n)), 0.0 * qo[:, None]],
            axis=1,
        )

    @property
    def r(self):
        return jnp.exp(self.log_r)

    def as_array(self):
        return jnp.stack([self.log_q_order, self.log_q_params, self.log_r])

    @classmethod
    def from_array(cls, z):
        return cls(z[0], z[1], z[2])


def predict(theta, phi, n):
    """``c + pᵀ Φ`` for states ``θ`` (…, d) and regressors ``Φ`` (…, n)."""
    return theta[..., -1] + jnp.sum(theta[..., 1 : 1 + n] * phi, axis=-1)


def linearise(theta, phi, dphi, bounds):
    """``h(θ̄)`` (N,) and the Jacobian rows ``H`` (N, d) at the nominal states ``θ̄`` (N, d)."""
    n = phi.shape[-1]
    _, dalpha = order_of(theta[..., 0], bounds)
    p = theta[..., 1 : 1 + n]
    h_beta = jnp.sum(p * dphi, axis=-1) * dalpha
    jac = jnp.concatenate([h_beta[..., None], phi, jnp.ones_like(h_beta)[..., None]], axis=-1)
    return predict(theta, phi, n), jac


def objective(theta, phi, y, mask, r, q, m0, p0_inv):
    """Negative log posterior (× 2, up to a constant) of a whole trajectory ``θ`` (N, d):
    data misfit, random-walk increments and the prior of ``θ_0``."""
    n = phi.shape[-1]
    res = y - predict(theta, phi, n)
    data = jnp.sum(mask * res * res) / r
    inc = theta[1:] - theta[:-1]
    qq = q[:-1]
    proc = jnp.sum(jnp.where(qq > 0, inc * inc / jnp.where(qq > 0, qq, 1.0), 0.0))
    e0 = theta[0] - m0
    return data + proc + e0 @ p0_inv @ e0
