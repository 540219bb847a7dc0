"""Refits that settle: a sign-constrained Kelvin–Voigt refit of the passive myocardium
ramp–hold records reaches the same answer from every start, and that answer is the least
squares over the order and the sign-constrained coefficients, found independently here by a
profile over the order (each order's coefficients by enumerating which signs bind)."""

import itertools
import math
import warnings
from pathlib import Path

import jax
import numpy as np
import pytest

import vojax
from vojax import _refit_active

jax.config.update("jax_enable_x64", True)

SHARED = Path(__file__).resolve().parents[2] / "shared" / "data" / "myocardium-ramp-hold"
STARTS = (0.1, 0.3, 0.5, 0.7, 0.9)


def _record(path):
    (rec,) = vojax.io.load_records(path, time="Time", inputs=["F"], output="L")
    strain = (rec.output - 0.95) / 0.95
    return rec.time, vojax.KelvinVoigt().inputs(rec.inputs[:, 0], strain), strain


def _constrained_rss(phi, y, signs):
    """The least sum of squares of ``y ≈ x0 + Φ p`` with ``sign_j p_j ≥ 0``: every subset of
    coefficients held at 0, the free ones by least squares, kept where their signs hold (the
    constrained optimum is one of these: the KKT conditions of a convex problem)."""
    best = math.inf
    for held in itertools.product((False, True), repeat=phi.shape[1]):
        cols = [np.ones_like(y)] + [phi[:, j] for j in range(phi.shape[1]) if not held[j]]
        a = np.column_stack(cols)
        coef = np.linalg.lstsq(a, y, rcond=None)[0]
        free = [s for s, h in zip(signs, held) if not h]
        if all(s * c >= 0 for s, c in zip(free, coef[1:])):
            best = min(best, float(np.sum((y - a @ coef) ** 2)))
    return best


def _profile_order(t, u, y, signs, lo=0.01, hi=0.99):
    """The order minimising `_constrained_rss`: the best of 99 orders, then golden-section
    search between its neighbours to 1e-9."""
    def rss(q):
        phi = np.column_stack([np.asarray(vojax.fractional_integral(u[:, j], q, t=t))
                               for j in range(u.shape[1])])
        return _constrained_rss(phi, y, signs)

    grid = np.linspace(lo, hi, 99)
    k = int(np.argmin([rss(q) for q in grid]))
    a, b = grid[max(k - 1, 0)], grid[min(k + 1, grid.size - 1)]
    g = (math.sqrt(5) - 1) / 2
    c, d = b - g * (b - a), a + g * (b - a)
    while b - a > 1e-9:
        if rss(c) < rss(d):
            b, d = d, c
            c = b - g * (b - a)
        else:
            a, c = c, d
            d = a + g * (b - a)
    return 0.5 * (a + b)


def _refits(t, u, y):
    signs = vojax.KelvinVoigt().p_signs
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", vojax.RefitWarning)
        return [vojax.refit(u, y, t=t, order0=q0, p_signs=signs) for q0 in STARTS]


def _check(path):
    t, u, y = _record(path)
    fits = _refits(t, u, y)
    orders = np.array([float(f.order[0]) for f in fits])
    assert np.ptp(orders) < 1e-6, orders
    coefficients = np.array([np.asarray(f.p) for f in fits])
    assert np.all(np.ptp(coefficients, axis=0) <= 1e-6 * np.abs(coefficients).max(axis=0))
    assert all(f.p_at_bound == fits[0].p_at_bound for f in fits)
    q = _profile_order(t, u, y, vojax.KelvinVoigt().p_signs)
    assert orders[0] == pytest.approx(q, abs=1e-6)


def test_the_shipped_myocardium_record_settles():
    _check(vojax.io.example_file("myocardium"))


@pytest.mark.slow
@pytest.mark.parametrize("name", ["AvgRelaxed_100s", "AvgRelaxedMavaSet_100s",
                                  "AvgRelaxed_0.1s", "AvgRelaxedMavaSet_1s"])
def test_the_myocardium_records_settle(name):
    """The 100 s ramps: from a start of 0.5 or above, the free fit breaks both signs, both
    coefficients were held at 0 and the solver stopped at its start (the order moving
    nothing), reported as converged; now run again from the other starts."""
    path = SHARED / f"{name}.csv"
    if not path.is_file():
        pytest.skip(f"{path} is not here (the shared data are not shipped)")
    _check(path)


def test_an_unsettled_fit_is_run_again_and_the_least_squares_kept(monkeypatch):
    """`_settled_fit` keeps the given start's fit where it settled; else the settled restart
    with the least weighted sum of squares, whichever start found it."""
    import optimistix as optx

    ok, failed = optx.RESULTS.successful, optx.RESULTS.max_steps_reached
    sw = np.ones(3)

    def fit(order, residual, result=ok, held=False):
        return (dict(order=np.full(3, order), residuals=np.full(3, residual), result=result),
                np.array([0.0 if held else 1.0, 1.0]))

    def run(outcomes):
        calls = []

        def fake(mem, u2, v, big_y, sw_, signs, num_knots, solver):
            calls.append(solver["order0"])
            return outcomes[len(calls) - 1]

        monkeypatch.setattr(_refit_active, "_active_set", fake)
        out, _ = _refit_active._settled_fit(None, np.zeros((3, 1)), None, None, sw, None, 1,
                                     dict(order0=0.42, bounds=(0.0, 1.0)))
        return float(out["order"][0]), calls

    # settled at the given start: no restart
    assert run([fit(0.42, 1.0)]) == (0.42, [0.42])
    # every integrated input held (the order moves nothing): the restarts, the least RSS kept
    order, calls = run([fit(0.42, 1.0, held=True), fit(0.1, 0.5), fit(0.3, 0.2),
                        fit(0.5, 0.2), fit(0.7, 0.3, result=failed), fit(0.9, 0.9)])
    assert calls == pytest.approx([0.42, *STARTS]) and order == 0.3
    # not converged: a converged restart beats it even with a larger sum of squares
    order, _ = run([fit(0.42, 0.1, result=failed), fit(0.1, 0.5), fit(0.3, 0.6),
                    fit(0.5, 0.7), fit(0.7, 0.8), fit(0.9, 0.9)])
    assert order == 0.1


@pytest.mark.xfail(
    strict=True,
    reason="open (issue 48): where the fit barely depends on the order, Levenberg-Marquardt's "
    "damping shrinks the order's step to nothing and the solver stops within 1e-12 of each start "
    "(0.1, 0.892, 0.892, 0.892, 0.9). A unit per knot (its Jacobian column's RMS, at most 4) "
    "settles this fit and 12 of 16 myocardium holds (6 now), but then padded and unpadded Maxwell "
    "fits end 2e-10 apart in the order and 1e-6 relative in 1/E (their sums of squares equal to "
    "1e-15, at tolerances of 1e-13 too: the flat direction's limit), beyond "
    "test_the_four_laws_share_a_program_and_padding_changes_no_fit's 1e-9: not adopted yet",
)
def test_the_shipped_myocardium_hold_settles_at_a_minimum_of_the_profile():
    """The hold alone (from the end of the 10 s ramp; the whole history drives the model),
    where the sum of squares varies by 0.6 % over the order's range: the five starts reach one
    order within 1e-6, at a minimum of the independent profile (the constrained sum of
    squares over the hold at the order ± 0.005 is larger). The profile falls again towards the upper bound (by 0.3 %): a local minimum is what a
    local solver promises (with a unit per knot it finds 0.10389, its interval [0.03, 0.40]
    local too)."""
    t, u, y = _record(vojax.io.example_file("myocardium"))
    hold = t >= t[0] + 10.0
    signs = vojax.KelvinVoigt().p_signs
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", vojax.RefitWarning)
        fits = [vojax.refit(u, y, t=t, order0=q0, p_signs=signs, window=(t[0] + 10.0, np.inf))
                for q0 in STARTS]
    orders = np.array([float(f.order[0]) for f in fits])
    assert np.ptp(orders) < 1e-6, orders

    def rss(q):
        phi = np.column_stack([np.asarray(vojax.fractional_integral(u[:, j], q, t=t))
                               for j in range(u.shape[1])])
        return _constrained_rss(phi[hold], y[hold], signs)

    found = float(np.sum(np.asarray(fits[0].residuals)[hold] ** 2))
    assert found == pytest.approx(rss(orders[0]), rel=1e-9)
    assert rss(orders[0] - 0.005) > found and rss(orders[0] + 0.005) > found
