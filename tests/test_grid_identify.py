"""`identify` and `tune_gains` on sample times (`t=`): the uniform grid given as times equals the
`dt` path, and on an irregular clock the law and the tracker recover an order simulated on a
fine uniform grid by the `dt` kernels (a different quadrature from the one under test)."""

import numpy as np
import pytest

import vojax

DT = 0.05
FINE = 10  # the truth is simulated on a grid FINE times finer


def _signals(t):
    return np.stack([np.sin(0.7 * t) + 0.3 * np.sin(1.9 * t), 1 + 0.5 * np.cos(0.25 * t)], 1)


P = np.array([2.0, -1.0])


def _uniform_record(n=400, order=0.45, noise=0.01, seed=0):
    t = DT * np.arange(n)
    x = np.asarray(vojax.simulate(_signals(t), order, P, DT))
    return t, _signals(t), x + noise * np.random.default_rng(seed).standard_normal(n)


@pytest.mark.parametrize(
    "kwargs",
    [
        dict(method="gradient", gamma=0.5, lam=0.9),
        pytest.param(dict(method="gradient"), marks=pytest.mark.slow),
        pytest.param(dict(method="kalman"), marks=pytest.mark.slow),
    ],
)
def test_uniform_times_equal_the_step(kwargs):
    """Fixed gains, tuned gains and the tracker: ``t = k·dt`` gives the `dt` results to the
    rounding of the steps (the tracker to its solver's tolerance)."""
    t, u, y = _uniform_record()
    a = vojax.identify(u, y, DT, warn=False, **kwargs)
    b = vojax.identify(u, y, t=t, warn=False, **kwargs)
    tol = 1e-9 if kwargs["method"] == "kalman" else 1e-11
    np.testing.assert_allclose(b.alpha, a.alpha, rtol=0, atol=tol)
    np.testing.assert_allclose(b.p, a.p, rtol=0, atol=tol * np.max(np.abs(a.p)))
    np.testing.assert_allclose(b.alpha_std, a.alpha_std, rtol=0, atol=tol)
    if kwargs["method"] == "gradient":
        assert float(b.gamma) == pytest.approx(float(a.gamma), rel=1e-9)
        assert float(b.lam) == pytest.approx(float(a.lam), rel=1e-9)
    assert float(b.dt) == pytest.approx(DT, rel=1e-12)


def _irregular_record(n=400, order=0.45, noise=0.01, seed=0):
    """Samples at an irregular subset of a fine uniform grid (steps of 1 to 19 fine steps,
    about DT on average), simulated on the fine grid with the `dt` kernels."""
    rng = np.random.default_rng(seed)
    fine_dt = DT / FINE
    picks = np.concatenate([[0], np.cumsum(rng.integers(1, 2 * FINE, n - 1))])
    t_fine = fine_dt * np.arange(picks[-1] + 1)
    x = np.asarray(vojax.simulate(_signals(t_fine), order, P, fine_dt))[picks]
    t = t_fine[picks]
    return t, _signals(t), x + noise * rng.standard_normal(n)


def test_law_on_an_irregular_clock_recovers_the_order():
    """The law with tuned gains on an irregular clock ends within 3 of its standard deviations
    (and 0.01) of the true order, p within 1 %; the same samples read as uniform at the median
    step (the clock ignored) miss the order and p by ten times more."""
    t, u, y = _irregular_record()
    res = vojax.identify(u, y, t=t, warn=False, method="gradient")
    last = slice(-50, None)
    err = np.abs(np.asarray(res.alpha)[last] - 0.45)
    assert np.max(err) < 0.01
    assert np.all(err < 3 * np.asarray(res.alpha_std)[last])
    p_err = np.max(np.abs(np.asarray(res.p)[-1] - P))
    assert p_err < 0.01 * np.max(np.abs(P))
    wrong = vojax.identify(u, y, float(np.median(np.diff(t))), warn=False, method="gradient")
    assert np.max(np.abs(np.asarray(wrong.alpha)[last] - 0.45)) > 10 * np.max(err)
    assert np.max(np.abs(np.asarray(wrong.p)[-1] - P)) > 10 * p_err


@pytest.mark.slow
def test_tracker_on_an_irregular_clock_recovers_the_order():
    """The tracker on the irregular clock: the true order inside its ±2σ band over the second
    half, and the offset estimated near 0."""
    t, u, y = _irregular_record()
    res = vojax.identify(u, y, t=t, method="kalman", warn=False)
    half = slice(t.size // 2, None)
    inside = (np.asarray(res.alpha_lower)[half] <= 0.45) & (0.45 <= np.asarray(res.alpha_upper)[half])
    assert inside.mean() > 0.9
    assert abs(float(res.x0)) < 3 * float(res.x0_std) + 0.01


def test_tune_gains_with_times_refuses_padding():
    t, u, y = _uniform_record(n=100)
    with pytest.raises(ValueError, match="`pad_to` pads a uniform record"):
        vojax.tune_gains(u, y, t=t, pad_to=128)
    with pytest.raises(TypeError, match="exactly one of `dt`"):
        vojax.identify(u, y, DT, t=t, method="gradient")
