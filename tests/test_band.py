"""The band from the explanations (`vojax._tracker._band`) as rules on stand-in explanations
whose answers are known: which explanations join the band, where the breakdown drift falls,
what the statement about the parameters admits; and the least drift of the trade-off's fits
against a brute-force search. The held answers and their held scales: `test_band_held.py`;
what the bands do on recorded inputs: `test_calibration.py`."""

import numpy as np
import pytest

from vojax._tracker._band import bands
from vojax._tracker._explanations import relative_drift
from vojax._tracker._model import order_of_np
from vojax._tracker._trade import least_drift

from .band_stand_ins import BOUNDS, FAILS, FITS, N, ex, halfwidth


def test_the_tuned_smoothing_alone_is_its_own_band():
    b = bands([ex("tuned", 0.0, var=0.04)], BOUNDS, N, np.inf)
    alpha, lower, upper, std = b.stated
    np.testing.assert_allclose(alpha, 0.5)
    np.testing.assert_allclose(lower, order_of_np(-0.4, BOUNDS)[0])  # β ± 2·0.2
    np.testing.assert_allclose(upper, order_of_np(0.4, BOUNDS)[0])
    np.testing.assert_allclose(std, 0.25 * 0.2)  # dα/dβ = 1/4 at β = 0
    assert b.breakdown_drift == np.inf
    for got, want in zip(b.conditional, b.stated):
        np.testing.assert_array_equal(got, want)
    # the calibrated scale multiplies every σ
    wider = bands([ex("tuned", 0.0, var=0.04)], BOUNDS, N, np.inf, scale=1.5)
    np.testing.assert_allclose(wider.stated[3], 1.5 * std)


def test_a_run_that_did_not_converge_neither_widens_the_band_nor_becomes_its_reference():
    """A smoothing whose optimiser failed (evidence −∞) may pass the χ² test by chance: it
    neither joins the band, nor sets the breakdown drift, nor replaces the tuned smoothing as
    the held reference where the tuned parameters drift."""
    failed = dict(chi2=FITS, evidence=-np.inf)
    tuned = ex("tuned", 0.0, var=0.04, drift=0.2)
    alone = bands([tuned], BOUNDS, N, np.inf)
    b = bands([tuned, ex("held", 1.0, **failed), ex("param_drift", 2.0, drift=0.5, **failed)],
              BOUNDS, N, np.inf)
    assert b.breakdown_drift == np.inf
    assert b.reference_drift == pytest.approx(0.2)
    for got, want in zip(b.stated, alone.stated):
        np.testing.assert_array_equal(got, want)
    # converged, the same runs are the reference and the breakdown drift
    held = ex("held", 0.1, var=0.04)  # the tuned β 0 inside its ±0.4
    b = bands([tuned, held, ex("param_drift", -2.0, drift=0.5)], BOUNDS, N, np.inf)
    assert b.reference_drift == 0.0
    assert b.breakdown_drift == pytest.approx(0.5)


def test_the_breakdown_drift_is_the_least_drift_of_an_order_outside_that_fits():
    """Going up in drift, a fitting explanation inside the band joins it; the first outside
    it sets the breakdown drift. One that does not fit never counts, whatever its drift."""
    tuned = ex("tuned", 0.0)
    inside = ex("param_drift", 0.15, drift=0.1)  # β 0.15: inside ±0.2 of the tuned one
    outside = ex("trade", 2.0, var=0.0, drift=0.3, accepted=True)
    misfit = ex("held_order", -3.0, drift=0.05, chi2=FAILS)
    farther = ex("trade", -2.0, var=0.0, drift=0.6, accepted=True)
    b = bands([tuned, inside, outside, misfit, farther], BOUNDS, N, np.inf)
    assert b.breakdown_drift == pytest.approx(0.3)
    # the conditional band: the tuned one's widened by the one inside
    lo, hi = order_of_np(np.array([-0.2, 0.15 + 0.2]), BOUNDS)[0]
    np.testing.assert_allclose(b.conditional[1], lo)
    np.testing.assert_allclose(b.conditional[2], hi)
    # its σ: a quarter of the widened ±2σ band (0.034), above the tuned one's 0.025
    np.testing.assert_allclose(b.conditional[3], (hi - lo) / 4)
    # free: every explanation that fits; a stated bound of 0.2 admits only the one inside
    assert halfwidth(b.stated) == pytest.approx(
        (order_of_np(2.0, BOUNDS)[0] - order_of_np(-2.0, BOUNDS)[0]) / 2)
    bounded = bands([tuned, inside, outside, misfit, farther], BOUNDS, N, 0.2)
    for got, want in zip(bounded.stated[1:3], b.conditional[1:3]):
        np.testing.assert_allclose(got, want)
    # a bound of 0.4, past the breakdown: the one outside (drift 0.3) joins, the farther one
    # (0.6) does not: the band runs from the tuned one's lower end to β = 2 (profiled: var 0)
    wide = bands([tuned, inside, outside, misfit, farther], BOUNDS, N, 0.4)
    np.testing.assert_allclose(wide.stated[1], order_of_np(-0.2, BOUNDS)[0])
    np.testing.assert_allclose(wide.stated[2], order_of_np(2.0, BOUNDS)[0])
    # nothing outside fits: no breakdown, the conditional band is the whole union
    b = bands([tuned, inside, misfit], BOUNDS, N, np.inf)
    assert b.breakdown_drift == np.inf


def test_a_moving_order_lowers_the_breakdown_drift_and_widens_no_band():
    """A moving order outside the band with less drift than the constant order outside sets
    the breakdown drift; it widens neither the conditional band nor, with the parameters
    free or stated to drift more than it, the stated band (its distance outside is a fixed
    offset, not the data's); inside the band, it joins nothing either."""
    tuned = ex("tuned", 0.0)
    constant = ex("trade", 2.0, var=0.0, drift=0.3, accepted=True)
    moving = ex("moving", -1.5, var=0.0, drift=0.12, accepted=True)
    without = bands([tuned, constant], BOUNDS, N, np.inf)
    b = bands([tuned, constant, moving], BOUNDS, N, np.inf)
    assert without.breakdown_drift == pytest.approx(0.3)
    assert b.breakdown_drift == pytest.approx(0.12)
    for got, want in zip(b.conditional + b.stated, without.conditional + without.stated):
        np.testing.assert_array_equal(got, want)
    stated = bands([tuned, constant, moving], BOUNDS, N, 0.2)
    assert halfwidth(stated.stated) == pytest.approx(halfwidth(
        bands([tuned, constant], BOUNDS, N, 0.2).stated))
    within = ex("moving", 0.15, var=0.01, drift=0.05, accepted=True)  # its band reaches 0.35
    c = bands([tuned, constant, within], BOUNDS, N, np.inf)
    for got, want in zip(c.conditional, without.conditional):
        np.testing.assert_array_equal(got, want)


def test_an_explanation_as_drift_free_as_the_answer_never_breaks_it():
    """An order outside the band whose parameters drift no more than the answer's own (within
    the drift floor) is not a drifting alternative: it cannot set the breakdown drift."""
    tuned = ex("tuned", 0.0, drift=0.1)
    same = ex("param_drift", 2.0, drift=0.102)
    b = bands([tuned, same], BOUNDS, N, np.inf, drift_floor=0.005)
    assert b.breakdown_drift == np.inf
    assert b.reference_drift == pytest.approx(0.1)


def test_relative_drift():
    p = np.stack([np.linspace(1.0, 1.2, 11), np.linspace(-2.0, -2.1, 11)], axis=1)
    assert relative_drift(p, 11) == pytest.approx(0.2 / 1.1)
    assert relative_drift(p, 6) == pytest.approx(0.1 / 1.05)  # the fitted span only
    assert relative_drift(np.zeros((5, 1)), 5) == np.inf


def _drift_design(seed=0, num=200, knots=6):
    rng = np.random.default_rng(seed)
    s = np.linspace(0.0, 1.0, num)
    basis = np.clip(1.0 - np.abs(s[:, None] * (knots - 1) - np.arange(knots)[None, :]), 0, None)
    phi = 1.0 + 0.5 * np.sin(7 * s)
    x = phi[:, None] * basis
    p = 2.0 + 0.3 * s  # a 15 % drift
    y = 0.1 + phi * p + 0.01 * rng.standard_normal(num)
    return x, y, basis, np.ones(num)


def test_least_drift_against_a_brute_force_search():
    """The least drift among fits within a χ² limit: 0 where constant parameters fit within
    it, ∞ where not even the best fit does, and in between a fit that meets the limit with
    no more drift than any of 4,000 random fits within it (a brute-force search over the
    coefficients near the least-squares ones)."""
    x, y, basis, mask = _drift_design()
    scale = 1.0 / 0.01**2
    cols = np.c_[x, np.ones(y.size)]
    coef = np.linalg.lstsq(cols, y, rcond=None)[0]
    best = float(np.sum((y - cols @ coef) ** 2)) * scale
    const = np.c_[x.sum(1), np.ones(y.size)]
    c_const = float(np.sum((y - const @ np.linalg.lstsq(const, y, rcond=None)[0]) ** 2)) * scale
    assert least_drift(x, y, mask, basis, y.size, best - 1.0, scale) == np.inf
    assert least_drift(x, y, mask, basis, y.size, c_const + 1.0, scale) == 0.0
    limit = best + 20.0
    got = least_drift(x, y, mask, basis, y.size, limit, scale)
    ls = relative_drift(basis @ coef[:-1], y.size)
    assert 0.0 < got < ls
    rng = np.random.default_rng(1)
    found = []
    for _ in range(4000):
        trial = coef + rng.standard_normal(coef.size) * 0.02 * rng.uniform(0, 1)
        if float(np.sum((y - cols @ trial) ** 2)) * scale <= limit:
            found.append(relative_drift(basis @ trial[:-1], y.size))
    assert found and got <= min(found) * 1.02
    # a tighter limit needs more drift, a looser one less (a fit that misses the limit
    # would give a drift near 0 whatever the limit)
    tight, loose = (least_drift(x, y, mask, basis, y.size, best + d, scale) for d in (5.0, 100.0))
    assert tight > got * 1.01 and got > loose * 1.01


def test_outside_is_judged_over_the_second_half():
    """An explanation far from the band over the first half only is inside (the verdict
    reads the second half, where the order has settled); one far over the second half is
    outside."""
    tuned = ex("tuned", 0.0)
    early = ex("trade", 0.0, var=0.0, drift=0.2, accepted=True)
    early.beta[: N // 2] = 3.0
    late = ex("trade", 0.0, var=0.0, drift=0.4, accepted=True)
    late.beta[N // 2 :] = 3.0
    b = bands([tuned, early, late], BOUNDS, N, np.inf)
    assert b.breakdown_drift == pytest.approx(0.4)


def test_a_drifting_smoothing_far_below_the_tuned_evidence_does_not_count():
    """A smoothing with drifting parameters that fits (χ² test) but whose evidence lies more
    than `evidence_floor` nats below the tuned one's neither breaks the band nor widens it;
    one just inside the floor does, and the trade-off's profile (no evidence) always can."""
    tuned = ex("tuned", 0.0, evidence=0.0)
    far = ex("held_order", 3.0, drift=0.2, evidence=-250.0)
    near = ex("param_drift", 3.0, drift=0.3, evidence=-150.0)
    b = bands([tuned, far, near], BOUNDS, N, np.inf, evidence_floor=200.0)
    assert b.breakdown_drift == pytest.approx(0.3)
    b = bands([tuned, far], BOUNDS, N, np.inf, evidence_floor=200.0)
    assert b.breakdown_drift == np.inf and halfwidth(b.stated) < 0.1
    profile = ex("trade", 3.0, var=0.0, drift=0.4, evidence=np.nan, accepted=True)
    b = bands([tuned, far, profile], BOUNDS, N, np.inf, evidence_floor=200.0)
    assert b.breakdown_drift == pytest.approx(0.4)


@pytest.mark.parametrize("kind", ["start", "order_drift", "param_drift", "held_order"])
def test_no_smoothing_far_below_the_tuned_evidence_widens_the_free_band(kind):
    """With the parameters free, an alternative smoothing of any kind that fits (χ² test)
    but whose evidence lies more than `evidence_floor` nats below the tuned one's is no
    account the band covers (the data exclude it: a smoothing freer than they need fits
    below the noise); one just inside the floor is covered. (The level profile's held
    scales enter the reference's variance by their own weights: `reference_variance`.)"""
    tuned = ex("tuned", 0.0, evidence=0.0)
    alone = halfwidth(bands([tuned], BOUNDS, N, np.inf).stated)
    far = ex(kind, 3.0, drift=0.2, evidence=-250.0)
    b = bands([tuned, far], BOUNDS, N, np.inf, evidence_floor=200.0)
    assert halfwidth(b.stated) == pytest.approx(alone, rel=1e-12)
    assert b.breakdown_drift == np.inf
    near = ex(kind, 3.0, drift=0.2, evidence=-150.0)
    b = bands([tuned, near], BOUNDS, N, np.inf, evidence_floor=200.0)
    np.testing.assert_allclose(b.stated[2], order_of_np(3.2, BOUNDS)[0])


def test_the_fit_test_rejects_a_correct_model_about_one_time_in_forty():
    """`chi2_fits` is a 2σ test of χ² (mean dof, standard deviation √(2·dof)): on residuals
    of a correct model (Gaussian, known σ) it rejects 2.6 % of records at dof = 400
    (the χ² distribution's right tail beyond 2σ: 2.6 % by its skew), by Monte Carlo over
    20,000 draws. A test with √dof in place of √(2·dof) rejects 8.2 %."""
    from scipy.stats import chi2 as chi2_dist

    from vojax._tracker._mixture import chi2_fits

    dof = 400
    draws = np.random.default_rng(0).chisquare(dof, 20_000)
    rate = 1.0 - np.mean(chi2_fits(draws, dof))
    exact = chi2_dist.sf(dof + 2 * np.sqrt(2 * dof), dof)
    assert exact == pytest.approx(0.0264, abs=0.0005)
    assert rate == pytest.approx(exact, abs=0.004)
