"""The offline band rules of `scripts/band_scores.py`: on explanations made by hand, each
rule that weighs the tuned run's far alternatives leaves out of the union exactly the
alternatives it names, and only those far below the tuned run's evidence; the second
clock's replay widens a band exactly where the tracker does."""

import numpy as np
import pytest

from vojax import TrackerSettings
from vojax._tracker._clock import weigh_clock
from vojax._tracker._model import beta_of_np

from .helpers import clock_fit, load_script

N = 40
BOUNDS = (0.01, 0.99)


@pytest.fixture(scope="module")
def scores():
    return load_script("band_scores")


def _beta(order):
    return beta_of_np(np.full(N, order), BOUNDS)


def _ex(kind, order, evidence, var=1e-4, chi2=38.0):
    return dict(kind=kind, beta=_beta(order), var=np.full(N, var), chi2=chi2, dof=40.0,
                evidence=evidence, drift=0.0, accepted=None)


def _record(evidences):
    """The tuned run at 0.50 (evidence 0); a start at 0.30 and the four order drifts
    (0.01×, 0.1×, 10×, 100× the tuned one's) at 0.40, 0.45, 0.60 and 0.70, with the
    evidences given (start first), each one fitting."""
    orders = (0.30, 0.40, 0.45, 0.60, 0.70)
    kinds = ("start", "order_drift", "order_drift", "order_drift", "order_drift")
    ex = [_ex("tuned", 0.50, 0.0)] + [_ex(k, a, e) for k, a, e in zip(kinds, orders, evidences)]
    return dict(explanations=ex, truth=np.full(N, 0.5), alpha=np.full(N, 0.5), bounds=BOUNDS,
                setting="free", other=None, other_reasons=())


def _edges(band):
    lower, upper = (float(np.median(np.asarray(a)[N // 2:])) for a in band[1:3])
    return lower, upper


@pytest.mark.parametrize("which, far_below, expected", [
    # every alternative 30 nats below: the rule's own ones leave the union
    ("starts", 30.0, (0.40, 0.70)), ("slower", 30.0, (0.49, 0.70)),
    ("faster", 30.0, (0.30, 0.51)), ("fastest", 30.0, (0.30, 0.61)),
    ("all", 30.0, (0.49, 0.51)),
    # 10 nats below, within the limit of 20: every one is covered, whatever the rule
    ("all", 10.0, (0.30, 0.70)),
])
def test_each_rule_leaves_out_only_the_far_alternatives_it_names(scores, which, far_below,
                                                                 expected):
    r = _record([-far_below] * 5)
    full = _edges(scores.as_reported(r))
    assert full[0] < 0.30 and full[1] > 0.70  # as reported: every one covered at ±2σ
    lower, upper = _edges(scores.far_alternatives_weighed(which)(r))
    # the edges of the members still covered, each at its own ±2σ (σ of β 0.01: the order
    # moves by less than 0.01 over 2σ at these orders)
    assert lower == pytest.approx(expected[0], abs=0.011)
    assert upper == pytest.approx(expected[1], abs=0.011)


def test_a_record_whose_order_drifts_did_not_all_run_is_scored_as_reported(scores):
    """With three order drifts of four, which is slower is not known: the band as
    reported."""
    r = _record([-30.0] * 5)
    r["explanations"] = r["explanations"][:-1]
    for which in ("slower", "faster"):
        got = scores.far_alternatives_weighed(which)(r)
        want = scores.as_reported(r)
        assert all(np.array_equal(a, b) for a, b in zip(got[:4], want[:4]))


def test_a_record_scored_from_a_given_point_is_scored_there(scores):
    """The demo's records are scored after t = 50 (``scored_from``), the suite's over the
    second half: a band that holds the truth only from point 30 of 40 covers half of the
    second half and all of the points from 30."""
    truth = np.full(N, 0.5)
    lower = np.where(np.arange(N) >= 30, 0.45, 0.55)
    band = (truth, lower, np.full(N, 0.6), np.full(N, 0.05))
    r = dict(truth=truth, other_reasons=())
    assert scores.score(r, band)["coverage"] == pytest.approx(0.5)
    assert scores.score(dict(r, scored_from=30), band)["coverage"] == 1.0
    assert scores.score(dict(r, scored_from=30), band)["count"] == 10



@pytest.mark.parametrize("setting, lead, profile", [
    (s, lead, profile) for s in ("free", "constant") for lead in (-0.05, 0.0, 1e-3, 0.1, 0.3)
    for profile in (None, 4.0)])
def test_the_second_clocks_replay_widens_exactly_where_the_tracker_does(scores, setting, lead,
                                                                        profile):
    """`clock_union` replays `weigh_clock` on a saved record: the span's band 0.30–0.40
    (±0.05), the data unit's order 0.1 above (±0.03; parameters constant in it drift 46 %
    on a span of 100 units), the span's fit ahead by `lead` nats per point. The union
    (±0.09) is still an answer, so where the tracker covers it the replay does, and where
    the tracker leaves the band (the evidence, or a constant statement with the span's fit
    ahead) so does the replay, to the last bit. With `profile` (Δχ² 4), a constant
    statement's excluded account is covered moved back by √(4/Δχ²), Δχ² = 2 × 40 × `lead`:
    beyond the span's band (0.05) while that share exceeds one half."""
    s = TrackerSettings()
    span = np.linspace(0.3, 0.4, N)
    mine, fit = clock_fit(span, 0.05, log_likelihood=10.0 + lead * N)
    other, other_fit = clock_fit(span + 0.1, 0.03, log_likelihood=10.0)
    bound = s.drift_floor if setting == "constant" else None
    new, _, _ = weigh_clock(mine, fit, other, other_fit, bound=bound, scale=100.0,
                            answer=s.identified_halfwidth, evidence=s.clock_evidence,
                            profile=profile)
    record = dict(truth=span, setting=setting, clock_scale=100.0,
                  log_likelihood=10.0 + lead * N,
                  other=dict(converged=True, alpha=other.alpha, lower=other.alpha_lower,
                             upper=other.alpha_upper, log_likelihood=10.0))
    band = (span, mine.alpha_lower, mine.alpha_upper, mine.alpha_std)
    replay = scores.clock_union(record, band, profile)
    np.testing.assert_array_equal(replay[1], np.asarray(new.alpha_lower))
    np.testing.assert_array_equal(replay[2], np.asarray(new.alpha_upper))
    widened = not np.array_equal(replay[2], band[2])
    gap = 2 * N * lead
    moved = profile is not None and 0.1 * (1.0 if gap <= profile else np.sqrt(profile / gap)) > 0.05
    assert widened == (lead <= 0.0 or (moved and lead <= s.clock_evidence)
                       if setting == "constant" else lead <= s.clock_evidence)


@pytest.mark.parametrize("held_below, excluded", [(30.0, True), (5.0, False)])
def test_the_held_smoothing_leaves_the_band_only_where_the_data_exclude_it(scores, held_below,
                                                                          excluded):
    """The tuned run at 0.50 with its parameters drifting 20 %; the held smoothing at 0.65
    and one held scale at 0.70 (parameters constant), both fitting. 30 nats below the tuned
    run (limit 20) both leave: the band is the tuned run's own; 5 nats below, the band is as
    reported, the held smoothing its reference and the held scale in it."""
    tuned = dict(_ex("tuned", 0.50, 0.0), drift=0.2)
    held = _ex("held", 0.65, -held_below)
    scale = dict(_ex("held_level", 0.70, -held_below - 1.0), factor=None)
    r = dict(_record([-300.0] * 5), explanations=[tuned, held, scale])
    lower, upper = _edges(scores.held_within(20.0)(r))
    reported = _edges(scores.as_reported(r))
    assert reported[1] > 0.65  # as reported: the held smoothing is in the band
    if excluded:
        assert (lower, upper) == pytest.approx((0.49, 0.51), abs=0.011)
    else:
        assert (lower, upper) == reported


def test_the_table_scores_each_record_once_and_pools_the_families_rows(scores):
    """Three records of two families under one rule that counts its calls: each record is
    scored once, each family's row counts its own identified records, and the pooled row
    all of them (a narrow band about the truth identified, a wide one not, a narrow one off
    the truth identified and confidently wrong)."""
    def band(order, half):
        a = np.full(N, order)
        return a, a - half, a + half, np.full(N, half / 2)

    rows = [dict(_record([0.0] * 5), family=f, index=i, band=b) for f, i, b in [
        ("a", 0, band(0.5, 0.02)), ("a", 1, band(0.5, 0.3)), ("b", 2, band(0.7, 0.02))]]
    calls = []

    def rule(r):
        calls.append(r["index"])
        return r["band"]

    lines = scores.table(rows, {"counted": rule}, ["free"], ["a", "b"])
    assert sorted(calls) == [0, 1, 2]
    cells = {c[3]: (c[4], c[9]) for c in ([x.strip() for x in line.split("|")]
                                          for line in lines[2:])}
    assert cells == {"a": ("1/2", "0/1"), "b": ("1/1", "1/1"), "pooled": ("2/3", "1/2")}


def test_a_band_longer_than_the_truth_is_scored_over_the_truth(scores):
    """A long record's fitted points run past its span (the point bucket's padding): the
    band is scored over the truth's points only, as the same band cut to them."""
    truth = np.full(N, 0.5)
    r = dict(truth=truth, other_reasons=())
    inside = (np.full(N, 0.5), np.full(N, 0.45), np.full(N, 0.55), np.full(N, 0.025))
    padded = tuple(np.concatenate([a, np.full(6, v)]) for a, v in zip(inside, (0.9, 0.0, 0.1,
                                                                                 1e-3)))
    assert scores.score(r, padded) == scores.score(r, inside)
    assert scores.score(r, padded)["coverage"] == 1.0


def test_a_false_statement_is_listed_where_its_reach_does_not_warn(scores):
    """`false_statements`: under a constant statement whose parameters truly drift by 20 %,
    a tuned run at 0.30 with the truth at 0.50 is confidently wrong; a trade-off order at
    0.50 that fits with 10 % drift warns of it (its breakdown drift below the true one), one
    that needs 30 % does not, and a record whose statement is true is not counted."""
    def record(trade_drift, true_drift=0.2):
        ex = [_ex("tuned", 0.30, 0.0), dict(_ex("trade", 0.50, np.nan), drift=trade_drift,
                                            accepted=True)]
        return dict(explanations=ex, truth=np.full(N, 0.5), alpha=np.full(N, 0.30),
                    bounds=BOUNDS, setting="constant", other=None, other_reasons=(),
                    family="drift", index=trade_drift * 100, true_drift=true_drift)

    rows = [record(0.1), record(0.3), record(0.3, true_drift=0.0)]
    lines = scores.false_statements(rows, {})
    assert lines[2] == "| constant | as reported | 2/2 | 1: drift 30.0 |"
    assert lines[3] == "| constant-x0 | as reported | 0/0 | 0: - |"
