"""The calibration suite of `scripts/bench_calibration.py`, reduced to what the slow tier can
afford: its truth is independent of the code under test and inside the model's class, the
tracker's band is never confidently wrong where a parameter drifts, with the parameters
stated constant it identifies most white-noise and noisy draws with bands that hold, and the
paper's law never claims a band. Needs ../shared/data (the recorded inputs); skipped where it is absent."""

import warnings

import numpy as np
import pytest

import vojax

from .helpers import SHARED_DATA as DATA
from .helpers import load_script

pytestmark = [
    pytest.mark.slow,
    pytest.mark.skipif(not DATA.is_dir(), reason="../shared/data is not present"),
]


def test_every_dataset_gives_inputs(suite):
    module, signals = suite
    names = " ".join(name for name, *_ in signals)
    for word in ("beef", "silicone", "AFM", "adhesive", "myocardium", "CreepDataPP",
                 "rheometer", "LAOS"):
        assert word in names


@pytest.mark.parametrize("family, index", [("white", 0), ("drift", 2), ("irregular", 1)])
def test_truth_is_inside_the_model_to_well_below_the_noise(suite, family, index):
    """The truth (the reference's direct sums on a grid twice as fine, p inside the integral,
    on the record's clock of time over its span) and vojax's own memory on the record's
    samples, at the true order: they differ by far less than the drawn noise, so the suite
    measures the estimators, not the quadrature."""
    module, signals = suite
    case = module.draw_case(family, index, signals)
    t = case["t"] / case["t"][-1]  # the tracker's clock
    grid = dict(t=t) if case["irregular"] else dict(dt=float(t[1] - t[0]))
    model = np.asarray(vojax.fractional_integral(case["u"] * case["p"], case["alpha"], **grid))
    sd = case["noise"] * np.ptp(case["x"])
    assert np.sqrt(np.mean((case["x"] - model) ** 2)) < 0.2 * sd


@pytest.mark.parametrize("index", [1, 2])
def test_the_clock_familys_parameter_is_constant_in_the_datas_unit(suite, index):
    """The `clock` family's records (a moving order; the oscillation superposed on odd
    draws): on the record's clock of time over its span the parameter is a gain that drifts,
    and in the data's own unit of time it is constant, ``x = c·I^α u`` with the integral on
    the recording's times (vojax's memory at the true order, the constant fitted): the
    record differs from that by far less than the drawn noise, while the same integral on
    the span's clock misses by more than the noise (the two accounts differ)."""
    module, signals = suite
    case = module.draw_case("clock", index, signals)
    assert np.ptp(case["alpha"]) > 0.05 and case["true_drift"] > 0.1
    sd = case["noise"] * np.ptp(case["x"])

    def miss(t):
        m = np.asarray(vojax.fractional_integral(case["u"], case["alpha"], dt=float(t[1] - t[0])))
        c = (m @ case["x"]) / (m @ m)
        return np.sqrt(np.mean((case["x"] - c * m) ** 2))

    assert miss(case["t"]) < 0.2 * sd
    assert miss(case["t"] / case["t"][-1]) > sd


def test_the_default_is_not_confidently_wrong_on_clock_draw_19(suite):
    """Clock draw 19 (see the `clock` family: an order following the load, 0.52–0.63, on a
    PVC creep strain input, the parameter constant in the data's unit of time, so drifting
    51 % on the span's clock): the default tracker either refuses the record or its band
    holds the truth on at least half of the second half's samples. With the smoothings'
    stopping rule of the damping alone (`BARELY_DAMPED` 0) it identified 0.47 ± 0.08 with the
    truth outside at 99 % of the second half; with settled smoothings ended where they
    settle, the record is refused (coverage 0.96)."""
    module, signals = suite
    case = module.draw_case("clock", 19, signals)
    row = module.score(case, module.run_method("tracker", case))
    assert not (row["identified"] and row["wrong"]), row


def _rows(module, signals, method, families, count=6):
    return [
        module.score(case, module.run_method(method, case))
        for case in (module.draw_case(f, i, signals) for f in families for i in range(count))
    ]


def test_default_tracker_is_never_confidently_wrong_where_a_parameter_drifts(suite):
    """Draws 0–5 of the drift and gain-drift families (a moving order and a parameter
    drifting 10–40 %, inside the integral or as a gain), the default tracker: every record
    gets a verdict and a breakdown drift, no record it calls identified is confidently
    wrong, and no conditional answer makes a false promise (its band missing the truth at
    more than half of the second half's samples while its breakdown drift, the drift up to
    which it promises its band, exceeds the parameter's true drift). The band of a record
    it refuses may miss the truth (drift 2, gain-drift 2): no answer is given there."""
    module, signals = suite
    cases = [module.draw_case(f, i, signals) for f in ("drift", "gain-drift") for i in range(6)]
    rows = [dict(module.score(case, module.run_method("tracker", case)),
                 name=(case["family"], case["index"]), true_drift=case["true_drift"])
            for case in cases]
    assert all(r["verdict"] in ("identified", "conditional", "not identified") for r in rows)
    assert all(r["breakdown_drift"] > 0 for r in rows)  # a reach each (inf: none fits)
    assert not any(r["wrong"] for r in rows if r["identified"])
    # a conditional answer whose band misses the truth while its reach exceeds the true drift
    assert not [r["name"] for r in rows if r["false_promise"]]


def test_tracker_with_constant_parameters_identifies_white_and_noisy_draws(suite):
    """Draws 0–5 of the white (0.5–2 %) and noisy (5–10 %, quantised) families, the
    parameters constant and stated so (``parameters="constant"``): at least 5 of the 12 are
    identified, the identified bands hold the truth at ≥ 85 % of the second halves' samples,
    and none is confidently wrong."""
    module, signals = suite
    rows = _rows(module, signals, "tracker-constant", ("white", "noisy"))
    identified = [r for r in rows if r["identified"]]
    assert len(identified) >= 5
    coverage = sum(r["inside"] for r in identified) / sum(r["count"] for r in identified)
    assert coverage >= 0.85
    assert not any(r["wrong"] for r in identified)


def test_constant_parameters_band_covers_the_level_another_scale_allows(suite):
    """White draw 16 (a beef force input, a smooth order, 1,200 samples, 0.84 % noise), the
    parameters constant and stated so: the tuned order's level sits about 0.09 below the
    truth (0.35 against 0.44 over the second half), where a larger parameter and another
    offset fit as well. The band must then hold the truth at more than half of the second
    half's samples (without the level profile's held scales it is ±0.019 and holds it
    nowhere, called identified), and the tuned order itself is still the low one (the
    profile widens the band, it does not move the estimate)."""
    module, signals = suite
    case = module.draw_case("white", 16, signals)
    row = module.score(case, module.run_method("tracker-constant", case))
    assert row["coverage"] > 0.5 and not row["wrong"]
    assert row["rms"] > 0.1


@pytest.mark.parametrize("family, index", [("white", 23), ("coloured", 15)])
def test_a_true_constant_statement_covers_the_tuned_runs_near_alternatives(suite, monkeypatch,
                                                                          family, index):
    """White draw 23 (the order falling from 0.61 to 0.50 in the first 50 of 600 samples) and
    coloured draw 15 (a constant order under AR(1) noise), the parameters constant and stated
    so: each identified, with the truth inside the band at most samples of the second half;
    with the tuned run's near alternatives only weighed (`near_alternatives` empty), each is
    identified with the truth outside at most of them (confidently wrong), the estimate the
    same: the rule widens the band, it does not move the order."""
    from vojax._tracker import _band

    module, signals = suite
    case = module.draw_case(family, index, signals)
    on = module.score(case, module.run_method("tracker-constant", case))
    monkeypatch.setattr(_band, "near_alternatives", lambda *args: [])
    off = module.score(case, module.run_method("tracker-constant", case))
    assert on["identified"] and on["coverage"] > 0.85
    assert off["identified"] and off["wrong"]
    assert on["rms"] == pytest.approx(off["rms"], rel=1e-9)


@pytest.fixture(scope="module")
def long_draw(suite):
    """Long draw 1 (20,000 samples; its truth takes a few seconds), drawn once."""
    module, signals = suite
    return module.draw_case("long", 1, signals)


def test_long_truth_by_the_reference_recursion_matches_the_direct_sums(long_draw):
    """The long family's truth is the reference's NumPy recursion of the exponential memory
    (the direct sums of 2e5 fine samples would take hours): on a record short enough for both,
    its first 4,000 fine samples of a long draw, the two agree to far below the noise, and the
    long draw's truth is inside vojax's model on its own samples as the other families' is."""
    from vojax import reference

    case = long_draw
    assert case["samples"] == 20000
    u, alpha = case["u"][:4000], case["alpha"][:4000]
    dt = float(case["t"][1] - case["t"][0]) / case["t"][-1]  # the tracker's clock
    direct = reference.fractional_integral(u, alpha, dt)
    recursion = reference.fractional_integral(u, alpha, dt, memory="exponential", tol=1e-10)
    assert np.max(np.abs(recursion - direct)) < 1e-9 * np.max(np.abs(direct))
    model = np.asarray(vojax.fractional_integral(case["u"] * case["p"], case["alpha"], dt=dt))
    sd = case["noise"] * np.ptp(case["x"])
    assert np.sqrt(np.mean((case["x"] - model) ** 2)) < 0.2 * sd


def test_a_sharp_long_record_is_not_confidently_wrong_with_constant_parameters(suite, long_draw):
    """Long draw 1 (a beef force input, a smooth order, 20,000 samples fitted as block means
    of 21), the parameters constant and stated so: the parameter scales that fit lie between
    0.8 and 1.24 of the tuned one, between the level profile's first ratios. Its band must hold
    the truth at more than half of the second half's samples (without the profile's
    bisection it held it at none, identified, an order 0.01 below the truth)."""
    module, _ = suite
    row = module.score(long_draw, module.run_method("tracker-constant", long_draw))
    assert row["coverage"] > 0.5 and not row["wrong"]


def test_the_law_is_never_identified_and_its_band_misses(suite):
    """The paper's law on draws 0–5 of the white family: never identified, and its band (the
    spread over the noise alone) misses the truth at most samples of nearly every draw."""
    module, signals = suite
    rows = [
        module.score(case, module.run_method("law", case))
        for case in (module.draw_case("white", i, signals) for i in range(6))
    ]
    assert not any(r["identified"] for r in rows)
    assert sum(r["coverage"] < 0.5 for r in rows) >= 5


def test_a_conditional_answer_promises_no_drift_its_moving_truth_breaks(suite):
    """Draw 21 of the stated-drift family (held out: a myocardium stretch, the order moving
    0.33 → 0.39 → 0.25, the gain drifting 25 %): the conditional answer's band misses the
    truth over the second half, so its breakdown drift must lie below the true drift. The
    constant orders alone put it at 28 % (a false promise); with moving orders it falls to
    22 %."""
    module, signals = suite
    case = module.draw_case("stated-drift", 21, signals)
    half = case["alpha"].size // 2

    def run(settings=None):
        res = vojax.identify(case["u"], case["y"], t=case["t"], warn=False,
                             settings=settings)
        c = res.conditional
        lower, upper = (np.asarray(a)[half:] for a in (c.alpha_lower, c.alpha_upper))
        return res.diagnostics, np.mean((case["alpha"][half:] < lower)
                                        | (case["alpha"][half:] > upper))

    diag, missed = run()
    assert diag.verdict == "conditional" and missed > 0.5
    assert diag.breakdown_drift < case["true_drift"]
    constant_only, _ = run(vojax.TrackerSettings(moving_offsets=()))
    assert constant_only.breakdown_drift > case["true_drift"]  # what the moving orders mend


def test_correlated_noise_the_white_models_states_absorbed_is_modelled_on_coloured_draw_4(
        suite):
    """Coloured draw 4 (AR(1) noise, ρ 0.81, 1,200 samples): the white-noise model's order and
    parameters drift fast enough to absorb the correlated noise, so its prediction errors
    look white (lag-1 below the limit) and its noise variance falls to a fifth of the data's
    own; its order was off by 0.10 (RMS over the second half). Tried where the white model's
    noise is below half the data's (`coloured_absorbed`), the coloured model is kept by its
    evidence and the order is off by about 0.01."""
    module, signals = suite
    case = module.draw_case("coloured", 4, signals)
    half = case["t"] > case["t"][-1] / 2

    def error(settings):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            res = vojax.identify(case["u"], case["y"], dt=float(case["t"][1] - case["t"][0]),
                                 settings=settings, warn=False)
        err = np.asarray(res.alpha)[half] - case["alpha"][half]
        return res, float(np.sqrt(np.mean(err**2)))

    white, white_error = error(vojax.TrackerSettings(coloured_absorbed=0.0))
    res, own_error = error(vojax.TrackerSettings())
    assert white.tuning.coloured_noise is None and white_error > 0.08  # 0.0999
    assert res.tuning.coloured_noise is not None and 0.6 < res.diagnostics.noise_correlation < 0.95
    assert own_error < 0.025  # 0.0107


@pytest.mark.parametrize("family, index, setting", [("white", 12, "constant"),
                                                    ("stated-drift", 13, "free")])
def test_saved_explanations_rescored_give_the_band_the_tracker_reported(suite, family, index,
                                                                        setting):
    """`scripts/band_scores.py::as_reported` on a record saved by `band_explanations.py`
    gives the band the call reported, the second clock's weighing included: on white draw
    12 with the parameters stated constant the data unit's order lies outside the span's
    band and the statement excludes that account (not covered, ±0.03); on stated-drift draw
    13 with the parameters free the span's fit is not far enough ahead (covered). Before,
    the rescoring covered both, and 20 of 240 saved records were scored otherwise than the
    tracker had reported them."""
    module, signals = suite
    dump, scores = load_script("band_explanations"), load_script("band_scores")
    undo = dump.spy(dump._CAP)
    dump._CAP["signals"] = signals
    try:
        r = dump._record(family, index, setting, str(DATA))
    finally:
        undo()
        dump._CAP.clear()
    band = scores.as_reported(r)
    for got, reported in zip(band[1:3], (r["final"]["lower"], r["final"]["upper"])):
        np.testing.assert_allclose(got, np.asarray(reported, float), atol=1e-6)
    assert scores.score(r, band)["identified"] == r["identified"]
