"""Where the parameters may drift, an alternative that fits worse than the tuned smoothing
(its freedom counted) covers nothing (`vojax._tracker._band.fits_as_well`, the setting
`relative_gap`): the test's closed form, its false-rejection rate on nested least squares
against the χ² tail it stands for, and on stand-in explanations what it moves in the band
(the stated band where more drift is allowed than the breakdown drift) and what it leaves
alone (the conditional answer, its reach, a constant statement)."""

import numpy as np
import pytest

from vojax import TrackerSettings
from vojax._tracker._band import bands, fits_as_well
from vojax._tracker._model import order_of_np

from .band_stand_ins import BOUNDS, N, halfwidth
from .band_stand_ins import ex as stand_in
from .helpers import band_calls


def ex(kind, beta, chi2, freedom, drift=0.0, var=0.01, evidence=0.0):
    """A stand-in at the constant β `beta` with its χ² and freedom (`band_stand_ins.ex`;
    every χ² below 70 passes the 2σ test at 50 dof)."""
    return stand_in(kind, beta, var, chi2, evidence, drift, freedom=freedom)


def edge(freer, z):
    """The χ² above the tuned run's (x) at which a run `freer` effective parameters freer
    than it (negative: less free) leaves the test at `z`: the gap x + freer equals z times
    √(2(|freer| + 1) + 4x), the larger root of the quadratic in x."""
    b = 2 * freer - 4 * z**2
    c = freer**2 - z**2 * 2 * (abs(freer) + 1)
    return (-b + np.sqrt(b**2 - 4 * c)) / 2


def test_the_gap_and_its_standard_deviation_in_closed_form():
    """The tuned run: χ² 30 with freedom 10 (score 40). A run with freedom 4 may fit up to
    49.81 units of χ² worse at z 3 (the gap x − 6 against 3√(14 + 4x)); one as free, 36.49
    (x against 3√(2 + 4x)); a freer one (freedom 20), 20.73 (x + 10 against 3√(22 + 4x)).
    A run that fits better always fits as well."""
    tuned = ex("tuned", 0.0, 30.0, 10.0)
    for freedom, x in ((4.0, 49.807), (10.0, 36.493), (20.0, 20.728)):
        assert edge(freedom - 10.0, 3.0) == pytest.approx(x, abs=1e-3)
        at = 30.0 + edge(freedom - 10.0, 3.0)
        assert fits_as_well(ex("held", 1.0, at - 1e-7, freedom), tuned, 3.0)
        assert not fits_as_well(ex("held", 1.0, at + 1e-7, freedom), tuned, 3.0)
    assert fits_as_well(ex("held", 1.0, 10.0, 4.0), tuned, 0.0)
    assert fits_as_well(ex("held", 1.0, 36.0, 4.0), tuned, 0.0)  # the gap 0
    assert not fits_as_well(ex("held", 1.0, 36.0 + 1e-7, 4.0), tuned, 0.0)


def test_unknown_freedom_or_the_rule_off_leaves_every_run_fitting():
    """A coloured noise leaves the freedom NaN (its χ² is not on the white part's scale):
    the test cannot be made, and the run fits as its χ² test says; None turns it off."""
    tuned = ex("tuned", 0.0, 30.0, 10.0)
    far = ex("held", 1.0, 65.0, 4.0)  # 35 above, beyond `edge(-6, 2)` = 28.7: out at z 2
    assert not fits_as_well(far, tuned, 2.0)
    assert fits_as_well(far, tuned, None)
    assert fits_as_well(ex("held", 1.0, 65.0, np.nan), tuned, 2.0)
    assert fits_as_well(far, ex("tuned", 0.0, 30.0, np.nan), 2.0)


def test_the_rate_at_which_a_true_nested_model_fails_is_the_chi2_tail():
    """Least squares on a random design: the smaller model (k columns) true, the larger one
    (k + ΔF columns, the smaller's among them) fits its noise too; freedoms are the column
    counts, so the gap is χ²_ΔF − ΔF. At z = 1 the true smaller model fails where χ²_ΔF
    exceeds `edge(−ΔF, 1)`: 1.94 % of draws at ΔF 3 and 2.81 % at ΔF 10 by the χ² tail,
    matched by 20,000 draws within Monte Carlo error (a test that left the freedoms out, or
    counted them with the wrong sign, would reject the true model in most draws)."""
    from scipy.stats import chi2 as chi2_dist

    rng = np.random.default_rng(1)
    n, k, draws = 80, 3, 20_000
    for extra, rate in ((3, 0.0194), (10, 0.0281)):
        x = rng.standard_normal((n, k + extra))
        hat_small = x[:, :k] @ np.linalg.pinv(x[:, :k])
        hat_big = x @ np.linalg.pinv(x)
        noise = rng.standard_normal((draws, n))
        chi2_small = np.sum((noise - noise @ hat_small.T) ** 2, axis=1)
        chi2_big = np.sum((noise - noise @ hat_big.T) ** 2, axis=1)
        failed = np.array([not fits_as_well(ex("held", 0.0, a, k),
                                            ex("tuned", 0.0, b, k + extra), 1.0)
                           for a, b in zip(chi2_small, chi2_big)])
        exact = chi2_dist.sf(edge(-extra, 1.0), extra)
        assert exact == pytest.approx(rate, abs=2e-4)
        assert np.mean(failed) == pytest.approx(exact, abs=4 * np.sqrt(exact / draws))


def test_a_worse_fitting_alternative_widens_no_free_band_and_keeps_the_reach():
    """Parameters free, z 2: a held run (χ² 60, as free as the tuned run, 30 above it
    against `edge(0, 2)` = 16.5) passes the 2σ test of χ² (≤ 70) but not the relative one:
    the stated band is the tuned run's alone, while the conditional answer (about the held
    run, the tuned one breaking it at its drift 0.3) is the same as with the rule off. At 2
    units above the held run is covered as before. A parameter drift that fits worse (25
    above, freedom 2 less: `edge(-2, 2)` = 21.0) widens no stated band, and still sets the
    breakdown drift."""
    tuned = ex("tuned", 0.0, 30.0, 10.0, drift=0.3)
    alone = bands([tuned], BOUNDS, N, np.inf)
    for other, covered in ((ex("held", 2.0, 60.0, 10.0), False),
                           (ex("held", 2.0, 32.0, 10.0), True),
                           (ex("param_drift", 2.0, 55.0, 8.0, drift=0.6), False)):
        on = bands([tuned, other], BOUNDS, N, np.inf, gap_z=2.0)
        off = bands([tuned, other], BOUNDS, N, np.inf, gap_z=None)
        for a, b in zip(on.conditional, off.conditional):
            np.testing.assert_array_equal(a, b)
        assert (on.breakdown_drift, on.reference_drift) == (off.breakdown_drift,
                                                            off.reference_drift)
        np.testing.assert_allclose(off.stated[2], order_of_np(2.2, BOUNDS)[0])
        if covered:
            np.testing.assert_array_equal(on.stated[2], off.stated[2])
        else:
            assert halfwidth(on.stated) == pytest.approx(halfwidth(alone.stated), rel=1e-12)
        # a band about the drifting tuned run, in place of the held one, covers a drift
        # (the verdict's trade-off reason); one that leaves out a drifting alternative, not
        assert on.drifting == (other.kind == "held" or covered) and off.drifting
    assert off.breakdown_drift == pytest.approx(0.6)
    # a drift bound below the breakdown drift: the conditional band, the rule or not
    b = bands([tuned, other], BOUNDS, N, 0.4, gap_z=2.0)
    np.testing.assert_array_equal(b.stated[2], off.conditional[2])


def test_a_constant_statement_is_untouched():
    """Stated constant (drift 0), the band and its reach are the same with the rule on and
    off: there the held scales and the statement's own alternatives have their own rules."""
    tuned = ex("tuned", 0.0, 30.0, 10.0)
    runs = [tuned, ex("order_drift", 1.0, 60.0, 10.0, evidence=-4.0),
            ex("level", 0.5, 62.0, 10.0),
            ex("param_drift", 2.0, 55.0, 8.0, drift=0.6)]
    on = bands(runs, BOUNDS, N, 0.0, gap_z=2.0, near_evidence=5.0)
    off = bands(runs, BOUNDS, N, 0.0, gap_z=None, near_evidence=5.0)
    # the near order drift (4 nats below, covered under the statement) sets the upper edge
    np.testing.assert_allclose(off.stated[2], order_of_np(1.2, BOUNDS)[0])
    for a, b in zip(on.stated + on.conditional, off.stated + off.conditional):
        np.testing.assert_array_equal(a, b)
    assert on.breakdown_drift == off.breakdown_drift == pytest.approx(0.6)


def test_the_band_gets_the_settings_relative_gap(monkeypatch):
    """`relative_gap` reaches the band of a fit."""
    seen = band_calls(monkeypatch, settings=TrackerSettings(relative_gap=2.5))
    assert seen and all(kwargs["gap_z"] == 2.5 for _, _, kwargs in seen)
