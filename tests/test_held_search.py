"""The held smoothing's order-drift search (`held_drift_search`) on scores whose peak is
known: it finds the peak within a quarter of its step wherever the peak lies against the
first ladder, keeps to its budget of runs and to the drift's range, and says so where no
run converged."""

import numpy as np
import pytest

import vojax
from vojax._tracker._mixture import held_drift_search


def _search(peak, settings=None, width=3.0, dead=None):
    """The search on a concave score in the log drift with its maximum at `peak` (log);
    `dead`: a predicate on the log drift where the run does not converge (score −∞).
    Returns the chosen log drift and every log drift run."""
    chosen, tried, _ = _search_calls(peak, settings, width, dead)
    return chosen, tried


def _search_calls(peak, settings=None, width=3.0, dead=None):
    """`_search`, and the log drifts of each call of `run` (the runs it may put side by
    side)."""
    settings = settings or vojax.TrackerSettings()
    tried, calls = [], []

    def one(log_drift):
        tried.append(log_drift)
        if dead is not None and dead(log_drift):
            return None, -np.inf
        return log_drift, -((log_drift - peak) / width) ** 2

    def run(log_drifts):
        calls.append(list(log_drifts))
        return [one(d) for d in log_drifts]

    chosen, _ = held_drift_search(run, np.log(1e-6), settings)
    return chosen, tried, calls


def _one_by_one(peak, settings, width=3.0):
    """The search as a sequence of single runs, written out: the ladder, the climb while the
    best is the outermost, then half and a quarter step either side of the best."""
    s = settings
    lo, hi = np.log(s.order_drift_range)
    budget = len(s.held_order_drift) + s.held_order_climb
    runs = {}

    def at(d):
        d = round(float(np.clip(d, lo, hi)), 9)
        if d not in runs and len(runs) < budget:
            runs[d] = -((d - peak) / width) ** 2

    for factor in s.held_order_drift:
        at(np.log(1e-6) + np.log(factor))
    step = np.log(s.held_order_step)
    while len(runs) < budget:
        best, keys = max(runs, key=runs.get), sorted(runs)
        count = len(runs)
        if best == keys[-1] and best < hi:
            at(best + step)
        elif best == keys[0] and best > lo:
            at(best - step)
        if len(runs) == count:
            break
    for fraction in (0.5, 0.25):
        best = max(runs, key=runs.get)
        at(best - fraction * step)
        at(best + fraction * step)
    return max(runs, key=runs.get), sorted(runs)


@pytest.mark.parametrize("peak_factor", [1.0, 30.0, 3e5, 2e7])
def test_the_runs_side_by_side_are_the_runs_one_by_one(peak_factor):
    """The ladder goes to `run` as one call and each refinement's pair as one call (the
    runs of a call may run in threads); the drifts run and the drift chosen are those of
    the search written out one run at a time."""
    s = vojax.TrackerSettings()
    peak = np.log(1e-6 * peak_factor)
    chosen, tried, calls = _search_calls(peak)
    want_chosen, want_tried = _one_by_one(peak, s)
    assert chosen == want_chosen and sorted(tried) == want_tried
    assert len(calls[0]) == len(s.held_order_drift)
    assert all(len(c) <= 2 for c in calls[1:])
    if peak_factor in (30.0, 3e5):  # inside the range: both refinements run in pairs
        assert [len(c) for c in calls[-2:]] == [2, 2]


@pytest.mark.parametrize("peak_factor", [1.0, 30.0, 1e4, 3e5, 1e6, 2e7])
def test_the_search_ends_within_a_quarter_step_of_the_evidence_peak(peak_factor):
    """Peaks below, between, at and beyond the first ladder (×1, 1e2, 1e4 of the tuned drift
    1e-6): the chosen drift within a quarter of the step (×10) of the peak, in at most
    3 + `held_order_climb` runs. A ladder that only tries its own rungs ends 1.5–3.3
    decades short of the peaks at ×3e5–2e7."""
    s = vojax.TrackerSettings()
    peak = np.log(1e-6 * peak_factor)
    chosen, tried = _search(peak)
    assert abs(chosen - peak) <= 0.25 * np.log(s.held_order_step) + 1e-9
    assert len(tried) <= len(s.held_order_drift) + s.held_order_climb
    assert len(set(tried)) == len(tried)  # no drift run twice


def test_the_search_keeps_to_the_drift_range():
    """A peak above the order drift's range: every run inside it, the range's top chosen."""
    s = vojax.TrackerSettings()
    lowest, highest = np.log(s.order_drift_range)
    chosen, tried = _search(highest + 5.0)
    assert min(tried) >= lowest - 1e-9 and max(tried) <= highest + 1e-9
    assert chosen == pytest.approx(highest)


def test_the_search_without_a_climb_is_the_ladder():
    """`held_order_climb=0`: the ladder's runs alone (×1, 1e2, 1e4), the best of them."""
    s = vojax.TrackerSettings(held_order_climb=0)
    chosen, tried = _search(np.log(1e-6 * 1e6), s)
    assert np.allclose(np.exp(np.asarray(tried)) / 1e-6, (1.0, 1e2, 1e4), rtol=1e-6)
    assert chosen == pytest.approx(np.log(1e-2))


def test_the_search_steps_past_runs_that_do_not_converge_and_reports_none_converged():
    """Runs that did not converge (score −∞) are never chosen; with none converged the
    search says so (no smoothing) after the ladder alone."""
    chosen, _ = _search(np.log(1e-6 * 1e6), dead=lambda d: d > np.log(1e-6 * 3e5))
    assert np.exp(chosen) <= 1e-6 * 3e5 * (1 + 1e-9)
    chosen, tried = _search(0.0, dead=lambda d: True)
    assert chosen is None and len(tried) == 3


@pytest.mark.parametrize("step", [1.0, 0.5, float("nan"), float("inf")])
def test_a_step_that_cannot_climb_is_refused(step):
    """A factor of 1 or below would climb nowhere (or backwards): refused in one sentence."""
    with pytest.raises(ValueError,
                       match="TrackerSettings.held_order_step must be a finite number > 1"):
        vojax.TrackerSettings(held_order_step=step)
