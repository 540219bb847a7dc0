"""The trade-off profile (constant orders with the parameters drifting on hat functions), its
breakdown drift, moving orders, and the level profile along the level-scale ridge."""

import functools

import jax.numpy as jnp
import numpy as np
import pytest

import vojax
from vojax._tracker import Hyper

from .helpers import gain_drift_case, make_problem, normalised_problem, ramp_case


def test_coarse_hats_are_sums_of_the_fine_ones():
    """The trade-off's profile runs the memory once for both of its drifts: the hat functions
    on 8 knots are `refinement`'s sums of those on 15 (the 8 and their midpoints), at
    irregular times with the fitted span ending before the record does."""
    from vojax._tracker._trade import hat_basis, refinement

    t = np.concatenate([[0.0], np.sort(np.random.default_rng(0).uniform(0, 3, 499))])
    for knots in (2, 3, 8):
        fine = hat_basis(t, 450, 2 * knots - 1)
        coarse = hat_basis(t, 450, knots)
        np.testing.assert_allclose(fine @ refinement(knots), coarse, rtol=0, atol=1e-15)
        assert np.all(coarse[451:] == coarse[450])  # held after the fitted span


@pytest.mark.parametrize("width, noise, fine", [
    (0.15, 0.01, False),
    pytest.param(0.1, 0.005, True, marks=pytest.mark.slow),
])
def test_trade_interval_against_an_independent_profile(width, noise, fine):
    """The constant orders with which a drifting parameter explains the data as well, against
    the same profile computed independently: `vojax.reference`'s direct sums on a grid of
    orders 0.02 apart refined to 0.0025 at the minimum and the ends, least squares in NumPy
    over hat functions built here on 8 knots and on 15, for a gain on the memory term and for
    a parameter inside the integral; each form on 15 knots where that lowers its best χ² by
    more than 14 (Akaike: 7 more coefficients), the interval where the better form's
    Δχ² ≤ 4. A smooth rise of the gain (over ±0.15 of the record, 1 % noise) keeps 8 knots;
    a faster one (±0.1, 0.5 % noise) takes 15, where both forms' intervals on 8 knots miss
    the true order. It holds the true order; with a noise level far below the data's, no
    drifting parameter explains them and there is no interval."""
    from vojax import reference
    from vojax._integral import make_memory
    from vojax._tracker._trade import trade_interval

    t, u, y, dt, sd = gain_drift_case(width=width, noise=noise)
    n, bounds = t.size, (0.01, 0.99)
    memory = make_memory("exponential", dt, n, order_range=bounds)
    problem = make_problem(memory, u[:, None], y, times=t, bounds=bounds)
    got, explanations, _ = trade_interval(problem, sd**2)
    s = t / t[-1]
    hats = [np.stack([np.interp(s, np.linspace(0, 1, k), np.eye(k)[j]) for j in range(k)],
                     axis=1) for k in (8, 15)]

    @functools.cache
    def chi2_at(a):  # χ² of (8 knots: gain, inside; 15 knots: gain, inside) at one order
        order = np.full(n, a)
        phi = np.asarray(reference.fractional_integral(u[:, None], order, dt))
        inside = np.asarray(reference.fractional_integral(
            u[:, None] * np.concatenate(hats, axis=1), order, dt))
        out = []
        for x in (phi * hats[0], inside[:, :8], phi * hats[1], inside[:, 8:]):
            x = np.column_stack([x, np.ones(n)])
            res = y - x @ np.linalg.lstsq(x, y, rcond=None)[0]
            out.append(res @ res / sd**2)
        return tuple(out)

    # a grid of 0.02, then 0.0025 around each form's minimum and each end of its interval
    # (an interval is one stretch of orders: χ² is convex in the order on this record)
    coarse = np.linspace(0.02, 0.98, 49)
    chi2 = np.array([chi2_at(a) for a in coarse])
    near = lambda a: np.round(np.clip(np.linspace(a - 0.02, a + 0.02, 17), 0.01, 0.99), 12)  # noqa: E731

    def best(f):
        return min(chi2[:, f].min(), min(chi2_at(a)[f] for a in near(coarse[chi2[:, f].argmin()])))

    # each form's knots: 15 where its best χ² is lower by more than 14
    forms = [f + 2 if best(f) - best(f + 2) > 14 else f for f in range(2)]
    assert (forms[0] >= 2) == fine  # the true gain form takes the finer drift where it needs it
    fits = [f for f in forms
            if chi2[:, f].min() <= (dof := n - (15 if f >= 2 else 8) - 1) + 2 * np.sqrt(2 * dof)]
    assert fits  # the gain form is the truth: it must explain the data

    def interval(f):  # the orders within Δχ² ≤ 4 of form f's best
        low, out = best(f), []
        inside = coarse[chi2[:, f] - low <= 4.0]
        for edge in (inside.min(), inside.max()):
            grid = near(edge)
            out.extend(grid[[chi2_at(a)[f] - low <= 4.0 for a in grid]])
        return out + list(inside)

    if fine:  # 8 knots alone would have left the truth out
        assert all(not min(interval(f)) <= 0.45 <= max(interval(f)) for f in range(2))
    within = np.array([a for f in fits for a in interval(f)])
    assert got is not None
    step = (bounds[1] - bounds[0]) / (problem.settings.trade_orders + 1)  # the library's grid
    for end, want, bound in ((got[0], within.min(), bounds[0]), (got[1], within.max(), bounds[1])):
        if end == bound:  # its outermost grid order is inside: the interval reaches the bound
            assert abs(want - bound) <= step + 0.0025
        else:
            assert end == pytest.approx(want, abs=0.01)
    assert got[0] <= 0.45 <= got[1]
    assert trade_interval(problem, 1e-4 * sd**2)[:2] == (None, [])


@pytest.mark.parametrize("inputs, fine", [(1, True), (2, False)])
def test_the_trade_offs_finer_drift_pays_two_per_coefficient_of_every_input(
        monkeypatch, inputs, fine):
    """Akaike's rule for the trade-off's drift: 15 knots instead of 8 add 7 coefficients per
    input, so they are taken where they lower the best χ² by more than 2·7·n. A profile
    whose finer drift gains 20 takes 15 knots with one input (20 > 14) and keeps 8 with two
    (20 < 28); the explanations' degrees of freedom, N − n·knots − 1, say which ran, and the
    interval is where the profile (20 |α − 0.5| above its best) stays within Δχ² ≤ 4."""
    from vojax._integral import make_memory
    from vojax._tracker import _trade

    num = 200
    t = np.linspace(0.0, 1.0, num)
    u = np.column_stack([np.sin(3 * t) + 1.5, np.cos(2 * t) + 2.0][:inputs])
    problem = make_problem(make_memory("exponential", t[1], num, order_range=(0.01, 0.99)),
                           u, np.sin(5 * t), times=t, bounds=(0.01, 0.99))

    def profile(problem, alphas, fine, whiten=None, offset=True):
        chi2 = np.full((alphas.size, 2, 2), np.inf)
        chi2[:, 0, 0] = 175.0 + 20 * abs(alphas - 0.5)  # linear: the crossing is exact
        chi2[:, 1, 0] = chi2[:, 0, 0] - 20.0
        return chi2, [[[None, None]] * 2] * alphas.size, None

    monkeypatch.setattr(_trade, "drift_profile", profile)
    monkeypatch.setattr(_trade, "least_drift", lambda *a, **k: 0.0)
    interval, explanations, _ = _trade.trade_interval(problem, 1.0)
    knots = 15 if fine else 8
    assert {e.dof for e in explanations} == {num - inputs * knots - 1.0}
    assert interval == pytest.approx((0.3, 0.7), abs=1e-12)


@pytest.mark.slow
def test_parameters_constant_holds_their_drift_and_keeps_the_trade_out_of_its_band(monkeypatch):
    """``parameters="constant"``: the parameters' drift is held at its floor exactly (never
    'at the edge'), the band's mixture has no drifting-parameter alternatives (the tuned
    run, one run per start, the order-drift levels), the parameters' scale is profiled (the
    level profile's held scales), and the trade-off's constant orders,
    which run for the conditional answer's breakdown drift, all drift (by more than 5 %) and
    do not widen the stated band: it stays narrower than their interval. The default mixes
    in the six drifting-parameter alternatives too, and its band, widened by the trade,
    holds each constant order the trade found to fit (the profile's grid orders inside its
    interval) and the true constant order of the drifting gain."""
    from vojax._identify import KALMAN_BOUNDS
    from vojax._tracker import _fit, _mixture
    from vojax._tracker._model import order_of_np

    runs, trades = [], []
    mix, trade = _mixture.mix_modes, _fit.trade_interval
    monkeypatch.setattr(_mixture, "mix_modes", lambda b, *a, **k: runs.append(len(b)) or mix(b, *a, **k))
    monkeypatch.setattr(_fit, "trade_interval", lambda *a, **k: trades.append(trade(*a, **k)) or trades[-1])
    levels, level = [], _fit.level_profile
    monkeypatch.setattr(_fit, "level_profile", lambda *a, **k: levels.append(level(*a, **k)) or levels[-1])
    settings = vojax.TrackerSettings()
    t, u, y, dt, _ = gain_drift_case()
    held = vojax.identify(u, y, dt, parameters="constant", warn=False)
    assert held.tuning.parameter_drift == pytest.approx(settings.constant_drift, rel=1e-12)
    assert "parameter_drift" not in held.tuning.at_edge
    # the parameters' scale, which trades off with the order's level, is profiled
    assert len(levels) == 1 and len(levels[0]) >= len(settings.level_ratios)
    assert {e.kind for e in levels[0]} == {"level"}
    starts = len(settings.start_orders) + 1
    assert runs == [1 + starts + len(settings.alt_order_drift)] and len(trades) == 1
    (lo, hi), traded, _ = trades[0]
    assert traded and all(e.drift > 0.05 for e in traded)
    second = slice(t.size // 2, None)
    width = np.asarray(held.alpha_upper)[second] - np.asarray(held.alpha_lower)[second]
    assert np.median(width) < hi - lo
    free = vojax.identify(u, y, dt, warn=False)
    assert runs[1] == runs[0] + 2 * len(settings.alt_param_drift)
    assert len(trades) == 2 and trades[1][0] is not None
    lower, upper = (np.asarray(a)[second] for a in (free.alpha_lower, free.alpha_upper))
    # the constant orders the trade found to fit (its explanations, on the grid)
    orders = [float(order_of_np(e.beta[:1], KALMAN_BOUNDS)[0][0]) for e in trades[1][1]]
    assert orders and trades[1][0][0] <= min(orders) and max(orders) <= trades[1][0][1]
    assert np.all(lower <= min(orders)) and np.all(upper >= max(orders))
    assert np.mean((lower <= 0.45) & (0.45 <= upper)) > 0.9


@pytest.mark.slow
@pytest.mark.xfail(
    strict=True,
    reason="open (issue 50): the free band holds each constant order the trade found on its "
    "grid (0.236-0.688 here) at its own +-2 sigma, not the interval's interpolated ends "
    "that the verdict line names (0.231-0.709): its upper edge reaches 0.693. The freest "
    "order drift covered the gap until it was left to its mixture weight (fastest_evidence). "
    "The ends as explanations close it but turn coloured draw 13 held out from identified to "
    "conditional (42 -> 41 of 144 identified; "
    "scripts/results/bench_calibration_trade_ends_held_out.txt)",
)
def test_the_free_band_holds_the_trade_interval_its_verdict_names(monkeypatch):
    """The default's band, where the trade-off widens it, holds the whole interval of
    constant orders the verdict line names ("with any constant order from lo to hi"), so
    the line and the band agree (the gain-drift record of the test above)."""
    from vojax._tracker import _fit

    trades, trade = [], _fit.trade_interval
    monkeypatch.setattr(_fit, "trade_interval", lambda *a, **k: trades.append(trade(*a, **k)) or trades[-1])
    t, u, y, dt, _ = gain_drift_case()
    free = vojax.identify(u, y, dt, warn=False)
    second = slice(t.size // 2, None)
    (lo, hi), _, _ = trades[-1]
    assert np.all(np.asarray(free.alpha_lower)[second] <= lo + 1e-12)
    assert np.all(np.asarray(free.alpha_upper)[second] >= hi - 1e-12)


@pytest.mark.slow
def test_band_covers_a_moving_order_with_a_drifting_gain_or_refuses():
    """A moving order (0.35 → 0.60) and a gain rising 30 % mid-record (a relative drift of
    0.26), one input: a drifting parameter and a moving order trade off. By default the band
    covers the truth at every sample of the second half, widened by the explanations with a
    drifting parameter that fit, and the order is refused with a reason that names
    ``parameters='constant'``. Stating the parameters constant, falsely, moves the order
    off the truth; the band is then the statement's, so what must hold is the verdict: not
    confidently wrong, and the reach it states (the drift at which an order outside the band
    fits as well) at or below the drift that misled it, so the answer tells the user how far
    the statement has to hold."""
    from vojax import reference

    n, dt = 400, 0.05
    t = np.arange(n) * dt
    s = t / t[-1]
    u = 1.0 - np.exp(-t / 3.0) + 0.2 * np.sin(0.7 * t)
    alpha = 0.35 + 0.25 * s
    p = 1.0 + 0.3 * (1.0 + np.tanh((s - 0.5) / 0.15)) / 2.0
    true_drift = np.ptp(p) / abs(np.mean(p))
    x = p * np.asarray(reference.fractional_integral(u[:, None], alpha, dt))[:, 0]
    y = x + 0.2 + 0.01 * np.ptp(x) * np.random.default_rng(3).standard_normal(n)
    half = slice(n // 2, None)

    def coverage(res):
        lo, hi = np.asarray(res.alpha_lower)[half], np.asarray(res.alpha_upper)[half]
        return np.mean((lo <= alpha[half]) & (alpha[half] <= hi))

    free = vojax.identify(u, y, dt, warn=False)
    d = free.diagnostics
    assert coverage(free) == 1.0 and not d.identified
    assert "because a drifting parameter explains the data as well" in d.message
    assert "parameters='constant'" in d.message
    held = vojax.identify(u, y, dt, parameters="constant", warn=False)
    rms = np.sqrt(np.mean((np.asarray(held.alpha) - alpha)[half] ** 2))
    assert rms > 0.05  # the false statement moves the estimate
    assert not (held.diagnostics.identified and coverage(held) < 0.5)
    assert 0.0 < held.diagnostics.breakdown_drift <= true_drift


@pytest.mark.parametrize("fits, visited", [
    (lambda r: False, [(0.5, 0.71, 1.41, 2.0)]),
    (lambda r: True, [(0.5, 0.71, 1.41, 2.0), (2.828, 0.354), (4.0, 0.25)]),
    # only the larger scales fit: the profile goes up on its own, never back down
    (lambda r: r >= 2.0, [(0.5, 0.71, 1.41, 2.0), (2.828,), (4.0,)]),
])
def test_level_profile_follows_the_ridge_while_it_fits(monkeypatch, fits, visited):
    """The level profile holds the parameters at `level_ratios` × the tuned ones; where the
    outermost ratio on a side still explains the data it goes on by √2 on that side, up to
    4× (down to ¼), and every run is an explanation the band weighs (its bisections, which
    depend on the runs' orders, are held off here: `test_level_profile_bisects_...`)."""
    from vojax._tracker import _level, _threads
    from vojax._tracker._tuning import Tuning

    seen, ratios = [], []
    monkeypatch.setattr(_threads.os, "cpu_count", lambda: 1)  # the runs in order
    monkeypatch.setattr(_level, "fitting", lambda residuals, *a: np.array(
        [fits(r) for r in ratios[len(ratios) - residuals.shape[0]:]]))
    original = _threads.in_threads

    def spy(problem, fn, count, call, key):
        out = original(problem, fn, count, call, key)
        seen.append(count)
        return out

    monkeypatch.setattr(_level, "in_threads", spy)
    original_modes = _level.smoother_modes

    def modes(memory, u, y, mask, steps, horizon, hyper, m, p, start, *rest):
        ratios.append(round(float(np.asarray(start)[0, 1] / mean_p), 3))
        return original_modes(memory, u, y, mask, steps, horizon, hyper, m, p, start, *rest)

    monkeypatch.setattr(_level, "smoother_modes", modes)
    # the first round's ratios and their extensions only (no bisections)
    problem, _ = normalised_problem(ramp_case(n=120), 120, columns=1,
                             settings=vojax.TrackerSettings(level_splits=0))
    hyper = Hyper(*(jnp.log(jnp.asarray(v)) for v in (0.1, 1e-6, 1e-2)))
    start = jnp.asarray(np.broadcast_to([0.0, 1.0, 0.0], (120, 3)))
    sm = problem.smooth(hyper, start)
    mean_p = float(np.mean(np.asarray(sm.theta)[:, 1]))
    tuning = Tuning.of(np.log([0.1, 1e-6, 1e-2]), (), sm.log_likelihood, True)
    out = _level.level_profile(problem, tuning, sm, 1e-2)
    groups, k = [], 0
    for count in seen:
        groups.append(tuple(ratios[k : k + count]))
        k += count
    assert groups == visited
    # every held run is an explanation for the band, each at a level of its own (a run that
    # ignored its ratio would repeat another's order)
    assert [e.kind for e in out] == ["level"] * len(ratios)
    levels = [round(float(np.mean(e.beta)), 6) for e in out]
    assert len(set(levels)) == len(ratios)


def test_level_profile_bisects_between_a_fitting_and_a_failing_scale():
    """`level_next`: between the nearest held ratio that does not fit and its fitting inner
    neighbour (the tuned scale, ratio 1, at the least) the profile bisects on the log scale
    while the failing run's order is more than 2σ of the neighbour's from it, down to √2's
    `level_splits`-th halving; past an outermost ratio that fits it goes on by √2."""
    from vojax._tracker._level import level_next

    settings = vojax.TrackerSettings()
    LEVEL_SPLITS = settings.level_splits

    def _level_next(tried, side, n):
        return level_next(tried, side, n, settings)

    n = 50
    sd = np.full(n, 0.01)

    def run(fits, beta):
        return (fits, np.full(n, beta), sd)

    def step(tried, side):
        return [round(r, 4) for r in _level_next(tried, side, n)]

    anchor = {1.0: run(True, 0.0)}
    # above: 1.41 fails with its order 5σ away → the log-midpoint 2^(1/4); below: every
    # ratio fits → past the outermost, 0.5/√2
    tried = {**anchor, 1.41421356: run(False, 0.05), 2.0: run(False, 0.2),
             0.70710678: run(True, -0.01), 0.5: run(True, -0.02)}
    assert step(tried, 1) == [round(2**0.25, 4)]
    assert step(tried, -1) == [round(0.5 / 2**0.5, 4)]
    # the failing run's order within 2σ of its neighbour's: that band covers the gap
    assert step({**anchor, 1.41421356: run(False, 0.015)}, 1) == []
    # the bisections go on from the ratio that fits, until √2's LEVEL_SPLITS-th halving
    tried = {**anchor, 1.41421356: run(False, 0.05)}
    visited = []
    while nxt := _level_next(tried, 1, n):
        (r,) = nxt
        visited.append(r)
        tried[r] = run(r < 1.2, 0.01 if r < 1.2 else 0.05)
    assert len(visited) == LEVEL_SPLITS == 3
    np.testing.assert_allclose(visited, [2 ** (1 / 4), 2 ** (3 / 8), 2 ** (5 / 16)])
    # a ratio that fits beyond one that does not: both the bisection and the extension
    tried = {**anchor, 1.41421356: run(False, 0.05), 2.0: run(True, 0.1)}
    assert sorted(step(tried, 1)) == [round(2**0.25, 4), round(2 * 2**0.5, 4)]
    # nothing beyond the outermost allowed ratio (4)
    assert step({**anchor, 4.0: run(True, 0.3)}, 1) == []
