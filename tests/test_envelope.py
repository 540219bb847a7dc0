"""What widens the tracker's band beyond its Laplace band, as control flow: the smoothings
are replaced by stand-ins whose answers are known, so that which runs widen the band, and
what the constant-parameter level profile pins, are checked by themselves. What they do to
recorded inputs: `tests/test_calibration.py`."""

import types

import jax.numpy as jnp
import numpy as np
import pytest

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
    return Problem(None, jnp.ones((N, 1)), np.zeros(N), np.ones(N), None, None, m0, p0,
                   (0.0, 1.0), None, N - 1, settings)


def _fake_modes(monkeypatch, fits_at, diverges_at=()):
    """A stand-in for `smoother_modes`: the run whose parameter is pinned at ratio r of the
    tuned mean has β = r everywhere, variance 0.01, residuals 0.1 (a χ² per sample of 1 at
    the noise variance 0.01: passes) where r is in `fits_at`, else 1 (fails), and no finite
    score where r is in `diverges_at`. Records what each run was given (its iteration
    budget too)."""
    calls = []

    def modes(memory, u, y, mask, steps, horizon, hyper, m0, p0, start, bounds, budget, *rest):
        m0, p0, start = np.asarray(m0), np.asarray(p0), np.asarray(start)
        ratio = round(float(m0[1] / 2.0), 2)  # the tuned mode's mean parameter is 2
        calls.append(dict(ratio=ratio, m0=m0, p0=p0, start=start, hyper=hyper, budget=budget))
        res = np.full((1, N), 0.1 if ratio in fits_at else 1.0)
        score = -np.inf if ratio in diverges_at else 0.0
        return (np.full((1, N), ratio), np.full((1, N), 0.01), np.array([score]), res,
                np.full((1, N, 1), 2.0 * ratio), np.array([3.0 + ratio]))

    monkeypatch.setattr(_level, "smoother_modes", modes)
    return calls


# the first round's ratios only: no bisections
FIRST_ROUND = TrackerSettings(level_splits=0)


def _profile(settings=FIRST_ROUND):
    theta = np.zeros((N, 3))
    theta[:, 0], theta[:, 1], theta[:, 2] = 0.3, 2.0, -1.0  # β, p, offset
    cov = np.zeros((N, 3, 3))
    cov[:, 0, 0] = 0.01  # the tuned run's β ± 0.1
    sm = types.SimpleNamespace(theta=theta, cov=cov)
    tuning = types.SimpleNamespace(values=(0.1, 1e-6, 0.01))
    return _level.level_profile(_problem(settings), tuning, sm, 0.01, None)


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
        assert c["budget"] == FIRST_ROUND.level_max_iter  # the held scales' own budget


def test_the_held_scales_run_on_their_own_iteration_budget(monkeypatch):
    """Every held scale's smoothing gets `level_max_iter` iterations, not the tuned
    smoothing's `max_iter`, whether that is the smaller budget or the larger."""
    for level, tuned in ((37, 400), (500, 200)):
        calls = _fake_modes(monkeypatch, fits_at=())
        _profile(TrackerSettings(level_splits=0, level_max_iter=level, max_iter=tuned))
        assert [c["budget"] for c in calls] == [level] * len(FIRST_ROUND.level_ratios)


def test_each_held_scale_is_an_explanation_with_its_fit(monkeypatch):
    """Each run of the profile is an `Explanation` of kind "level": its order and variance
    as the run gave them, its χ² over the fitted samples at the noise variance (residuals
    0.1 at 0.01: χ² = N where the run fits, 100 N where it does not), which `fits` reads, its
    fitted freedom beyond the constant fit's, and a run that did not converge is kept,
    marked by its evidence (−∞)."""
    _fake_modes(monkeypatch, fits_at=(0.71, 1.41), diverges_at=(1.41,))
    out = _profile()
    assert all(e.kind == "level" for e in out)
    by_ratio = {round(float(e.beta[0]), 2): e for e in out[:4]}
    assert sorted(by_ratio) == [0.5, 0.71, 1.41, 2.0]  # the first round
    for ratio, e in by_ratio.items():
        fits = ratio in (0.71, 1.41)
        assert e.chi2 == pytest.approx(N * (1.0 if fits else 100.0)) and e.fits == fits
        np.testing.assert_allclose(e.var, 0.01)
        assert e.drift == 0.0  # the stand-in's parameter is held: no drift
        assert e.freedom == pytest.approx(ratio)  # its trace (3 + ratio) less the constant 3
    assert by_ratio[1.41].evidence == -np.inf and not by_ratio[1.41].converged
    assert by_ratio[0.71].converged


def test_the_profile_bisects_to_a_fitting_scale_between_its_ratios(monkeypatch):
    """Only the scale √1.41 (β = 1.19 in the stand-in) fits: none of the first ratios does,
    the bisection between 1 and 1.41 finds it, and it is the only one that fits. Above it
    the profile stops once the failing run's β (1.29) is within 2σ of the fitting one's; below
    1 it halves the gap until √2's third halving (0.84, 0.92, 0.96: none fits)."""
    monkeypatch.setattr(_threads.os, "cpu_count", lambda: 1)  # each round's runs in order
    calls = _fake_modes(monkeypatch, fits_at=(1.19,))
    out = _profile(settings=TrackerSettings())
    # log-midpoints: √1.41 = 1.19, √0.71 = 0.84, √(1.19·1.41) = 1.29, √0.84 = 0.92, …
    assert [c["ratio"] for c in calls] == [0.5, 0.71, 1.41, 2.0, 1.19, 0.84, 1.29, 0.92, 0.96]
    assert [round(float(e.beta[0]), 2) for e in out if e.fits] == [1.19]


def test_a_run_that_did_not_converge_ends_the_profile_on_its_side(monkeypatch):
    """The held scale 2 fits by its residuals but its smoothing did not converge (evidence
    −∞): it counts as not fitting, so the profile does not step past it (to 2√2); the
    bisections then stay between 1.41 and 2."""
    monkeypatch.setattr(_threads.os, "cpu_count", lambda: 1)
    calls = _fake_modes(monkeypatch, fits_at=(0.71, 1.41, 2.0), diverges_at=(2.0,))
    _profile(settings=TrackerSettings())
    above = [c["ratio"] for c in calls if c["ratio"] > 1.0]
    assert max(above) == 2.0 and all(1.41 <= r <= 2.0 for r in above)
    assert any(1.41 < r < 2.0 for r in above)  # bisected towards the run that failed


# ------------------------------------------------ the mixture's explanations


STARTS = np.zeros((6, 3))  # the mixture's starts: alternatives 1…6


def _mixture(monkeypatch, residual, scores, tuned=0.0):
    """`mixture` (6 starts, the noise variance 0.01) with a stand-in for its smoothings: run k
    of the stand-in, alternative k + 1, has β = k + 1 everywhere, variance 0.01, residuals
    `residual(k)`, Laplace evidence ``scores(C)[k]`` (C runs) and a parameter rising
    linearly by k % over the record; the tuned run (alternative 0) has evidence `tuned`.
    Returns the explanations and the rows of intensities it asked for."""
    rows_seen = []

    def modes(problem, rows, firsts, budget):
        rows_seen[:] = rows
        c = len(rows)
        ramp = np.linspace(0.0, 1.0, N)[None, :, None]
        params = 1.0 + 0.01 * np.arange(c)[:, None, None] * ramp
        return (np.arange(1.0, c + 1.0)[:, None] * np.ones((1, N)), np.full((c, N), 0.01),
                scores(c), np.array([residual(k) for k in range(c)]), params,
                3.0 + np.arange(c, dtype=float))

    monkeypatch.setattr(mixture_module, "run_mode_shares", modes)
    cov = np.tile(np.eye(3) * 0.01, (N, 1, 1))
    theta = np.zeros((N, 3))
    theta[:, 1] = 1.0
    sm = types.SimpleNamespace(theta=theta, cov=cov, log_likelihood=tuned,
                               objective=0.0, converged=np.isfinite(tuned), phi=np.zeros((N, 1)),
                               jacobian=np.ones((N, 3)))
    tuning = types.SimpleNamespace(values=(0.1, 1e-6, 0.01))
    _, _, explanations = mixture_module.mixture(_problem(), tuning, STARTS, sm, False, 0.01,
                                                None)
    return explanations, rows_seen


def test_the_mixtures_runs_are_explanations_of_their_kinds(monkeypatch):
    """The tuned run first, then the starts, the parameters drifting at each level, the
    order held with them drifting, the order's other drifts: each an `Explanation` of its
    kind with its χ² (residuals 0.1 at the noise variance 0.01: χ² = N; 1: 100 N), its
    evidence and its parameters' relative drift over the record."""
    settings = TrackerSettings()
    explanations, rows = _mixture(monkeypatch, lambda k: np.full(N, 0.1 if k < 8 else 1.0),
                                  lambda c: -np.arange(c, dtype=float))
    kinds = [e.kind for e in explanations]
    m = len(settings.alt_param_drift)
    assert kinds == (["tuned"] + ["start"] * len(STARTS) + ["param_drift"] * m
                     + ["held_order"] * m + ["order_drift"] * len(settings.alt_order_drift))
    assert rows[len(STARTS)][1] == settings.alt_param_drift[0]
    for k, e in enumerate(explanations[1:]):
        assert e.chi2 == pytest.approx(N * (1.0 if k < 8 else 100.0)) and e.fits == (k < 8)
        assert e.evidence == -k
        assert e.drift == pytest.approx(0.01 * k / (1 + 0.005 * k))  # (max − min)/|mean|
    assert explanations[0].drift == 0.0 and explanations[0].chi2 == 0.0  # fits exactly
    # each run's fitted freedom less the constant fit's 3: the runs' as given (3 + k), the
    # tuned run's its trace at the tuned noise 0.01 (a unit Jacobian, variance 0.01 a state)
    assert [e.freedom for e in explanations[1:]] == list(range(len(explanations) - 1))
    assert explanations[0].freedom == pytest.approx(N * 0.03 / 0.01 - 3.0, rel=1e-12)


def test_each_order_drift_carries_the_factor_its_run_was_given(monkeypatch):
    """The order drifts' explanations carry their factor of `alt_order_drift` (the band leaves
    the largest out where it lies far below the tuned evidence): each factor × the tuned
    order drift (0.1 here, above `order_drift_base`) is the order drift of the row its run was
    given, and no other kind carries one."""
    settings = TrackerSettings()
    explanations, rows = _mixture(monkeypatch, lambda k: np.full(N, 0.1),
                                  lambda c: np.zeros(c))
    drifts = [(e, row) for e, row in zip(explanations[1:], rows) if e.kind == "order_drift"]
    assert [e.factor for e, _ in drifts] == list(settings.alt_order_drift)
    lowest, highest = settings.order_drift_range
    for e, row in drifts:
        assert row[0] == pytest.approx(np.clip(0.1 * e.factor, lowest, highest), rel=1e-12)
    assert all(e.factor is None for e in explanations if e.kind != "order_drift")
