"""The smoother's Levenberg–Marquardt step rules: Nielsen's update of the damping μ, and when an
accepted step's decrease may end the iteration (a barely damped step, read from μ itself or
from how much μ shortens the step)."""

import jax.numpy as jnp

REL_TOL = 1e-9  # relative decrease of the objective below which the iteration stops
MU_START, MU_MIN, MU_MAX = 1e-2, 1e-9, 1e12  # Levenberg–Marquardt damping (normalised units)
MU_DOWN = 1.0 / 3.0  # the largest fall of the damping after a step the linearised model predicted
# above MU_START, an accepted step also counts as barely damped where the damping shortens it
# by at most this share along every state coordinate (`shortfall`): μ·P_ii ≤ share, P the
# damped pass's smoothed covariances (a coordinate of curvature λ is shortened by μ/(λ + μ);
# a flat ridge keeps P_ii near 1/μ). 0: off, μ ≤ MU_START alone; read when the smoother is
# traced. Without it μ settles at 0.1–0.6 where each step gains about half of what the
# linearised model predicts, and such settled runs use their whole budget and are counted
# unconverged (docs/calibration.md, "When a smoothing stops"): on the 1,000-sample benchmark
# record 2,521 → 1,570 iterations; held out, the same identifications and one confidently
# wrong answer fewer (clock draw 19)
BARELY_DAMPED = 0.1


def shortfall(mu, cov):
    """How much the damping μ shortens a step at most, read on the damped pass's smoothed
    covariances `cov` (N, d, d): μ times the largest variance of any state at any sample (a
    coordinate of curvature λ has variance about 1/(λ + μ), shortened by μ/(λ + μ))."""
    return mu * jnp.max(jnp.diagonal(cov, axis1=-2, axis2=-1))


def progress(accepted, mu, value, new_value, rel, short=None, share=0.0):
    """The relative decrease that the iteration's convergence test (``≤ REL_TOL``) reads after
    a step: an accepted step's ``(value − new_value)/max(|new_value|, 1)`` where it was
    barely damped (μ ≤ `MU_START`, or, with a `share` above 0, its shortfall `short` at most
    that share, see `shortfall` and `BARELY_DAMPED`); after an accepted, heavily damped step
    ∞ (its small decrease says the damping is heavy, not that the minimum is near); after a
    rejected step, `rel` unchanged."""
    dec = (value - new_value) / jnp.maximum(jnp.abs(new_value), 1.0)
    barely = mu <= MU_START
    if short is not None and share > 0:
        barely = barely | (short <= share)
    return jnp.where(accepted & barely, dec, jnp.where(accepted, jnp.inf, rel))


def damping(mu, nu, accepted, value, new_value, predicted):
    """Nielsen's update of the Levenberg–Marquardt damping μ and its growth factor ν after a
    step from cost `value` to `new_value`, where the linearised model predicted the cost
    `predicted`: with ``ρ = (value − new_value) / (value − predicted)`` (1 when no decrease
    was predicted), an `accepted` step scales μ by ``max(MU_DOWN, 1 − (2ρ − 1)³)`` (÷3 for
    ρ ≥ 1, ×1 for ρ = ½, ×2 for ρ ≤ 0) and resets ν to 2; a rejected one scales μ by ν and
    doubles ν. μ stays within [`MU_MIN`, `MU_MAX`] after an accepted step. Returns
    ``(μ, ν)``."""
    gain = value - predicted
    rho = jnp.where(gain > 0, (value - new_value) / jnp.where(gain > 0, gain, 1.0), 1.0)
    scale = jnp.maximum(MU_DOWN, 1.0 - (2.0 * rho - 1.0) ** 3)
    new_mu = jnp.where(accepted, jnp.clip(mu * scale, MU_MIN, MU_MAX), mu * nu)
    return new_mu, jnp.where(accepted, jnp.full_like(nu, 2.0), 2.0 * nu)
