"""The tuning's second climb: where the first climb ends with the order's drift at the
bottom of its box while the parameters drift (`collapsed`), the tuning climbs again from the
first pass's best run at another order drift (`second_start`). Checked here on the choice of
that run, on the test of collapse and on `tune` with its runs stubbed (which climb it keeps);
the record that needs it is in the slow tier (`tests/test_calibration.py`, stated-drift draw
16)."""

import dataclasses
import importlib
import math

import numpy as np
import pytest

import vojax
from vojax._tracker._tuning import Tuning, at_edges, box, collapsed, second_start

_tuning = importlib.import_module("vojax._tracker._tuning")  # the module, not a name in it
S = vojax.TrackerSettings()
ROWS = [(qo, S.constant_drift, 1e-4) for _ in range(2) for qo in S.grid_order]  # 2 starts


def test_the_second_start_is_the_best_run_at_another_order_drift():
    scores = [10.0, 30.0, 5.0, 12.0, 29.0, 7.0]  # run 1 (order drift 1.0) is the best
    j = second_start(ROWS, scores, 1)
    # 12 at 0.1 beats 10 at 0.1 and 7 at 10; run 4 (29) shares run 1's order drift
    assert j == 3


def test_the_second_start_skips_runs_that_did_not_score_and_may_be_none():
    scores = [math.nan, 30.0, -math.inf, math.nan, 29.0, 3.0]
    assert second_start(ROWS, scores, 1) == 5
    assert second_start(ROWS, [math.nan, 30.0, math.nan, math.nan, 29.0, math.nan], 1) == -1


def _tuned(order_drift, parameter_drift, limits):
    x = (math.log(order_drift), math.log(parameter_drift), math.log(1e-4))
    return Tuning(order_drift, parameter_drift, 1e-4, at_edges(x, limits, S.edge), 0.0, True)


def test_a_climb_has_collapsed_only_with_the_order_at_its_floor_and_the_parameters_drifting():
    limits = box(S, 1e-8)
    lo, hi = limits["order_drift"]
    near = float(np.exp(lo + 0.5 * S.edge * (hi - lo)))  # inside the edge's margin
    beyond = float(np.exp(lo + 2.0 * S.edge * (hi - lo)))  # outside it
    drifting, held = 10 * S.held_ratio * S.constant_drift, S.held_ratio * S.constant_drift
    assert collapsed(_tuned(S.order_drift_range[0], drifting, limits), S)
    assert collapsed(_tuned(near, drifting, limits), S)
    assert not collapsed(_tuned(beyond, drifting, limits), S)
    assert not collapsed(_tuned(S.order_drift_range[0], held, limits), S)  # nothing drifts
    assert not collapsed(_tuned(S.order_drift_range[1], drifting, limits), S)  # the top


@pytest.mark.parametrize("value", ["yes", 1, None])
def test_second_climb_must_be_a_boolean(value):
    with pytest.raises(ValueError, match="second_climb"):
        vojax.TrackerSettings(second_climb=value)


@dataclasses.dataclass
class _Run:
    """A stand-in smoothing: `host_score` reads these three."""

    log_likelihood: float
    objective: float = 0.0
    converged: bool = True


class _Problem:
    settings = S

    def smooth_from(self, hyper, start):
        return _Run(float(np.exp(hyper.log_q_order)))  # which order drift it started from


@pytest.mark.parametrize("hold", [False, True])
@pytest.mark.parametrize("second_score", [2000.0, 1000.0])
def test_tune_keeps_the_second_climb_where_its_evidence_is_higher(monkeypatch, hold,
                                                                   second_score):
    """`tune` with its runs stubbed: the first pass's best run is at order drift 1.0, the
    second best at another drift (0.1); the first climb collapses (evidence 1599). The
    second climb starts from 0.1 and is kept only where its evidence is higher; with the
    parameters held there is no second climb."""
    climbs = []

    def first_pass(problem, rows, firsts, budget):
        scores = np.asarray([10.0 if r[0] == 1.0 else 5.0 if r[0] == 0.1 else 1.0
                             for r in rows])
        i = int(np.argmax(scores))
        return _Run(scores[i]), i, i, scores

    def climb(problem, limits, hyper, sm, rounds):
        climbs.append(float(np.exp(hyper.log_q_order)))
        if len(climbs) == 1:
            return hyper, _Run(1599.0), _tuned(S.order_drift_range[0], 0.04, limits)
        return hyper, _Run(second_score), _tuned(0.13, 0.007, limits)

    monkeypatch.setattr(_tuning, "run_batch_shares", first_pass)
    monkeypatch.setattr(_tuning, "climb", climb)
    _, sm, tuning = _tuning.tune(_Problem(), np.zeros((2, 3)), [1e-4], 1e-8, hold=hold)
    if hold:
        assert climbs == [pytest.approx(1.0)]
        return
    assert climbs == [pytest.approx(1.0), pytest.approx(0.1)]
    kept = second_score > 1599.0
    assert sm.log_likelihood == (second_score if kept else 1599.0)
    assert tuning.order_drift == (0.13 if kept else S.order_drift_range[0])
