"""The whole adaptive law (29)–(30) against an independent transcription in plain NumPy.

The transcription imports nothing of the library's law, LSFF or memory kernels: at each sample
it takes φ_k and ∂φ_k/∂β at the current order α̂_k from `vojax.reference` (hand-written direct
sums, or the hand-written readout of the exponential memory), p_k from the batch sums of (23)
and ∂p_k/∂β from the corrected closed form (26) (`vojax.reference.lsff`, `lsff_sensitivity`,
explicit sums, not a recursion), then Λ_k of (30) and the projected order update (29).
A non-identity R₀ and a gain large enough that α̂ visits a bound are used, so that a
forgotten R₀, a dropped projection, an a-priori error in place of y − ŷ, a lost h or a
sign slip each change the trajectory.
"""

import numpy as np
import pytest

import vojax
from vojax import reference

DT, N = 0.1, 80
BOUNDS = (0.05, 0.95)


def _case():
    t = np.arange(N) * DT
    u = np.stack([np.sin(1.3 * t) + 0.4, np.cos(0.5 * t)], axis=1)
    alpha = 0.35 + 0.2 * np.sin(0.3 * t)
    y = np.asarray(reference.fractional_integral(u, alpha, DT) @ np.array([1.5, -2.0]))
    y = y + 0.01 * np.random.default_rng(0).standard_normal(N)
    return u, y


def transcription(u, y, *, gamma, lam, alpha0, r0, rule, memory):
    """The law written out sample by sample from the paper's equations."""
    n = u.shape[1]
    orders = np.full(N, alpha0)  # orders[j] = α̂_j, the order used at sample j
    phis, dphis = np.zeros((N, n)), np.zeros((N, n))
    out = {k: [] for k in ("alpha", "p", "dp", "y_hat", "y_pred", "Lambda")}
    p_prev = np.zeros(n)
    alpha = alpha0
    for k in range(N):
        orders[k] = alpha
        # Φ(α̂_k, t_k): the order at the evaluation time; entries after k are not read
        opts = dict(rule=rule, memory=memory, order_range=BOUNDS)
        phis[k] = reference.fractional_integral(u, orders, DT, **opts)[k]
        dphis[k] = reference.order_sensitivity(u, orders, DT, **opts)[k]
        p = reference.lsff(phis[: k + 1], y[: k + 1], DT, lam, r0)[-1]
        dp = reference.lsff_sensitivity(phis[: k + 1], dphis[: k + 1], y[: k + 1], DT, lam, r0)[-1]
        y_hat = p @ phis[k]
        lam_k = p @ dphis[k] + dp @ phis[k]  # Λ_k, eq. (30)
        for key, v in zip(out, (alpha, p, dp, y_hat, p_prev @ phis[k], lam_k)):
            out[key].append(v)
        alpha = min(max(alpha + DT * gamma * lam_k * (y[k] - y_hat), BOUNDS[0]), BOUNDS[1])
        p_prev = p
    return {k: np.asarray(v) for k, v in out.items()}


@pytest.mark.parametrize("memory", ["direct", "exponential"])
@pytest.mark.parametrize("rule", ["trapezoid", "rectangle"])
def test_identify_equals_the_transcription_at_every_sample(rule, memory):
    u, y = _case()
    r0 = np.array([[2.0, 0.3], [0.3, 0.5]])
    settings = dict(gamma=40.0, lam=0.7, alpha0=0.3, r0=r0)
    want = transcription(u, y, rule=rule, memory=memory, **settings)
    got = vojax.identify(
        u, y, DT, x0=0.0, alpha_bounds=BOUNDS, rule=rule, memory=memory, warn=False, **settings, method="gradient"
    )
    # the gain drives α̂ onto a bound and off it again: the projection is exercised
    at_bound = (want["alpha"] <= BOUNDS[0] + 1e-12) | (want["alpha"] >= BOUNDS[1] - 1e-12)
    assert 0 < at_bound.sum() < N - 10
    for key, attr in (("alpha", "alpha"), ("p", "p"), ("dp", "dp"), ("y_hat", "y_hat"),
                      ("y_pred", "y_pred"), ("Lambda", "Lambda")):
        a, b = np.asarray(getattr(got, attr)), want[key]
        scale = max(np.max(np.abs(b)), 1e-300)
        assert np.max(np.abs(a - b)) <= 1e-10 * scale, (key, np.max(np.abs(a - b)) / scale)
