"""Moving orders in the trade-off (`vojax._tracker._moving`): their memory columns against
the reference's direct sums at a moving order, their designs and penalised fits against
least squares written here, the shape fit against known minima, and on a record whose gain
drifts, explanations outside the band that fit within the limit."""

import functools

import numpy as np
import pytest

import vojax
from vojax import reference
from vojax._integral import make_memory
from vojax._tracker._band import outside
from vojax._tracker._explanations import relative_drift
from vojax._tracker._model import order_of_np
from vojax._tracker._moving import (
    LADDER,
    _last,
    columns_at,
    design,
    levenberg,
    moving_orders,
    penalised_fit,
    penalised_jacobian,
)
from vojax._tracker._trade import trade_interval

from .helpers import gain_drift_case, make_problem

BOUNDS = (0.01, 0.99)


@functools.cache
def _profile():
    t, u, y, dt, sd = gain_drift_case()
    memory = make_memory("exponential", dt, t.size, order_range=BOUNDS)
    problem = make_problem(memory, u[:, None], y, times=t, bounds=BOUNDS)
    _, _, profile = trade_interval(problem, sd**2)
    return t, u, y, dt, sd, profile


def _reference_design(u, dt, alpha, hats, form):
    """The design of a drifting parameter on `hats` at the order trajectory `alpha` from the
    reference's direct sums: a gain on ``I^α u`` (form 0) or ``I^α (hats · u)`` (form 1)."""
    if form == 0:
        return np.asarray(reference.fractional_integral(u[:, None], alpha, dt)) * hats
    return np.asarray(reference.fractional_integral(u[:, None] * hats, alpha, dt))


def _hats(s, k):
    """Hat functions (N, k) on k evenly spaced knots over s ∈ [0, 1], by interpolation."""
    return np.stack([np.interp(s, np.linspace(0, 1, k), np.eye(k)[j]) for j in range(k)], 1)


@pytest.mark.parametrize("shape", ["sine", "ramp", "constant"])
def test_columns_at_a_moving_order_equal_the_direct_sums_there(shape):
    """The memory columns at a moving order, interpolated across the profiled constant orders
    (0.038 apart), equal the reference's direct sums at that order, the input's and the
    input times each fine hat's, to 2e-6 of their largest (the memory's own error is 7e-7:
    the constant order gives the same); a linear interpolation between orders errs by 1e-3."""
    t, u, _, dt, _, profile = _profile()
    s = t / t[-1]
    alpha = {"sine": 0.3 + 0.2 * np.sin(3 * s), "ramp": 0.6 - 0.3 * s,
             "constant": np.full(t.size, 0.45)}[shape]
    got = columns_at(profile, alpha)
    want = np.concatenate([_reference_design(u, dt, alpha, np.ones((t.size, 1)), 1),
                           _reference_design(u, dt, alpha, profile.bases[1], 1)], axis=1)
    assert got.shape == want.shape
    err = np.max(np.abs(got - want), axis=0) / np.max(np.abs(want), axis=0)
    assert np.max(err) < 2e-6


@pytest.mark.parametrize("level, form", [(0, 0), (0, 1), (1, 0), (1, 1)])
def test_designs_at_a_moving_order_equal_the_direct_sums(level, form):
    """Each form's design at a moving order, on the coarse (8) and the fine (15) hat
    functions, equals the one built here from the reference's direct sums and hat functions
    interpolated here, to 2e-6."""
    t, u, _, dt, _, profile = _profile()
    s = t / t[-1]
    alpha = 0.35 + 0.15 * s**2
    want = _reference_design(u, dt, alpha, _hats(s, (8, 15)[level]), form)
    got = design(profile, alpha, level, form)
    assert np.max(np.abs(got - want)) < 2e-6 * np.max(np.abs(want))


def test_penalised_fit_against_least_squares_written_here():
    """At λ = 0 the χ² and drift are those of plain least squares (NumPy, an offset column);
    at λ > 0 the residuals' squares sum to the χ² plus λ·unit·scale times the squared first
    differences of each input's coefficients, and the drift falls."""
    t, _, y, _, sd, profile = _profile()
    alpha = np.full(t.size, 0.45)
    x = design(profile, alpha, 0, 0)
    cols = np.column_stack([x, np.ones(t.size)])
    coef = np.linalg.lstsq(cols, y, rcond=None)[0]
    chi2 = float(np.sum((y - cols @ coef) ** 2)) / sd**2
    res, got, drift = penalised_fit(profile, x, 0, 0.0)
    assert got == pytest.approx(chi2, rel=1e-9)
    assert float(res @ res) == pytest.approx(chi2, rel=1e-9)
    assert drift == pytest.approx(relative_drift(profile.bases[0] @ coef[:-1], t.size), rel=1e-6)
    res1, chi2_1, drift1 = penalised_fit(profile, x, 0, 1.0)
    assert chi2_1 > chi2 and drift1 < drift
    assert float(res1 @ res1) > chi2_1  # the penalty's rows add to the objective
    # the shape fit's residuals skip the drift only: the same residuals and χ², bit for bit
    lean = penalised_fit(profile, x, 0, 1.0, drift=False)
    np.testing.assert_array_equal(lean[0], res1)
    assert lean[1] == chi2_1 and lean[2] is None


def test_levenberg_reaches_known_minima_within_bounds():
    """The shape fit's Levenberg–Marquardt, given steps enough: Rosenbrock's residuals from
    (−1.2, 1) reach (1, 1);
    with an upper bound of 0.8 on the first coordinate, the constrained minimum (0.8, 0.64)."""
    def rosen(th):
        return np.array([10 * (th[1] - th[0] ** 2), 1 - th[0]])

    def rosen_jac(th):
        return np.array([[-20 * th[0], 10.0], [-1.0, 0.0]])

    free = levenberg(rosen, rosen_jac, np.array([-1.2, 1.0]), -2.0, 2.0, iterations=200,
                     tol=1e-14)
    assert np.allclose(free, [1.0, 1.0], atol=2e-3)
    held = levenberg(rosen, rosen_jac, np.array([0.0, 0.0]), -2.0, 0.8, iterations=200,
                     tol=1e-14)
    assert np.allclose(held, [0.8, 0.64], atol=2e-3)


def _off_nodes(profile, alpha, step):
    """`alpha` nudged so that no sample lies within `step` of a profiled order, where the
    interpolant's slope jumps (a central difference there straddles two stencils)."""
    grid = profile.alphas
    h = grid[1] - grid[0]
    x = (alpha - grid[0]) / h
    near = np.abs(x - np.round(x)) * h < 10 * step
    return np.where(near, alpha + 20 * step, alpha)


def test_the_columns_slopes_are_the_interpolants_derivatives():
    """The memory columns' derivatives with respect to each sample's order equal central
    differences of the columns themselves (step 1e-6) to 1e-6 of their largest, every column;
    where the trajectory is held at the profiled range's ends, they are 0; and the values
    returned with them are the columns, bit for bit."""
    t, _, _, _, _, profile = _profile()
    s = t / t[-1]
    step = 1e-6
    alpha = _off_nodes(profile, 0.3 + 0.25 * np.sin(4 * s) ** 2, step)
    values, slopes = columns_at(profile, alpha, slopes=True)
    np.testing.assert_array_equal(values, columns_at(profile, alpha))
    want = (columns_at(profile, alpha + step) - columns_at(profile, alpha - step)) / (2 * step)
    err = np.max(np.abs(slopes - want), axis=0) / np.max(np.abs(want), axis=0)
    assert np.max(err) < 1e-6
    held = np.where(s > 0.5, profile.alphas[-1] + 0.1, alpha)
    _, held_slopes = columns_at(profile, held, slopes=True)
    assert np.all(held_slopes[s > 0.5] == 0.0) and np.any(slopes[s > 0.5] != 0.0)
    np.testing.assert_array_equal(held_slopes[s <= 0.5], slopes[s <= 0.5])


def _coloured_profile(profile):
    """The profile under an AR(1)-plus-white noise's whitener (the tracker's own)."""
    import dataclasses
    from types import SimpleNamespace

    from vojax._tracker._coloured import ar_whitener

    num = profile.y.size
    tuning = SimpleNamespace(coloured_noise=2.0, noise=0.5, noise_time=0.05)
    whiten = ar_whitener(np.ones(num), profile.mask, num, tuning)
    return dataclasses.replace(profile, whiten=whiten, scale=1.0)


def _masked_profile(profile):
    """The profile with some samples out of the fit (a window's end and every seventh one:
    their mask 0), as a fitted window or a padded block leaves them."""
    import dataclasses

    mask = np.ones(profile.y.size)
    mask[profile.y.size * 4 // 5 :] = 0.0
    mask[::7] = 0.0
    return dataclasses.replace(profile, mask=mask)


@pytest.mark.parametrize("noise", ["white", "coloured", "masked"])
@pytest.mark.parametrize("level, form, lam", [(0, 0, 0.0), (0, 1, 1e-2), (1, 0, 1.0),
                                               (1, 1, 100.0)])
def test_the_shape_fits_jacobian_equals_central_differences(level, form, lam, noise):
    """The Jacobian of the shape fit's residuals (the penalised fit at a moving order, the
    order piecewise linear on 8 knots, the drifting parameters projected out) equals central
    differences of those residuals in each knot's order (step 1e-6), to 1e-6 of its largest
    entry: each form and level, with the penalty off and on (its unit moves with the
    columns), white, under an AR(1) whitener, and with samples out of the fit."""
    profile = _profile()[-1]
    if noise == "coloured":
        profile = _coloured_profile(profile)
    elif noise == "masked":
        profile = _masked_profile(profile)
    shape, step = profile.shape, 1e-6
    theta = 0.45 + 0.08 * np.sin(np.arange(shape.shape[1]) * 1.3)

    def res(th):
        return penalised_fit(profile, design(profile, shape @ th, level, form), level, lam,
                             False)[0]

    x, dx = design(profile, shape @ theta, level, form, slopes=True)
    got = penalised_jacobian(profile, x, dx[None] * shape.T[:, :, None], level, lam)
    want = np.stack([(res(theta + step * e) - res(theta - step * e)) / (2 * step)
                     for e in np.eye(theta.size)], axis=1)
    assert got.shape == want.shape
    assert np.max(np.abs(got - want)) < 1e-6 * np.max(np.abs(want))


def test_moving_orders_lie_outside_the_band_and_fit_within_the_limit():
    """On a record whose gain rises 30 % (the true order 0.45 constant), with a band of
    0.45 ± 0.03: moving orders are found, each outside the band over most of the second
    half, with a χ² within Δχ² 4 of its form's best drifting constant-order fit and no lower
    than least squares at its order allows (from the reference's direct sums, every form
    tried here), and a drift above 0; the least of them below the truth's own 30 %."""
    t, u, y, dt, sd, profile = _profile()
    n, half = t.size, t.size // 2
    band = (np.full(n, 0.45), np.full(n, 0.42), np.full(n, 0.48), np.full(n, 0.015))
    found = moving_orders(profile, band, half)
    assert found
    bests = [best for _, _, best, _ in profile.forms]
    s = t / t[-1]
    for e in found:
        alpha = order_of_np(e.beta, BOUNDS)[0]
        assert e.kind == "moving" and e.fits
        assert outside(alpha, band, half)
        assert e.chi2 <= max(bests) + 4.0 + 1e-6  # within its own form's limit
        assert 0.0 < e.drift < 1.5
        # its χ²: some form's design from the direct sums fits at least that well
        best_here = np.inf
        for level, k in ((0, 8), (1, 15)):
            hats = _hats(s, k)
            for form in (0, 1):
                cols = np.column_stack([_reference_design(u, dt, alpha, hats, form),
                                        np.ones(n)])
                res = y - cols @ np.linalg.lstsq(cols, y, rcond=None)[0]
                best_here = min(best_here, float(res @ res) / sd**2)
        assert best_here <= e.chi2 * (1 + 1e-6)
        # its χ² and drift are those of its own order: some form's penalised fit at one rung
        # of the penalty ladder gives both (numbers kept from another shape would not)
        assert any(np.allclose(penalised_fit(profile, design(profile, alpha, level, form), level,
                                             lam)[1:], (e.chi2, e.drift), rtol=1e-8, atol=0.0)
                   for level, form, _, _ in profile.forms for lam in LADDER)
    assert min(e.drift for e in found) < 0.3


def test_the_shape_fits_memory_answers_at_the_theta_asked_for():
    """`_last` keeps one answer, that of the last θ: asked again at that θ it does not call
    again; asked at another θ, or back at an earlier one, or at a θ that differs in its last
    bit, it does (a kept answer returned for another θ would fit the wrong order)."""
    calls = []

    def norm(theta):
        calls.append(theta.copy())
        return float(np.sum(theta**2))

    kept = _last(norm)
    a, b = np.array([0.3, 0.4]), np.array([0.3, 0.5])
    near = np.nextafter(a, 1.0)
    answers = [kept(a), kept(a), kept(b), kept(a), kept(near), kept(near.copy())]
    want = [float(np.sum(theta**2)) for theta in (a, a, b, a, near, near)]
    assert answers == want and want[3] != want[4]
    assert len(calls) == 4


def test_moves_of_the_answer_keep_a_step_the_hats_cannot_follow():
    """A record whose order steps 0.45 → 0.55 a quarter of the way in (8 hats cannot follow
    a step) while its gain rises 27 % late, with an answer that follows the step but drifts
    0.1 above the truth by the end (±0.03): moved as its projection on the hats
    (`moving_base` off), the least drift found outside the band is above the true one (the
    reach would promise too much); moved as the answer itself, the step kept, it is below;
    both searches (``"both"``) find each one's orders, the least drift the lower; the
    default (``"stated"``) runs both where the call states the parameters, the projected
    one alone where they are free."""
    from vojax import TrackerSettings

    n = 300
    s = np.arange(n) / (n - 1)
    alpha = np.where(s < 0.25, 0.45, 0.55)
    t, u, y, dt, sd = gain_drift_case(n, alpha, noise=0.005, width=0.1, centre=0.7)
    p = 1.0 + 0.3 * (1.0 + np.tanh((s - 0.7) / 0.1)) / 2.0
    true_drift = relative_drift(p[:, None], n)
    memory = make_memory("exponential", dt, n, order_range=BOUNDS)
    centre = alpha + 0.1 * s
    band = (centre, centre - 0.03, centre + 0.03, np.full(n, 0.015))
    least, count = {}, {}
    for base, stated in ((False, True), (True, False), ("both", False), ("stated", True),
                         ("stated", False)):
        problem = make_problem(memory, u[:, None], y, times=t, bounds=BOUNDS,
                               settings=TrackerSettings(moving_base=base))
        _, _, profile = trade_interval(problem, sd**2)
        found = moving_orders(profile, band, n // 2, stated)
        assert found and all(outside(order_of_np(e.beta, BOUNDS)[0], band, n // 2)
                             for e in found)
        key = (base, stated) if base == "stated" else base
        least[key], count[key] = min(e.drift for e in found), len(found)
    assert 0.25 < true_drift < 0.3
    assert least[False] > 1.1 * true_drift and least[True] < 0.9 * true_drift
    assert least["both"] == least[True] and count["both"] == count[False] + count[True]
    assert (least["stated", True], count["stated", True]) == (least["both"], count["both"])
    assert (least["stated", False], count["stated", False]) == (least[False], count[False])
    assert TrackerSettings().moving_base == "stated"


def test_the_fit_tells_the_search_whether_the_call_states_the_parameters(monkeypatch):
    """`identify` passes the statement to the moving-order search: stated for a constant
    statement or a drift bound, not for free parameters (whose search then runs from the
    projection alone by default); and the freedom the answer's drifts fit, known under
    white noise."""
    from vojax._tracker import _fit

    seen = []

    def spy(profile, band, half, stated=False, freedom=np.nan):
        seen.append(stated)
        freedoms.append(freedom)
        return moving_orders(profile, band, half, stated, freedom)

    monkeypatch.setattr(_fit, "moving_orders", spy)
    t, u, y, dt, _ = gain_drift_case()
    told, freedoms = {}, []
    for parameters in ("free", "constant", 0.3):
        seen.clear()
        vojax.identify(u, y, dt, parameters=parameters, method="kalman", warn=False)
        told[parameters] = set(seen)
    assert told == {"free": {False}, "constant": {True}, 0.3: {True}}
    # and the freedom the answer's drifts fit (white noise here: known, above 0)
    assert freedoms and all(np.isfinite(f) and f > 0 for f in freedoms)


def test_moves_of_an_answer_that_fitted_the_noise_under_each_limit():
    """An answer whose shape follows the noise (each sample's order moved, by at most 0.05,
    toward its measured output) fits far below any order the hats can follow: its own best
    fit lies about 230 units of χ² below the best constant order's. Held to Δχ² 4 of its own
    best (``moving_limit="own"``), a move must keep fitting that noise, and every least
    drift it finds is above the least the constant orders' bar allows. Held to the form's
    best constant-order fit (``"trade"``), each move fits within Δχ² 4 of that, some lie
    above Δχ² 4 of the answer's own best, and the least drift is lower (here 0: the noise
    the answer fitted carries a move outside the band with no drift at all). With
    ``"freedom"`` (the default) the answer's own best is raised by the freedom its drifts
    fit less the hats': at a freedom above the gap the bar is the constant orders' (the
    moves those of ``"trade"``), at an unknown one (NaN) its own (those of ``"own"``). The
    projection's moves are the same under each."""
    from vojax import TrackerSettings
    from vojax._tracker import _moving

    n = 300
    t, u, y, dt, sd = gain_drift_case(n, 0.45, noise=0.01)
    s = t / t[-1]
    gain = 1.0 + 0.3 * (1.0 + np.tanh((s - 0.5) / 0.15)) / 2.0

    def output(order):
        return gain * np.asarray(reference.fractional_integral(
            u[:, None], np.full(n, order), dt))[:, 0]

    slope = (output(0.451) - output(0.449)) / 0.002
    wiggle = np.clip((y - output(0.45) - 0.2) / np.where(slope > 0, slope, np.inf), -0.05, 0.05)
    answer = 0.45 + wiggle
    band = (answer, answer - 0.03, answer + 0.03, np.full(n, 0.015))
    memory = make_memory("exponential", dt, n, order_range=BOUNDS)
    found, own = {}, []
    for limit in ("own", "trade", "freedom"):
        for base in (True, False):
            problem = make_problem(memory, u[:, None], y, times=t, bounds=BOUNDS,
                                   settings=TrackerSettings(moving_base=base,
                                                            moving_limit=limit))
            _, _, profile = trade_interval(problem, sd**2)
            for freedom in ((np.nan, 308.0) if limit == "freedom" else (np.nan,)):
                key = (limit, base) if np.isnan(freedom) else (limit, base, freedom)
                found[key] = moving_orders(profile, band, n // 2, True, freedom)
    bests = [best for _, _, best, _ in profile.forms]
    # the answer's own best fit in each form: its shape kept, the hats and drift free
    _, theta0, kept = _moving.start_of(profile, band)
    for level, form, _, _ in profile.forms:
        def residuals(theta, level=level, form=form):
            x = design(profile, np.clip(kept + profile.shape @ theta, *BOUNDS), level, form)
            return penalised_fit(profile, x, level, 0.0, False)[0]
        theta = levenberg(residuals, lambda th, r=residuals: np.stack(
            [(r(th + 1e-6 * e) - r(th - 1e-6 * e)) / 2e-6 for e in np.eye(th.size)], 1),
            theta0, *BOUNDS)
        own.append(float(residuals(theta) @ residuals(theta)))
    assert max(own) < min(bests) - 200.0
    assert TrackerSettings().moving_limit == "freedom"
    assert found["trade", True] and found["own", True]
    assert all(e.chi2 <= max(bests) + 4.0 + 1e-6 for e in found["trade", True])
    assert any(e.chi2 > max(own) + 4.0 for e in found["trade", True])
    assert all(e.chi2 <= max(own) + 4.0 + 1e-6 for e in found["own", True])
    assert min(e.drift for e in found["trade", True]) < min(e.drift for e in found["own", True])
    # "freedom": the answer's own best raised by the freedom its drifts fit less the 8
    # hats'; 300 here, more than the gap, so the constant orders' fit is the bar, as with
    # "trade"; an unknown freedom (NaN) raises nothing
    assert min(bests) < max(own) + 300.0
    assert [(e.chi2, e.drift) for e in found["freedom", True, 308.0]] == [
        (e.chi2, e.drift) for e in found["trade", True]]
    assert [(e.chi2, e.drift) for e in found["freedom", True]] == [
        (e.chi2, e.drift) for e in found["own", True]]
    for key in (("trade", False), ("freedom", False), ("freedom", False, 308.0)):
        assert [(e.chi2, e.drift) for e in found[key]] == [
            (e.chi2, e.drift) for e in found["own", False]]
