"""The calibration suite's held smoothing (the explanation with the parameters held, where
the default's band is weighed): it follows a step drifting parameters absorbed, climbs to its
evidence's peak, a true stated drift bound reaches the moving order's mode, and the held
answer weighs the held scales. Needs ../shared/data (the recorded inputs); skipped where it
is absent."""

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


def _held_explanation(case, settings):
    """The default tracker on `case` with `settings`: its result and its held smoothing's
    explanation (the span clock's fit, where the band is weighed), caught by the spy of
    `scripts/band_explanations.py`."""
    caught = {}
    undo = load_script("band_explanations").spy(caught)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            res = vojax.identify(case["u"], case["y"], dt=float(case["t"][1] - case["t"][0]),
                                 warn=False, settings=settings)
    finally:
        undo()
    held = next(e for e in caught["result"].explanations if e.kind == "held")
    return res, held


def test_the_held_smoothing_follows_a_step_that_drifting_parameters_absorbed(suite):
    """Lengths draw 7 (the order steps from 0.25 to 0.12, the parameter constant, 2,400
    samples of a myocardium stretch, 1 % white noise): the tuned smoothing lets the parameter
    drift 12 % and puts the order at 0.26. Held at the tuned order drift, the parameters-held
    smoothing cannot follow the step (χ²/dof about 16), so no explanation placed the order
    at the truth and the default was confidently wrong (0.26 ± 0.07). With the held
    smoothing's order drift chosen by evidence it fits (χ² test) at the truth, and the
    default's band holds the truth on most of the second half (the suite's line for
    confidently wrong)."""
    module, signals = suite
    case = module.draw_case("lengths", 7, signals)
    half = case["t"] > case["t"][-1] / 2
    truth = float(np.median(case["alpha"][half]))
    _, stuck = _held_explanation(case, vojax.TrackerSettings(held_order_drift=(1.0,),
                                                             held_order_climb=0))
    assert not stuck.fits
    res, held = _held_explanation(case, vojax.TrackerSettings())
    assert held.fits
    order = np.asarray(res.alpha_bounds[0] + np.ptp(res.alpha_bounds) / (1 + np.exp(-held.beta)))
    n = order.size
    assert abs(float(np.median(order[n // 2:])) - truth) < 0.01
    lower, upper = np.asarray(res.alpha_lower), np.asarray(res.alpha_upper)
    inside = (case["alpha"] >= lower) & (case["alpha"] <= upper)
    assert inside[half].mean() > 0.5  # 0.77; the step's edge lies in the second half


def test_the_held_smoothing_reaches_its_evidence_peak_where_the_tuned_drift_is_at_the_floor(
        suite):
    """White draw 9 (a silicone force record, the order constant at 0.50, the parameters
    constant, 1.8 % noise): the tuned smoothing lets the parameters drift 32 % with its order
    drift at the range's floor (1.1e-6). The held smoothing's ladder (×1, 1e2, 1e4 of that)
    ends below its evidence's peak (×1e5–1e6): χ² 742 for 597 degrees of freedom, no fit,
    and the conditional answer fell back on the drifting tuned smoothing, promising a drift
    of 35 % with the truth outside its band (a false promise). Climbed to the peak, the held
    smoothing fits and has the larger evidence, and no conditional answer misses the
    truth."""
    module, signals = suite
    case = module.draw_case("white", 9, signals)
    _, ladder = _held_explanation(case, vojax.TrackerSettings(held_order_climb=0))
    assert not ladder.fits
    _, held = _held_explanation(case, vojax.TrackerSettings())
    assert held.fits and held.evidence > ladder.evidence + 100.0  # 667 against 423
    row = module.score(case, module.run_method("tracker", case))
    assert not row.get("false_promise", False), row  # no conditional answer: no promise


def test_a_true_stated_drift_bound_is_not_confidently_wrong_on_stated_drift_draw_16(suite):
    """Stated-drift draw 16 (an adhesive shear relaxation, the order moving smoothly about
    0.29, the gain drifting 21.5 %, the user stating at most 30 %, which is true). Two modes
    of the tuning's evidence are known: the order's drift at its floor with the parameters
    drifting 52 % (evidence 1599; the answer under the statement is then the held
    smoothing's, 0.47 +- 0.08, with the truth outside at 86 % of the second half), and the
    order moving (order drift about 0.1, evidence 1630-1631). Which mode the first climb
    ends in depends on the rounding of the installed versions (each has been seen with the
    newest versions of a different month); the second climb, from another order
    drift where the first ends at the floor, must reach the moving order's mode either way,
    never lower the evidence, and the answer must not be identified-and-wrong (the suite's
    line: the truth outside the band at more than half of the second half)."""
    module, signals = suite
    case = module.draw_case("stated-drift", 16, signals)
    assert case["true_drift"] < case["stated"]

    def tuned(settings):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return vojax.identify(case["u"], case["y"], dt=float(case["t"][1] - case["t"][0]),
                                  warn=False, parameters=case["stated"],
                                  settings=settings).tuning

    once = tuned(vojax.TrackerSettings(second_climb=False))
    twice = tuned(vojax.TrackerSettings())
    assert twice.log_likelihood >= once.log_likelihood - 1e-6
    assert twice.order_drift > 1e-3 and twice.log_likelihood > 1620.0, twice
    row = module.score(case, module.run_method("tracker-stated", case))
    assert not (row["identified"] and row["wrong"]), row


def test_the_held_answer_weighs_the_held_scales_on_white_draw_16(suite):
    """White draw 16 (a beef force input, an order moving smoothly about 0.46, the parameter
    constant, 0.8 % noise), the offset stated (``x0=0``). The tuned parameters drift 2.4 %,
    so the smoothing with them held (order about 0.35) is the conditional answer; without the
    parameters' scale weighed about it, its band missed the truth on most of the second half
    with a breakdown drift of 18 % (a false promise: the truth's drift is 0). A held scale
    with the order near 0.54 fits better (χ² 461 for 598 dof, the held smoothing's 465):
    weighed in, the conditional band holds the truth on most of the second half, or there is
    no promise."""
    module, signals = suite
    case = module.draw_case("white", 16, signals)
    assert case["true_drift"] == 0.0
    row = module.score(case, module.run_method("tracker-x0", case))
    assert not row.get("false_promise", False), row
    assert not (row["identified"] and row["wrong"]), row
    if row.get("verdict") == "conditional":
        assert row["c_coverage"] >= 0.5, row


def test_a_false_constant_statement_states_a_reach_below_the_drift_that_misled_it(suite):
    """Gain-drift-constant draw 18 (a constant order under a gain drifting 16 %), stated
    constant, which is false: one input cannot tell the drift from a moving order, and the
    answer is identified with the truth outside its band at most of the second half. No
    constant order outside the band fits with any drift of the parameters; a moving one
    does, with less drift than the truth's. So the answer states a reach below the true
    drift and the verdict line gives it: whoever knows the gain drifts that much is warned.
    Searched only where a constant order set a finite breakdown drift, the moving orders
    never ran here, and the line said nothing of how far the statement carries."""
    module, signals = suite
    case = module.draw_case("gain-drift-constant", 18, signals)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = vojax.identify(case["u"], case["y"], dt=float(case["t"][1] - case["t"][0]),
                             warn=False, parameters="constant")
    d = res.diagnostics
    half = case["t"] > case["t"][-1] / 2
    inside = ((case["alpha"] >= np.asarray(res.alpha_lower))
              & (case["alpha"] <= np.asarray(res.alpha_upper)))[half]
    assert d.verdict == "identified" and np.mean(inside) < 0.5  # confidently wrong
    assert 0 < d.breakdown_drift <= case["true_drift"], (d.breakdown_drift, case["true_drift"])
    assert res.verdict_line().endswith(
        f"; with a drift of {100 * d.breakdown_drift:.2g} % over the test an order outside "
        "the band fits as well")
