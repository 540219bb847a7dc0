"""The tracker and the bands: Kalman = dense batch posterior, accuracy with calibrated bands,
unit invariance, the law's band against Monte Carlo, no silent NaN."""

import functools

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import vojax
from vojax._tracker import Hyper, KalmanTracker, kalman_filter, rts_smoother
from vojax._tracker._fit import _scan_filter

from .helpers import make_problem


def _batch_posterior(h, z, r, q, m0, p0):
    """Dense Gaussian conditioning of the whole trajectory θ_0 … θ_{N−1} (written without any
    recursion): prior θ = m0 + L w with L the cumulative-sum map of the increments."""
    n, d = h.shape
    # θ_k = θ_0 + Σ_{j<k} w_j: covariance of the stacked trajectory
    cov = np.zeros((n * d, n * d))
    for i in range(n):
        for k in range(n):
            c = p0 + np.diag(q[: min(i, k)].sum(axis=0))
            cov[i * d : (i + 1) * d, k * d : (k + 1) * d] = c
    return _condition(h, z, r, np.tile(m0, n), cov)


def _condition(h, z, r, mean, cov):
    """Gaussian conditioning of the stacked trajectory (mean, cov) on ``z_k = h_k·θ_k + v_k``:
    the posterior means (N, d), the marginal covariances (N, d, d), the log-likelihood."""
    n, d = h.shape
    big_h = np.zeros((n, n * d))
    for k in range(n):
        big_h[k, k * d : (k + 1) * d] = h[k]
    s = big_h @ cov @ big_h.T + r * np.eye(n)
    gain = cov @ big_h.T @ np.linalg.inv(s)
    post_mean = mean + gain @ (z - big_h @ mean)
    post_cov = cov - gain @ big_h @ cov
    e = z - big_h @ mean
    _, logdet = np.linalg.slogdet(s)
    loglik = -0.5 * (n * np.log(2 * np.pi) + logdet + e @ np.linalg.solve(s, e))
    covs = np.stack([post_cov[k * d : (k + 1) * d, k * d : (k + 1) * d] for k in range(n)])
    return post_mean.reshape(n, d), covs, loglik


def test_kalman_and_rts_equal_the_dense_posterior():
    rng = np.random.default_rng(3)
    n, d = 25, 3
    h = rng.standard_normal((n, d))
    z = rng.standard_normal(n)
    q = np.abs(rng.standard_normal((n, d))) * 0.1
    q[:, -1] = 0.0  # a constant component, as the tracker's offset
    m0 = rng.standard_normal(d)
    a = rng.standard_normal((d, d))
    p0 = a @ a.T + np.eye(d)
    r = 0.3
    filt = kalman_filter(*(jnp.asarray(x) for x in (h, z, r, q, m0, p0)))
    ms, ps = rts_smoother(filt, jnp.asarray(q))
    means, covs, loglik = _batch_posterior(h, z, r, q, m0, p0)
    np.testing.assert_allclose(ms, means, rtol=0, atol=1e-11)
    np.testing.assert_allclose(ps, covs, rtol=0, atol=1e-11)
    # the innovation likelihood is the batch Gaussian likelihood of all the measurements
    assert float(filt.log_likelihood) == pytest.approx(loglik, rel=1e-12)
    # the filtered mean at k is the batch posterior given z_0 … z_k
    k = 11
    mk, _, _ = _batch_posterior(h[: k + 1], z[: k + 1], r, q[: k + 1], m0, p0)
    np.testing.assert_allclose(filt.mean[k], mk[-1], atol=1e-11)
    # a masked sample is skipped: the same as leaving it out of the record
    mask = np.ones(n)
    mask[5] = 0.0
    fm = kalman_filter(*(jnp.asarray(x) for x in (h, z, r, q, m0, p0, mask)))
    keep = np.arange(n) != 5
    q_drop = q.copy()
    q_drop[4] += q[5]  # the two steps around the dropped sample merge
    ref = kalman_filter(*(jnp.asarray(x) for x in (h[keep], z[keep], r, q_drop[keep], m0, p0)))
    np.testing.assert_allclose(fm.mean[-1], ref.mean[-1], atol=1e-11)
    assert float(fm.log_likelihood) == pytest.approx(float(ref.log_likelihood), rel=1e-12)


def _batch_posterior_ar(h, z, r, q, f, m0, p0):
    """`_batch_posterior` for ``θ_{k+1} = diag(f_k) θ_k + w_k``, from the stacked trajectory's
    moments written out: ``E θ_k = Π_{j<k} f_j · m0``, ``Cov θ_k = F P F + Q`` step by step,
    ``Cov(θ_k, θ_i) = Π_{i≤j<k} f_j · Cov θ_i`` for i ≤ k."""
    n, d = h.shape
    var, means = [p0], [m0]
    for k in range(n - 1):
        var.append(f[k][:, None] * var[-1] * f[k][None, :] + np.diag(q[k]))
        means.append(f[k] * means[-1])
    cov = np.zeros((n * d, n * d))
    for i in range(n):
        for k in range(i, n):
            c = np.prod(f[i:k], axis=0)[:, None] * var[i] if k > i else var[i]
            cov[k * d : (k + 1) * d, i * d : (i + 1) * d] = c
            cov[i * d : (i + 1) * d, k * d : (k + 1) * d] = c.T
    return _condition(h, z, r, np.concatenate(means), cov)


def test_kalman_and_rts_with_an_ar1_state_equal_the_dense_posterior():
    # the coloured-noise model: random-walk states and one AR(1) state (0 < f < 1)
    rng = np.random.default_rng(4)
    n, d = 20, 4
    h = rng.standard_normal((n, d))
    h[:, -1] = 1.0  # the noise state enters the measurement with weight one
    z = rng.standard_normal(n)
    q = np.abs(rng.standard_normal((n, d))) * 0.1
    f = np.ones((n, d))
    f[:, -1] = rng.uniform(0.5, 0.95, n)
    q[:, -1] = 0.7 * (1 - f[:, -1] ** 2)
    m0 = rng.standard_normal(d)
    a = rng.standard_normal((d, d))
    p0 = a @ a.T + np.eye(d)
    r = 0.2
    filt = kalman_filter(*(jnp.asarray(x) for x in (h, z, r, q, m0, p0)), f=jnp.asarray(f))
    ms, ps = rts_smoother(filt, jnp.asarray(q), jnp.asarray(f))
    means, covs, loglik = _batch_posterior_ar(h, z, r, q, f, m0, p0)
    np.testing.assert_allclose(ms, means, rtol=0, atol=1e-11)
    np.testing.assert_allclose(ps, covs, rtol=0, atol=1e-11)
    assert float(filt.log_likelihood) == pytest.approx(loglik, rel=1e-12)
    # with f = 1 the dense form is the random walk's
    ones = np.ones((n, d))
    np.testing.assert_allclose(
        _batch_posterior_ar(h, z, r, q, ones, m0, p0)[0], _batch_posterior(h, z, r, q, m0, p0)[0],
        atol=1e-11,
    )


def test_damped_pass_is_the_posterior_with_the_anchor_observed():
    """The Levenberg–Marquardt step of the smoother: the same dense conditioning with every
    state also observed at its anchor value with variance 1/μ (and no change of likelihood)."""
    rng = np.random.default_rng(4)
    n, d, mu = 12, 3, 0.7
    h = rng.standard_normal((n, d))
    z = rng.standard_normal(n)
    q = np.abs(rng.standard_normal((n, d))) * 0.1
    q[:, -1] = 0.0
    m0, p0, r = rng.standard_normal(d), 2.0 * np.eye(d), 0.3
    anchor = rng.standard_normal((n, d))
    filt = kalman_filter(*(jnp.asarray(x) for x in (h, z, r, q, m0, p0)), None, jnp.asarray(anchor), mu)
    ms, ps = rts_smoother(filt, jnp.asarray(q))
    # dense: append d identity rows per sample, measured as the anchor with variance 1/μ
    rows_h, rows_z = [], []
    for k in range(n):
        rows_h.append(np.eye(d))
        rows_z.append(anchor[k])
    big_h = np.zeros((n + n * d, n * d))
    big_z = np.concatenate([z, np.concatenate(rows_z)])
    for k in range(n):
        big_h[k, k * d : (k + 1) * d] = h[k]
        big_h[n + k * d : n + (k + 1) * d, k * d : (k + 1) * d] = np.eye(d)
    var = np.concatenate([np.full(n, r), np.full(n * d, 1.0 / mu)])
    cov = np.zeros((n * d, n * d))
    for i in range(n):
        for k in range(n):
            cov[i * d : (i + 1) * d, k * d : (k + 1) * d] = p0 + np.diag(q[: min(i, k)].sum(axis=0))
    s = big_h @ cov @ big_h.T + np.diag(var)
    gain = cov @ big_h.T @ np.linalg.inv(s)
    mean = np.tile(m0, n) + gain @ (big_z - big_h @ np.tile(m0, n))
    post = cov - gain @ big_h @ cov
    np.testing.assert_allclose(ms, mean.reshape(n, d), atol=1e-11)
    np.testing.assert_allclose(ps[3], post[3 * d : 4 * d, 3 * d : 4 * d], atol=1e-11)
    # the innovations are those of the real measurements: with μ → 0 the plain filter's
    plain = kalman_filter(*(jnp.asarray(x) for x in (h, z, r, q, m0, p0)))
    tiny = kalman_filter(*(jnp.asarray(x) for x in (h, z, r, q, m0, p0)), None, jnp.asarray(anchor), 1e-12)
    assert float(tiny.log_likelihood) == pytest.approx(float(plain.log_likelihood), rel=1e-9)


def test_damping_follows_nielsens_rule():
    """The Levenberg–Marquardt damping after a step, by hand: ρ = achieved / predicted
    decrease; accepted: μ × max(1/3, 1 − (2ρ − 1)³), ν = 2; rejected: μ × ν, ν × 2."""
    from vojax._tracker._smoother import MU_MIN, damping

    def step(mu, nu, ok, value, new, predicted):
        out = damping(*(jnp.asarray(v) for v in (mu, nu, ok, value, new, predicted)))
        return tuple(float(v) for v in out)

    assert step(0.3, 8.0, True, 10.0, 9.0, 9.0) == pytest.approx((0.1, 2.0))  # ρ = 1: ÷3
    assert step(0.3, 8.0, True, 10.0, 7.0, 9.0) == pytest.approx((0.1, 2.0))  # ρ = 3: ÷3
    assert step(0.3, 8.0, True, 10.0, 9.5, 9.0) == pytest.approx((0.3, 2.0))  # ρ = ½: ×1
    assert step(0.3, 8.0, True, 10.0, 9.25, 9.0) == pytest.approx((0.3 * 0.875, 2.0))  # ρ = ¾
    assert step(0.3, 8.0, True, 10.0, 10.0, 9.0) == pytest.approx((0.6, 2.0))  # ρ = 0: ×2
    assert step(0.3, 8.0, False, 10.0, 12.0, 9.0) == pytest.approx((2.4, 16.0))  # rejected
    assert step(0.3, 8.0, True, 10.0, 10.0, 10.0) == pytest.approx((0.1, 2.0))  # none predicted
    assert step(MU_MIN, 2.0, True, 10.0, 9.0, 9.0) == pytest.approx((MU_MIN, 2.0))  # floor


def test_a_batch_of_runs_keeps_the_best_by_evidence_and_by_objective(monkeypatch):
    """`smoother_batch` keeps the run of highest evidence among those that converged to a
    finite mode (the first of equal ones), and the index of the lowest objective of any run:
    here run 2 (evidence 5) over run 1 (3) and run 3 (9, not converged), run 3 by
    objective; the scores of the runs that do not qualify are −∞."""
    from typing import NamedTuple

    from vojax._tracker import _smoother

    class Run(NamedTuple):
        log_likelihood: float
        objective: float
        converged: bool
        iterations: int

    runs = [Run(np.nan, 10.0, True, 4), Run(3.0, 8.0, True, 5), Run(5.0, 7.0, True, 6),
            Run(9.0, 1.0, False, 7), Run(5.0, 9.0, True, 8)]
    monkeypatch.setattr(_smoother, "_runs", lambda *a, **k: iter(runs))
    best, i_best, i_alt, scores, iterations, alts = _smoother.smoother_batch(
        *([None] * 12))
    assert (i_best, i_alt) == (2, 3) and float(best.log_likelihood) == 5.0
    np.testing.assert_array_equal(scores, [-np.inf, 3.0, 5.0, -np.inf, 5.0])
    np.testing.assert_array_equal(iterations, [4, 5, 6, 7, 8])
    np.testing.assert_array_equal(alts, [-10.0, -8.0, -7.0, -1.0, -9.0])


def test_tune_tries_each_noise_level_then_the_full_budget(monkeypatch):
    """The first pass of `tune`: every start × order drift at each noise level of `noises`
    in turn with `grid_max_iter` iterations while none converges, then at each level again
    with `max_iter`; it stops at the first pass where a run converges and climbs from that
    run's intensities."""
    from types import SimpleNamespace

    from vojax._tracker import _tuning

    s = vojax.TrackerSettings()
    seen = []

    converges = {(0.01, s.max_iter)}  # the passes at which a run converges

    def batch(problem, rows, first, budget):
        seen.append((rows[0][2], budget))
        converged = (rows[0][2], budget) in converges
        scores = np.full(len(rows), 1.0 if converged else -np.inf)
        return "smoothed", 1 if converged else -1, 0, scores

    monkeypatch.setattr(_tuning, "run_batch_shares", batch)
    # the climb as it returns: (Hyper, Smoothed, Tuning), here not collapsed (no second climb)
    tuning = _tuning.Tuning(s.grid_order[1], s.constant_drift, 0.01, (), 0.0, True)
    monkeypatch.setattr(_tuning, "climb",
                        lambda problem, limits, hyper, sm, rounds: (hyper, sm, tuning))
    problem = SimpleNamespace(settings=s)
    hyper, sm, _ = _tuning.tune(problem, np.zeros((2, 3)), (0.01, 0.5), 1e-6)
    assert seen == [(0.01, s.grid_max_iter), (0.5, s.grid_max_iter), (0.01, s.max_iter)]
    assert sm == "smoothed"
    np.testing.assert_allclose(np.exp(float(hyper.log_q_order)), s.grid_order[1], rtol=1e-12)
    np.testing.assert_allclose(np.exp(float(hyper.log_r)), 0.01, rtol=1e-12)
    # a level whose runs converge only with the full budget is tried with it too
    seen.clear()
    converges = {(0.5, s.max_iter)}
    hyper, sm, _ = _tuning.tune(problem, np.zeros((2, 3)), (0.01, 0.5), 1e-6)
    assert seen == [(0.01, s.grid_max_iter), (0.5, s.grid_max_iter), (0.01, s.max_iter),
                    (0.5, s.max_iter)]
    np.testing.assert_allclose(np.exp(float(hyper.log_r)), 0.5, rtol=1e-12)


def test_only_a_barely_damped_step_can_end_the_iteration():
    """The convergence test reads the relative decrease of an accepted step taken at the
    starting damping or below; a heavily damped step's small decrease (damping raised
    after rejections, far from the minimum) must not end the iteration, and a rejected step
    leaves what was read before."""
    from vojax._tracker._smoother import MU_START, REL_TOL, progress

    def read(ok, mu, value, new, rel=0.5):
        return float(progress(*(jnp.asarray(v) for v in (ok, mu, value, new, rel))))

    assert read(True, MU_START, 1000.0, 999.99) == pytest.approx(0.01 / 999.99)
    assert read(True, 0.1 * MU_START, 0.5, 0.25) == pytest.approx(0.25)  # ÷ max(|v|, 1)
    tiny = read(True, 1e3 * MU_START, 1000.0, 1000.0 - 1e-9)  # damped hard: keeps going
    assert tiny == np.inf and read(True, MU_START, 1000.0, 1000.0 - 1e-9) <= REL_TOL
    assert read(False, MU_START, 1000.0, 1200.0) == 0.5  # rejected: unchanged


@pytest.mark.parametrize("coloured", [False, True])
def test_damped_step_minimises_the_linearised_posterior_it_predicts(coloured):
    """The cost the damping rule compares with (`posterior_cost` of the model linearised at
    θ) equals the posterior's `objective` at θ itself, and the damped pass's step minimises
    it plus μ‖x − θ‖²: the autodiff gradient of that sum vanishes at the step (summed over
    time for the offset, which is one constant)."""
    import jax

    from vojax._integral import make_memory, order_map
    from vojax._tracker._model import objective, posterior_cost
    from vojax._tracker._smoother import _linear_pass, _regressors

    rng = np.random.default_rng(8)
    n, dt, bounds, mu = 30, 0.1, (0.01, 0.99), 0.05
    t = np.arange(n) * dt
    u = jnp.asarray(np.stack([np.sin(t) + 1.2, np.cos(0.7 * t)], axis=1))
    y = jnp.asarray(rng.standard_normal(n))
    values = (0.5, 1e-2, 1e-2, 1e-2, 0.3) if coloured else (0.5, 1e-2, 1e-2)
    hyper = Hyper(*(jnp.log(jnp.asarray(v)) for v in values))
    steps, horizon = jnp.full((n,), dt), jnp.asarray((n - 1) * dt)
    q, f = hyper.process(steps, horizon, 2), hyper.transition(steps, horizon, 2)
    d = 5 if coloured else 4
    m0 = jnp.asarray(rng.standard_normal(d))
    p0 = hyper.initial(jnp.asarray(np.diag(rng.uniform(1.0, 3.0, d))))
    p0_inv, r = jnp.linalg.inv(p0), hyper.r
    theta = rng.standard_normal((n, d)) * 0.3
    theta[:, 3] = 0.4  # the offset: one constant
    theta = jnp.asarray(theta)
    mask = jnp.asarray((rng.uniform(size=n) > 0.2).astype(float))
    evaluate = order_map(make_memory("direct", dt, n, order_range=bounds), u)
    phi, dphi = _regressors(evaluate, theta, bounds)
    _, (ms, _), jac, z = _linear_pass(theta, phi, dphi, y, mask, r, q, f, m0, p0, bounds, mu)

    def linear(x):
        return posterior_cost(x, z - jnp.sum(jac * x, -1), mask, r, q, m0, p0_inv, f)

    exact = objective(theta, phi, y, mask, r, q, m0, p0_inv, f)
    assert float(linear(theta)) == pytest.approx(float(exact), rel=1e-12)
    grad = np.asarray(jax.grad(lambda x: linear(x) + mu * jnp.sum((x - theta) ** 2))(ms))
    scale = np.abs(np.asarray(jax.grad(linear)(theta))).max()
    free = [c for c in range(d) if c != 3]
    assert np.abs(grad[:, free]).max() < 1e-9 * scale
    assert abs(grad[:, 3].sum()) < 1e-9 * scale
    assert float(linear(ms)) < float(exact)  # a decrease is predicted


def _ramp_case(n=1500, dt=0.1, noise=0.02, seed=0):
    t = np.arange(n) * dt
    u = np.stack([np.sin(0.5 * t) + 0.3, np.cos(0.2 * t)], axis=1)
    alpha = 0.3 + 0.4 * t / t[-1]
    p = np.array([2.0, -1.5])
    x = np.asarray(vojax.simulate(u, alpha, p, dt)) + 0.7
    y = x + noise * np.std(x) * np.random.default_rng(seed).standard_normal(n)
    return t, u, y, alpha, p, dt


def _normalised(case, num, columns=None, settings=None):
    """The tracker's problem for the first `num` samples of a `_ramp_case` (its first
    `columns` inputs, or all), its input and output normalised (the constant fit's rescaling
    left out) and the constant starts: ``(Problem, starts)``."""
    from vojax._integral import make_memory
    from vojax._tracker._problem import data_scales
    from vojax._tracker._start import starting_trajectories

    t, u, y, *_, dt = case
    u, y = jnp.asarray(u[:num, :columns]), jnp.asarray(y[:num])
    memory = make_memory("exponential", dt, num, order_range=(0.01, 0.99))
    scales = data_scales(u, y, jnp.ones(num))
    un = u / jnp.asarray(scales.u_scale)
    yn = (y - scales.y_ref) / scales.y_scale
    problem = make_problem(memory, un, yn, dt=dt, settings=settings)
    return problem, np.asarray(starting_trajectories(problem, 0.5))


@pytest.fixture(scope="module")
def ramp():
    return _ramp_case()


@pytest.fixture(scope="module")
def smoothed(ramp):
    t, u, y, *_, dt = ramp
    return vojax.identify(u, y, dt, method="kalman")


@pytest.mark.slow
def test_smoother_tracks_a_ramp_with_calibrated_bands(ramp):
    """The ramp's parameters are constant in seconds: the tracker is told so
    (``time_scale=1``); on the span's clock, the default, they drift as 150^(−α(t))."""
    t, u, y, alpha, p, dt = ramp
    res = vojax.identify(u, y, dt, method="kalman", time_scale=1.0)
    err = np.asarray(res.alpha) - alpha
    second = t > t[-1] / 2
    assert np.sqrt(np.mean(err[second] ** 2)) < 0.004
    assert np.sqrt(np.mean(err**2)) < 0.015
    inside = (alpha >= np.asarray(res.alpha_lower)) & (alpha <= np.asarray(res.alpha_upper))
    assert 0.8 <= inside.mean() <= 1.0
    # constant truth: the parameters and the offset lie within 3 standard deviations
    z = (np.asarray(res.p[-1]) - p) / np.asarray(res.p_std[-1])
    assert np.all(np.abs(z) < 3), z
    assert abs(float(res.x0) - 0.7) < 3 * float(res.x0_std)
    assert res.diagnostics.converged and res.diagnostics.identified
    assert res.dp is None and res.method == "kalman"


@pytest.fixture(scope="module")
def noise_seeds():
    """40 noise realisations of one record whose truth comes from `vojax.reference` (direct
    sums on a grid twice as fine, no JAX kernel), two inputs, the default tracker: the
    coverage of the ±2σ band over all samples and the RMS of the errors in units of σ."""
    from vojax import reference

    n, dt = 300, 0.05
    t = np.arange(n) * dt
    u = np.stack([np.sin(0.9 * t) + 0.5 * np.cos(2.3 * t) + 0.4, np.cos(0.3 * t)], axis=1)
    alpha = 0.35 + 0.25 * t / t[-1]
    p = np.array([1.5, -1.0])
    fine = np.arange(2 * n - 1) * dt / 2
    af = np.interp(fine, t, alpha)
    x = 0.3 + sum(
        p[j] * np.asarray(reference.fractional_integral(np.interp(fine, t, u[:, j]), af, dt / 2))[::2]
        for j in range(2)
    )
    inside, z = [], []
    for seed in range(40):
        y = x + 0.03 * np.std(x) * np.random.default_rng(seed).standard_normal(n)
        res = vojax.identify(u, y, dt, method="kalman", warn=False)
        lo, hi = np.asarray(res.alpha_lower), np.asarray(res.alpha_upper)
        inside.append((alpha >= lo) & (alpha <= hi))
        z.append((np.asarray(res.alpha) - alpha) / np.asarray(res.alpha_std))
    return np.mean(inside), np.sqrt(np.mean(np.square(z)))


@pytest.mark.slow
def test_smoother_bands_are_not_overconfident_over_noise_seeds(noise_seeds):
    """Over the 40 realisations the ±2σ band covers the true order at ≥ 80 % of all samples,
    and the errors in units of the reported σ have an RMS ≤ 1.4."""
    coverage, z_rms = noise_seeds
    assert coverage >= 0.8 and z_rms <= 1.4, (coverage, z_rms)


@pytest.mark.slow
def test_smoother_bands_are_not_wider_than_calibrated_over_noise_seeds(noise_seeds):
    """A calibrated ±2σ band covers at most 99 % of the samples, with a z RMS of at least 0.7."""
    coverage, z_rms = noise_seeds
    assert coverage <= 0.99 and z_rms >= 0.7, (coverage, z_rms)


def test_filter_scan_equals_streaming_by_hand(ramp):
    t, u, y, *_ = ramp
    n = 60
    mem = vojax.ExponentialMemory.design(0.1, n, order_range=(0.01, 0.99))
    hyper = Hyper(*(jnp.log(jnp.asarray(v)) for v in (0.1, 1e-4, 1e-3)))
    m0 = jnp.asarray([0.0, 1.0, -1.0, 0.5])
    tracker = KalmanTracker(mem, hyper, jnp.asarray(6.0), m0, 4.0 * jnp.eye(4), (0.01, 0.99), 3)
    un, yn = jnp.asarray(u[:n]), jnp.asarray((y[:n] - y.mean()) / y.std())
    steps = jnp.full((n,), 0.1)
    out = _scan_filter(tracker, un, yn, steps, jnp.ones(n))
    state, step = tracker.init(2), eqx.filter_jit(tracker.step)
    for k in range(n):
        state, o = step(state, un[k], yn[k], steps[k], 1.0)
    np.testing.assert_allclose(out.mean[-1], o.mean, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(out.cov[-1], o.cov, rtol=1e-12, atol=1e-14)


@pytest.mark.slow
@pytest.mark.parametrize("method", ["gradient", "kalman"])
def test_automatic_settings_are_unit_free(ramp, smoothed, method):
    t, u, y, *_, dt = ramp
    a = smoothed if method == "kalman" else vojax.identify(u, y, dt, method="gradient")
    for cu, cy in ((1e3, 1e-3), (1e-3, 1e3)):
        b = vojax.identify(u * cu, y * cy, dt, method=method)
        assert np.max(np.abs(np.asarray(b.alpha) - np.asarray(a.alpha))) < 1e-6
        np.testing.assert_allclose(np.asarray(b.p)[5:], np.asarray(a.p)[5:] * cy / cu, rtol=1e-6)
        np.testing.assert_allclose(b.alpha_std, a.alpha_std, rtol=1e-5, atol=1e-9)
    # numbers the user gives are literal: the same gains in other units give another answer
    c = vojax.identify(u, y, dt, gamma=0.01, lam=0.9, method="gradient")
    d = vojax.identify(u * 1e3, y, dt, gamma=0.01, lam=0.9, method="gradient", r0=np.eye(2))
    e = vojax.identify(u, y, dt, gamma=0.01, lam=0.9, method="gradient", r0=np.eye(2))
    assert np.max(np.abs(np.asarray(d.alpha) - np.asarray(e.alpha))) > 1e-3
    assert np.max(np.abs(np.asarray(c.alpha) - np.asarray(e.alpha))) > 0  # R0 = auto ≠ I


@pytest.mark.slow
def test_law_band_matches_monte_carlo():
    """The law's alpha_std against the spread of α̂ over 30 noise realisations."""
    t, u, _, alpha, p, dt = _ramp_case()
    x = np.asarray(vojax.simulate(u, alpha, p, dt))
    sd = 0.05 * np.std(x)
    alphas, stds = [], []
    for seed in range(30):
        y = x + sd * np.random.default_rng(100 + seed).standard_normal(x.shape)
        res = vojax.identify(u, y, dt, gamma=0.01, lam=0.9, x0=0.0, method="gradient")
        alphas.append(np.asarray(res.alpha))
        stds.append(np.asarray(res.alpha_std))
    half = slice(t.size // 2, None)
    ratio = np.median(np.std(alphas, axis=0)[half] / np.mean(stds, axis=0)[half])
    assert 0.7 <= ratio <= 1.4, ratio


def test_noise_variance_estimate():
    from vojax._stats import noise_variance

    t = np.linspace(0, 10, 4000)
    y = np.sin(t) + 0.3 * np.random.default_rng(0).standard_normal(t.size)
    assert noise_variance(y) == pytest.approx(0.09, rel=0.08)


def test_no_silent_nan():
    t = np.arange(400) * 60.0
    u = np.stack([np.sin(1e-4 * t) + 1.0, np.cos(2e-4 * t)], axis=1)  # two slow inputs
    y = np.asarray(vojax.simulate(u, 0.5, np.array([1.0, 0.5]), 60.0))
    with pytest.raises(ValueError, match="diverged at sample"):
        vojax.identify(u, y, 60.0, gamma=0.01, lam=0.9, r0=np.eye(2), method="gradient")
    # the automatic prior scales with the inputs: no breakdown at any input scale
    for scale in (1.0, 1e11, 1e-11):
        res = vojax.identify(u * scale, y, 1.0, gamma=0.01, lam=0.01, method="gradient")
        assert np.all(np.isfinite(res.alpha)) and np.all(np.isfinite(res.p))


@pytest.mark.slow
def test_wide_band_warns():
    t, u, y, *_ = _ramp_case(n=60, noise=0.5, seed=1)
    with pytest.warns(vojax.IdentifiabilityWarning, match=r"the order band is ±0\.\d+ wide"):
        res = vojax.identify(u[:, :1], y, 0.1, method="kalman")
    assert not res.diagnostics.identified
    assert res.diagnostics.band_halfwidth > 0.1


@pytest.mark.parametrize(
    "kwargs, match",
    [
        (dict(method="ekf"), "`method` must be one of"),
        (dict(method="kalman", noise=dict(order_drift=1.0)), "`noise` must be a dict"),
        (dict(method="gradient", lam="auto"), "`lam` must be a positive number or None"),
        (dict(method="gradient", r0="eye"), "`r0` must be 'auto'"),
        # the law's settings with the tracker (the default) are an error, never ignored
        (dict(gamma=0.01, lam=0.9), "`gamma`, `lam` set the paper's law"),
        (dict(alpha0=0.4), "add method='gradient'"),
        (dict(method="gradient", noise=dict(noise_std=0.1)), "`noise` sets the tracker"),
        (dict(method="gradient", smooth=False), "`smooth=False` sets the tracker"),
        (dict(parameters="fixed"), "`parameters` must be 'free', 'constant' or the largest"),
        (dict(parameters=-0.1), "`parameters` as a drift bound must be a finite number ≥ 0"),
        (dict(parameters=np.inf), "`parameters` as a drift bound must be a finite number ≥ 0"),
        (dict(method="gradient", parameters="constant"), "`parameters` sets the tracker"),
        (dict(parameters="constant",
              noise=dict(order_drift=1.0, parameter_drift=1.0, noise_std=0.1)), "not both"),
        (dict(time_scale=-1.0), "`time_scale` must be a positive finite number, got -1.0"),
        (dict(time_scale=np.nan), "`time_scale` must be a positive finite number, got nan"),
        (dict(time_scale=[1.0, 2.0]), r"`time_scale` must be a scalar, got shape \(2,\)"),
        (dict(method="gradient", time_scale=1.0), "`time_scale` sets the tracker"),
        (dict(method="gradient", settings=vojax.TrackerSettings()),
         "`settings` sets the tracker"),
        (dict(settings="fast"), "`settings` must be a vojax.TrackerSettings, got 'fast'"),
    ],
)
def test_identify_kalman_validation(ramp, kwargs, match):
    t, u, y, *_, dt = ramp
    error = TypeError if isinstance(kwargs.get("settings"), str) else ValueError
    with pytest.raises(error, match=match):
        vojax.identify(u, y, dt, **kwargs)


def test_an_intensity_is_at_the_edge_of_the_box_searched_not_of_the_full_box():
    """Within 5 % of the searched box's width (logs) of an end: the noise's box starts at its
    floor, so a noise 1.5x the floor is at the edge and one 2x the floor is not (5 % of the full
    box, 1e-10 to 2, would be a factor 3.3 and flag both); a drift at its lower end is named
    as such, a held coordinate (a box of zero width) never."""
    from vojax._tracker._tuning import at_edges, box

    settings = vojax.TrackerSettings()
    floor = 1e-4
    limits = box(settings, floor, hold=True)
    x = lambda noise, order=0.0: (order, np.log(1e-6), np.log(noise))  # noqa: E731
    assert at_edges(x(1.5 * floor), limits, settings.edge) == ("noise",)
    assert at_edges(x(2.0 * floor), limits, settings.edge) == ()
    assert at_edges(x(1.9), limits, settings.edge) == ("noise",)
    low, high = np.log(settings.order_drift_range)
    assert at_edges(x(1e-2, low + 0.01), limits, settings.edge) == ("order_drift (lower edge)",)
    assert at_edges(x(1e-2, high - 0.01), limits, settings.edge) == ("order_drift",)


def test_constant_output_is_refused(ramp):
    """An output that never changes, over the record or over its fitted samples (the rest
    masked), is refused: there is nothing to identify."""
    t, u, y, *_, dt = ramp
    with pytest.raises(ValueError, match="`y` is 1 at every sample: there is no response"):
        vojax.identify(u, np.ones_like(y), dt, method="kalman")
    flat = np.ones_like(y)
    flat[-5:] = 2.0
    mask = np.r_[np.ones(y.size - 5), np.zeros(5)]
    with pytest.raises(ValueError, match="`y` is constant over the fitted samples"):
        vojax.identify(u, flat, dt, method="kalman", mask=mask)


def test_diagnostics_refuse_unconverged_or_noise_at_its_floor():
    from vojax._diagnostics import diagnose

    alpha = np.full(100, 0.4)
    lo, hi = alpha - 0.01, alpha + 0.01
    ok = diagnose(alpha, lo, hi, (0.01, 0.99), True, ())
    assert ok.identified and ok.message == "" and ok.band_halfwidth == pytest.approx(0.01)
    for converged, edge, text in (
        (False, (), "did not converge"),
        (True, ("noise",), "the band is not a statement about the data"),
    ):
        d = diagnose(alpha, lo, hi, (0.01, 0.99), converged, edge)
        assert not d.identified and text in d.message
    drift = diagnose(alpha, lo, hi, (0.01, 0.99), True, ("order_drift",))
    assert drift.identified and "order_drift at the upper edge" in drift.message
    # a drift at its lower edge (none found) is a finding: no message, nothing refused
    still = diagnose(alpha, lo, hi, (0.01, 0.99), True, ("parameter_drift (lower edge)",))
    assert still.identified and still.message == ""
    gains = diagnose(alpha, lo, hi, (0.01, 0.99), True, ("gamma",))
    assert "gamma at the edge of the search box. Next: (1) give the gains" in gains.message
    wide = diagnose(alpha, alpha - 0.3, alpha + 0.3, (0.01, 0.99), True, ())
    assert not wide.identified and "±0.3 wide" in wide.message
    stuck = diagnose(np.full(100, 0.99), lo, hi, (0.01, 0.99), True, ())
    assert not stuck.identified and "bound" in stuck.message
    # the order with the drifting parameters held: refused when it moves by more than the band
    traded = diagnose(alpha, lo, hi, (0.01, 0.99), True, (), held_shift=0.02)
    assert not traded.identified and "moves by 0.02, more than its band (±0.01)" in traded.message
    assert diagnose(alpha, lo, hi, (0.01, 0.99), True, (), held_shift=0.005).identified


def test_order_traded_against_drifting_parameters_is_refused():
    """The shipped adhesive staircase (a controlled, noise-free strain): the tracker's best
    mode lets η drift (27 % over the record), and its order then sits 0.15 from the order a
    separate smoothing with η held (through `noise=`) gives, far outside its ±0.03 band. The
    verdict must not be "identified", free or with the parameters stated constant, and it
    must give a typed reason. The band's own held smoothing (its order drift chosen by
    evidence) fits and is the answer's reference, with the drifting mode outside its band:
    the breakdown drift is that mode's 27 %."""
    from vojax._integral import make_memory
    from vojax._tracker._problem import data_scales
    from vojax._tracker._start import constant_fit

    PARAM_DRIFT0 = vojax.TrackerSettings().constant_drift

    (rec,) = vojax.load_records(vojax.io.example_file("adhesive"), time="time_s",
                                inputs=["nominal_shear_stress_kPa"], output="shear_strain")
    res = vojax.identify(rec.inputs, rec.output, **rec.grid, method="kalman", warn=False)
    d = res.diagnostics
    assert d.verdict == "not identified" and d.reasons
    assert d.reference_drift < 0.01 and 0.2 < d.breakdown_drift < 0.35
    # the same held smoothing, asked for by hand: tuned order drift, parameters held, the
    # noise at the constant fit's misfit (the tracker's normalised units, back in strain)
    scales = data_scales(rec.inputs, rec.output, np.ones(rec.time.size))
    memory = make_memory("exponential", None, rec.time.size, order_range=(0.01, 0.99),
                         times=rec.time)
    yn = (rec.output - scales.y_ref) / scales.y_scale
    un = rec.inputs / np.asarray(scales.u_scale)
    _, _, rss, _ = constant_fit(memory, un, yn, np.ones(rec.time.size), (0.01, 0.99),
                                vojax.TrackerSettings())
    noise = {"order_drift": res.tuning.order_drift, "parameter_drift": PARAM_DRIFT0,
             "noise_std": float(np.sqrt(rss / (rec.time.size - 3)) * scales.y_scale)}
    held = vojax.identify(rec.inputs, rec.output, **rec.grid, method="kalman", noise=noise,
                          warn=False)
    half = rec.time.size // 2
    shift = float(np.median(np.abs(np.asarray(held.alpha) - np.asarray(res.alpha))[half:]))
    assert shift > 2 * d.band_halfwidth  # why the band alone would be confidently wrong
    stated = vojax.identify(rec.inputs, rec.output, **rec.grid, parameters="constant",
                            warn=False)
    assert stated.diagnostics.verdict == "not identified" and stated.diagnostics.reasons


@pytest.mark.slow
def test_padding_with_a_mask_changes_nothing_and_reuses_the_program():
    """A record padded after its end and masked gives the unpadded record's results (to the
    smoother's convergence tolerance, 1e-9 relative in the objective); two records of
    different lengths padded to one bucket length trace the smoother once."""
    from vojax._data._pipeline import _padded, bucket_length
    from vojax._tracker._smoother import TRACES

    t, u, y, *_ = _ramp_case(n=150, dt=0.1, noise=0.02, seed=3)
    a = vojax.identify(u, y, 0.1, method="kalman", warn=False)
    b = _padded(vojax.identify, u, y, 192, dt=0.1, method="kalman", warn=False)
    assert b.alpha.shape == (150,) and b.p.shape == (150, 2)
    for name in ("alpha", "p", "p_std", "y_hat", "y_pred"):
        np.testing.assert_allclose(getattr(b, name), getattr(a, name), rtol=1e-7, atol=1e-8)
    assert float(b.x0) == pytest.approx(float(a.x0), rel=1e-8)
    # the order's band is the union of the alternatives' bands that fit, and the modes of
    # the alternatives at a high order drift lie along flat directions of their objectives:
    # the smoother's tolerance (1e-9 in the objective) leaves them 1e-3 apart
    np.testing.assert_allclose(b.alpha_std, a.alpha_std, rtol=3e-3)
    assert b.diagnostics.band_halfwidth == pytest.approx(a.diagnostics.band_halfwidth, rel=3e-3)
    before = TRACES["smoother"]
    t2, u2, y2, *_ = _ramp_case(n=170, dt=0.1, noise=0.02, seed=4)
    _padded(vojax.identify, u2, y2, 192, dt=0.1, method="kalman", warn=False)
    assert TRACES["smoother"] == before
    assert [bucket_length(n) for n in (3, 28, 29, 150, 160, 161, 1000)] == [4, 32, 32, 192, 192, 192, 1024]
    with pytest.raises(ValueError, match="`mask` must hold only 0"):
        vojax.identify(u, y, 0.1, method="kalman", mask=np.full(150, 0.5))
    with pytest.raises(ValueError, match="`mask` is for method='kalman'"):
        vojax.identify(u, y, 0.1, mask=np.ones(150), method="gradient")


@pytest.mark.parametrize("coloured", [False, True])
def test_smoother_mode_and_bands_against_a_dense_numpy_posterior(coloured):
    """The iterated smoother's answer checked from outside: with φ and ∂φ/∂β from
    `vojax.reference` (direct sums by hand) at the returned orders, the gradient of the negative
    log posterior vanishes at the returned trajectory (a mode), and the returned covariances are
    the diagonal blocks of the inverse Gauss–Newton Hessian of that posterior, built densely.
    `coloured`: with the coloured noise's AR(1) state e (increments e_{k+1} − a e_k of
    variance s(1 − a²), e_0 of variance s) added to the prediction."""
    from vojax import reference
    from vojax._integral import make_memory
    from vojax._tracker._smoother import iterated_smoother

    n, dt, bounds = 40, 0.1, (0.01, 0.99)
    lo, hi = bounds
    t = np.arange(n) * dt
    u = (np.sin(1.1 * t) + 0.6)[:, None]
    truth = 0.3 + 0.3 * t / t[-1]
    y = 1.2 * np.asarray(reference.fractional_integral(u[:, 0], truth, dt)) - 0.2
    rng = np.random.default_rng(5)
    y = y + 0.01 * rng.standard_normal(n)
    qo, qp, r = 1.0, 1e-3, 1e-4
    s_ar, tau = 2e-4, 0.08  # the AR(1) part: variance, correlation time / span
    horizon = (n - 1) * dt
    a = np.exp(-dt / (tau * horizon))
    if coloured:  # and the data's noise with such a part
        ar = np.zeros(n)
        for k in range(1, n):
            ar[k] = a * ar[k - 1] + np.sqrt(s_ar * (1 - a * a)) * rng.standard_normal()
        y = y + ar
    values = (qo, qp, r, s_ar, tau) if coloured else (qo, qp, r)
    hyper = Hyper(*(jnp.log(jnp.asarray(v)) for v in values))
    m0 = np.array([0.0, 1.0, 0.0] + [0.0] * coloured)
    p0 = np.diag([4.0, 100.0, 100.0] + [1.0] * coloured)  # e_0's variance set by the hyper
    nominal = jnp.tile(jnp.asarray(m0), (n, 1))
    mem = make_memory("direct", dt, n, order_range=bounds)
    sm = iterated_smoother(
        mem, jnp.asarray(u), jnp.asarray(y), jnp.ones(n), jnp.full((n,), dt), jnp.asarray(horizon),
        hyper, jnp.asarray(m0), jnp.asarray(p0), nominal, bounds, 400,
    )
    assert bool(sm.converged)
    theta = np.asarray(sm.theta)
    beta, p, c = theta[:, 0], theta[:, 1], theta[0, 2]
    assert np.allclose(theta[:, 2], c, rtol=0, atol=1e-12)  # the offset is one constant
    e = theta[:, 3] if coloured else np.zeros(n)
    s = 1 / (1 + np.exp(-beta))
    alpha, dadb = lo + (hi - lo) * s, (hi - lo) * s * (1 - s)
    phi = np.asarray(reference.fractional_integral(u[:, 0], alpha, dt))
    dphi = np.asarray(reference.order_sensitivity(u[:, 0], alpha, dt))
    res = y - c - p * phi - e
    # unknowns x = [β_0…β_{N−1}, p_0…p_{N−1}, c, (e_0…e_{N−1})]; J = ∂(prediction)/∂x,
    # D = increments, each with its weight w
    ne = n if coloured else 0
    dim = 2 * n + 1 + ne
    jac = np.zeros((n, dim))
    jac[np.arange(n), np.arange(n)] = p * dphi * dadb
    jac[np.arange(n), n + np.arange(n)] = phi
    jac[:, 2 * n] = 1.0
    jac[np.arange(ne), 2 * n + 1 + np.arange(ne)] = 1.0
    rows = 2 * (n - 1) + (n - 1) * coloured
    diff, w = np.zeros((rows, dim)), np.zeros(rows)
    for k in range(n - 1):
        diff[k, k], diff[k, k + 1], w[k] = -1.0, 1.0, 1 / (qo * dt / horizon)
        j = n - 1 + k
        diff[j, n + k], diff[j, n + k + 1], w[j] = -1.0, 1.0, 1 / (qp * dt / horizon)
        if coloured:
            j = 2 * (n - 1) + k
            diff[j, 2 * n + 1 + k], diff[j, 2 * n + 2 + k] = -a, 1.0
            w[j] = 1 / (s_ar * (1 - a * a))
    sel = np.zeros((len(m0), dim))
    sel[0, 0], sel[1, n], sel[2, 2 * n] = 1.0, 1.0, 1.0
    p0_used = p0.copy()
    if coloured:
        sel[3, 2 * n + 1] = 1.0
        p0_used[3, 3] = s_ar
    x = np.concatenate([beta, p, [c], e[:ne]])
    p0_inv = np.linalg.inv(p0_used)
    # half the gradient of the objective (data misfit / r + increments / q + prior)
    grad = -jac.T @ res / r + diff.T @ (w * (diff @ x)) + sel.T @ p0_inv @ (sel @ x - m0)
    scale = np.abs(jac.T @ res / r).max() + np.abs(diff.T @ (w * (diff @ x))).max()
    assert np.max(np.abs(grad)) < 1e-6 * scale, np.max(np.abs(grad)) / scale
    hess = jac.T @ jac / r + diff.T @ (w[:, None] * diff) + sel.T @ p0_inv @ sel
    cov = np.linalg.inv(hess)
    got = np.asarray(sm.cov)
    np.testing.assert_allclose(got[:, 0, 0], np.diag(cov)[:n], rtol=1e-6)
    np.testing.assert_allclose(got[:, 1, 1], np.diag(cov)[n : 2 * n], rtol=1e-6)
    np.testing.assert_allclose(got[:, 0, 1], cov[np.arange(n), n + np.arange(n)], rtol=1e-6, atol=1e-12)
    np.testing.assert_allclose(got[:, 2, 2], cov[2 * n, 2 * n], rtol=1e-6)
    if coloured:
        np.testing.assert_allclose(got[:, 3, 3], np.diag(cov)[2 * n + 1 :], rtol=1e-6)


def test_online_filter_against_a_textbook_iterated_ekf():
    """The online tracker (`smooth=False`'s engine) against an iterated EKF written from the
    textbook in NumPy: Φ and ∂Φ/∂b from `vojax.reference` (direct sums by hand) at the current
    iterate's order, the gain ``K = P⁻Hᵀ/S`` and the short covariance form ``(I − KH)P⁻``
    (the library uses Joseph's), the logistic order map and the random-walk prediction written
    out. Means, covariances, a-priori and a-posteriori predictions agree to rounding."""
    from vojax import reference
    from vojax._integral import make_memory

    n, dt, bounds, its = 35, 0.1, (0.01, 0.99), 3
    lo, hi = bounds
    t = np.arange(n) * dt
    u = np.stack([np.sin(0.9 * t) + 0.5, np.cos(0.4 * t)], axis=1)
    truth = 0.25 + 0.4 * t / t[-1]
    y = np.asarray(reference.fractional_integral(u, truth, dt)) @ np.array([0.8, -0.5]) + 0.3
    y = y + 0.01 * np.random.default_rng(8).standard_normal(n)
    qo, qp, r, horizon = 0.5, 1e-3, 1e-3, (n - 1) * dt
    m0 = np.array([0.2, 0.5, -0.3, 0.1])
    p0 = np.diag([4.0, 9.0, 9.0, 9.0])
    mem = make_memory("direct", dt, n, order_range=bounds)
    tracker = KalmanTracker(
        mem, Hyper(*(jnp.log(jnp.asarray(v)) for v in (qo, qp, r))), jnp.asarray(horizon),
        jnp.asarray(m0), jnp.asarray(p0), bounds, its,
    )
    got = _scan_filter(tracker, jnp.asarray(u), jnp.asarray(y), jnp.full((n,), dt), jnp.ones(n))

    def at(k, beta):
        s = 1.0 / (1.0 + np.exp(-beta))
        a = lo + (hi - lo) * s
        phi = np.asarray(reference.fractional_integral(u[: k + 1], a, dt))[-1]
        dphi = np.asarray(reference.order_sensitivity(u[: k + 1], a, dt))[-1]
        return phi, dphi, (hi - lo) * s * (1 - s)

    m_pred, p_pred = m0.copy(), p0.copy()
    q_step = np.array([qo, qp, qp, 0.0]) * dt / horizon
    for k in range(n):
        theta = m_pred.copy()
        for i in range(its):
            phi, dphi, dadb = at(k, theta[0])
            h = theta[3] + theta[1:3] @ phi
            jac = np.concatenate([[theta[1:3] @ dphi * dadb], phi, [1.0]])
            if i == 0:
                y_prior = h
            # iterated EKF: relinearise at θ_i, the update always from the prediction
            s = jac @ p_pred @ jac + r
            gain = p_pred @ jac / s
            theta = m_pred + gain * (y[k] - h - jac @ (m_pred - theta))
            cov = (np.eye(4) - np.outer(gain, jac)) @ p_pred
        phi, _, _ = at(k, theta[0])
        np.testing.assert_allclose(got.mean[k], theta, rtol=1e-9, atol=1e-10)
        np.testing.assert_allclose(got.cov[k], cov, rtol=1e-8, atol=1e-11)
        assert float(got.y_pred[k]) == pytest.approx(y_prior, rel=1e-9, abs=1e-11)
        assert float(got.y_hat[k]) == pytest.approx(theta[3] + theta[1:3] @ phi, rel=1e-9, abs=1e-11)
        m_pred, p_pred = theta, cov + np.diag(q_step)


def test_small_spd_solve_equals_lapack():
    """`cholesky_solve` (unrolled inside the filter and smoother scans and LSFF's step, LAPACK
    beyond 6 unknowns) against NumPy's LU solve, for d = 1…8, right-hand sides (d,) and (d, d),
    conditioning up to 1e8."""
    from vojax._linalg import cholesky_solve as solve_spd

    rng = np.random.default_rng(11)
    for d in range(1, 9):
        for cond in (1.0, 1e4, 1e8):
            q, _ = np.linalg.qr(rng.standard_normal((d, d)))
            a = q @ np.diag(np.geomspace(1.0, 1.0 / cond, d)) @ q.T
            a = 0.5 * (a + a.T)
            for b in (rng.standard_normal(d), rng.standard_normal((d, d))):
                want = np.linalg.solve(a, b)
                got = np.asarray(solve_spd(jnp.asarray(a), jnp.asarray(b)))
                assert got.shape == want.shape
                np.testing.assert_allclose(got, want, rtol=0, atol=1e-13 * cond * np.max(np.abs(want)))


@pytest.mark.slow
def test_first_pass_keeps_the_best_run_and_falls_back_on_the_full_budget(ramp, monkeypatch):
    """`smoother_batch` over three (intensity, start) pairs keeps the run of the highest
    evidence: its trajectory, index and scores equal those of the three runs made one by one.
    With a first-pass budget of one iteration (no run converges) the tracker runs the pass
    again at each noise level with the full budget (`max_iter`), and returns what a first
    pass given that budget returns: on this record one of its two fits converges only at
    the constant fit's misfit, which the fallback once tried with one iteration alone
    (order drift 0.152 against 0.142). Not what the default budget (60) returns: a run that
    converges only past it is out of that pass and may be the best of the full one."""
    from vojax._tracker._smoother import iterated_smoother, score, smoother_batch
    from vojax._tracker._threads import run_batch_shares, run_mode_shares, stack_hypers

    num = 120
    problem, starts = _normalised(ramp, num)
    memory, un, yn, mask, steps, horizon = problem.record
    m0, p0, bounds = problem.m0, problem.p0, problem.bounds
    starts = starts[[0, 1, 5]]
    rows = [(0.1, 1e-6, 1e-3), (10.0, 1e-6, 1e-2), (1.0, 1e-4, 1e-3)]
    hyper = stack_hypers(rows)
    nominal = jnp.broadcast_to(jnp.asarray(starts)[:, None, :], (3, num, starts.shape[1]))
    best, i, i_alt, scores, iterations, alts = smoother_batch(
        memory, un, yn, mask, steps, horizon, hyper, m0, p0, jnp.asarray(starts), bounds, 400
    )
    alone = [
        iterated_smoother(memory, un, yn, mask, steps, horizon, Hyper(*np.log(row)), m0, p0,
                          nominal[k], bounds, 400)
        for k, row in enumerate(rows)
    ]
    want = [float(score(sm)) for sm in alone]
    np.testing.assert_allclose(np.asarray(scores), want, rtol=1e-12)
    assert int(i) == int(np.argmax(want)) and len(set(np.round(want, 6))) == 3
    np.testing.assert_allclose(best.theta, alone[int(i)].theta, rtol=1e-12, atol=1e-12)
    assert [int(k) for k in iterations] == [int(sm.iterations) for sm in alone]
    # the same runs in shares of two (one padded with a copy of its last run), in threads
    # once compiled: the same best run, indices and scores, and the same modes
    from vojax._tracker import _threads
    from vojax._tracker._smoother import smoother_modes

    monkeypatch.setattr(_threads.os, "cpu_count", lambda: 2)
    modes = smoother_modes(memory, un, yn, mask, steps, horizon, hyper, m0, p0,
                           jnp.asarray(starts), bounds, 400)
    for _ in range(2):  # the first time share after share, then side by side
        b2, i2, alt2, s2 = run_batch_shares(problem, rows, jnp.asarray(starts), 400)
        assert (i2, alt2) == (int(i), int(i_alt)) and np.array_equal(s2, np.asarray(scores))
        np.testing.assert_array_equal(b2.theta, best.theta)
        shared = run_mode_shares(problem, rows, jnp.asarray(starts), 400)
        for a, b in zip(shared, modes):
            np.testing.assert_array_equal(a, np.asarray(b))
    # the fallback: nothing converges in one iteration, so the pass runs again in full
    t, u, y, *_, dt = ramp
    again = vojax.identify(u, y, dt, method="kalman",
                           settings=vojax.TrackerSettings(grid_max_iter=1))
    full = vojax.identify(u, y, dt, method="kalman",
                          settings=vojax.TrackerSettings(grid_max_iter=400, max_iter=400))
    assert again.tuning == full.tuning
    np.testing.assert_allclose(again.alpha, full.alpha, rtol=1e-12)


def test_output_smoother_than_the_model_converges_with_the_noise_it_leaves():
    """A controlled ramp–hold displacement (exact, no noise) driven by a strain-stiffening,
    relaxing force that no springpot matches: the output's second differences show no noise,
    so every run of the first pass at that noise stalls, a misfit the model cannot remove
    being charged as 1e8 noise variances. The tracker must then start again from the misfit a
    constant order leaves and converge, with a tuned noise between the smoothed and the
    one-step-ahead residuals (the noise it claims is the noise it leaves), not at its floor."""
    from vojax._stats import noise_variance

    rng = np.random.default_rng(3)
    dt, num = 0.1, 165
    t = dt * np.arange(num)
    y = np.minimum(t, 6.0)
    relax = np.where(t < 6.0, 1.0, 0.6 + 0.4 * np.exp(-(t - 6.0) / 2.0))
    force = (0.02 + 0.05 * y + 0.01 * y**2) * relax + 1e-3 * rng.standard_normal(num)
    assert noise_variance(y / y.std()) < 1e-20  # the output is noise-free
    res = vojax.identify(force[:, None], y, dt, method="kalman", warn=False)
    assert res.diagnostics.converged and "noise" not in res.diagnostics.at_edge
    noise_sd = np.sqrt(res.tuning.noise) * y.std()
    fitted = np.sqrt(np.mean((y - np.asarray(res.y_hat)) ** 2))
    ahead = np.sqrt(np.mean((y - np.asarray(res.y_pred))[5:] ** 2))
    assert fitted < noise_sd < ahead
    assert np.all(np.asarray(res.alpha_std) > 1e-3)  # a band, not ±0.000


def test_first_pass_noise_levels_follow_the_data_and_the_constant_fits_misfit():
    """The first pass's noise levels, tried in turn: the data's own (second differences)
    where the constant order fits about as well as that noise allows; the data's, then the
    constant fit's misfit, where the misfit is `misfit_ratio` times larger; the misfit first
    where the output shows no noise at all (a controlled signal, as in the test above)."""
    import jax.numpy as jnp

    from vojax import reference
    from vojax._integral import make_memory
    from vojax._tracker._fit import start

    s = vojax.TrackerSettings()
    dt, num = 0.1, 165
    t = dt * np.arange(num)
    y = np.minimum(t, 6.0)
    relax = np.where(t < 6.0, 1.0, 0.6 + 0.4 * np.exp(-(t - 6.0) / 2.0))
    force = (0.02 + 0.05 * y + 0.01 * y**2) * relax
    memory = make_memory("exponential", dt, num, order_range=(0.01, 0.99))
    rng = np.random.default_rng(0)
    spring = np.asarray(reference.fractional_integral(force[:, None], 0.4, dt))[:, 0]

    def first(u, out):
        st = start(memory, jnp.asarray(u[:, None]), jnp.asarray(out), dt, (0.01, 0.99), s,
                   None, None, None, False)
        noise0 = float(np.clip(st.noise_data, s.noise_min, st.misfit))
        return st, noise0

    st, noise0 = first(force, y)  # no noise, a misfit the model cannot remove
    assert st.noise_data < s.noise_min <= noise0 and st.misfit >= s.misfit_ratio * noise0
    assert st.noises == (st.misfit, noise0)
    noisy = y + 1e-4 * rng.standard_normal(num)  # the same misfit, with some noise
    st, noise0 = first(force, noisy)
    assert st.noise_data >= s.noise_min and st.misfit >= s.misfit_ratio * noise0
    assert st.noises == (noise0, st.misfit)
    fits = spring + 0.01 * np.ptp(spring) * rng.standard_normal(num)  # the model, 1 % noise
    st, noise0 = first(force, fits)
    assert st.misfit < s.misfit_ratio * noise0 and st.noises == (noise0,)


def _oscillation_record(per_cycle, num=300, dt=0.1, order=0.4, seed=1):
    """A constant order's response to a sine of `per_cycle` samples a cycle (as a large
    amplitude oscillatory test samples it), with 1 % white noise: ``(u, y, x, sd)``."""
    from vojax import reference

    t = dt * np.arange(num)
    u = np.sin(2 * np.pi * t / (per_cycle * dt)) + 0.2
    x = np.asarray(reference.fractional_integral(u, np.full(num, order), dt, memory="direct"))
    sd = 0.01 * np.ptp(x)
    return u, x + sd * np.random.default_rng(seed).standard_normal(num), x, sd


def test_noise_floor_is_the_noise_where_the_signal_curves_at_the_sampling_scale():
    """A sine of 12 samples a cycle puts its curvature into the second differences (their
    estimate of the noise is many times the true one); the differences of order 4 and 6 see
    through it. The noise's floor is `noise_floor` times the least of the three: within 30 %
    of that fraction of the true noise, not the inflated second-difference one."""
    import jax.numpy as jnp

    from vojax._integral import make_memory
    from vojax._tracker._fit import start

    s = vojax.TrackerSettings()
    dt = 0.1
    u, y, _, sd = _oscillation_record(12, dt=dt)
    memory = make_memory("exponential", dt, y.size, order_range=(0.01, 0.99))
    st = start(memory, jnp.asarray(u[:, None]), jnp.asarray(y), dt, (0.01, 0.99), s, None,
               None, None, False)
    true = (sd / st.scales.y_scale) ** 2  # the noise's variance on the normalised output
    assert st.noise_data > 3 * true  # second differences: the sine's curvature as noise
    assert 0.7 < st.noise_floor / (s.noise_floor * true) < 1.3


@pytest.mark.parametrize("per_cycle", [12, 16])
def test_an_oscillation_sampled_coarsely_is_identified(per_cycle):
    """With a floor from the second differences alone, the tuned noise of these records sat at
    its floor's edge (an inflated one) and the order was refused at an error below 0.001; the
    order is now identified, its band within ±0.1 and covering the truth."""
    u, y, *_ = _oscillation_record(per_cycle)
    res = vojax.identify(u, y, 0.1, warn=False)
    d = res.diagnostics
    assert "noise" not in d.at_edge and d.verdict == "identified", d.reasons
    half = slice(y.size // 2, None)
    lower, upper = (np.asarray(a)[half] for a in (res.alpha_lower, res.alpha_upper))
    assert np.all((lower <= 0.4) & (0.4 <= upper)) and np.max(upper - lower) <= 0.2


@pytest.mark.slow
def test_smoother_recovers_a_ramp_order_driven_by_the_myocardium_stretch():
    """Semi-synthetic: the shipped myocardium stretch (a measured ramp–hold) on 600 samples
    drives an order ramping from 0.25 to 0.65 (p = 1); the truth from `vojax.reference`'s
    direct sums on a grid twice as fine, then 1 % and 5 % noise, three seeds each. The
    tracker's order must be within 0.08 RMS of the truth (a fifth of the ramp) in the median
    case. A first pass started only from the constant fit's misfit (the misfit of a varying
    order) settles on a smooth mode instead and misses by 0.12 in the median case."""
    from vojax import reference
    from vojax.io import example_file

    raw = np.genfromtxt(example_file("myocardium"), delimiter=",", names=True)
    num = 600
    t = np.linspace(0.0, raw["Time"][-1] - raw["Time"][0], num)
    dt = float(t[1])
    u = np.interp(t + raw["Time"][0], raw["Time"], raw["L"] - raw["L"][0])
    u /= np.sqrt(np.mean(u**2))
    alpha = 0.25 + 0.4 * t / t[-1]
    fine = np.arange(2 * num - 1) * dt / 2
    x = np.asarray(
        reference.fractional_integral(np.interp(fine, t, u), np.interp(fine, t, alpha), dt / 2)
    )[::2]
    errors = []
    for seed in range(3):
        for level in (0.01, 0.05):
            y = x + level * np.std(x) * np.random.default_rng(seed).standard_normal(num)
            # p = 1 in seconds: the tracker is told the clock its parameter is constant on
            res = vojax.identify(u[:, None], y, dt, method="kalman", warn=False, time_scale=1.0)
            errors.append(np.sqrt(np.mean((np.asarray(res.alpha) - alpha) ** 2)))
    assert np.median(errors) < 0.08, np.round(errors, 3)


def test_constant_fit_finds_the_least_squares_order_of_a_dense_scan():
    """The grid-and-golden-section search of the constant order against a dense scan of the
    same profile (2,001 orders): the same minimum, to the dense scan's spacing."""
    from vojax._integral import make_memory
    from vojax._tracker._model import order_of
    from vojax._tracker._start import constant_fit, constant_profile

    t, u, y, *_, dt = _ramp_case(n=300, noise=0.05, seed=8)
    bounds = (0.01, 0.99)
    memory = make_memory("exponential", dt, 300, order_range=bounds)
    u, y, mask = jnp.asarray(u), jnp.asarray((y - y.mean()) / y.std()), jnp.ones(300)
    alpha, coef, rss, _ = constant_fit(memory, u, y, mask, bounds, vojax.TrackerSettings())
    betas = np.linspace(-5.0, 5.0, 2001)
    alphas = np.asarray(order_of(jnp.asarray(betas), bounds)[0])
    host = [np.asarray(a) for a in (u, y, mask)]
    block = vojax.TrackerSettings().phi_block
    dense = np.array([float(constant_profile(memory, *host, a, block)[0]) for a in alphas])
    k = int(np.argmin(dense))
    assert 0 < k < 2000  # an interior minimum
    assert rss <= dense[k] * (1 + 1e-12)
    assert abs(alpha - alphas[k]) <= abs(alphas[k + 1] - alphas[k - 1])
    refit = constant_profile(memory, *host, alpha, block)
    np.testing.assert_allclose(coef, refit[1], rtol=1e-10)


def test_mixture_of_modes_is_the_evidence_weighted_spread():
    """`mix_modes` by hand: weights exp(score), normalised; a run that reached the reported
    run's mode counts once; the variance about the reported run is Σ w (var + Δβ²)."""
    from vojax._tracker._smoother import mix_modes

    n = 50
    betas = np.stack([np.zeros(n), np.zeros(n) + 1e-3, np.full(n, 0.5), np.full(n, -2.0)])
    variances = np.stack([np.full(n, 0.01), np.full(n, 0.01), np.full(n, 0.04), np.full(n, 0.09)])
    scores = np.array([10.0, 10.5, 9.0, -np.inf])  # run 1 = run 0's mode; run 3 did not converge
    var, w = mix_modes(betas, variances, scores, 0, n)
    expected_w = np.array([1.0, 0.0, np.exp(-1.0), 0.0]) / (1 + np.exp(-1.0))
    np.testing.assert_allclose(w, expected_w, rtol=1e-14)
    expected = expected_w[0] * 0.01 + expected_w[2] * (0.04 + 0.25)
    np.testing.assert_allclose(var, expected, rtol=1e-14)
    # a reported run that did not converge: its own variance, no mixture
    var, w = mix_modes(betas, variances, np.array([-np.inf, 1.0, 2.0, 3.0]), 0, n)
    np.testing.assert_array_equal(var, variances[0])
    np.testing.assert_array_equal(w, [1.0, 0.0, 0.0, 0.0])


def test_band_covers_the_other_modes_in_proportion_to_their_evidence():
    """The tracker's reported band is the mixture's: at least as wide as the tuned run's own
    Laplace band at every sample, and its weights sum to one with the tuned run first."""
    from vojax._integral import make_memory
    from vojax._tracker._fit import fit_points

    t = np.arange(300) * 0.1
    u = np.where(t < 5.0, t / 5.0, 1.0)
    y = np.asarray(vojax.simulate(u, 0.3 + 0.3 * t / t[-1], np.array([1.0]), 0.1))
    y = y + 0.01 * np.ptp(y) * np.random.default_rng(7).standard_normal(t.size)
    mem = make_memory("exponential", 0.1, t.size, rule="trapezoid", order_range=(0.01, 0.99))
    settings = vojax.TrackerSettings()
    res = fit_points(mem, jnp.asarray(u[:, None]), jnp.asarray(y), 0.1, (0.01, 0.99), settings)
    w = np.asarray(res.mixture_weights)
    assert w.sum() == pytest.approx(1.0, rel=1e-12) and w[0] > 0
    own = fit_points(mem, jnp.asarray(u[:, None]), jnp.asarray(y), 0.1, (0.01, 0.99), settings,
                     noise=dict(order_drift=res.tuning.order_drift,
                                parameter_drift=res.tuning.parameter_drift,
                                noise_std=np.sqrt(res.tuning.noise) * np.std(y)))
    assert np.all(np.asarray(res.alpha_std) >= np.asarray(own.alpha_std) * (1 - 1e-6))


def test_correlated_prediction_errors_are_refused_and_coloured_noise_is_modelled():
    """AR(1) measurement noise (ρ = 0.9) on a record that white noise leaves identified (its
    parameters stated constant): the innovations' lag-1 autocorrelation exceeds 0.25 and the
    band is refused, with what to do;
    with white noise of the same level it stays below the limit."""
    from vojax._diagnostics import diagnose
    from vojax._stats import MAX_CORRELATION, correlation_limit, lag1_correlation

    alpha = np.full(100, 0.4)
    d = diagnose(alpha, alpha - 0.01, alpha + 0.01, (0.01, 0.99), True, (), correlation=0.3)
    assert not d.identified and "coarser clock" in d.message and d.innovation_correlation == 0.3
    # the limit: three standard errors of a white sequence's (1/√n), within 0.1–0.25
    for n, limit in ((50, 0.25), (144, 0.25), (400, 0.15), (900, 0.1), (10_000, 0.1)):
        assert correlation_limit(n) == pytest.approx(limit)
    for r, n, refused in ((0.16, 400, True), (0.14, 400, False), (0.12, 5000, True),
                          (0.24, 100, False)):
        d = diagnose(alpha, alpha - 0.01, alpha + 0.01, (0.01, 0.99), True, (), correlation=r,
                     samples=n)
        assert d.identified is not refused and ("> 0.15" in d.message) is (n == 400 and refused)
    t = np.arange(600) * 0.05
    u = np.where(t < 3.0, t / 3.0, 1.0) + 0.3 * np.sin(0.4 * t)
    x = np.asarray(vojax.simulate(u, np.full(t.size, 0.45), np.array([1.0]), 0.05))
    rng = np.random.default_rng(3)
    white = rng.standard_normal(t.size)
    ar = np.zeros(t.size)
    for k in range(1, t.size):
        ar[k] = 0.9 * ar[k - 1] + np.sqrt(1 - 0.81) * white[k]
    level = 0.01 * np.ptp(x)
    # the parameters stated constant: by default a drifting one explains this record too
    clean = vojax.identify(u, x + level * white, 0.05, parameters="constant", warn=False)
    d = clean.diagnostics
    assert d.identified and d.innovation_correlation < 0.1  # the rule is one-sided
    assert clean.tuning.coloured_noise is None and np.isnan(d.noise_correlation)
    # coloured noise is modelled (an AR(1) part, chosen by evidence), not refused: the white
    # model's errors are correlated, the coloured model's are not, and its band holds 0.45
    res = vojax.identify(u, x + level * ar, 0.05, parameters="constant", warn=False)
    d = res.diagnostics
    assert lag1_correlation((x + level * ar - np.asarray(res.y_hat))[1:]) > MAX_CORRELATION
    assert d.innovation_correlation < correlation_limit(t.size - 1) and d.identified
    assert 0.8 < d.noise_correlation < 0.97, d.noise_correlation
    half = slice(t.size // 2, None)
    inside = (np.asarray(res.alpha_lower) <= 0.45) & (0.45 <= np.asarray(res.alpha_upper))
    assert np.mean(inside[half]) > 0.95


def test_an_unstable_law_reports_an_infinite_band_with_its_reason(monkeypatch):
    """At γ = 0.05 on this noise-free record the law is unstable: a change of 1e-9 in the data
    moves its order by more than 1e-3 within 10,000 samples (checked here, by running it
    twice), and the delta-method spread grows geometrically (1e55 at sample 20,000, beyond
    the float range by 57,500). It must never come out as NaN, with the reason in the
    message; and the rescaled
    recursion gives the plain one's numbers where both are finite."""
    from vojax._adaptive import _bands

    dt, n = 0.01, 60_000
    t = dt * np.arange(n)
    u = (np.sin(0.5 * t) + 1.5)[:, None]
    y = np.asarray(vojax.simulate(u, 0.6, np.array([2.0]), dt, memory="exponential"))
    res = vojax.identify(u, y, dt, gamma=0.05, lam=0.9, warn=False, method="gradient")
    nudged = y.copy()
    nudged[100:] += 1e-9
    other = vojax.identify(u, nudged, dt, gamma=0.05, lam=0.9, warn=False, method="gradient")
    assert np.max(np.abs(np.asarray(other.alpha) - np.asarray(res.alpha))[:10_000]) > 1e-3
    std = np.asarray(res.alpha_std)
    assert not np.any(np.isnan(std)) and not np.any(np.isnan(np.asarray(res.p_std)))
    # it grows through hundreds of orders of magnitude (past the float range with the newest
    # JAX, 3e130 at most with JAX 0.4.30: the unstable law's path depends on the last digits);
    # where the order is clipped at a bound the linearised spread is 0 (the clip's derivative)
    assert np.max(std) > 1e100 and np.all(np.isfinite(np.asarray(res.alpha_lower)))
    assert "unstable at these gains" in res.diagnostics.message
    assert not res.diagnostics.identified
    # renormalising at every step (a threshold of 1e-30) changes nothing but rounding
    short = vojax.identify(u[:3001], y[:3001], dt, gamma=0.05, lam=0.9, warn=False, method="gradient")
    every_step = functools.partial(_bands.law_covariance, rescale=1e-30)
    monkeypatch.setattr(_bands, "law_covariance", every_step)
    again = vojax.identify(u[:3001], y[:3001], dt, gamma=0.05, lam=0.9, warn=False, method="gradient")
    np.testing.assert_allclose(again.alpha_std, short.alpha_std, rtol=1e-9)
    np.testing.assert_allclose(again.p_std, short.p_std, rtol=1e-9)


@pytest.mark.slow
@pytest.mark.parametrize("parameters", ["constant", None])
def test_the_order_does_not_depend_on_the_unit_of_time(parameters):
    """A constant order with the times in s, ms, h and ×1e12, on a uniform and an irregular
    clock: the tracker's order, its band and its verdict agree to 1e-6 (the parameters are
    held, or their drift tuned, in units of the record's span; measured: 3e-11 at most), and
    so does the refit's order. A tuning or a memory that depended on the unit of time (a
    drift intensity per second, say) moves the order by many σ (0.40 → 0.80 was seen with
    ×1e12)."""
    n, dt = 300, 0.05
    fine = dt * np.arange(n)
    gaps = np.random.default_rng(1).integers(1, 4, n)
    for t in (fine, dt * np.concatenate([[0], np.cumsum(gaps[1:])])):
        u = np.sin(0.7 * t) + 0.3 * np.sin(1.9 * t) + 1.0
        x = np.asarray(vojax.simulate(u, 0.4, np.array([2.0]), t=t))
        y = x + 0.01 * np.ptp(x) * np.random.default_rng(0).standard_normal(n)
        a = vojax.identify(u, y, t=t, parameters=parameters, warn=False)
        fit = vojax.refit(u, y, t=t, warn=False)
        assert a.diagnostics.verdict == "identified"
        for c in (1e-3, 1 / 3600, 1e12):
            b = vojax.identify(u, y, t=t * c, parameters=parameters, warn=False)
            assert b.diagnostics.verdict == a.diagnostics.verdict
            for name in ("alpha", "alpha_lower", "alpha_upper"):
                diff = np.max(np.abs(np.asarray(getattr(b, name)) - np.asarray(getattr(a, name))))
                assert diff < 1e-6, (c, name, diff)
            other = vojax.refit(u, y, t=t * c, warn=False)
            assert abs(float(other.order[0]) - float(fit.order[0])) < 1e-6, c


def _gain_drift_case(n=300, alpha=0.45, noise=0.01, seed=3, width=0.15):
    """One input, a constant order, and a gain that rises by 30 % mid-record over about
    ±`width` of it: ``y = p(t)·I^α u + c`` (a tissue stiffening during a test)."""
    from vojax import reference

    dt = 0.05
    t = np.arange(n) * dt
    u = 1.0 - np.exp(-t / 3.0) + 0.2 * np.sin(0.7 * t)
    s = t / t[-1]
    p = 1.0 + 0.3 * (1.0 + np.tanh((s - 0.5) / width)) / 2.0
    x = p * np.asarray(reference.fractional_integral(u[:, None], np.full(n, alpha), dt))[:, 0]
    sd = noise * np.ptp(x)
    y = x + 0.2 + sd * np.random.default_rng(seed).standard_normal(n)
    return t, u, y, dt, sd


def test_coarse_hats_are_sums_of_the_fine_ones():
    """The trade-off's profile runs the memory once for both of its drifts: the hat functions
    on 8 knots are `refinement`'s sums of those on 15 (the 8 and their midpoints), at
    irregular times with the fitted span ending before the record does."""
    from vojax._tracker._trade import hat_basis, refinement

    t = np.concatenate([[0.0], np.sort(np.random.default_rng(0).uniform(0, 3, 499))])
    for knots in (2, 3, 8):
        fine = hat_basis(t, 450, 2 * knots - 1)
        coarse = hat_basis(t, 450, knots)
        np.testing.assert_allclose(fine @ refinement(knots), coarse, rtol=0, atol=1e-15)
        assert np.all(coarse[451:] == coarse[450])  # held after the fitted span


@pytest.mark.parametrize("width, noise, fine", [
    (0.15, 0.01, False),
    pytest.param(0.1, 0.005, True, marks=pytest.mark.slow),
])
def test_trade_interval_against_an_independent_profile(width, noise, fine):
    """The constant orders with which a drifting parameter explains the data as well, against
    the same profile computed independently: `vojax.reference`'s direct sums on a grid of
    orders 0.02 apart refined to 0.0025 at the minimum and the ends, least squares in NumPy
    over hat functions built here on 8 knots and on 15, for a gain on the memory term and for
    a parameter inside the integral; each form on 15 knots where that lowers its best χ² by
    more than 14 (Akaike: 7 more coefficients), the interval where the better form's
    Δχ² ≤ 4. A smooth rise of the gain (over ±0.15 of the record, 1 % noise) keeps 8 knots;
    a faster one (±0.1, 0.5 % noise) takes 15, where both forms' intervals on 8 knots miss
    the true order. It holds the true order; with a noise level far below the data's, no
    drifting parameter explains them and there is no interval."""
    from vojax import reference
    from vojax._integral import make_memory
    from vojax._tracker._trade import trade_interval

    t, u, y, dt, sd = _gain_drift_case(width=width, noise=noise)
    n, bounds = t.size, (0.01, 0.99)
    memory = make_memory("exponential", dt, n, order_range=bounds)
    problem = make_problem(memory, u[:, None], y, times=t, bounds=bounds)
    got, explanations, _ = trade_interval(problem, sd**2)
    s = t / t[-1]
    hats = [np.stack([np.interp(s, np.linspace(0, 1, k), np.eye(k)[j]) for j in range(k)],
                     axis=1) for k in (8, 15)]

    @functools.cache
    def chi2_at(a):  # χ² of (8 knots: gain, inside; 15 knots: gain, inside) at one order
        order = np.full(n, a)
        phi = np.asarray(reference.fractional_integral(u[:, None], order, dt))
        inside = np.asarray(reference.fractional_integral(
            u[:, None] * np.concatenate(hats, axis=1), order, dt))
        out = []
        for x in (phi * hats[0], inside[:, :8], phi * hats[1], inside[:, 8:]):
            x = np.column_stack([x, np.ones(n)])
            res = y - x @ np.linalg.lstsq(x, y, rcond=None)[0]
            out.append(res @ res / sd**2)
        return tuple(out)

    # a grid of 0.02, then 0.0025 around each form's minimum and each end of its interval
    # (an interval is one stretch of orders: χ² is convex in the order on this record)
    coarse = np.linspace(0.02, 0.98, 49)
    chi2 = np.array([chi2_at(a) for a in coarse])
    near = lambda a: np.round(np.clip(np.linspace(a - 0.02, a + 0.02, 17), 0.01, 0.99), 12)  # noqa: E731

    def best(f):
        return min(chi2[:, f].min(), min(chi2_at(a)[f] for a in near(coarse[chi2[:, f].argmin()])))

    # each form's knots: 15 where its best χ² is lower by more than 14
    forms = [f + 2 if best(f) - best(f + 2) > 14 else f for f in range(2)]
    assert (forms[0] >= 2) == fine  # the true gain form takes the finer drift where it needs it
    fits = [f for f in forms
            if chi2[:, f].min() <= (dof := n - (15 if f >= 2 else 8) - 1) + 2 * np.sqrt(2 * dof)]
    assert fits  # the gain form is the truth: it must explain the data

    def interval(f):  # the orders within Δχ² ≤ 4 of form f's best
        low, out = best(f), []
        inside = coarse[chi2[:, f] - low <= 4.0]
        for edge in (inside.min(), inside.max()):
            grid = near(edge)
            out.extend(grid[[chi2_at(a)[f] - low <= 4.0 for a in grid]])
        return out + list(inside)

    if fine:  # 8 knots alone would have left the truth out
        assert all(not min(interval(f)) <= 0.45 <= max(interval(f)) for f in range(2))
    within = np.array([a for f in fits for a in interval(f)])
    assert got is not None
    step = (bounds[1] - bounds[0]) / (problem.settings.trade_orders + 1)  # the library's grid
    for end, want, bound in ((got[0], within.min(), bounds[0]), (got[1], within.max(), bounds[1])):
        if end == bound:  # its outermost grid order is inside: the interval reaches the bound
            assert abs(want - bound) <= step + 0.0025
        else:
            assert end == pytest.approx(want, abs=0.01)
    assert got[0] <= 0.45 <= got[1]
    assert trade_interval(problem, 1e-4 * sd**2)[:2] == (None, [])


@pytest.mark.parametrize("inputs, fine", [(1, True), (2, False)])
def test_the_trade_offs_finer_drift_pays_two_per_coefficient_of_every_input(
        monkeypatch, inputs, fine):
    """Akaike's rule for the trade-off's drift: 15 knots instead of 8 add 7 coefficients per
    input, so they are taken where they lower the best χ² by more than 2·7·n. A profile
    whose finer drift gains 20 takes 15 knots with one input (20 > 14) and keeps 8 with two
    (20 < 28); the explanations' degrees of freedom, N − n·knots − 1, say which ran, and the
    interval is where the profile (20 |α − 0.5| above its best) stays within Δχ² ≤ 4."""
    from vojax._integral import make_memory
    from vojax._tracker import _trade

    num = 200
    t = np.linspace(0.0, 1.0, num)
    u = np.column_stack([np.sin(3 * t) + 1.5, np.cos(2 * t) + 2.0][:inputs])
    problem = make_problem(make_memory("exponential", t[1], num, order_range=(0.01, 0.99)),
                           u, np.sin(5 * t), times=t, bounds=(0.01, 0.99))

    def profile(problem, alphas, fine, whiten=None, offset=True):
        chi2 = np.full((alphas.size, 2, 2), np.inf)
        chi2[:, 0, 0] = 175.0 + 20 * abs(alphas - 0.5)  # linear: the crossing is exact
        chi2[:, 1, 0] = chi2[:, 0, 0] - 20.0
        return chi2, [[[None, None]] * 2] * alphas.size, None

    monkeypatch.setattr(_trade, "drift_profile", profile)
    monkeypatch.setattr(_trade, "least_drift", lambda *a, **k: 0.0)
    interval, explanations, _ = _trade.trade_interval(problem, 1.0)
    knots = 15 if fine else 8
    assert {e.dof for e in explanations} == {num - inputs * knots - 1.0}
    assert interval == pytest.approx((0.3, 0.7), abs=1e-12)


@pytest.mark.slow
def test_parameters_constant_holds_their_drift_and_keeps_the_trade_out_of_its_band(monkeypatch):
    """``parameters="constant"``: the parameters' drift is held at its floor exactly (never
    'at the edge'), the band's mixture has no drifting-parameter alternatives (the tuned
    run, one run per start, the order-drift levels), the parameters' scale is profiled (the
    level profile's held scales), and the trade-off's constant orders,
    which run for the conditional answer's breakdown drift, all drift (by more than 5 %) and
    do not widen the stated band: it stays narrower than their interval. The default mixes
    in the six drifting-parameter alternatives too, and its band, widened by the trade,
    holds the trade's interval and the true constant order of the drifting gain."""
    from vojax._tracker import _fit, _mixture

    runs, trades = [], []
    mix, trade = _mixture.mix_modes, _fit.trade_interval
    monkeypatch.setattr(_mixture, "mix_modes", lambda b, *a, **k: runs.append(len(b)) or mix(b, *a, **k))
    monkeypatch.setattr(_fit, "trade_interval", lambda *a, **k: trades.append(trade(*a, **k)) or trades[-1])
    levels, level = [], _fit.level_profile
    monkeypatch.setattr(_fit, "level_profile", lambda *a, **k: levels.append(level(*a, **k)) or levels[-1])
    settings = vojax.TrackerSettings()
    t, u, y, dt, _ = _gain_drift_case()
    held = vojax.identify(u, y, dt, parameters="constant", warn=False)
    assert held.tuning.parameter_drift == pytest.approx(settings.constant_drift, rel=1e-12)
    assert "parameter_drift" not in held.tuning.at_edge
    # the parameters' scale, which trades off with the order's level, is profiled
    assert len(levels) == 1 and len(levels[0]) >= len(settings.level_ratios)
    assert {e.kind for e in levels[0]} == {"level"}
    starts = len(settings.start_orders) + 1
    assert runs == [1 + starts + len(settings.alt_order_drift)] and len(trades) == 1
    (lo, hi), traded, _ = trades[0]
    assert traded and all(e.drift > 0.05 for e in traded)
    second = slice(t.size // 2, None)
    width = np.asarray(held.alpha_upper)[second] - np.asarray(held.alpha_lower)[second]
    assert np.median(width) < hi - lo
    free = vojax.identify(u, y, dt, warn=False)
    assert runs[1] == runs[0] + 2 * len(settings.alt_param_drift)
    assert len(trades) == 2 and trades[1][0] is not None
    lower, upper = (np.asarray(a)[second] for a in (free.alpha_lower, free.alpha_upper))
    assert np.all(lower <= trades[1][0][0] + 1e-12) and np.all(upper >= trades[1][0][1] - 1e-12)
    assert np.mean((lower <= 0.45) & (0.45 <= upper)) > 0.9


@pytest.mark.slow
@pytest.mark.xfail(
    strict=False, run=False,  # not run: it fails for the reason below, and the slow tier is long
    reason="open (issue 50): with the parameters stated constant (false here: the gain drifts) the band is identified yet covers 0.38 of the samples; the statement's band is not refused where a drifting explanation fits",
)
def test_band_covers_a_moving_order_with_a_drifting_gain_or_refuses():
    """A moving order (0.35 → 0.60) and a gain rising 30 % mid-record, one input: a drifting
    parameter and a moving order trade off. By default the band covers the truth at every
    sample of the second half, widened by the explanations with a drifting parameter that
    fit, and the order is refused with a reason that names
    ``parameters='constant'``. Stating the parameters constant, falsely, puts the order 0.1
    off the truth; its Laplace band alone (±0.06) would miss the truth at most samples of the
    second half, but another scale of the held parameter fits as well, so the band covers it
    and the order is refused (the level profile)."""
    from vojax import reference

    n, dt = 400, 0.05
    t = np.arange(n) * dt
    s = t / t[-1]
    u = 1.0 - np.exp(-t / 3.0) + 0.2 * np.sin(0.7 * t)
    alpha = 0.35 + 0.25 * s
    p = 1.0 + 0.3 * (1.0 + np.tanh((s - 0.5) / 0.15)) / 2.0
    x = p * np.asarray(reference.fractional_integral(u[:, None], alpha, dt))[:, 0]
    y = x + 0.2 + 0.01 * np.ptp(x) * np.random.default_rng(3).standard_normal(n)
    half = slice(n // 2, None)

    def coverage(res):
        lo, hi = np.asarray(res.alpha_lower)[half], np.asarray(res.alpha_upper)[half]
        return np.mean((lo <= alpha[half]) & (alpha[half] <= hi))

    free = vojax.identify(u, y, dt, warn=False)
    d = free.diagnostics
    assert coverage(free) == 1.0 and not d.identified
    assert "because a drifting parameter explains the data as well" in d.message
    assert "parameters='constant'" in d.message
    held = vojax.identify(u, y, dt, parameters="constant", warn=False)
    rms = np.sqrt(np.mean((np.asarray(held.alpha) - alpha)[half] ** 2))
    assert rms > 0.05  # the false statement moves the estimate
    assert coverage(held) == 1.0 and not held.diagnostics.identified  # refused, not wrong


def test_threaded_smoothings_leave_sys_stderr_as_they_found_it():
    """A second tracker call on a record shape runs its smoothings in threads. Libraries that
    swap ``sys.stderr`` around a compiled call without a lock (equinox before 0.11.6) leave a
    wrapper behind when two threads overlap, and the process then exits with status 120 at
    shutdown (the wrapper has no ``flush``). Both calls here must leave ``sys.stderr`` as it was."""
    import sys

    dt = 0.1
    t = np.arange(187) * dt  # a length no other test uses: the first call compiles, the second threads
    u = np.minimum(t, 5.0) + 0.2 * np.sin(t)
    y = np.asarray(vojax.reference.fractional_integral(u, 0.3 + 0.3 * t / t[-1], dt))
    y = y + 0.01 * np.ptp(y) * np.random.default_rng(0).standard_normal(t.size)
    before = sys.stderr
    for scale in (1.0, 1.01):
        vojax.identify(u, scale * y, dt, method="kalman", warn=False)
        assert sys.stderr is before


def test_phi_of_each_column_equals_the_memory_run_on_all_columns():
    """`phi_columns` (the constant fit's and the trade-off profile's Φ, one input column at
    a time through one compiled program) equals one run of the memory over all the columns
    at once, and the direct sum of `vojax.reference` to the memory's accuracy."""
    from vojax._integral import make_memory
    from vojax._tracker._start import phi_columns

    n, dt = 240, 0.05
    t = dt * np.arange(n)
    x = np.stack([np.sin(t) + 1.0, np.minimum(t, 4.0), np.cos(0.3 * t)], axis=1)
    memory = make_memory("exponential", dt, n, order_range=(0.01, 0.99))
    got = phi_columns(memory, x, 0.37, vojax.TrackerSettings().phi_block)
    whole = np.asarray(memory.run(jnp.asarray(x), jnp.full((n,), 0.37), False))
    np.testing.assert_allclose(got, whole, rtol=1e-13, atol=1e-13)
    direct = np.stack([np.asarray(vojax.reference.fractional_integral(x[:, j], 0.37, dt))
                       for j in range(3)], axis=1)
    np.testing.assert_allclose(got, direct, rtol=1e-6, atol=1e-6 * np.abs(direct).max())


def test_coloured_starts_side_by_side_equal_one_after_another(monkeypatch):
    """The coloured-noise model's starting smoothings (one per starting correlation) run one
    after another the first time a record shape is seen, then in threads: the two calls give
    the same estimates and band, to the last digit (the same compiled program, the runs in
    the same order)."""
    from vojax._tracker import _coloured, _problem, _threads

    monkeypatch.setattr(_threads.os, "cpu_count", lambda: 2)
    seen = []
    original = _threads.in_threads

    def spy(problem, fn, count, call, key):
        seen.append((fn.__name__, count))
        return original(problem, fn, count, call, key)

    monkeypatch.setattr(_coloured, "in_threads", spy)
    times = []  # the AR(1) part's correlation time of each coloured smoothing, in call order
    smoother = _problem.iterated_smoother

    def spy_smoother(memory, u, y, mask, steps, horizon, hyper, *rest):
        if hyper.coloured:
            times.append(float(hyper.log_ar_time))
        return smoother(memory, u, y, mask, steps, horizon, hyper, *rest)

    monkeypatch.setattr(_problem, "iterated_smoother", spy_smoother)
    dt = 0.05
    t = np.arange(211) * dt  # a length no other test uses: the first call runs them in turn
    u = np.where(t < 3.0, t / 3.0, 1.0) + 0.3 * np.sin(0.4 * t)
    x = np.asarray(vojax.simulate(u, np.full(t.size, 0.45), np.array([1.0]), dt))
    white = np.random.default_rng(5).standard_normal(t.size)
    ar = np.zeros(t.size)
    for k in range(1, t.size):
        ar[k] = 0.9 * ar[k - 1] + np.sqrt(1 - 0.81) * white[k]
    y = x + 0.01 * np.ptp(x) * ar
    # the span stated as the time scale: one fit per call (no second clock, see test_clock)
    first, second = (vojax.identify(u, y, dt, parameters="constant", warn=False,
                                    time_scale=dt * (t.size - 1)) for _ in range(2))
    rho_starts = vojax.TrackerSettings().rho_starts
    assert seen.count(("coloured", len(rho_starts))) == 2
    # each call starts once from every starting correlation (the shares cover them all)
    starts = len(rho_starts)
    assert len(times) >= 2 * starts and len(set(times[:starts])) == starts
    assert first.tuning == second.tuning
    for name in ("alpha", "alpha_lower", "alpha_upper", "p", "y_hat"):
        np.testing.assert_array_equal(getattr(first, name), getattr(second, name))


def test_batched_runs_equal_the_runs_one_by_one(ramp):
    """`smoother_batch` and `smoother_modes` with ``batched=True`` (chunks of `RUN_BATCH`
    runs through one vmapped program, the last chunk padded with copies of its last run):
    11 runs (a full chunk and a padded one) give the same best run, index, iteration counts,
    scores and modes as the runs one after another, to the smoother's convergence test (a
    relative decrease of 1e-9: the two programs round differently)."""
    from vojax._tracker._smoother import RUN_BATCH, smoother_batch, smoother_modes
    from vojax._tracker._threads import stack_hypers

    problem, starts = _normalised(ramp, 150)
    rows = [(q, d, r) for q in (0.1, 1.0, 10.0) for d, r in ((1e-6, 1e-3), (1e-4, 1e-2))]
    rows = (rows + rows[:5])[:11]
    assert RUN_BATCH < len(rows) < 2 * RUN_BATCH
    firsts = jnp.asarray(np.resize(starts, (len(rows), starts.shape[1])))
    hyper = stack_hypers(rows)
    args = (*problem.record, hyper, problem.m0, problem.p0, firsts, problem.bounds, 400)
    one = smoother_batch(*args)
    many = smoother_batch(*args, batched=True)
    assert many[1] == one[1] and many[2] == one[2]
    assert np.array_equal(many[4], one[4])  # iterations
    assert np.all(np.isfinite(one[3][one[3] > -np.inf])) and np.sum(np.isfinite(one[3])) >= 6
    np.testing.assert_allclose(many[3], one[3], rtol=1e-8)
    np.testing.assert_allclose(many[0].theta, one[0].theta, rtol=0, atol=1e-6)
    assert isinstance(many[0].theta, jax.Array)  # the best run handed on as JAX arrays
    modes_one = smoother_modes(*args)
    modes_many = smoother_modes(*args, batched=True)
    for a, b in zip(modes_many, modes_one):
        assert a.shape == b.shape
        np.testing.assert_allclose(a, b, rtol=1e-6, atol=1e-6)


def test_blocked_records_batch_their_passes_where_it_pays(monkeypatch):
    """Block means of ≥ `batched_block` samples run the first pass's and the mixture's
    smoothings batched under XLA's default loops, with the estimates of the runs one by one
    to rounding; under `use_fast_cpu_loops` (its flag in XLA_FLAGS) and for shorter blocks
    they run one by one."""
    from vojax._tracker import _smoother

    calls = []
    original = _smoother.smooth_batched

    def spy(*args):
        calls.append(args[1].shape)
        return original(*args)

    monkeypatch.setattr(_smoother, "smooth_batched", spy)
    dt = 0.01
    t = np.arange(1090) * dt
    u = np.minimum(t / 2.0, 1.0) + 0.1 * np.sin(2 * t)
    x = np.asarray(vojax.simulate(u, 0.35 + 0.2 * t / t[-1], np.array([2.0]), dt,
                                  memory="exponential"))
    y = x + 0.01 * np.ptp(x) * np.random.default_rng(2).standard_normal(t.size)
    kwargs = dict(max_points=100, warn=False)  # blocks of 11 samples
    monkeypatch.delenv("XLA_FLAGS", raising=False)
    batched = vojax.identify(u, y, dt, **kwargs)
    assert calls and all(shape[0] == 100 for shape in calls)
    del calls[:]
    alone = vojax.identify(u, y, dt, **kwargs,
                           settings=vojax.TrackerSettings(batched_block=12))
    assert not calls
    assert batched.tuning.values == pytest.approx(alone.tuning.values, rel=1e-5)
    for name in ("alpha", "alpha_lower", "alpha_upper", "y_hat"):
        np.testing.assert_allclose(getattr(batched, name), getattr(alone, name), rtol=0,
                                   atol=1e-6)
    monkeypatch.setenv("XLA_FLAGS", "--xla_backend_extra_options="
                       "xla_cpu_small_while_loop_byte_threshold=1048576")
    vojax.identify(u, y, dt, **kwargs)
    assert not calls


@pytest.mark.parametrize("fits, visited", [
    (lambda r: False, [(0.5, 0.71, 1.41, 2.0)]),
    (lambda r: True, [(0.5, 0.71, 1.41, 2.0), (2.828, 0.354), (4.0, 0.25)]),
    # only the larger scales fit: the profile goes up on its own, never back down
    (lambda r: r >= 2.0, [(0.5, 0.71, 1.41, 2.0), (2.828,), (4.0,)]),
])
def test_level_profile_follows_the_ridge_while_it_fits(monkeypatch, fits, visited):
    """The level profile holds the parameters at `level_ratios` × the tuned ones; where the
    outermost ratio on a side still explains the data it goes on by √2 on that side, up to
    4× (down to ¼), and every run is an explanation the band weighs (its bisections, which
    depend on the runs' orders, are held off here: `test_level_profile_bisects_...`)."""
    from vojax._tracker import _level, _threads
    from vojax._tracker._tuning import Tuning

    seen, ratios = [], []
    monkeypatch.setattr(_threads.os, "cpu_count", lambda: 1)  # the runs in order
    monkeypatch.setattr(_level, "fitting", lambda residuals, *a: np.array(
        [fits(r) for r in ratios[len(ratios) - residuals.shape[0]:]]))
    original = _threads.in_threads

    def spy(problem, fn, count, call, key):
        out = original(problem, fn, count, call, key)
        seen.append(count)
        return out

    monkeypatch.setattr(_level, "in_threads", spy)
    original_modes = _level.smoother_modes

    def modes(memory, u, y, mask, steps, horizon, hyper, m, p, start, *rest):
        ratios.append(round(float(np.asarray(start)[0, 1] / mean_p), 3))
        return original_modes(memory, u, y, mask, steps, horizon, hyper, m, p, start, *rest)

    monkeypatch.setattr(_level, "smoother_modes", modes)
    # the first round's ratios and their extensions only (no bisections)
    problem, _ = _normalised(_ramp_case(n=120), 120, columns=1,
                             settings=vojax.TrackerSettings(level_splits=0))
    hyper = Hyper(*(jnp.log(jnp.asarray(v)) for v in (0.1, 1e-6, 1e-2)))
    start = jnp.asarray(np.broadcast_to([0.0, 1.0, 0.0], (120, 3)))
    sm = problem.smooth(hyper, start)
    mean_p = float(np.mean(np.asarray(sm.theta)[:, 1]))
    tuning = Tuning.of(np.log([0.1, 1e-6, 1e-2]), (), sm.log_likelihood, True)
    out = _level.level_profile(problem, tuning, sm, 1e-2)
    groups, k = [], 0
    for count in seen:
        groups.append(tuple(ratios[k : k + count]))
        k += count
    assert groups == visited
    # every held run is an explanation for the band, each at a level of its own (a run that
    # ignored its ratio would repeat another's order)
    assert [e.kind for e in out] == ["level"] * len(ratios)
    levels = [round(float(np.mean(e.beta)), 6) for e in out]
    assert len(set(levels)) == len(ratios)


def test_level_profile_bisects_between_a_fitting_and_a_failing_scale():
    """`level_next`: between the nearest held ratio that does not fit and its fitting inner
    neighbour (the tuned scale, ratio 1, at the least) the profile bisects on the log scale
    while the failing run's order is more than 2σ of the neighbour's from it, down to √2's
    `level_splits`-th halving; past an outermost ratio that fits it goes on by √2."""
    from vojax._tracker._level import level_next

    settings = vojax.TrackerSettings()
    LEVEL_SPLITS = settings.level_splits

    def _level_next(tried, side, n):
        return level_next(tried, side, n, settings)

    n = 50
    sd = np.full(n, 0.01)

    def run(fits, beta):
        return (fits, np.full(n, beta), sd)

    def step(tried, side):
        return [round(r, 4) for r in _level_next(tried, side, n)]

    anchor = {1.0: run(True, 0.0)}
    # above: 1.41 fails with its order 5σ away → the log-midpoint 2^(1/4); below: every
    # ratio fits → past the outermost, 0.5/√2
    tried = {**anchor, 1.41421356: run(False, 0.05), 2.0: run(False, 0.2),
             0.70710678: run(True, -0.01), 0.5: run(True, -0.02)}
    assert step(tried, 1) == [round(2**0.25, 4)]
    assert step(tried, -1) == [round(0.5 / 2**0.5, 4)]
    # the failing run's order within 2σ of its neighbour's: that band covers the gap
    assert step({**anchor, 1.41421356: run(False, 0.015)}, 1) == []
    # the bisections go on from the ratio that fits, until √2's LEVEL_SPLITS-th halving
    tried = {**anchor, 1.41421356: run(False, 0.05)}
    visited = []
    while nxt := _level_next(tried, 1, n):
        (r,) = nxt
        visited.append(r)
        tried[r] = run(r < 1.2, 0.01 if r < 1.2 else 0.05)
    assert len(visited) == LEVEL_SPLITS == 3
    np.testing.assert_allclose(visited, [2 ** (1 / 4), 2 ** (3 / 8), 2 ** (5 / 16)])
    # a ratio that fits beyond one that does not: both the bisection and the extension
    tried = {**anchor, 1.41421356: run(False, 0.05), 2.0: run(True, 0.1)}
    assert sorted(step(tried, 1)) == [round(2**0.25, 4), round(2 * 2**0.5, 4)]
    # nothing beyond the outermost allowed ratio (4)
    assert step({**anchor, 4.0: run(True, 0.3)}, 1) == []
