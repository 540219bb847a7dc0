"""The level profile read as a profile likelihood (``level_weights="profile"``): each held
scale that fits moves the band's edge to its own ±2σ, moved back towards the tuned order by
√(4/Δχ²) where its χ² lies Δχ² > 4 above the tuned one's. Closed forms on stand-ins whose
orders are constant in β."""

import numpy as np
import pytest

from vojax import TrackerSettings
from vojax._tracker._band import bands, profile_spread
from vojax._tracker._model import order_of_np

from .band_stand_ins import BOUNDS, FAILS, FITS, N, ex, halfwidth

SD = 0.1  # every stand-in's σ of β (variance 0.01)


def _upper(explanations, **kwargs):
    """The stated band's upper edge on β (constant over the samples), parameters constant."""
    band = bands(explanations, BOUNDS, N, 0.0, level_weights="profile", **kwargs).stated
    edge = np.asarray(band[2])
    assert np.ptp(edge) < 1e-12
    # back from the order scale to β (the order range is (0, 1): the logistic)
    return float(np.log(edge[0] / (1 - edge[0])))


@pytest.mark.parametrize("gap", [-3.0, 0.0, 2.0, 4.0])
def test_a_held_scale_within_four_units_of_chi2_counts_in_full(gap):
    tuned, level = ex("tuned", 0.0), ex("level", 0.6, chi2=FITS + gap)
    # the band's +2σ edge reaches the held scale's own: 0.6 + 2 × 0.1
    assert _upper([tuned, level]) == pytest.approx(0.6 + 2 * SD, abs=1e-9)


@pytest.mark.parametrize("gap, moved", [(16.0, 0.5), (9.0, 2 / 3), (25.0, 0.4)])
def test_a_held_scale_further_above_is_moved_back_by_the_quadratic_profile(gap, moved):
    tuned, level = ex("tuned", 0.0), ex("level", 0.6, chi2=FITS + gap)
    assert _upper([tuned, level]) == pytest.approx(0.6 * moved + 2 * SD, abs=1e-9)
    # and the spread on its own, in β's variance: (|moved shift|/2 + σ)² − σ²
    assert np.allclose(profile_spread([level], tuned), (0.3 * moved + SD) ** 2 - SD**2)


def test_only_held_scales_that_fit_count_and_the_widest_moved_edge_sets_the_band():
    tuned = ex("tuned", 0.0)
    # fails the χ² test: no account of the data (counted, it would be moved to 0.79)
    failing = ex("level", 5.0, chi2=FAILS)
    low = ex("level", -0.4, chi2=FITS + 1.0)  # below, in full
    far = ex("level", 0.9, chi2=FITS + 25.0)  # above, moved to 0.36
    near = ex("level", 0.3, chi2=FITS + 1.0)  # above, in full, inside far's moved edge
    band = bands([tuned, failing, low, far, near], BOUNDS, N, 0.0,
                 level_weights="profile").stated
    # symmetric about the tuned order: the widest need, the held scale below (0.2 + 0.1)
    half = 2 * np.sqrt(SD**2 + (0.2 + SD) ** 2 - SD**2)
    assert np.allclose(band[1], order_of_np(np.full(N, -half), BOUNDS)[0])
    assert np.allclose(band[2], order_of_np(np.full(N, half), BOUNDS)[0])
    assert half == pytest.approx(0.6)


def test_a_held_scale_inside_the_tuned_band_adds_nothing():
    tuned = ex("tuned", 0.0, var=0.04)
    inside = ex("level", 0.1, var=0.001, chi2=FITS + 1.0)
    assert np.all(profile_spread([inside], tuned) == 0.0)
    alone = bands([tuned], BOUNDS, N, 0.0, level_weights="profile").stated
    assert halfwidth(bands([tuned, inside], BOUNDS, N, 0.0,
                           level_weights="profile").stated) == halfwidth(alone)


def test_no_held_scale_that_fits_leaves_the_tuned_band():
    tuned = ex("tuned", 0.0)
    assert profile_spread([], tuned) == 0.0
    assert _upper([tuned, ex("level", 2.0, chi2=FAILS)]) == pytest.approx(2 * SD, abs=1e-9)


def test_the_profile_level_is_a_setting_with_its_limits():
    assert TrackerSettings(level_weights="profile").level_weights == "profile"
    tuned, level = ex("tuned", 0.0), ex("level", 0.6, chi2=FITS + 16.0)
    # at 16 units, that held scale counts in full
    assert _upper([tuned, level], profile_chi2=16.0) == pytest.approx(0.6 + 2 * SD, abs=1e-9)
    with pytest.raises(ValueError, match="level_profile_chi2"):
        TrackerSettings(level_profile_chi2=0.0)
    with pytest.raises(ValueError, match="level_weights"):
        TrackerSettings(level_weights="profiles")


@pytest.mark.parametrize("lead, share", [(0.0, 1.0), (0.02, 1.0), (0.08, 0.5), (0.18, 1 / 3)])
def test_an_account_the_statement_excludes_is_covered_moved_back_on_the_profile(lead, share):
    """The data unit's account (its parameters drift on the span's clock beyond the stated
    bound) with `profile`: the band reaches its order moved back towards the span's by
    √(4/Δχ²), Δχ² = twice the log-likelihood it loses (the span's lead × 100 points), all
    of it up to 4; the reported order is the span's, the clock's median is named."""
    from vojax._tracker._band import moved_share
    from vojax._tracker._clock import weigh_clock

    from .helpers import clock_fit

    n = 100
    span = np.linspace(0.3, 0.4, n)
    res, fit = clock_fit(span, 0.05, log_likelihood=100.0 + lead * n)
    other, other_fit = clock_fit(span + 0.2, 0.08, log_likelihood=100.0)
    assert moved_share(2 * lead * n, 4.0) == pytest.approx(share)
    new, new_fit, clock = weigh_clock(res, fit, other, other_fit, bound=0.01, scale=100.0,
                                      answer=0.1, evidence=0.2, profile=4.0)
    edge = span + max(0.05, 0.2 * share)
    np.testing.assert_allclose(np.asarray(new.alpha_upper), edge, atol=1e-12)
    np.testing.assert_allclose(np.asarray(new_fit["upper"]), edge, atol=1e-12)
    np.testing.assert_array_equal(np.asarray(new.alpha_lower), res.alpha_lower)
    np.testing.assert_array_equal(np.asarray(new.alpha), res.alpha)
    assert clock == pytest.approx(float(np.median((span + 0.2)[n // 2:])))
    # without `profile` the statement excludes it: nothing changes where the span leads
    # or covering it would leave no answer (a half-width 0.165 > 0.1)
    same, same_fit, none = weigh_clock(res, fit, other, other_fit, bound=0.01, scale=100.0,
                                       answer=0.1, evidence=0.2)
    assert same is res and same_fit is fit and none is None


def test_an_excluded_account_moved_back_inside_the_band_changes_nothing():
    from vojax._tracker._clock import weigh_clock

    from .helpers import clock_fit

    span = np.linspace(0.3, 0.4, 100)
    res, fit = clock_fit(span, 0.05, log_likelihood=100.0 + 4.0)  # Δχ² 8: share 0.71
    other, other_fit = clock_fit(span + 0.06, 0.01, log_likelihood=100.0)  # moved: +0.042
    new, new_fit, clock = weigh_clock(res, fit, other, other_fit, bound=0.01, scale=100.0,
                                      answer=0.1, evidence=0.2, profile=4.0)
    assert new is res and new_fit is fit and clock is None
