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


def test_the_four_laws_share_a_program_and_padding_changes_no_fit(monkeypatch):
    """The springpot, Maxwell, Kelvin–Voigt and Zener fits of one record trace the fit once
    between them (each padded to two integrated inputs and one direct regressor with zero
    columns, held at 0); each equals its fit without the padding to the solver's tolerance,
    its coefficients' covariance included."""
    import functools

    from vojax import _refit_active
    from vojax._refit import TRACES

    n = 263  # a length no other test fits: the first law traces, the others reuse it
    stress = U[:n, 1]
    strain = np.asarray(vojax.simulate(stress, 0.5, np.array([0.8]), DT))
    strain = strain + NOISE * np.random.default_rng(9).standard_normal(n)
    laws = (vojax.Springpot(), vojax.FractionalMaxwell(), vojax.KelvinVoigt(),
            vojax.FractionalZener())

    def fit(m):
        return vojax.refit(m.inputs(stress, strain), strain, DT, direct=m.direct(stress, strain),
                           p_signs=m.p_signs)

    padded = []
    for k, m in enumerate(laws):
        before = TRACES["fit"]
        padded.append(fit(m))
        assert TRACES["fit"] == before + (k == 0), m  # after the first law: no trace
    monkeypatch.setattr(_refit_active, "_active_set", functools.partial(
        _refit_active._active_set, pad_direct=0, pad_inputs=0))
    for m, a in zip(laws, padded):
        b = fit(m)
        assert a.p_at_bound == b.p_at_bound
        for name in ("order", "order_stderr", "p", "p_stderr", "p_cov", "y_hat"):
            np.testing.assert_allclose(getattr(a, name), getattr(b, name), rtol=1e-8, atol=1e-9)
        assert float(a.sigma) == pytest.approx(float(b.sigma), rel=1e-8)


@pytest.mark.parametrize("order", ["constant", pytest.param(3, marks=pytest.mark.slow)])
def test_padding_with_a_mask_changes_nothing(order):
    """Padded after the end and masked: the same fit (knots over the fitted span), to the
    solver's tolerance (rtol = atol = 1e-10 on the parameters)."""
    from vojax._data._pipeline import _padded

    n = 300
    y = _data(0.5, seed=8)[:n]
    a = vojax.refit(U[:n], y, DT, order=order)
    b = _padded(vojax.refit, U[:n], y, 384, dt=DT, order=order)
    for name in ("order", "order_stderr", "p", "p_stderr", "y_hat", "knot_times"):
        np.testing.assert_allclose(getattr(b, name), getattr(a, name), rtol=1e-8, atol=1e-9)
    assert float(b.sigma) == pytest.approx(float(a.sigma), rel=1e-8)


@pytest.mark.parametrize("order", ["constant", 0.4])
def test_a_coefficient_fitted_to_rounding_is_exactly_zero(order):
    """An output constant over the fit window, offset estimated: no coefficient explains anything. Least
    squares leaves them at ±1e-16 (the sign set by the machine's rounding, and 1/p of a model
    at ±1e16); the refit reports 0, and the offset is the constant."""
    y = 0.2 * np.minimum(T / 10.0, 1.0)  # a ramp, then a hold: only the hold is fitted
    fixed = order if isinstance(order, str) else np.full(T.size, order)
    fit = vojax.refit(U, y, DT, order=fixed, window=(20.0, 80.0))
    assert np.all(np.asarray(fit.p) == 0.0)
    assert float(fit.x0) == pytest.approx(0.2, rel=1e-12)
    # a real coefficient of the same size as the data is not touched
    fit = vojax.refit(U, _data(0.62, seed=0), DT, x0=0.0)
    assert np.all(np.asarray(fit.p) != 0.0)


@pytest.mark.parametrize("order", ["constant", 0.5, 2])
def test_sign_constraints_do_not_depend_on_the_units_of_the_inputs(order):
    """Two coefficients break their signs in the free fit; which one the active set holds
    first decides the answer (here: the first held, the second positive, or both held).
    Ranked in standard errors the choice is unit-free: the second input in other units
    (×1e-4, ×1e4) gives the same physical coefficients. Ranked by magnitude, ×1e-4 makes the
    second coefficient 1e4 times larger and holds it first, and both end at 0. The order
    fixed (0.5), constant, or moving on 2 knots (an integer): a constant order's profile
    check can mend a wrong first choice, the knots' fit has none."""
    n, dt = 300, 0.01
    t = dt * np.arange(n)
    u1 = np.sin(2 * np.pi * t) + 1.0
    u2 = -0.8 * u1 + 0.3 * np.cos(5 * t)
    fixed = order if isinstance(order, (str, int)) else np.full(n, order)
    phi = np.asarray(vojax.fractional_integral(np.stack([u1, u2], 1), np.full(n, 0.5), dt))
    y = -phi[:, 0] - 0.6 * phi[:, 1] + 0.01 * np.random.default_rng(0).standard_normal(n)
    fits = {}
    for c in (1.0, 1e-4, 1e4):
        fit = vojax.refit(np.stack([u1, c * u2], 1), y, dt, order=fixed, p_signs=[1, 1], x0=0.0)
        fits[c] = (np.asarray(fit.p) * [1.0, c], fit.p_at_bound)
    assert fits[1.0][1] == (True, False) and fits[1.0][0][1] > 0.5
    for c in (1e-4, 1e4):
        assert fits[c][1] == fits[1.0][1]
        np.testing.assert_allclose(fits[c][0], fits[1.0][0], rtol=1e-6)


def test_a_constant_order_does_not_depend_on_the_unit_of_time():
    """φ in another time unit is φ·c^α, which the coefficient absorbs at a constant order: the
    same order (to the solver's tolerance) and p·c^α, with the times in s, ms, h, ×1e12 and
    ×1e-12. (A variable order is another matter: "p constant" means another model in
    another unit, docs/choices.md.)"""
    y = _data(0.42, seed=3)[:400]
    t = T[:400]
    a = vojax.refit(U[:400], y, t=t)
    for c in (1e-3, 1 / 3600, 1e12, 1e-12):
        b = vojax.refit(U[:400], y, t=t * c)
        assert float(b.order[0]) == pytest.approx(float(a.order[0]), abs=1e-8)
        np.testing.assert_allclose(np.asarray(b.p) * c ** float(a.order[0]), a.p, rtol=1e-6)
        assert float(b.order_stderr[0]) == pytest.approx(float(a.order_stderr[0]), rel=1e-5)


@pytest.mark.parametrize("knots", ["constant", 3])
def test_the_fit_does_not_depend_on_the_units_of_the_data(knots):
    """The output in metres of an AFM indentation (~1e-10 as a contact strain) and the input in
    newtons, or both ×1e9, or the input ×1e-6 and the output ×1e6: the same orders (to the
    solver's tolerance), p scaled by c_y/c_u, x0 and σ by c_y. Absolute tolerances on the
    residuals and coefficients made the solver stop at its start (order 0.5 with 1e-10-sized
    data)."""
    y = _data(0.42, seed=3)[:400]
    u = U[:400]
    a = vojax.refit(u, y, t=T[:400], order=knots)
    assert abs(float(a.order[-1]) - 0.5) > 0.02  # the start is not the answer
    for cu, cy in ((1.0, 1e-10), (1e-9, 1e-18), (1e-6, 1e6), (1e9, 1.0)):
        b = vojax.refit(u * cu, y * cy, t=T[:400], order=knots)
        np.testing.assert_allclose(np.asarray(b.order), np.asarray(a.order), rtol=0, atol=1e-7)
        np.testing.assert_allclose(np.asarray(b.p) * cu / cy, np.asarray(a.p), rtol=1e-6)
        assert float(b.x0) / cy == pytest.approx(float(a.x0), rel=1e-6, abs=1e-9 * np.ptp(y))
        assert float(b.sigma) / cy == pytest.approx(float(a.sigma), rel=1e-6)


def test_a_start_on_a_bound_starts_inside_and_an_order_beyond_the_range_sits_at_its_bound():
    """The default start 0.5 on the lower bound of (0.5, 0.9): the fit starts just inside (its
    logit would be −∞ there). Inside the range it finds the true 0.62 as from any start;
    with the true order 0.35 below the range it ends at the bound, says so, and its band is
    finite and within the range."""
    y = _data(0.62, seed=0)
    inside = vojax.refit(U, y, DT, x0=0.0, order_bounds=(0.5, 0.9))
    free = vojax.refit(U, y, DT, x0=0.0)
    assert inside.result == optx.RESULTS.successful and not inside.at_bound
    assert float(inside.order[0]) == pytest.approx(float(free.order[0]), abs=1e-8)
    low = _data(0.35, seed=0)
    with pytest.warns(vojax.RefitWarning, match="sits at a bound"):
        fit = vojax.refit(U, low, DT, x0=0.0, order_bounds=(0.5, 0.9))
    assert fit.at_bound and float(fit.order[0]) == pytest.approx(0.5, abs=1e-4)
    for name in ("order_lower", "order_upper", "order_stderr"):
        assert np.all(np.isfinite(np.asarray(getattr(fit, name)))), name
    assert 0.5 <= float(fit.order_lower[0]) <= float(fit.order[0]) <= float(fit.order_upper[0]) <= 0.9


def test_the_second_opinion_also_starts_inside_a_bound():
    """`refit_lbfgsb` from the default start 0.5 on the lower bound of (0.5, 0.9): its start's
    logit would be −∞ and its coefficients NaN; started inside, it finds the same order and
    coefficients as `refit` on the same record."""
    pytest.importorskip("jaxopt")
    from vojax._refit import refit_lbfgsb

    n = 400
    y = _data(0.62, seed=0)[:n]
    lm = vojax.refit(U[:n], y, DT, x0=0.0, order_bounds=(0.5, 0.9))
    beta, p = refit_lbfgsb(U[:n], y, DT, x0=0.0, order_bounds=(0.5, 0.9))
    assert np.all(np.isfinite(np.asarray(p)))
    assert abs(float(beta[0]) - float(lm.order[0])) < 0.1 * float(lm.order_stderr[0])
    assert np.max(np.abs(np.asarray(p) - np.asarray(lm.p)) / np.asarray(lm.p_stderr)) < 0.1


def _short_record():
    """A 40-sample record at 0.1 s (order 0.4, p 1, a small sine on top): ``(u, y)``. At a
    step of 1e-300 s its columns are ~1e-120."""
    t = 0.1 * np.arange(40)
    u = np.minimum(t, 1.0) + 0.1
    return u, np.asarray(vojax.simulate(u, 0.4, 1.0, 0.1)) + 1e-3 * np.sin(7 * t)


def test_the_second_opinion_checks_its_solver_settings_and_its_answer():
    """`refit_lbfgsb`'s `tol` and `max_steps` are checked (a text `tol` failed inside the
    solver with "'>' not supported between instances of 'DynamicJaxprTracer' and 'str'"),
    and an answer outside float64's range is refused, not returned as NaN: with an offset
    of 2**63 or a step of 1e-300 s (columns of ~1e-150) the solver steps out of it or stops
    at a finite answer, by the versions installed (the newest: the offset steps out); never
    NaN."""
    pytest.importorskip("jaxopt")
    from vojax._refit import refit_lbfgsb

    y = _data(0.62, seed=0)[:200]
    for tol in (None, "1e-9", -1.0, float("nan")):
        with pytest.raises((TypeError, ValueError), match="`tol` must be"):
            refit_lbfgsb(U[:200], y, DT, x0=0.0, tol=tol)
    for steps in (0, 2.5, True):
        with pytest.raises((TypeError, ValueError), match="`max_steps` must be"):
            refit_lbfgsb(U[:200], y, DT, x0=0.0, max_steps=steps)
    u, short = _short_record()
    for step, x0 in ((0.1, 2**63), (1e-300, 0.0)):
        try:
            answer = refit_lbfgsb(u, short, step, x0=x0, max_steps=30)
        except ValueError as e:
            assert "refit_lbfgsb reached no finite answer on these data" in str(e)
        else:
            assert all(np.all(np.isfinite(np.asarray(a))) for a in answer)
    order, p = refit_lbfgsb(u, short, 0.1, x0=0.0, max_steps=30)  # the same record, in seconds
    assert np.all(np.isfinite(np.asarray(order))) and np.all(np.isfinite(np.asarray(p)))


def _lbfgsb_warnings(*args, **kwargs):
    """`refit_lbfgsb`'s answer and the `RefitWarning` messages it gave."""
    import warnings

    from vojax._refit import refit_lbfgsb

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", vojax.RefitWarning)
        answer = refit_lbfgsb(*args, **kwargs)
    return answer, [str(w.message) for w in caught if w.category is vojax.RefitWarning]


def test_the_second_opinion_says_when_it_stopped_before_converging():
    """L-BFGS-B stopped by `max_steps` returns where it stopped: with 3 steps on a 40-sample
    record the projected gradient's norm is ~0.3 (converged, 8 steps, it is 2e-13), and on a
    step of 1e-300 s (columns of ~1e-120) the order stays at its start 0.5 with p ~1e149 after
    all 30 steps. Both are said (`RefitWarning`, the norm and `tol` named), or refused as no
    finite answer; the converged fit says nothing, and `warn=False` silences it."""
    pytest.importorskip("jaxopt")
    u, short = _short_record()
    (order, p), said = _lbfgsb_warnings(u, short, 0.1, x0=0.0)
    assert said == [] and abs(float(order[0]) - 0.4) < 1e-3 and abs(float(p[0]) - 1.0) < 1e-3
    (order, _), said = _lbfgsb_warnings(u, short, 0.1, x0=0.0, max_steps=3)
    assert len(said) == 1 and "did not converge (it took all 3 of `max_steps`" in said[0]
    assert "above `tol` 1e-12" in said[0]
    assert _lbfgsb_warnings(u, short, 0.1, x0=0.0, max_steps=3, warn=False)[1] == []
    try:
        _, said = _lbfgsb_warnings(u, short, 1e-300, x0=0.0, max_steps=30)
    except ValueError as e:
        assert "refit_lbfgsb reached no finite answer on these data" in str(e)
    else:
        assert len(said) == 1 and "did not converge" in said[0]
    from vojax._refit import refit_lbfgsb

    with pytest.raises((TypeError, ValueError), match="`warn` must be"):
        refit_lbfgsb(u, short, 0.1, x0=0.0, warn="yes")


@pytest.mark.parametrize("second_opinion", [False, True])
def test_a_start_outside_the_range_is_named_in_the_refits_own_words(second_opinion):
    """The message names `order0` and `order_bounds`, the arguments the caller gave (not the
    tracker's `alpha0` and `alpha_bounds`)."""
    if second_opinion:
        pytest.importorskip("jaxopt")
        from vojax._refit import refit_lbfgsb as fit
    else:
        fit = vojax.refit
    y = _data(0.62, seed=0)
    with pytest.raises(ValueError, match=r"`order0` must lie inside `order_bounds` \(0.1, 0.4\)"):
        fit(U, y, DT, x0=0.0, order0=0.5, order_bounds=(0.1, 0.4))
    with pytest.raises(ValueError, match="`order0` must be a positive finite number"):
        fit(U, y, DT, x0=0.0, order0=float("nan"))
