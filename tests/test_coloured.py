"""Coloured measurement noise: the AR(1) noise state's model and the whitening behind the
tracker's χ² tests, against dense linear algebra (the tracker choosing the coloured model by
evidence: `tests/test_first_pass.py`; its Kalman passes and mode: the dense posteriors of
`tests/test_kalman.py`)."""

import jax.numpy as jnp
import numpy as np
import pytest

from vojax._tracker import Hyper
from vojax._tracker._coloured import ar_whitener
from vojax._tracker._start import least_squares as _least_squares
from vojax._tracker._tuning import Tuning


def _ar_covariance(times, s, tau, r):
    """Σ_ij = s·exp(−|t_i − t_j|/τ) + r·δ_ij: a stationary AR(1) part sampled at `times`
    (an Ornstein–Uhlenbeck process) plus white noise, written directly."""
    gaps = np.abs(times[:, None] - times[None, :])
    return s * np.exp(-gaps / tau) + r * np.eye(times.size)


def _irregular(n, seed):
    rng = np.random.default_rng(seed)
    times = np.concatenate([[0.0], np.cumsum(rng.uniform(0.5, 2.0, n - 1))])
    steps = np.concatenate([np.diff(times), [1.0]])
    return rng, times, steps


def test_hyper_transition_keeps_the_ar_part_stationary():
    rng, times, steps = _irregular(30, 1)
    horizon = float(times[-1])
    s, tau = 0.3, 0.05  # τ as a fraction of the span
    hyper = Hyper(*(jnp.log(jnp.asarray(v)) for v in (0.1, 1e-3, 0.01, s, tau)))
    f = np.asarray(hyper.transition(jnp.asarray(steps), horizon, 1))
    q = np.asarray(hyper.process(jnp.asarray(steps), horizon, 1))
    a = np.exp(-steps / (tau * horizon))
    np.testing.assert_allclose(f[:, -1], a, rtol=1e-14)
    np.testing.assert_array_equal(f[:, :-1], 1.0)  # β, p, c stay random walks
    # Var e_{k+1} = a² Var e_k + q_k = s whenever Var e_k = s
    np.testing.assert_allclose(a**2 * s + q[:, -1], s, rtol=1e-13)
    p0 = np.asarray(hyper.initial(jnp.eye(4)))
    assert p0[-1, -1] == pytest.approx(s, rel=1e-14) and p0[0, 0] == 1.0
    # white noise: no transition, no noise state
    white = Hyper(*(jnp.log(jnp.asarray(v)) for v in (0.1, 1e-3, 0.01)))
    assert white.transition(jnp.asarray(steps), horizon, 1) is None
    assert np.asarray(white.process(jnp.asarray(steps), horizon, 1)).shape == (30, 3)


@pytest.mark.parametrize("memory", ["short", "long"])
@pytest.mark.parametrize("n", [1, 2, 3, 64, 65, 1000])
def test_whitener_equals_the_kalman_filter_step_by_step(n, memory):
    """The whitener (a doubling scan over the AR(1) part's predictions) equals the scalar
    Kalman filter run sample by sample, written here, to 1e-12 of the data's scale: on an
    irregular clock with skipped samples (their state carried forward unseen), on arrays of
    one, two and three dimensions (each column alone), at lengths about powers of two; with
    a correlation time of 4 % of the record and one of ten records under a white part six
    times the coloured one (each prediction then weighs the whole record)."""
    rng, times, steps = _irregular(n, 3)
    s, tau_frac, r = (0.8, 0.04, 0.05) if memory == "short" else (0.8, 10.0, 5.0)
    horizon = float(times[-1]) if n > 1 else 1.0
    mask = (rng.uniform(size=n) > 0.2).astype(float)
    tuning = Tuning(0.1, 1e-6, r, (), 0.0, True, s, tau_frac)
    whiten = ar_whitener(steps, mask, horizon, tuning)
    a = np.exp(-steps / (tau_frac * horizon))

    def filtered(x):
        out, pred, var = np.empty_like(x), np.zeros(x.shape[1:]), s
        for k in range(n):
            g = mask[k] * var / (var + r)
            out[k] = (x[k] - pred) / np.sqrt(var + r)
            pred = a[k] * (pred + g * (x[k] - pred))
            var = a[k] ** 2 * (1.0 - g) * var + s * (1.0 - a[k] ** 2)
        return out

    for shape in ((n,), (n, 4), (n, 3, 5)):
        x = rng.standard_normal(shape)
        got = whiten(x)
        assert got.shape == x.shape
        np.testing.assert_allclose(got, filtered(x), rtol=0, atol=1e-12)


def test_whitener_gives_the_dense_quadratic_form_and_gls():
    n = 60
    rng, times, steps = _irregular(n, 2)
    s, tau_frac, r = 0.8, 0.04, 0.05
    horizon = float(times[-1])
    mask = np.ones(n)
    mask[[7, 8, 30]] = 0.0  # skipped samples: the fitted samples' marginal
    tuning = Tuning(0.1, 1e-6, r, (), 0.0, True, s, tau_frac)
    whiten = ar_whitener(steps, mask, horizon, tuning)
    keep = mask > 0
    cov = _ar_covariance(times[keep], s, tau_frac * horizon, r)
    x = rng.standard_normal(n)
    dense = x[keep] @ np.linalg.solve(cov, x[keep])
    assert np.sum(mask * whiten(x) ** 2) == pytest.approx(dense, rel=1e-11)
    # generalised least squares with an offset: the same coefficients and χ² as dense GLS
    cols = rng.standard_normal((n, 2))
    y = cols @ np.array([0.7, -1.3]) + 0.4 + np.linalg.cholesky(
        _ar_covariance(times, s, tau_frac * horizon, r)) @ rng.standard_normal(n)
    chi2, coef = _least_squares(cols, y, mask, whiten)
    design = np.concatenate([cols, np.ones((n, 1))], axis=1)[keep]
    gls = np.linalg.solve(design.T @ np.linalg.solve(cov, design),
                          design.T @ np.linalg.solve(cov, y[keep]))
    np.testing.assert_allclose(coef, gls, rtol=1e-10)
    res = y[keep] - design @ gls
    assert chi2 == pytest.approx(res @ np.linalg.solve(cov, res), rel=1e-10)


def _ar_record():
    """A 400-sample ramp with a slow sine, order 0.45, AR(1) noise (ρ = 0.9, 1 % of the
    range): a function of `TrackerSettings` that fits it with the parameters constant."""
    import vojax
    from vojax._integral import make_memory
    from vojax._tracker._fit import fit_points

    t = np.arange(400) * 0.05
    u = np.where(t < 3.0, t / 3.0, 1.0) + 0.3 * np.sin(0.4 * t)
    x = np.asarray(vojax.simulate(u, np.full(t.size, 0.45), np.array([1.0]), 0.05))
    white = np.random.default_rng(3).standard_normal(t.size)
    ar = np.zeros(t.size)
    for k in range(1, t.size):
        ar[k] = 0.9 * ar[k - 1] + np.sqrt(1 - 0.81) * white[k]
    y = jnp.asarray(x + 0.01 * np.ptp(x) * ar)
    mem = make_memory("exponential", 0.05, t.size, rule="trapezoid", order_range=(0.01, 0.99))
    return lambda settings: fit_points(mem, jnp.asarray(u[:, None]), y, 0.05, (0.01, 0.99),
                                       settings, parameters="constant")


def test_the_coloured_model_is_tried_where_the_white_ones_noise_fell_below_the_datas(
        monkeypatch):
    """The second way in to the coloured model: the white model's noise variance below
    `coloured_absorbed` × the data's own (differences of order 4), its prediction errors'
    correlation left out (held at 0 here). Just above the white model's ratio the coloured
    model is tried, just below it is not; where it is tried on this AR(1) record (ρ = 0.9)
    the evidence keeps it with ρ̂ near 0.9."""
    import vojax
    from vojax._tracker import _coloured

    monkeypatch.setattr(_coloured, "prediction_error_correlation",
                        lambda y, pred, fitted: (0.0, int(np.sum(fitted))))
    tried = []
    in_threads = _coloured.in_threads
    monkeypatch.setattr(_coloured, "in_threads",
                        lambda *a, **k: tried.append(1) or in_threads(*a, **k))
    fit_record = _ar_record()

    def fit(ratio):
        tried.clear()
        res = fit_record(vojax.TrackerSettings(coloured_absorbed=ratio, level_ratios=()))
        return res, bool(tried)

    white_fit, was_tried = fit(0.0)
    levels = white_fit.noise_levels
    assert not was_tried and not levels["coloured"]
    ratio = levels["tuned"] / levels["data4"]  # the white model's, as the gate compares them
    assert ratio > 0  # (2.5 here: differences see an AR(1) noise's fast part alone)
    below, was_tried = fit(0.99 * ratio)
    assert not was_tried and not below.noise_levels["coloured"]
    above, was_tried = fit(1.01 * ratio)
    assert was_tried and above.noise_levels["coloured"]
    assert 0.8 < above.tuning.noise_correlation < 0.97


class _Tried(Exception):
    """Raised where the coloured model's starts are smoothed: the gate let it in."""


@pytest.mark.parametrize("lag", [2.0, 0.0])
def test_the_coloured_model_is_tried_where_the_lag1_passes_coloured_lag_over_root_n(
        monkeypatch, lag):
    """The first way in to the coloured model: the white model's prediction errors' lag-1
    above `coloured_lag`/√n for n errors (0: the refusal limit, `correlation_limit`), the
    second way (`coloured_absorbed`) shut. The lag-1 is set just above and just below the
    limit: the coloured model is tried above it only."""
    import vojax
    from vojax._tracker import _coloured

    counts, r1 = [], [0.0]

    def correlation(y, pred, fitted):
        counts.append(int(np.sum(fitted)))
        return r1[0], counts[-1]

    def tried(*args, **kwargs):
        raise _Tried

    monkeypatch.setattr(_coloured, "prediction_error_correlation", correlation)
    monkeypatch.setattr(_coloured, "in_threads", tried)
    fit_record = _ar_record()
    settings = vojax.TrackerSettings(coloured_absorbed=0.0, coloured_lag=lag, level_ratios=())
    fit_record(settings)  # a lag-1 of 0: white noise kept, and the count of errors seen
    n = counts[0]
    limit = lag / np.sqrt(n) if lag else min(max(3 / np.sqrt(n), 0.1), 0.25)
    r1[0] = 0.99 * limit
    assert not fit_record(settings).noise_levels["coloured"]
    r1[0] = 1.01 * limit
    with pytest.raises(_Tried):
        fit_record(settings)
