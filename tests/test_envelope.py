"""What widens the tracker's band beyond its Laplace band, as control flow: the smoothings
are replaced by stand-ins whose answers are known, so that which runs widen the band, and
what the constant-parameter level profile pins, are checked by themselves. What they do to
recorded inputs: `tests/test_calibration.py`."""

import types

import jax.numpy as jnp
import numpy as np

from vojax import TrackerSettings
from vojax._tracker import _level, _threads
from vojax._tracker import _mixture as mixture_module
from vojax._tracker._problem import Problem, prior

N = 40


def _problem(settings=None):
    """A stand-in record of N samples, one input: only the mask, the prior and the settings
    are read where the smoothings are stood in for."""
    settings = TrackerSettings() if settings is None else settings
    m0, p0 = prior(1, np.float64, settings)
    return Problem(None, jnp.ones((N, 1)), None, np.ones(N), None, None, m0, p0, (0.0, 1.0),
                   None, N - 1, settings)


def _fake_modes(monkeypatch, fits_at, diverges_at=()):
    """A stand-in for `smoother_modes`: the run whose parameter is pinned at ratio r of the
    tuned mean has β = r everywhere, variance 0.01, residuals 0.1 (a χ² per sample of 1 at
    the noise variance 0.01: passes) where r is in `fits_at`, else 1 (fails), and no finite
    score where r is in `diverges_at`. Records what each run was given."""
    calls = []

    def modes(memory, u, y, mask, steps, horizon, hyper, m0, p0, start, bounds, budget, *rest):
        m0, p0, start = np.asarray(m0), np.asarray(p0), np.asarray(start)
        ratio = round(float(m0[1] / 2.0), 2)  # the tuned mode's mean parameter is 2
        calls.append(dict(ratio=ratio, m0=m0, p0=p0, start=start, hyper=hyper))
        res = np.full((1, N), 0.1 if ratio in fits_at else 1.0)
        score = -np.inf if ratio in diverges_at else 0.0
        return (np.full((1, N), ratio), np.full((1, N), 0.01), np.array([score]), res)

    monkeypatch.setattr(_level, "smoother_modes", modes)
    return calls


# the first round's ratios only: no bisections
FIRST_ROUND = TrackerSettings(level_splits=0)


def _profile(envelope=None, settings=FIRST_ROUND):
    theta = np.zeros((N, 3))
    theta[:, 0], theta[:, 1], theta[:, 2] = 0.3, 2.0, -1.0  # β, p, offset
    cov = np.zeros((N, 3, 3))
    cov[:, 0, 0] = 0.01  # the tuned run's β ± 0.1
    sm = types.SimpleNamespace(theta=theta, cov=cov)
    tuning = types.SimpleNamespace(values=(0.1, 1e-6, 0.01))
    return _level.level_profile(_problem(settings), tuning, sm, 0.01, None, envelope)


def test_each_run_holds_the_parameter_at_its_multiple_of_the_tuned_one(monkeypatch):
    calls = _fake_modes(monkeypatch, fits_at=())
    _profile()
    assert sorted(c["ratio"] for c in calls) == sorted(FIRST_ROUND.level_ratios)
    m0, p0 = prior(1, np.float64, FIRST_ROUND)
    for c in calls:
        r = c["ratio"]
        held = 2.0 * r
        # pinned: the prior of θ_0's parameter at the held value with a tiny variance; the
        # order's and the offset's priors as the tracker's
        assert c["m0"][1] == held and c["p0"][1, 1] == FIRST_ROUND.level_pin * max(held**2, 1.0)
        np.testing.assert_array_equal(np.delete(c["m0"], 1), np.delete(np.asarray(m0), 1))
        np.testing.assert_array_equal(c["p0"][0], np.asarray(p0)[0])
        assert c["p0"][2, 2] == np.asarray(p0)[2, 2]
        # started from the tuned mode's mean with the parameter held
        np.testing.assert_allclose(c["start"], [[0.3, held, -1.0]], rtol=1e-15)
        np.testing.assert_allclose(np.exp(c["hyper"].log_r[0]), 0.01, rtol=1e-14)  # tuned


def test_the_band_covers_exactly_the_runs_that_fit(monkeypatch):
    # no bisections (the next test)
    # none fits: the envelope is left as it was
    _fake_modes(monkeypatch, fits_at=())
    assert _profile() is None
    before = (np.full(N, 0.2), np.full(N, 0.4))
    out = _profile(before)
    np.testing.assert_array_equal(out[0], before[0])
    np.testing.assert_array_equal(out[1], before[1])
    # two fit (β = 0.71 and 1.41, ±2·0.1), one of which diverged: only the other counts
    _fake_modes(monkeypatch, fits_at=(0.71, 1.41), diverges_at=(1.41,))
    lo, hi = _profile()
    np.testing.assert_allclose(lo, 0.71 - 0.2)
    np.testing.assert_allclose(hi, 0.71 + 0.2)
    # both count, and the union with an envelope already there
    _fake_modes(monkeypatch, fits_at=(0.5, 2.0))
    lo, hi = _profile(before)
    np.testing.assert_allclose(lo, 0.2)  # min(0.2, 0.5 − 0.2)
    np.testing.assert_allclose(hi, 2.2)


def test_the_profile_bisects_to_a_fitting_scale_between_its_ratios(monkeypatch):
    """Only the scale √1.41 (β = 1.19 in the stand-in) fits: none of the first ratios does,
    the bisection between 1 and 1.41 finds it, and the band is that run's ±2σ alone. Above it
    the profile stops once the failing run's β (1.29) is within 2σ of the fitting one's; below
    1 it halves the gap until √2's third halving (0.84, 0.92, 0.96: none fits)."""
    monkeypatch.setattr(_threads.os, "cpu_count", lambda: 1)  # each round's runs in order
    calls = _fake_modes(monkeypatch, fits_at=(1.19,))
    lo, hi = _profile(settings=TrackerSettings())
    # log-midpoints: √1.41 = 1.19, √0.71 = 0.84, √(1.19·1.41) = 1.29, √0.84 = 0.92, …
    assert [c["ratio"] for c in calls] == [0.5, 0.71, 1.41, 2.0, 1.19, 0.84, 1.29, 0.92, 0.96]
    np.testing.assert_allclose(lo, 1.19 - 0.2)
    np.testing.assert_allclose(hi, 1.19 + 0.2)


# ------------------------------------------------ the mixture's envelope


STARTS = np.zeros((6, 3))  # the mixture's starts: alternatives 1…6


def _mixture(monkeypatch, residual, scores, tuned=0.0):
    """`mixture` (6 starts, the noise variance 0.01) with a stand-in for its smoothings: run k
    of the stand-in, alternative k + 1, has β = k + 1 everywhere, variance 0.01, residuals
    `residual(k)` and Laplace evidence ``scores(C)[k]`` (C runs); the tuned run (alternative
    0) has evidence `tuned` (−∞: not converged). Returns the mixture's output and the rows
    of intensities it asked for."""
    rows_seen = []

    def modes(problem, rows, firsts, budget):
        rows_seen[:] = rows
        c = len(rows)
        return (np.arange(1.0, c + 1.0)[:, None] * np.ones((1, N)), np.full((c, N), 0.01),
                scores(c), np.array([residual(k) for k in range(c)]))

    monkeypatch.setattr(mixture_module, "run_mode_shares", modes)
    cov = np.tile(np.eye(3) * 0.01, (N, 1, 1))
    sm = types.SimpleNamespace(theta=np.zeros((N, 3)), cov=cov, log_likelihood=tuned,
                               objective=0.0, converged=np.isfinite(tuned))
    tuning = types.SimpleNamespace(values=(0.1, 1e-6, 0.01))
    out = mixture_module.mixture(_problem(), tuning, STARTS, sm, False, 0.01, None)
    return out, rows_seen


def test_the_mixtures_envelope_covers_exactly_the_alternatives_that_fit(monkeypatch):
    """Every alternative converged (evidence 0) and its residuals passing the χ² test (0.1
    at the noise variance 0.01) only for the runs chosen: the envelope is the union of their
    ±2σ, and `drifting` says whether one of them has the parameters drifting."""

    def run(fits):
        return _mixture(monkeypatch, lambda k: np.full(N, 0.1 if k in fits else 1.0), np.zeros)

    # run k of the stand-in is alternative k + 1 (the tuned run is alternative 0); the rows
    # after the starts are the parameters' drift levels
    first_drift = len(STARTS)
    (_, _, envelope, drifting), _ = run(fits=())
    assert envelope is None and not drifting
    (_, _, (lo, hi), drifting), _ = run(fits=(1, 3))  # two starts: β = 2 and 4
    np.testing.assert_allclose(lo, 2 - 0.2)
    np.testing.assert_allclose(hi, 4 + 0.2)
    assert not drifting
    (_, _, (lo, hi), drifting), rows = run(fits=(first_drift,))  # a drifting-parameter run
    np.testing.assert_allclose(lo, first_drift + 1 - 0.2)
    assert drifting and rows[first_drift][1] == TrackerSettings().alt_param_drift[0]


def test_a_drifting_parameter_run_far_less_probable_than_the_tuned_run_does_not_widen_the_band(
    monkeypatch,
):
    """Every alternative fitting (residuals 0.1 at the noise variance 0.01), the tuned run's
    evidence at 0: a run with the parameters drifting more than `envelope_evidence` nats
    below it stays out of the envelope, one just inside the limit counts; a run at another
    order drift counts whatever its evidence; a run that did not converge (−∞) never does.
    With the tuned run not converged, every converged run counts."""
    settings = TrackerSettings()
    limit = settings.envelope_evidence
    first = len(STARTS) + 1  # alternatives 1…6 are the starts, 7… the drifting parameters
    count = 2 * len(settings.alt_param_drift)

    def run(drift_scores, order_score, tuned=0.0):
        def scores(c):
            s = np.full(c, -np.inf)  # the starts, and drifting runs not given: not converged
            s[first - 1 : first - 1 + len(drift_scores)] = drift_scores
            s[first - 1 + count :] = order_score  # the order's other drifts
            return s

        return _mixture(monkeypatch, lambda k: np.full(N, 0.1), scores, tuned)[0][2:]

    last = first + count + len(settings.alt_order_drift) - 1  # β of the last order-drift run
    # drifting parameters 4 nats below, just inside the limit, just beyond it, far beyond; the
    # order's other drifts not converged
    (lo, hi), drifting = run([-4.0, -(limit - 0.5), -(limit + 0.5), -5.0 * limit], -np.inf)
    np.testing.assert_allclose(lo, first - 0.2)
    np.testing.assert_allclose(hi, first + 1 + 0.2)
    assert drifting
    # none of the drifting runs counts; the order's other drifts, far below, all do
    (lo, hi), drifting = run([-(limit + 0.5)] * count, -5.0 * limit)
    np.testing.assert_allclose(lo, first + count - 0.2)
    np.testing.assert_allclose(hi, last + 0.2)
    assert not drifting
    # the tuned run did not converge: its evidence is no reference, and converged runs count
    (lo, hi), _ = run([-(limit + 0.5), -2.0 * limit], -np.inf, tuned=-np.inf)
    np.testing.assert_allclose(lo, first - 0.2)
    np.testing.assert_allclose(hi, first + 1 + 0.2)
