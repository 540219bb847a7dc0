"""The freest order drift the tuned run tried, left to its mixture weight where its evidence
lies far below the tuned one's (`vojax._tracker._band.fastest_far`, the setting
`fastest_evidence`): on stand-in explanations whose bands are closed forms, exactly that
alternative leaves the band, and only under the conditions the setting names."""

import numpy as np
import pytest

from vojax import TrackerSettings
from vojax._tracker._band import bands, fastest_far
from vojax._tracker._explanations import Explanation
from vojax._tracker._model import order_of_np

from .helpers import band_calls

N = 60
BOUNDS = (0.0, 1.0)
SD = 0.1  # every stand-in's σ of β


def ex(kind, beta, evidence=0.0, factor=None):
    """A stand-in that fits (χ² 40 at 50 dof), its parameters held, β constant."""
    return Explanation(kind, np.full(N, float(beta)), np.full(N, SD**2), 40.0, 50.0,
                       float(evidence), 0.0, None, factor)


def drifts(fastest_evidence, far_slow=-60.0, far_fast=-30.0, beta_fast=1.0):
    """The tuned run at β 0 and its four order drifts: ×0.01 and ×0.1 at β −0.3 and −0.5,
    ×10 at β 0.5, ×100 at `beta_fast`; the slower ones `far_slow`, the faster `far_fast`
    nats below the tuned evidence (every alternative's weight in the mixture below e^−30,
    so the reference band is the tuned run's own)."""
    return [ex("tuned", 0.0), ex("order_drift", -0.3, far_slow, 0.01),
            ex("order_drift", -0.5, far_slow, 0.1), ex("order_drift", 0.5, far_fast, 10.0),
            ex("order_drift", beta_fast, far_fast, 100.0)]


def upper(explanations, fastest_evidence, stated=np.inf):
    b = bands(explanations, BOUNDS, N, stated, fastest_evidence=fastest_evidence)
    return float(np.median(b.stated[2])), float(np.median(b.stated[1]))


def test_the_fastest_far_below_leaves_the_free_band_and_the_slower_stay():
    """Parameters free: the band is the union of the fitting alternatives' ±2σ. With the ×100
    drift 30 nats below and the limit 20, the upper edge is the ×10 drift's (β 0.5 + 2σ),
    not the ×100's (β 1 + 2σ); the ×10 drift, as far below, stays covered, as do the slower
    ones (the lower edge at β −0.5 − 2σ)."""
    top, bottom = upper(drifts(20.0), 20.0)
    assert top == pytest.approx(order_of_np(0.5 + 2 * SD, BOUNDS)[0], rel=1e-12)
    assert bottom == pytest.approx(order_of_np(-0.5 - 2 * SD, BOUNDS)[0], rel=1e-12)
    # off (∞, or nearer than the limit): the ×100 drift's edge
    want = order_of_np(1.0 + 2 * SD, BOUNDS)[0]
    assert upper(drifts(np.inf), np.inf)[0] == pytest.approx(want, rel=1e-12)
    assert upper(drifts(20.0, far_fast=-10.0), 20.0)[0] == pytest.approx(want, rel=1e-12)


def test_the_limit_is_measured_from_the_tuned_evidence():
    """19 and 21 nats below a tuned evidence of 100 (not of 0): kept, left out."""
    def at(below):
        e = drifts(20.0)
        e[0] = Explanation("tuned", e[0].beta, e[0].var, 40.0, 50.0, 100.0, 0.0)
        e[4] = ex("order_drift", 1.0, 100.0 - below, 100.0)
        return [x.factor for x in fastest_far(e, e[0], 20.0) if x.kind == "order_drift"]

    assert at(19.0) == [0.01, 0.1, 10.0, 100.0]
    assert at(21.0) == [0.01, 0.1, 10.0]


def test_only_the_largest_factor_is_weighed_whatever_the_order_of_the_list():
    e = drifts(20.0)
    shuffled = [e[0], e[4], e[2], e[3], e[1]]
    kept = fastest_far(shuffled, e[0], 20.0)
    assert sorted(x.factor for x in kept if x.kind == "order_drift") == [0.01, 0.1, 10.0]
    # only the order drifts: a start at the same evidence stays
    start = ex("start", 1.0, -30.0)
    assert start in fastest_far([*e, start], e[0], 20.0)


def test_nothing_is_left_out_without_factors_or_a_tuned_evidence():
    """Explanations without factors (saved before they were kept) and a tuned run whose
    evidence is not finite leave the list as it was."""
    bare = [ex("tuned", 0.0)] + [ex("order_drift", b, -30.0) for b in (0.5, 1.0)]
    assert fastest_far(bare, bare[0], 20.0) == bare
    e = drifts(20.0)
    e[0] = Explanation("tuned", e[0].beta, e[0].var, 40.0, 50.0, np.nan, 0.0)
    assert fastest_far(e, e[0], 20.0) == e


def test_a_constant_statement_is_untouched():
    """Parameters stated constant: the band is the reference's, with or without the rule (to
    the ×100 drift's weight in the mixture, e^−30)."""
    on = bands(drifts(20.0), BOUNDS, N, 0.0, fastest_evidence=20.0).stated
    off = bands(drifts(20.0), BOUNDS, N, 0.0).stated
    for a, b in zip(on, off):
        np.testing.assert_allclose(a, b, rtol=1e-9)


def test_the_setting_is_checked():
    assert TrackerSettings().fastest_evidence == 20.0
    assert TrackerSettings(fastest_evidence=1e9).fastest_evidence == 1e9  # in effect, off
    for bad in (-1.0, np.inf, np.nan):
        with pytest.raises(ValueError, match="fastest_evidence"):
            TrackerSettings(fastest_evidence=bad)


def test_the_tracker_passes_its_setting_to_the_band(monkeypatch):
    """`identify` hands `TrackerSettings.fastest_evidence` (and the band's other settings) to
    `bands`, with the order drifts' factors on their explanations."""
    settings = TrackerSettings(fastest_evidence=7.0)
    seen = band_calls(monkeypatch, settings=settings)
    assert seen
    for explanations, _, kwargs in seen:
        assert kwargs["fastest_evidence"] == 7.0
        assert kwargs["evidence_floor"] == settings.envelope_evidence
        factors = [e.factor for e in explanations if e.kind == "order_drift"]
        assert factors == list(settings.alt_order_drift)
