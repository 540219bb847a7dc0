"""The tracker's state-space model of eq. (12) with a random-walk order and parameters.

State ``θ_k = [β_k, p_k (n), c]``: the order through an unbounded (logistic) coordinate,
``α_k = lo + (hi − lo)·sigmoid(β_k)``, the parameters of eq. (11) and the output offset
``c = x(0)``. All three are in normalised units (see `_scaling`):

    θ_{k+1} = θ_k + w_k,   w_k ~ N(0, diag(q_β, q_p·1, 0) · (t_{k+1} − t_k)/T)
    y_k     = c + p_kᵀ Φ(α_k, t_k) + v_k,   v_k ~ N(0, r)

With a coloured measurement noise the state has one more component, the noise's AR(1) part
``e`` (stationary variance ``s``, correlation time ``τ``), appended last:

    e_{k+1} = a_k e_k + w_k,   a_k = exp(−(t_{k+1} − t_k)/τ),   w_k ~ N(0, s (1 − a_k²))
    y_k     = c + p_kᵀ Φ(α_k, t_k) + e_k + v_k

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
    ``log_r`` (white measurement variance of the normalised output), and for a coloured
    measurement noise ``log_ar_var`` (stationary variance of its AR(1) part) and
    ``log_ar_time`` (its correlation time as a fraction of the record's span); both None for
    white noise, and then the state has no noise component."""

    log_q_order: Float[Array, ""]
    log_q_params: Float[Array, ""]
    log_r: Float[Array, ""]
    log_ar_var: Float[Array, ""] | None = None
    log_ar_time: Float[Array, ""] | None = None

    @property
    def coloured(self) -> bool:
        return self.log_ar_var is not None

    def _ar(self, steps, horizon):
        """The AR(1) part's transition ``a_k`` (N,)."""
        return jnp.exp(-steps / (horizon * jnp.exp(self.log_ar_time)))

    def process(self, steps, horizon, n):
        """Process variances ``q`` (N, d) for the steps ``t_{k+1} − t_k`` (N,)."""
        frac = steps / horizon
        qo = jnp.exp(self.log_q_order) * frac
        qp = jnp.exp(self.log_q_params) * frac
        cols = [qo[:, None], jnp.broadcast_to(qp[:, None], (frac.shape[0], n)), 0.0 * qo[:, None]]
        if self.coloured:
            a = self._ar(steps, horizon)
            cols.append((jnp.exp(self.log_ar_var) * (1.0 - a * a))[:, None])
        return jnp.concatenate(cols, axis=1)

    def transition(self, steps, horizon, n):
        """The diagonal of the transition (N, d): ones (a random walk) but for the noise's
        AR(1) part; None for white noise."""
        if not self.coloured:
            return None
        ones = jnp.ones((steps.shape[0], n + 2), steps.dtype)
        return jnp.concatenate([ones, self._ar(steps, horizon)[:, None]], axis=1)

    def initial(self, p0):
        """The prior covariance of θ_0 with the noise's AR(1) part at its stationary variance."""
        if not self.coloured:
            return p0
        return p0.at[-1, -1].set(jnp.exp(self.log_ar_var))

    @property
    def r(self):
        return jnp.exp(self.log_r)

    def as_array(self):
        extra = [self.log_ar_var, self.log_ar_time] if self.coloured else []
        return jnp.stack([self.log_q_order, self.log_q_params, self.log_r, *extra])

    @classmethod
    def from_array(cls, z):
        return cls(*(z[i] for i in range(z.shape[0])))


def model_output(theta, phi, n):
    """``c + pᵀ Φ`` (the noise-free output) for states ``θ`` (…, d), regressors ``Φ`` (…, n):
    JAX or NumPy arrays (array methods only, so that host arrays stay on the host)."""
    return theta[..., 1 + n] + (theta[..., 1 : 1 + n] * phi).sum(axis=-1)


def predict(theta, phi, n):
    """The measurement function: `model_output`, plus the noise's AR(1) part where the state
    has one (d = n + 3)."""
    out = model_output(theta, phi, n)
    return out + theta[..., 2 + n] if theta.shape[-1] == n + 3 else out


def linearise(theta, phi, dphi, bounds):
    """``h(θ̄)`` (N,) and the Jacobian rows ``H`` (N, d) at the nominal states ``θ̄`` (N, d)."""
    n = phi.shape[-1]
    _, dalpha = order_of(theta[..., 0], bounds)
    p = theta[..., 1 : 1 + n]
    h_beta = jnp.sum(p * dphi, axis=-1) * dalpha
    ones = jnp.ones_like(h_beta)[..., None]
    cols = [h_beta[..., None], phi, ones] + [ones] * (theta.shape[-1] - n - 2)
    return predict(theta, phi, n), jnp.concatenate(cols, axis=-1)


def objective(theta, phi, y, mask, r, q, m0, p0_inv, f=None):
    """Negative log posterior (× 2, up to a constant) of a whole trajectory ``θ`` (N, d):
    data misfit, state increments ``θ_{k+1} − F_k θ_k`` (`f`: the transition's diagonal, ones
    when None) and the prior of ``θ_0``."""
    return posterior_cost(theta, y - predict(theta, phi, phi.shape[-1]), mask, r, q, m0, p0_inv, f)


def posterior_cost(theta, residuals, mask, r, q, m0, p0_inv, f=None):
    """`objective` with the measurement residuals (N,) given: the true model's, or a
    linearised model's (the cost a Gauss–Newton step predicts)."""
    data = jnp.sum(mask * residuals * residuals) / r
    inc = theta[1:] - (theta[:-1] if f is None else f[:-1] * theta[:-1])
    qq = q[:-1]
    proc = jnp.sum(jnp.where(qq > 0, inc * inc / jnp.where(qq > 0, qq, 1.0), 0.0))
    e0 = theta[0] - m0
    return data + proc + e0 @ p0_inv @ e0
