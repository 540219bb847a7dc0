"""With the parameters stated constant, the tuned run's own alternatives near its evidence
covered, not only weighed (`vojax._tracker._band.near_alternatives`, the setting
`near_evidence`): on stand-in explanations whose bands are closed forms, the stated band is
the union of the reference's and theirs, only for those the setting names, and nothing else
moves."""

import numpy as np
import pytest

from vojax import TrackerSettings
from vojax._tracker._band import bands, near_alternatives
from vojax._tracker._explanations import Explanation
from vojax._tracker._model import order_of_np

from .helpers import band_calls

N = 60
BOUNDS = (0.0, 1.0)
SD, SD_DRIFT, BETA_DRIFT = 0.1, 0.2, 0.5  # the tuned run's σ of β; the ×10 drift's σ and β


def ex(kind, beta, sd, evidence=0.0, chi2=40.0, factor=None):
    """A stand-in (χ² 40 at 50 dof fits), its parameters held, β constant."""
    return Explanation(kind, np.full(N, float(beta)), np.full(N, sd**2), chi2, 50.0,
                       float(evidence), 0.0, None, factor)


def pair(below, tuned_evidence=0.0, kind="order_drift", chi2=40.0):
    """The tuned run at β 0 and one alternative at β 0.5, σ 0.2, `below` nats under it."""
    return [ex("tuned", 0.0, SD, tuned_evidence),
            ex(kind, BETA_DRIFT, SD_DRIFT, tuned_evidence - below, chi2, factor=10.0)]


def mixture_sd(below):
    """The reference's σ of β, closed form: the evidence-weighted mixture of the two runs
    (weights 1 : e^−below), its variance about the tuned β."""
    w = np.exp(-below) / (1 + np.exp(-below))
    return np.sqrt((1 - w) * SD**2 + w * (SD_DRIFT**2 + BETA_DRIFT**2))


def edges(explanations, stated=0.0, near=5.0):
    b = bands(explanations, BOUNDS, N, stated, near_evidence=near)
    return float(np.median(b.stated[1])), float(np.median(b.stated[2]))


def test_a_near_alternative_widens_the_constant_band_to_its_own():
    """4 nats below: the upper edge is the alternative's β + 2σ (0.9), the lower the
    reference's (its mixture's σ); 6 nats below, both edges are the reference's."""
    lower, upper = edges(pair(4.0))
    assert upper == pytest.approx(order_of_np(BETA_DRIFT + 2 * SD_DRIFT, BOUNDS)[0], rel=1e-12)
    assert lower == pytest.approx(order_of_np(-2 * mixture_sd(4.0), BOUNDS)[0], rel=1e-12)
    lower, upper = edges(pair(6.0))
    assert upper == pytest.approx(order_of_np(2 * mixture_sd(6.0), BOUNDS)[0], rel=1e-12)
    assert lower == pytest.approx(order_of_np(-2 * mixture_sd(6.0), BOUNDS)[0], rel=1e-12)
    # the rule off (None): weighed only, whatever the distance
    lower, upper = edges(pair(4.0), near=None)
    assert upper == pytest.approx(order_of_np(2 * mixture_sd(4.0), BOUNDS)[0], rel=1e-12)


def test_the_limit_is_measured_from_the_tuned_evidence():
    """4.9 and 5.1 nats below a tuned evidence of 100 (not of 0): covered, not."""
    for below, kept in ((4.9, 1), (5.1, 0)):
        e = pair(below, tuned_evidence=100.0)
        assert len(near_alternatives(e, e[0], 5.0)) == kept
    # a better alternative (above the tuned evidence) is near at any limit, 0 included
    e = pair(-1.0)
    assert near_alternatives(e, e[0], 0.0) == [e[1]]


def test_only_the_tuned_runs_own_alternatives_that_hold():
    """Another start is covered like an order drift; a held scale of the level profile, a
    parameter drift and a trade-off profile at the same evidence are not (the level profile
    is integrated by its χ²; drifting parameters are what the statement excludes); nor an
    order drift that does not fit (χ² 80 at 50 dof) or did not converge."""
    tuned = ex("tuned", 0.0, SD)
    start = ex("start", BETA_DRIFT, SD_DRIFT, -1.0)
    others = [ex(k, BETA_DRIFT, SD_DRIFT, -1.0) for k in ("level", "param_drift", "trade")]
    misfit = ex("order_drift", BETA_DRIFT, SD_DRIFT, -1.0, chi2=80.0)
    lost = ex("order_drift", BETA_DRIFT, SD_DRIFT, -np.inf)
    assert near_alternatives([tuned, start, *others, misfit, lost], tuned, 5.0) == [start]
    # a tuned run without a finite evidence: none
    blind = ex("tuned", 0.0, SD, np.nan)
    assert near_alternatives([blind, start], blind, 5.0) == []


def test_other_statements_and_the_conditional_answer_do_not_move():
    """Free or drift-bounded parameters: the stated band is the same with and without the
    rule (free: every fitting alternative is covered already); the conditional answer and
    the breakdown drift are the same under every statement."""
    e = pair(4.0)
    for stated in (0.0, 0.1, np.inf):
        on = bands(e, BOUNDS, N, stated, near_evidence=5.0)
        off = bands(e, BOUNDS, N, stated, near_evidence=None)
        for a, b in zip(on.conditional, off.conditional):
            np.testing.assert_array_equal(a, b)
        assert on.breakdown_drift == off.breakdown_drift
        if stated > 0:
            for a, b in zip(on.stated, off.stated):
                np.testing.assert_array_equal(a, b)


def test_the_setting_is_checked():
    assert TrackerSettings().near_evidence == 5.0
    assert TrackerSettings(near_evidence=0.0).near_evidence == 0.0
    for bad in (-1.0, np.inf, np.nan):
        with pytest.raises(ValueError, match="near_evidence"):
            TrackerSettings(near_evidence=bad)


def test_the_tracker_passes_its_setting_to_the_band(monkeypatch):
    """`identify(parameters="constant")` hands `TrackerSettings.near_evidence` to `bands`."""
    seen = band_calls(monkeypatch, parameters="constant",
                      settings=TrackerSettings(near_evidence=7.0))
    assert seen
    for _, args, kwargs in seen:
        assert kwargs["near_evidence"] == 7.0
        assert args[2] == 0.0  # the constant statement
