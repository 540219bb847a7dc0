"""The band's held answers (`vojax._tracker._band`) on stand-in explanations whose answers
are known: the held smoothing as the conditional answer where the tuned parameters drift,
and the level profile's held scales weighed into the stated and held bands (their weights
by χ² or evidence, the held scales' gap, the settings that choose them)."""

import numpy as np
import pytest

from vojax._tracker._band import bands, own_halfwidth, reference_variance
from vojax._tracker._model import order_of_np

from .band_stand_ins import BOUNDS, DOF, FAILS, N, ex, halfwidth


def test_the_held_smoothing_answers_where_the_tuned_parameters_drift():
    """The tuned smoothing lets the parameters drift by 20 %; the smoothing with them held
    fits too: it is the conditional answer (its own Laplace band), and the tuned one, outside
    it, breaks it at its drift. Where the held smoothing does not fit, the tuned one answers."""
    tuned = ex("tuned", 1.0, drift=0.2)
    held = ex("held", 0.0, var=0.0025)
    b = bands([tuned, held], BOUNDS, N, np.inf)
    np.testing.assert_allclose(b.conditional[0], 0.5)
    np.testing.assert_allclose(b.conditional[2], order_of_np(0.1, BOUNDS)[0])
    assert b.breakdown_drift == pytest.approx(0.2) and b.reference_drift == 0.0
    b = bands([tuned, ex("held", 0.0, chi2=FAILS)], BOUNDS, N, np.inf)
    np.testing.assert_allclose(b.conditional[0], order_of_np(1.0, BOUNDS)[0])
    assert b.reference_drift == pytest.approx(0.2)


def test_the_held_answer_weighs_its_own_held_scales_by_their_likelihood():
    """Where the held smoothing answers, the level profile ran about it (kind "held_level"):
    its held scales weigh by exp(−Δχ²/2) with no floor at the degrees of freedom (they share
    every intensity with it). One as good (both χ² below dof) weighs alike: the band's
    variance on the β scale is 0.5·0.0025 + 0.5·(0.02 + 0.6²) about the held β; one 4 above
    weighs e^−2 : 1. They move neither the estimate nor the breakdown drift the tuned run
    sets, and are never unioned: a scale with no weight leaves the band, free or not, as
    the held smoothing's own. The tuned smoothing's own scales (kind "level") do not enter."""
    tuned = ex("tuned", 1.5, drift=0.2, chi2=DOF - 20.0)
    held = ex("held", 0.0, var=0.0025, chi2=DOF - 15.0)
    same = ex("held_level", 0.6, var=0.02, chi2=DOF - 15.0)
    b = bands([tuned, held, same], BOUNDS, N, np.inf)
    np.testing.assert_allclose(b.conditional[0], 0.5)
    sd = np.sqrt(0.5 * 0.0025 + 0.5 * (0.02 + 0.36))
    np.testing.assert_allclose(b.conditional[2], order_of_np(2 * sd, BOUNDS)[0])
    assert b.breakdown_drift == pytest.approx(0.2)  # the tuned β 1.5 is beyond 2σ = 0.87
    worse = ex("held_level", 0.6, var=0.02, chi2=DOF - 11.0)
    w = np.exp(-2.0) / (1.0 + np.exp(-2.0))
    b = bands([tuned, held, worse], BOUNDS, N, np.inf)
    sd = np.sqrt((1 - w) * 0.0025 + w * (0.02 + 0.36))
    np.testing.assert_allclose(b.conditional[2], order_of_np(2 * sd, BOUNDS)[0])
    # a scale as good by χ² but 300 nats of evidence below the tuned run (beyond the
    # evidence floor): the data exclude it, and the band is the held smoothing's own
    excluded = ex("held_level", 0.6, var=0.02, chi2=DOF - 15.0, evidence=-300.0)
    b = bands([tuned, held, excluded], BOUNDS, N, np.inf, evidence_floor=200.0)
    np.testing.assert_allclose(b.conditional[2], order_of_np(0.1, BOUNDS)[0])
    b = bands([tuned, held, same], BOUNDS, N, np.inf, evidence_floor=200.0)  # 0 nats below
    np.testing.assert_allclose(b.conditional[2], order_of_np(2 * np.sqrt(
        0.5 * 0.0025 + 0.5 * (0.02 + 0.36)), BOUNDS)[0])
    # a scale that passes the χ² test but weighs e^−12.5 leaves the free band where the
    # tuned run (β 1.5 ± 0.2) puts its edge: unioned, it would reach β 3.2
    far = ex("held_level", 3.0, chi2=DOF + 10.0)
    assert far.fits
    b = bands([tuned, held, far], BOUNDS, N, np.inf)
    assert np.all(b.stated[2] < order_of_np(2.0, BOUNDS)[0])
    for far in (ex("held_level", 3.0, chi2=FAILS + 500.0), ex("level", 0.6, chi2=DOF - 15.0)):
        b = bands([tuned, held, far], BOUNDS, N, 0.0)  # stated constant: the reference's band
        np.testing.assert_allclose(b.stated[2], order_of_np(0.1, BOUNDS)[0])
        b = bands([tuned, held, far], BOUNDS, N, np.inf)
        assert b.breakdown_drift == pytest.approx(0.2)


def test_the_held_scales_never_narrow_the_held_band():
    """A held scale at the held β with a sharper curvature (variance 0.0004 against 0.0025),
    as likely: the mixture's variance (0.00145) would be below the held smoothing's own; the
    band stays the held smoothing's own (±2·0.05 on β), the width `own_halfwidth` reads."""
    tuned = ex("tuned", 1.5, drift=0.2, chi2=DOF - 20.0)
    held = ex("held", 0.0, var=0.0025, chi2=DOF - 15.0)
    sharp = ex("held_level", 0.0, var=0.0004, chi2=DOF - 15.0)
    b = bands([tuned, held, sharp], BOUNDS, N, np.inf)
    np.testing.assert_allclose(b.conditional[2], order_of_np(0.1, BOUNDS)[0])
    assert halfwidth(b.conditional) == pytest.approx(
        own_halfwidth(held, BOUNDS, 1.0, 0.0, N // 2, N), rel=1e-12)


def test_integrated_alternatives_are_weighed_not_unioned():
    """Other starts and order drifts enter by evidence, the level profile's held scales by
    exp(−Δχ²/2): the variance is the weighted spread about the tuned mode, and an
    alternative that fits but carries almost no weight widens neither the band with the
    parameters stated constant nor the conditional band; with the parameters free, every
    explanation that fits is covered, that one too."""
    tuned = ex("tuned", 0.0, var=0.01, evidence=0.0, chi2=40.0)
    start = ex("start", 1.0, var=0.01, evidence=-np.log(3.0))  # weight 1/4 against 3/4
    var = reference_variance([tuned, start], tuned, N)
    np.testing.assert_allclose(var, 0.01 + 0.25 * 1.0)
    far = ex("order_drift", 3.0, var=0.01, evidence=-50.0)  # fits, weight e^−50
    alone = halfwidth(bands([tuned], BOUNDS, N, 0.0).stated)
    held = bands([tuned, far], BOUNDS, N, 0.0)
    assert halfwidth(held.stated) == pytest.approx(alone, rel=1e-12)
    free = bands([tuned, far], BOUNDS, N, np.inf)
    assert halfwidth(free.conditional) == pytest.approx(alone, rel=1e-12)
    np.testing.assert_allclose(free.stated[2], order_of_np(3.2, BOUNDS)[0])
    # a held scale 2 units of χ² above the tuned run, both above the noise's dof: 1 : e^−1
    above = ex("tuned", 0.0, var=0.01, evidence=0.0, chi2=DOF + 3.0)
    level = ex("level", 0.5, var=0.02, chi2=DOF + 5.0, evidence=-5.0)
    w = np.exp(-1.0) / (1.0 + np.exp(-1.0))
    want = (1 - w) * 0.01 + w * (0.02 + 0.25)
    np.testing.assert_allclose(reference_variance([above, level], above, N), want)
    # by evidence (`level_weights="evidence"`): 5 nats below, 1 : e^−5
    w = np.exp(-5.0) / (1.0 + np.exp(-5.0))
    want = (1 - w) * 0.01 + w * (0.02 + 0.25)
    np.testing.assert_allclose(reference_variance([above, level], above, N, "evidence"), want)


def test_a_held_scale_weighs_by_its_evidence_not_by_a_fit_below_the_noise():
    """By evidence (``level_weights="evidence"``), a held scale that fits below the noise as
    the tuned run does still weighs by the evidence between them: 3 nats, 1 : e^−3, where the
    χ² rule weighs the two alike (below). A held scale of higher evidence than the tuned run
    outweighs it, and the variance is then mostly its spread about the tuned mode. Where an
    evidence is not finite the χ² rule decides."""
    tuned = ex("tuned", 0.0, var=0.01, evidence=0.0, chi2=DOF - 40.0)
    level = ex("level", 0.5, var=0.02, chi2=DOF - 10.0, evidence=-3.0)
    w = np.exp(-3.0) / (1.0 + np.exp(-3.0))
    np.testing.assert_allclose(reference_variance([tuned, level], tuned, N, "evidence"),
                               (1 - w) * 0.01 + w * (0.02 + 0.25))
    better = ex("level", 0.5, var=0.02, chi2=DOF - 10.0, evidence=2.0)
    w = 1.0 / (1.0 + np.exp(-2.0))
    np.testing.assert_allclose(reference_variance([tuned, better], tuned, N, "evidence"),
                               (1 - w) * 0.01 + w * (0.02 + 0.25))
    lost = ex("level", 0.5, var=0.02, chi2=DOF - 10.0, evidence=np.nan)
    np.testing.assert_allclose(reference_variance([tuned, lost], tuned, N, "evidence"),
                               0.5 * 0.01 + 0.5 * (0.02 + 0.25))


def test_a_fit_below_the_noise_earns_no_weight_over_the_level_profile():
    """By χ² (the default): a χ² below its degrees of freedom fits the noise, not
    the signal: the tuned run's and a held scale's χ² count as no better than dof, so two
    runs below the noise weigh alike (exp(−Δχ²/2) on the raw χ², 40 against 10 below dof,
    would give the held scale e^−15); one below and one 4 above weigh 1 : e^−2."""
    tuned = ex("tuned", 0.0, var=0.01, evidence=0.0, chi2=DOF - 40.0)
    level = ex("level", 0.5, var=0.02, chi2=DOF - 10.0, evidence=-5.0)
    want = 0.5 * 0.01 + 0.5 * (0.02 + 0.25)
    np.testing.assert_allclose(reference_variance([tuned, level], tuned, N), want)
    worse = ex("level", 0.5, var=0.02, chi2=DOF + 4.0, evidence=-5.0)
    w = np.exp(-2.0) / (1.0 + np.exp(-2.0))
    want = (1 - w) * 0.01 + w * (0.02 + 0.25)
    np.testing.assert_allclose(reference_variance([tuned, worse], tuned, N), want)


def test_a_held_scale_far_above_the_tuned_fit_is_left_out_of_the_band():
    """`level_gap` (None, the default: off): a held scale whose χ² exceeds the tuned run's by
    more than that many standard deviations of a χ² with its degrees of freedom (√(2·50) =
    10 here) leaves the band, even where both fit below the noise (which the χ² weights count
    as alike): 30 above is 3 σ, out at a gap of 2.5 and in at 3 (the limit is kept), at 3.5
    and with none. It judges the held scales alone: another start as far above weighs by its
    evidence as before, and the held smoothing's own scales (`held_level`) are weighed
    without it."""
    tuned = ex("tuned", 0.0, var=0.01, evidence=0.0, chi2=DOF - 40.0)
    level = ex("level", 0.5, var=0.02, chi2=DOF - 10.0, evidence=-5.0)
    both = 0.5 * 0.01 + 0.5 * (0.02 + 0.25)  # weighed alike (the χ² rule's floor at dof)
    np.testing.assert_allclose(reference_variance([tuned, level], tuned, N, "chi2", 2.5), 0.01)
    np.testing.assert_allclose(reference_variance([tuned, level], tuned, N, "chi2", 3.0), both)
    np.testing.assert_allclose(reference_variance([tuned, level], tuned, N, "chi2", 3.5), both)
    np.testing.assert_allclose(reference_variance([tuned, level], tuned, N), both)
    nearer = ex("level", 0.5, var=0.02, chi2=DOF - 16.0, evidence=-5.0)  # 24 above: 2.4 σ
    np.testing.assert_allclose(reference_variance([tuned, nearer], tuned, N, "chi2", 2.5), both)
    start = ex("start", 1.0, var=0.01, chi2=DOF - 10.0, evidence=-np.log(3.0))
    np.testing.assert_allclose(reference_variance([tuned, start], tuned, N, "chi2", 0.0),
                               0.01 + 0.25 * 1.0)
    # through `bands`, with the parameters stated constant: the band is the tuned run's own
    alone = bands([tuned], BOUNDS, N, 0.0)
    gap = bands([tuned, level], BOUNDS, N, 0.0, level_gap=2.5)
    np.testing.assert_allclose(gap.stated[1], alone.stated[1], rtol=1e-12)
    assert halfwidth(bands([tuned, level], BOUNDS, N, 0.0).stated) > 2 * halfwidth(alone.stated)
    # the held smoothing's scales: weighed by exp(−Δχ²/2) whatever the gap (2 above: e^−1)
    drifting = ex("tuned", 1.5, drift=0.2, chi2=DOF - 20.0)
    held = ex("held", 0.0, var=0.01, chi2=DOF - 40.0)
    scale = ex("held_level", 0.5, var=0.01, chi2=DOF - 38.0)
    for g in (0.0, None):
        b = bands([drifting, held, scale], BOUNDS, N, 0.0, level_gap=g)
        w = np.exp(-1.0) / (1.0 + np.exp(-1.0))
        np.testing.assert_allclose(b.stated[3] / order_of_np(0.0, BOUNDS)[1],
                                   np.sqrt(0.01 + w * 0.25), rtol=1e-9)


def test_the_band_weighs_held_scales_as_its_setting_says():
    """`bands` passes `level_weights` on: with the parameters stated constant, a held scale
    1 nat of evidence below the tuned run widens the band by the equal weight of a fit below
    the noise by χ² (the default), and by its weight e^−1 : 1 by evidence."""
    tuned = ex("tuned", 0.0, var=0.01, evidence=0.0, chi2=DOF - 40.0)
    level = ex("level", 1.0, var=0.01, chi2=DOF - 10.0, evidence=-1.0)
    by_evidence = bands([tuned, level], BOUNDS, N, 0.0, level_weights="evidence")
    by_chi2 = bands([tuned, level], BOUNDS, N, 0.0)
    w = np.exp(-1.0) / (1.0 + np.exp(-1.0))
    np.testing.assert_allclose(by_evidence.stated[3] ** 2 / (order_of_np(0.0, BOUNDS)[1] ** 2),
                               0.01 + w * 1.0, rtol=1e-12)
    np.testing.assert_allclose(by_chi2.stated[3] ** 2 / (order_of_np(0.0, BOUNDS)[1] ** 2),
                               0.01 + 0.5 * 1.0, rtol=1e-12)


def test_the_level_weights_setting_is_checked():
    import vojax

    assert vojax.TrackerSettings().level_weights == "chi2"
    with pytest.raises(ValueError, match="`level_weights` must be 'evidence', 'chi2', 'profile', 'freedom' or 'excess', got 'aic'"):
        vojax.TrackerSettings(level_weights="aic")
    with pytest.raises(ValueError, match="TrackerSettings.level_pin must be a finite number > 0"):
        vojax.TrackerSettings(level_pin="evidence")
