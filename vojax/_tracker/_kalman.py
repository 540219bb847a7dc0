"""Kalman filter and Rauch–Tung–Striebel smoother for a diagonal linear state equation seen
through one scalar, linear measurement per sample: ``θ_{k+1} = F_k θ_k + w_k``,
``z_k = H_k θ_k + v_k``, with ``F_k = diag(f_k)`` (a random walk where ``f = 1``; an AR(1)
state, such as a coloured measurement noise, where ``0 < f < 1``).

This is the linear engine of the tracker: each Gauss–Newton iteration of the iterated smoother
linearises the measurement around a nominal trajectory and runs these two scans. The process
noise is diagonal, ``w_k ~ N(0, diag(q_k))``; ``v_k ~ N(0, r / mask_k)`` and a sample with
``mask_k = 0`` is skipped (padding, or a sample outside a fit window).
"""

import equinox as eqx
import jax
import jax.numpy as jnp
from jax import lax
from jaxtyping import Array, Float

from .._linalg import cholesky_solve

LOG_2PI = 1.8378770664093453


class Filtered(eqx.Module):
    mean: Float[Array, "N d"]  # m_k = E[θ_k | z_0 … z_k]
    cov: Float[Array, "N d d"]
    pred_mean: Float[Array, "N d"]  # m_k⁻ = E[θ_k | z_0 … z_{k−1}]
    pred_cov: Float[Array, "N d d"]
    innovation: Float[Array, " N"]  # z_k − H_k m_k⁻
    innovation_var: Float[Array, " N"]  # H_k P_k⁻ H_kᵀ + r
    log_likelihood: Float[Array, ""]  # Σ log N(z_k; H_k m_k⁻, S_k) over unmasked samples


def _symmetric(a):
    return 0.5 * (a + a.T)


def update(mean, cov, h, z, r, mask):
    """One measurement update in Joseph form; returns ``(mean, cov, innovation, S, log-lik)``."""
    ph = cov @ h
    s = jnp.dot(h, ph) + r
    gain = mask * ph / s
    e = z - jnp.dot(h, mean)
    new_mean = mean + gain * e
    a = jnp.eye(mean.shape[0], dtype=mean.dtype) - jnp.outer(gain, h)
    new_cov = _symmetric(a @ cov @ a.T + r * jnp.outer(gain, gain))
    ll = -0.5 * mask * (LOG_2PI + jnp.log(s) + e * e / s)
    return new_mean, new_cov, e, s, ll


def anchor_update(mean, cov, anchor, damping):
    """Levenberg–Marquardt damping as a measurement: ``anchor = θ + v``, ``v ~ N(0, I/damping)``."""
    d = mean.shape[0]
    s = cov + jnp.eye(d, dtype=cov.dtype) / damping
    gain = cholesky_solve(s, cov).T  # P S⁻¹ (both symmetric)
    new_cov = _symmetric(cov - gain @ cov)
    return mean + gain @ (anchor - mean), new_cov


def _predicted(m, p, q_k, f_k=None):
    """``F m`` and ``F P Fᵀ + diag(q)`` for a diagonal ``F = diag(f_k)`` (the identity, a
    random walk, when `f_k` is None)."""
    if f_k is None:
        return m, p + jnp.diag(q_k)
    return f_k * m, p * f_k[:, None] * f_k[None, :] + jnp.diag(q_k)


@jax.named_scope("vojax.kalman_filter")
def kalman_filter(h, z, r, q, m0, p0, mask=None, anchor=None, damping=None, f=None) -> Filtered:
    """The filter over ``h`` (N, d), ``z`` (N,), with ``r`` the measurement variance, ``q``
    (N, d) the process variances from sample k to k+1, ``f`` (N, d) the diagonal of the
    transition from sample k to k+1 (ones, a random walk, when None), and the prior
    ``N(m0, p0)`` of θ_0.

    With `anchor` (N, d) and `damping` μ > 0, each state is also observed as ``anchor_k`` with
    variance ``1/μ`` per component: the smoothed mean is then the Levenberg–Marquardt step of
    the Gauss–Newton iteration around ``anchor``. These pseudo-measurements do not enter the
    innovations or the likelihood."""
    if mask is None:
        mask = jnp.ones(z.shape, z.dtype)
    if anchor is None:
        anchor = jnp.zeros(h.shape, h.dtype)
    # a random walk's scan step has no transition to apply
    xs = (h, z, q, mask, anchor) + (() if f is None else (f,))

    def body(carry, x):
        m_pred, p_pred = carry
        h_k, z_k, q_k, w_k, a_k, *f_k = x
        m, p, e, s, ll = update(m_pred, p_pred, h_k, z_k, r, w_k)
        if damping is not None:
            m, p = anchor_update(m, p, a_k, damping)
        return _predicted(m, p, q_k, *f_k), (m, p, m_pred, p_pred, e, s, ll)

    _, (m, p, mp, pp, e, s, ll) = lax.scan(body, (m0, p0), xs)
    return Filtered(m, p, mp, pp, e, s, jnp.sum(ll))


@jax.named_scope("vojax.rts_smoother")
def rts_smoother(filtered: Filtered, q, f=None):
    """Rauch–Tung–Striebel: the smoothed means (N, d) and covariances (N, d, d); `q`, `f` as
    in `kalman_filter`."""
    def body(carry, x):
        ms_next, ps_next = carry
        m, p, q_k, *f_k = x
        m_pred, p_pred = _predicted(m, p, q_k, *f_k)
        # G = P_k Fᵀ (P_{k+1}⁻)⁻¹, P and P⁻ symmetric: solve rather than invert
        g = cholesky_solve(p_pred, p if not f_k else p * f_k[0][:, None]).T
        ms = m + g @ (ms_next - m_pred)
        ps = _symmetric(p + g @ (ps_next - p_pred) @ g.T)
        return (ms, ps), (ms, ps)

    m, p = filtered.mean, filtered.cov
    last = (m[-1], p[-1])
    xs = (m[:-1], p[:-1], q[:-1]) + (() if f is None else (f[:-1],))
    _, (ms, ps) = lax.scan(body, last, xs, reverse=True)
    return jnp.concatenate([ms, m[-1:]]), jnp.concatenate([ps, p[-1:]])
