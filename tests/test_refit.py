"""`refit` against known truth and against linear least squares."""

import jax.numpy as jnp
import numpy as np
import optimistix as optx
import pytest

import vojax
from vojax._refit import _order_curve

DT = 0.05
T = np.arange(1601) * DT
U = np.stack([np.sin(0.7 * T) + 0.3 * np.sin(1.9 * T), 1 + 0.5 * np.cos(0.25 * T)], axis=1)
P = np.array([2.0, -1.0])
NOISE = 0.01


def _data(order, seed):
    x = np.asarray(vojax.simulate(U, order, P, DT))
    return x + NOISE * np.random.default_rng(seed).standard_normal(x.shape)


def test_constant_order_recovered_within_standard_errors():
    y = _data(0.62, seed=0)
    fit = vojax.refit(U, y, DT, x0=0.0)
    assert fit.result == optx.RESULTS.successful
    se = float(fit.order_stderr[0])
    assert 0 < se < 1e-3
    assert float(fit.knots_stderr[0]) == pytest.approx(se, rel=1e-12)
    assert abs(float(fit.order[0]) - 0.62) < 4 * se
    assert np.all(np.abs(np.asarray(fit.p) - P) < 4 * np.asarray(fit.p_stderr))
    assert abs(float(fit.sigma) - NOISE) < 0.1 * NOISE


def test_knot_order_recovered_within_standard_errors():
    raw = jnp.array([-0.6, 0.3, 0.9])  # an order curve from the model's own family
    truth = np.asarray(_order_curve(raw, T.size, (0.01, 0.99)))
    y = _data(truth, seed=1)
    fit = vojax.refit(U, y, DT, order=3, x0=0.0)
    assert fit.result == optx.RESULTS.successful
    err = np.abs(np.asarray(fit.order) - truth)
    assert np.all(err < 4 * np.asarray(fit.order_stderr) + 1e-12)
    assert np.all(np.abs(np.asarray(fit.p) - P) < 4 * np.asarray(fit.p_stderr))


def test_fixed_order_is_linear_least_squares():
    order = 0.4 + 0.1 * np.sin(0.05 * T)
    y = _data(order, seed=2)
    fit = vojax.refit(U, y, DT, order=order, x0=0.0)
    phi = np.asarray(vojax.fractional_integral(U, order, DT, memory="exponential"))
    p_ls = np.linalg.lstsq(phi, y, rcond=None)[0]
    assert np.max(np.abs(np.asarray(fit.p) - p_ls)) < 1e-10
    assert np.max(np.abs(np.asarray(fit.y_hat) - phi @ p_ls)) < 1e-10


@pytest.mark.parametrize(
    "kwargs, match",
    [
        (dict(order="spline"), "`order` must be 'constant'"),
        (dict(order=0), "number of knots must be in"),
        (dict(order=np.full(5, 0.5)), "`order` must be a scalar or have shape"),
        (dict(order_bounds=(0.5, 0.2)), "`order_bounds` must satisfy"),
    ],
)
def test_refit_validation(kwargs, match):
    with pytest.raises(ValueError, match=match):
        vojax.refit(U, np.linspace(0.0, 1.0, T.size), DT, **kwargs)


@pytest.mark.slow
@pytest.mark.parametrize("order", ["constant", 3])
def test_lbfgsb_second_opinion_agrees(order):
    pytest.importorskip("jaxopt")
    from vojax._refit import refit_lbfgsb

    raw = jnp.array([-0.6, 0.3, 0.9])
    truth = 0.62 if order == "constant" else np.asarray(_order_curve(raw, T.size, (0.01, 0.99)))
    n = 600  # a shorter record: L-BFGS-B takes a few hundred gradient evaluations
    y = _data(truth, seed=3)[:n]
    lm = vojax.refit(U[:n], y, DT, order=order, x0=0.0)
    beta, p = refit_lbfgsb(U[:n], y, DT, order=order, x0=0.0)
    # both minimise the same objective: they agree well inside the standard errors
    assert (
        np.max(np.abs(np.asarray(beta) - np.asarray(lm.order)) / np.asarray(lm.order_stderr)) < 0.1
    )
    assert np.max(np.abs(np.asarray(p) - np.asarray(lm.p)) / np.asarray(lm.p_stderr)) < 0.1


def test_refit_intervals_cover_and_offset_is_estimated():
    """20 noise seeds of a white-noise-driven record: the ±2σ interval (95 %) of the order,
    of p and of the estimated offset cover the truth in ≥ 17 of 20."""
    n, dt = 600, 0.05
    rng = np.random.default_rng(7)
    u = rng.standard_normal(n)
    x = np.asarray(vojax.simulate(u, 0.45, np.array([1.3]), dt)) + 2.0
    hits = np.zeros(3, int)
    for seed in range(20):
        y = x + 0.05 * np.std(x) * np.random.default_rng(seed).standard_normal(n)
        fit = vojax.refit(u, y, dt)
        hits[0] += float(fit.order_lower[0]) <= 0.45 <= float(fit.order_upper[0])
        hits[1] += abs(float(fit.p[0]) - 1.3) <= 2 * float(fit.p_stderr[0])
        hits[2] += abs(float(fit.x0) - 2.0) <= 2 * float(fit.x0_stderr)
        assert not fit.at_bound
    assert np.all(hits >= 17), hits


def test_refit_knots_avoid_t0_and_flag_bounds():
    n, dt = 400, 0.05
    u = np.random.default_rng(2).standard_normal(n)
    x = np.asarray(vojax.simulate(u, 0.02, np.array([1.0]), dt))
    fit = vojax.refit(u, x, dt, order=3, order_bounds=(0.05, 0.95))
    assert float(fit.knot_times[0]) > 0.0
    np.testing.assert_allclose(fit.knot_times, (np.arange(3) + 0.5) / 3 * (n - 1) * dt)
    assert fit.at_bound  # the truth 0.02 lies below the range: the fit sits on the bound
    assert np.all(np.asarray(fit.order_lower) >= 0.05)


def test_standard_errors_are_the_gauss_newton_covariance():
    """p_stderr and order_stderr equal sqrt(diag(σ̂² (JᵀJ)⁻¹)) with J = [Σ p_j ∂φ_j/∂β, φ]
    built from `order_sensitivity` (direct memory) at the fitted order."""
    y = _data(0.55, seed=4)[:800]
    u = U[:800]
    fit = vojax.refit(u, y, DT, x0=0.0)
    q = float(fit.order[0])
    phi = np.asarray(vojax.fractional_integral(u, q, DT))
    dphi = np.asarray(vojax.order_sensitivity(u, q, DT))
    p = np.asarray(fit.p)
    jac = np.column_stack([dphi @ p, phi])
    res = y - phi @ p
    sigma2 = res @ res / (y.size - 3)
    cov = sigma2 * np.linalg.inv(jac.T @ jac)
    np.testing.assert_allclose(fit.order_stderr[0], np.sqrt(cov[0, 0]), rtol=1e-6)
    np.testing.assert_allclose(fit.p_stderr, np.sqrt(np.diag(cov)[1:]), rtol=1e-6)
    np.testing.assert_allclose(fit.p_cov, cov[1:, 1:], rtol=1e-6)


def _ar1(n, rho, seed):
    white = np.random.default_rng(seed).standard_normal(n)
    out = np.empty(n)
    out[0] = white[0]
    for k in range(1, n):
        out[k] = rho * out[k - 1] + np.sqrt(1 - rho**2) * white[k]
    return out


def test_correlated_residuals_inflate_the_gauss_newton_errors():
    """AR(1) measurement noise (ρ = 0.9): the errors are the Gauss–Newton ones (as the test
    above builds them) × √((1 + ρ̂)/(1 − ρ̂)), ρ̂ the residuals' lag-1 autocorrelation
    computed here; the order's interval is ±2 of the inflated σ on the logistic scale; the
    fit warns that its residuals are correlated."""
    n = 800
    x = np.asarray(vojax.simulate(U[:n], 0.55, P, DT))
    y = x + NOISE * _ar1(n, 0.9, 7)
    with pytest.warns(vojax.RefitWarning, match="residuals are correlated"):
        fit = vojax.refit(U[:n], y, DT, x0=0.0)
    q = float(fit.order[0])
    phi = np.asarray(vojax.fractional_integral(U[:n], q, DT))
    dphi = np.asarray(vojax.order_sensitivity(U[:n], q, DT))
    p = np.asarray(fit.p)
    jac = np.column_stack([dphi @ p, phi])
    res = y - phi @ p
    e = res - res.mean()
    rho = float(e[1:] @ e[:-1] / (e @ e))
    assert rho > 0.5 and fit.residual_correlation == pytest.approx(rho, rel=1e-6)
    factor = np.sqrt((1 + rho) / (1 - rho))
    assert fit.error_inflation == pytest.approx(factor, rel=1e-6)
    cov = res @ res / (n - 3) * np.linalg.inv(jac.T @ jac) * factor**2
    np.testing.assert_allclose(fit.order_stderr[0], np.sqrt(cov[0, 0]), rtol=1e-5)
    np.testing.assert_allclose(fit.p_stderr, np.sqrt(np.diag(cov)[1:]), rtol=1e-5)
    z = (q - 0.01) / 0.98
    raw, raw_sd = np.log(z / (1 - z)), np.sqrt(cov[0, 0]) / (0.98 * z * (1 - z))
    upper = 0.01 + 0.98 / (1 + np.exp(-(raw + 2 * raw_sd)))
    np.testing.assert_allclose(fit.order_upper[0], upper, rtol=1e-6)


@pytest.mark.slow
def test_standard_errors_with_ar1_noise_are_calibrated_over_40_seeds():
    """As the white-noise test below, with AR(1) noise of ρ = 0.8: the spread of the order
    over 40 realisations over its mean reported (inflated) error lies in [0.7, 1.4], and the
    ±2σ interval holds the truth in 85–99 % of them (without the inflation, in about half)."""
    n = 500
    x = np.asarray(vojax.simulate(U[:n], 0.45, P, DT))
    orders, se, inside = [], [], []
    for seed in range(40):
        fit = vojax.refit(U[:n], x + 0.02 * _ar1(n, 0.8, 300 + seed), DT, x0=0.0, warn=False)
        orders.append(float(fit.order[0]))
        se.append(float(fit.order_stderr[0]))
        inside.append(float(fit.order_lower[0]) <= 0.45 <= float(fit.order_upper[0]))
    ratio = np.std(orders, ddof=1) / np.mean(se)
    assert 0.7 <= ratio <= 1.4, ratio
    assert 0.85 <= np.mean(inside) <= 0.99, np.mean(inside)


def test_knot_standard_errors_from_an_autodiff_jacobian(monkeypatch):
    """With three knots, the order's standard errors equal the delta method on σ̂² (JᵀJ)⁻¹ with J
    the autodiff Jacobian of the model written afresh (direct memory, `jax.jacfwd`); and the
    fit is the same whether the order-free history is stored or the record is scanned at every
    evaluation."""
    import functools

    import jax

    from vojax import _refit_solve

    lo, hi = 0.01, 0.99
    y = _data(0.55, seed=4)[:600]
    u = U[:600]
    fit = vojax.refit(u, y, DT, order=3, x0=0.0)
    raw = np.log((np.asarray(fit.knots) - lo) / (hi - fit.knots))

    def model(theta):
        beta = _order_curve(theta[:3], 600, (lo, hi))
        return vojax.fractional_integral(u, beta, DT) @ theta[3:]

    theta = jnp.concatenate([jnp.asarray(raw), fit.p])
    jac = np.asarray(jax.jacfwd(model)(theta))
    res = y - np.asarray(model(theta))
    cov = res @ res / (y.size - 5) * np.linalg.inv(jac.T @ jac)
    grad = np.asarray(jax.jacfwd(lambda r: _order_curve(r, 600, (lo, hi)))(theta[:3]))
    np.testing.assert_allclose(
        fit.order_stderr, np.sqrt(np.einsum("ni,ij,nj->n", grad, cov[:3, :3], grad)), rtol=1e-5
    )
    np.testing.assert_allclose(fit.p_stderr, np.sqrt(np.diag(cov)[3:]), rtol=1e-5)
    # the knots' own errors (the summary's), by the delta method through the logistic map
    s = (np.asarray(fit.knots) - lo) / (hi - lo)
    np.testing.assert_allclose(
        fit.knots_stderr, (hi - lo) * s * (1 - s) * np.sqrt(np.diag(cov)[:3]), rtol=1e-5
    )
    table = fit.summary()
    assert [v["stderr"] for k, v in table.items() if k.startswith("order at knot")] == [
        float(v) for v in np.asarray(fit.knots_stderr)
    ]
    scan_always = functools.partial(_refit_solve.order_map, history_limit=0)
    monkeypatch.setattr(_refit_solve, "order_map", scan_always)
    scanned = vojax.refit(u, y, DT, order=3, x0=0.0, max_steps=201)  # a new program
    for name in ("order", "order_stderr", "p", "p_stderr"):
        np.testing.assert_allclose(getattr(scanned, name), getattr(fit, name), rtol=1e-7)


def test_standard_errors_are_calibrated_over_40_seeds():
    """The spread of the order and of p over 40 noise realisations, divided by the mean
    reported standard error, lies in [0.7, 1.4] (too small or too large errors both fail)."""
    n = 500
    x = np.asarray(vojax.simulate(U[:n], 0.45, P, DT))
    orders, ps, se_order, se_p = [], [], [], []
    for seed in range(40):
        y = x + 0.02 * np.random.default_rng(100 + seed).standard_normal(n)
        fit = vojax.refit(U[:n], y, DT, x0=0.0)
        orders.append(float(fit.order[0]))
        ps.append(np.asarray(fit.p))
        se_order.append(float(fit.order_stderr[0]))
        se_p.append(np.asarray(fit.p_stderr))
    ratio_order = np.std(orders, ddof=1) / np.mean(se_order)
    ratio_p = np.std(ps, axis=0, ddof=1) / np.mean(se_p, axis=0)
    assert 0.7 <= ratio_order <= 1.4, ratio_order
    assert np.all((ratio_p >= 0.7) & (ratio_p <= 1.4)), ratio_p


def test_refit_traces_once_per_shape():
    """Numbers are arrays and the model is built inside the compiled function: new data, a new
    start order and new tolerances reuse the program; only a new shape traces again."""
    from vojax._refit import TRACES

    n = 300
    vojax.refit(U[:n], _data(0.5, seed=5)[:n], DT)
    before = TRACES["fit"]
    vojax.refit(U[:n], _data(0.4, seed=6)[:n], DT, order0=0.3, rtol=1e-9, atol=1e-9)
    vojax.refit(U[:n], _data(0.6, seed=7)[:n], DT * 1.01)
    assert TRACES["fit"] == before
    vojax.refit(U[: n + 1], _data(0.6, seed=7)[: n + 1], DT)
    assert TRACES["fit"] == before + 1
