"""The Kalman passes and the smoother's iteration: the filter and the RTS smoother equal the
dense batch posterior, the damped pass and Nielsen's damping, the mode and bands against a
dense NumPy posterior, the online filter against a textbook iterated EKF."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from vojax._tracker import Hyper, KalmanTracker, kalman_filter, rts_smoother
from vojax._tracker._fit import _scan_filter


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
    from vojax._tracker._damping import MU_MIN, damping

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


@pytest.mark.parametrize("coloured", [False, True])
def test_damped_step_minimises_the_linearised_posterior_it_predicts(coloured):
    """The cost the damping rule compares with (`posterior_cost` of the model linearised at
    θ) equals the posterior's `objective` at θ itself, and the damped pass's step minimises
    it plus μ‖x − θ‖²: the autodiff gradient of that sum vanishes at the step (summed over
    time for the offset, which is one constant)."""

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
