"""`refit` on recordings as they come: sample times, the start of the test before the first
sample, fit windows and weights, order-0 regressors and sign constraints."""

import math

import numpy as np
import optimistix as optx
import pytest

import vojax

Q, INV_ETA, SIGMA0 = 0.23, 0.8, 2.0


def _creep_grid(num=160, first=10.0, last=1e6):
    return np.geomspace(first, last, num)


def _closed_form_fit(t, y, origin=0.0):
    """Least squares of ``y = x0 + c (t − T0)^q / Γ(1+q)`` on the samples, independently of
    vojax: for each q the model is linear in (x0, c); q minimises the residual sum of squares
    by golden-section search to 1e-12."""

    def rss(q):
        a = np.column_stack([np.ones_like(t), (t - origin) ** q / math.gamma(1 + q)])
        coef = np.linalg.lstsq(a, y, rcond=None)[0]
        return np.sum((y - a @ coef) ** 2), coef

    lo, hi = 0.02, 0.98
    g = (math.sqrt(5) - 1) / 2
    c, d = hi - g * (hi - lo), lo + g * (hi - lo)
    while hi - lo > 1e-12:
        if rss(c)[0] < rss(d)[0]:
            hi, d = d, c
            c = hi - g * (hi - lo)
        else:
            lo, c = c, d
            d = lo + g * (hi - lo)
    q = 0.5 * (lo + hi)
    return q, rss(q)[1]


def test_log_spaced_creep_from_the_true_origin_matches_the_closed_form():
    """A step load at t = 0, samples log-spaced from 10 to 1e6 s: `refit(t=…, origin=0)` finds
    the same q as the closed-form least squares on the same samples, to 1e-6; started at the
    first sample instead (no origin) it fits a different model."""
    t = _creep_grid()
    rng = np.random.default_rng(0)
    x = 0.1 + SIGMA0 * INV_ETA * t**Q / math.gamma(1 + Q)
    y = x * (1 + 0.01 * rng.standard_normal(t.size))
    q_ref, coef = _closed_form_fit(t, y)
    u = np.full(t.size, SIGMA0)
    fit = vojax.refit(u, y, t=t, origin=0.0)
    assert fit.result == optx.RESULTS.successful
    assert abs(float(fit.order[0]) - q_ref) < 1e-6
    assert abs(float(fit.p[0]) * SIGMA0 - coef[1]) < 1e-5 * coef[1]
    assert abs(float(fit.x0) - coef[0]) < 1e-5 * abs(coef[1])
    late = vojax.refit(u, y, t=t)
    assert abs(float(late.order[0]) - q_ref) > 10 * float(fit.order_stderr[0])


def test_origin_with_a_step_equals_origin_with_times():
    """``dt`` with an origin and the same samples given as times run the same grid."""
    dt, n = 0.5, 120
    t = dt * np.arange(n)
    u = 1.0 + 0.3 * np.sin(t)
    x = np.asarray(vojax.simulate(np.r_[u[0], u], Q, np.array([INV_ETA]), t=np.r_[-3.0, t]))[1:]
    y = x + 1e-4 * np.random.default_rng(1).standard_normal(n)
    a = vojax.refit(u, y, dt, origin=-3.0)
    b = vojax.refit(u, y, t=t, origin=-3.0)
    for name in ("order", "order_stderr", "p", "p_stderr", "y_hat", "x0"):
        np.testing.assert_allclose(getattr(a, name), getattr(b, name), rtol=1e-9, atol=1e-12)
    assert a.y_hat.shape == (n,) and a.order.shape == (n,)
    assert abs(float(a.order[0]) - Q) < 4 * float(a.order_stderr[0])


def _ramp_hold(n=400, dt=0.05, ramp=60):
    """Strain-driven ramp–hold: the hold phase follows σ = η D^q ε written as ε = I^q σ / η with
    the measured σ; during the ramp the data follow another law (a stiffening 30 % excess)."""
    t = dt * np.arange(n)
    sigma = np.where(t < ramp * dt, t / (ramp * dt), 1.0) * 3.0
    x = np.asarray(vojax.simulate(sigma, Q, np.array([INV_ETA]), dt))
    bump = np.where(t < ramp * dt, 0.3 * x * np.sin(np.pi * t / (ramp * dt)), 0.0)
    y = x + bump + 2e-3 * np.random.default_rng(2).standard_normal(n)
    return t, sigma, y, ramp * dt


def test_window_recovers_the_hold_phase_truth():
    """Fitting the hold phase only (the whole stress history still drives the model) recovers
    q and 1/η within 3 standard errors; the whole record is biased by far more, and says so."""
    t, sigma, y, end = _ramp_hold()
    hold = vojax.refit(sigma, y, 0.05, window=(end, t[-1]), x0=0.0)
    assert abs(float(hold.order[0]) - Q) < 3 * float(hold.order_stderr[0])
    assert abs(float(hold.p[0]) - INV_ETA) < 3 * float(hold.p_stderr[0])
    # the whole record is biased by far more than the hold's error, its residuals follow
    # the missed bump (lag-1 correlation near 1): it warns, and its errors, inflated by
    # √((1 + ρ)/(1 − ρ)), cover its bias
    with pytest.warns(vojax.RefitWarning, match="correlated"):
        whole = vojax.refit(sigma, y, 0.05, x0=0.0)
    bias = abs(float(whole.order[0]) - Q)
    assert bias > 100 * float(hold.order_stderr[0])
    rho = whole.residual_correlation
    r = min(rho, 0.99)  # the inflation stops at ρ = 0.99 (×14)
    assert rho > 0.9 and whole.error_inflation == pytest.approx(np.sqrt((1 + r) / (1 - r)))
    assert bias < 2 * float(whole.order_stderr[0])
    assert hold.error_inflation == 1.0
    # the window is a weight: the same as a 0/1 mask
    mask = (t >= end).astype(float)
    masked = vojax.refit(sigma, y, 0.05, mask=mask, x0=0.0)
    np.testing.assert_allclose(masked.order, hold.order, rtol=1e-9)
    np.testing.assert_allclose(masked.p_stderr, hold.p_stderr, rtol=1e-7)


def test_weights_are_weighted_least_squares():
    """Weights: scaling them all changes nothing (σ̂² absorbs the scale); `relative` is
    weights 1/y²; and the errors are σ̂² (JᵀWJ)⁻¹ with J from `order_sensitivity`."""
    t, sigma, y, end = _ramp_hold()
    w = np.linspace(0.5, 2.0, t.size)
    a = vojax.refit(sigma, y, 0.05, weights=w, window=(end, t[-1]), x0=0.0)
    b = vojax.refit(sigma, y, 0.05, weights=7.0 * w, window=(end, t[-1]), x0=0.0)
    for name in ("order", "order_stderr", "p", "p_stderr"):
        np.testing.assert_allclose(getattr(a, name), getattr(b, name), rtol=1e-8)
    rel = vojax.refit(sigma, y, 0.05, relative=True, window=(end, t[-1]), x0=0.0)
    inv = vojax.refit(sigma, y, 0.05, weights=1 / y**2, window=(end, t[-1]), x0=0.0)
    np.testing.assert_allclose(rel.order, inv.order, rtol=1e-10)
    q, p = float(a.order[0]), np.asarray(a.p)
    phi = np.asarray(vojax.fractional_integral(sigma, q, 0.05))
    dphi = np.asarray(vojax.order_sensitivity(sigma, q, 0.05))
    ww = w * (t >= end)
    jac = np.column_stack([dphi * p[0], phi])
    res = y - phi * p[0]
    sigma2 = np.sum(ww * res**2) / (np.count_nonzero(ww) - 2)
    cov = sigma2 * np.linalg.inv(jac.T @ (ww[:, None] * jac))
    np.testing.assert_allclose(a.order_stderr[0], np.sqrt(cov[0, 0]), rtol=1e-5)
    np.testing.assert_allclose(a.p_stderr, np.sqrt(cov[1, 1]), rtol=1e-5)


def test_direct_regressor_fractional_maxwell():
    """ε = σ/E + I^q σ/η with a varying stress: the order-0 regressor (the spring) and the
    springpot are separated, each within 4 standard errors."""
    dt, n = 0.02, 800
    t = dt * np.arange(n)
    sigma = 1.0 + 0.5 * np.sin(1.3 * t) + 0.2 * np.cos(4.1 * t)
    inv_e = 0.4
    x = np.asarray(vojax.simulate(sigma, Q, np.array([INV_ETA]), dt)) + inv_e * sigma
    y = x + 1e-3 * np.random.default_rng(3).standard_normal(n)
    fit = vojax.refit(sigma, y, dt, direct=sigma, x0=0.0)
    assert fit.p.shape == (2,) and fit.p_cov.shape == (2, 2)
    truth = np.array([INV_ETA, inv_e])
    assert np.all(np.abs(np.asarray(fit.p) - truth) < 4 * np.asarray(fit.p_stderr))
    assert abs(float(fit.order[0]) - Q) < 4 * float(fit.order_stderr[0])


@pytest.mark.parametrize("fixed_order", [False, True])
def test_sign_constraint_holds_the_broken_coefficient_at_zero(fixed_order):
    """Data whose free two-input fit has the wrong sign on the second coefficient (a negative
    stiffness): with p_signs = (+1, −1) that coefficient is held at 0 and the rest equals the
    fit of the one-input model, which is what the constrained optimum is."""
    dt, n = 0.05, 300
    t = dt * np.arange(n)
    sigma = 1.0 + 0.4 * np.sin(0.9 * t)
    x = np.asarray(vojax.simulate(sigma, 0.4, np.array([1.0]), dt))
    y = x + 0.02 * x * np.sin(2.3 * t) + 1e-3 * np.random.default_rng(4).standard_normal(n)
    u = np.stack([sigma, y], axis=1)  # a Kelvin–Voigt-shaped regression
    order = np.full(n, 0.4) if fixed_order else "constant"
    free = vojax.refit(u, y, dt, order=order, x0=0.0)
    assert float(free.p[1]) > 0, "the data must break the sign for this test to mean anything"
    held = vojax.refit(u, y, dt, order=order, x0=0.0, p_signs=(1, -1))
    one = vojax.refit(sigma, y, dt, order=order, x0=0.0)
    assert held.p_at_bound == (False, True)
    assert float(held.p[1]) == 0.0 and float(held.p_stderr[1]) == 0.0
    np.testing.assert_allclose(held.p[0], one.p[0], rtol=1e-7)
    np.testing.assert_allclose(held.p_stderr[0], one.p_stderr[0], rtol=1e-6)
    np.testing.assert_allclose(held.order, one.order, rtol=1e-7)
    kept = vojax.refit(u, y, dt, order=order, x0=0.0, p_signs=(1, 1))
    assert kept.p_at_bound == (False, False)
    np.testing.assert_allclose(kept.p, free.p, rtol=1e-9)


@pytest.mark.parametrize(
    "kwargs, error, match",
    [
        (dict(weights=np.ones(5)), ValueError, r"`weights` must have shape \(50,\)"),
        (dict(weights=-np.ones(50)), ValueError, "non-negative"),
        (dict(window=(3.0, 1.0)), ValueError, "from < to"),
        (dict(window=3.0), TypeError, "pair of times"),
        (dict(window=(100.0, 200.0)), ValueError, "0 samples have a non-zero weight"),
        (dict(origin=0.0), ValueError, "before the first sample"),
        (dict(origin=-1.0, x0=None), ValueError, "output at the origin"),
        (dict(p_signs=(1, 2)), ValueError, "`p_signs` must hold 1 values"),
        (dict(direct=np.ones(7)), ValueError, "`direct` must have 50 samples"),
        (dict(relative=True), ValueError, "relative residuals divide by y"),
        (dict(t=np.arange(50.0)), TypeError, "exactly one of `dt`"),
    ],
)
def test_recording_options_validation(kwargs, error, match):
    u = np.ones(50)
    y = np.linspace(0.0, 1.0, 50)
    with pytest.raises(error, match=match):
        vojax.refit(u, y, 0.1, **kwargs)


def _kelvin_voigt_relaxation(q=0.3, eta=40.0, k=20.0, ramp=1.0, n=240):
    """A strain ramp to 0.2 over `ramp` s, then held; the stress of σ = kε + η D^q ε in closed
    form (Riemann–Liouville from rest): D^q of the ramp r t is r t^{1−q}/Γ(2−q), and the hold
    subtracts the same from t − ramp. Log-spaced times after a linear ramp, like the
    myocardium files."""
    t = np.concatenate([np.linspace(0.0, ramp, 41), ramp + np.geomspace(0.01, 100.0, n - 41)])
    r = 0.2 / ramp
    strain = np.minimum(t, ramp) * r
    d = r * (t ** (1 - q) - np.where(t > ramp, t - ramp, 0.0) ** (1 - q)) / math.gamma(2 - q)
    return t, k * strain + eta * d, strain


def test_a_hold_of_constant_output_is_not_a_confident_order():
    """Strain as output during a strain hold is constant: with the offset estimated, the hold
    alone does not determine the order, and the refit must not say it does (a pseudo-inverse of
    the normal matrix reported ±5e-10 here). From rest (x0 = 0) the same window recovers the
    truth (noise-free data: to the quadrature's error on this grid)."""
    t, stress, strain = _kelvin_voigt_relaxation()
    u = np.stack([stress, strain], axis=1)
    hold = (1.0, np.inf)
    loose = vojax.refit(u, strain, t=t, window=hold)
    assert not float(loose.order_stderr[0]) < 0.05
    assert float(loose.order_lower[0]) < 0.2 and float(loose.order_upper[0]) > 0.8
    fit = vojax.refit(u, strain, t=t, window=hold, x0=0.0)
    assert abs(float(fit.order[0]) - 0.3) < 0.01
    phys = vojax.KelvinVoigt().parameters(fit.p)
    assert abs(float(phys["k"]) - 20.0) < 0.05 * 20.0


def test_an_undetermined_coefficient_has_an_infinite_error():
    """An input that is zero over the fitted samples (it acts only in the masked end: the
    memory carries nothing back) leaves its coefficient undetermined: its standard error and
    variance are inf (not the 0 a pseudo-inverse gives), the other coefficient's is the
    one-input fit's, and the delta method keeps quantities free of it finite. (An input that
    is zero over the whole record is refused before the fit.)"""
    from vojax._stats import delta_stderr

    dt, n = 0.05, 300
    t = dt * np.arange(n)
    s = np.sin(0.9 * t) + 0.5
    y = np.asarray(vojax.simulate(s, 0.4, np.array([1.5]), dt))
    y = y + 1e-3 * np.random.default_rng(5).standard_normal(n)
    late = (np.arange(n) >= n - 10).astype(float)
    mask = 1.0 - late
    fit = vojax.refit(np.stack([s, late], 1), y, dt, x0=0.0, mask=mask)
    one = vojax.refit(s, y, dt, x0=0.0, mask=mask)
    with pytest.raises(ValueError, match="input 2 of `u` is 0 at every sample"):
        vojax.refit(np.stack([s, np.zeros(n)], 1), y, dt, x0=0.0)
    assert np.isinf(float(fit.p_stderr[1])) and np.isinf(float(fit.p_cov[1, 1]))
    np.testing.assert_allclose(fit.p_stderr[0], one.p_stderr[0], rtol=1e-6)
    np.testing.assert_allclose(fit.order_stderr, one.order_stderr, rtol=1e-6)
    se = delta_stderr(lambda p: {"a": 1 / p[0], "b": p[1] / p[0]}, fit.p, fit.p_cov)
    assert np.isfinite(se["a"]) and np.isinf(se["b"])
    assert se["a"] == pytest.approx(float(one.p_stderr[0]) / float(one.p[0]) ** 2, rel=1e-6)
