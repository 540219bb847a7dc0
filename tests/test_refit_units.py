"""`refit` whatever the units and the padding: the four laws share a program, padding and
units change no fit, sign constraints and starts on a bound, and the second opinion's
checks and warnings."""

import numpy as np
import optimistix as optx
import pytest

import vojax

from .test_refit import DT, NOISE, T, U, _data


def test_the_four_laws_share_a_program_and_padding_changes_no_fit(monkeypatch):
    """The springpot, Maxwell, Kelvin–Voigt and Zener fits of one record trace the fit once
    between them (each padded to two integrated inputs and one direct regressor with zero
    columns, held at 0); each equals its fit without the padding to the solver's tolerance,
    its coefficients' covariance included."""
    import functools

    from vojax import _refit_active
    from vojax._refit import TRACES

    n = 263  # a length no other test fits: the first law traces, the others reuse it
    stress = U[:n, 1]
    strain = np.asarray(vojax.simulate(stress, 0.5, np.array([0.8]), DT))
    strain = strain + NOISE * np.random.default_rng(9).standard_normal(n)
    laws = (vojax.Springpot(), vojax.FractionalMaxwell(), vojax.KelvinVoigt(),
            vojax.FractionalZener())

    def fit(m):
        return vojax.refit(m.inputs(stress, strain), strain, DT, direct=m.direct(stress, strain),
                           p_signs=m.p_signs)

    padded = []
    for k, m in enumerate(laws):
        before = TRACES["fit"]
        padded.append(fit(m))
        assert TRACES["fit"] == before + (k == 0), m  # after the first law: no trace
    monkeypatch.setattr(_refit_active, "_active_set", functools.partial(
        _refit_active._active_set, pad_direct=0, pad_inputs=0))
    for m, a in zip(laws, padded):
        b = fit(m)
        assert a.p_at_bound == b.p_at_bound
        for name in ("order", "order_stderr", "p", "p_stderr", "p_cov", "y_hat"):
            np.testing.assert_allclose(getattr(a, name), getattr(b, name), rtol=1e-8, atol=1e-9)
        assert float(a.sigma) == pytest.approx(float(b.sigma), rel=1e-8)


@pytest.mark.parametrize("order", ["constant", pytest.param(3, marks=pytest.mark.slow)])
def test_padding_with_a_mask_changes_nothing(order):
    """Padded after the end and masked: the same fit (knots over the fitted span), to the
    solver's tolerance (rtol = atol = 1e-10 on the parameters)."""
    from vojax._data._pipeline import _padded

    n = 300
    y = _data(0.5, seed=8)[:n]
    a = vojax.refit(U[:n], y, DT, order=order)
    b = _padded(vojax.refit, U[:n], y, 384, dt=DT, order=order)
    for name in ("order", "order_stderr", "p", "p_stderr", "y_hat", "knot_times"):
        np.testing.assert_allclose(getattr(b, name), getattr(a, name), rtol=1e-8, atol=1e-9)
    assert float(b.sigma) == pytest.approx(float(a.sigma), rel=1e-8)


@pytest.mark.parametrize("order", ["constant", 0.4])
def test_a_coefficient_fitted_to_rounding_is_exactly_zero(order):
    """An output constant over the fit window, offset estimated: no coefficient explains anything. Least
    squares leaves them at ±1e-16 (the sign set by the machine's rounding, and 1/p of a model
    at ±1e16); the refit reports 0, and the offset is the constant."""
    y = 0.2 * np.minimum(T / 10.0, 1.0)  # a ramp, then a hold: only the hold is fitted
    fixed = order if isinstance(order, str) else np.full(T.size, order)
    fit = vojax.refit(U, y, DT, order=fixed, window=(20.0, 80.0))
    assert np.all(np.asarray(fit.p) == 0.0)
    assert float(fit.x0) == pytest.approx(0.2, rel=1e-12)
    # a real coefficient of the same size as the data is not touched
    fit = vojax.refit(U, _data(0.62, seed=0), DT, x0=0.0)
    assert np.all(np.asarray(fit.p) != 0.0)


@pytest.mark.parametrize("order", ["constant", 0.5, 2])
def test_sign_constraints_do_not_depend_on_the_units_of_the_inputs(order):
    """Two coefficients break their signs in the free fit; which one the active set holds
    first decides the answer (here: the first held, the second positive, or both held).
    Ranked in standard errors the choice is unit-free: the second input in other units
    (×1e-4, ×1e4) gives the same physical coefficients. Ranked by magnitude, ×1e-4 makes the
    second coefficient 1e4 times larger and holds it first, and both end at 0. The order
    fixed (0.5), constant, or moving on 2 knots (an integer): a constant order's profile
    check can mend a wrong first choice, the knots' fit has none."""
    n, dt = 300, 0.01
    t = dt * np.arange(n)
    u1 = np.sin(2 * np.pi * t) + 1.0
    u2 = -0.8 * u1 + 0.3 * np.cos(5 * t)
    fixed = order if isinstance(order, (str, int)) else np.full(n, order)
    phi = np.asarray(vojax.fractional_integral(np.stack([u1, u2], 1), np.full(n, 0.5), dt))
    y = -phi[:, 0] - 0.6 * phi[:, 1] + 0.01 * np.random.default_rng(0).standard_normal(n)
    fits = {}
    for c in (1.0, 1e-4, 1e4):
        fit = vojax.refit(np.stack([u1, c * u2], 1), y, dt, order=fixed, p_signs=[1, 1], x0=0.0)
        fits[c] = (np.asarray(fit.p) * [1.0, c], fit.p_at_bound)
    assert fits[1.0][1] == (True, False) and fits[1.0][0][1] > 0.5
    for c in (1e-4, 1e4):
        assert fits[c][1] == fits[1.0][1]
        np.testing.assert_allclose(fits[c][0], fits[1.0][0], rtol=1e-6)


def test_a_constant_order_does_not_depend_on_the_unit_of_time():
    """φ in another time unit is φ·c^α, which the coefficient absorbs at a constant order: the
    same order (to the solver's tolerance) and p·c^α, with the times in s, ms, h, ×1e12 and
    ×1e-12. (A variable order is another matter: "p constant" means another model in
    another unit, docs/choices.md.)"""
    y = _data(0.42, seed=3)[:400]
    t = T[:400]
    a = vojax.refit(U[:400], y, t=t)
    for c in (1e-3, 1 / 3600, 1e12, 1e-12):
        b = vojax.refit(U[:400], y, t=t * c)
        assert float(b.order[0]) == pytest.approx(float(a.order[0]), abs=1e-8)
        np.testing.assert_allclose(np.asarray(b.p) * c ** float(a.order[0]), a.p, rtol=1e-6)
        assert float(b.order_stderr[0]) == pytest.approx(float(a.order_stderr[0]), rel=1e-5)


@pytest.mark.parametrize("knots", ["constant", 3])
def test_the_fit_does_not_depend_on_the_units_of_the_data(knots):
    """The output in metres of an AFM indentation (~1e-10 as a contact strain) and the input in
    newtons, or both ×1e9, or the input ×1e-6 and the output ×1e6: the same orders (to the
    solver's tolerance), p scaled by c_y/c_u, x0 and σ by c_y. Absolute tolerances on the
    residuals and coefficients made the solver stop at its start (order 0.5 with 1e-10-sized
    data)."""
    y = _data(0.42, seed=3)[:400]
    u = U[:400]
    a = vojax.refit(u, y, t=T[:400], order=knots)
    assert abs(float(a.order[-1]) - 0.5) > 0.02  # the start is not the answer
    for cu, cy in ((1.0, 1e-10), (1e-9, 1e-18), (1e-6, 1e6), (1e9, 1.0)):
        b = vojax.refit(u * cu, y * cy, t=T[:400], order=knots)
        np.testing.assert_allclose(np.asarray(b.order), np.asarray(a.order), rtol=0, atol=1e-7)
        np.testing.assert_allclose(np.asarray(b.p) * cu / cy, np.asarray(a.p), rtol=1e-6)
        assert float(b.x0) / cy == pytest.approx(float(a.x0), rel=1e-6, abs=1e-9 * np.ptp(y))
        assert float(b.sigma) / cy == pytest.approx(float(a.sigma), rel=1e-6)


def test_a_start_on_a_bound_starts_inside_and_an_order_beyond_the_range_sits_at_its_bound():
    """The default start 0.5 on the lower bound of (0.5, 0.9): the fit starts just inside (its
    logit would be −∞ there). Inside the range it finds the true 0.62 as from any start;
    with the true order 0.35 below the range it ends at the bound, says so, and its band is
    finite and within the range."""
    y = _data(0.62, seed=0)
    inside = vojax.refit(U, y, DT, x0=0.0, order_bounds=(0.5, 0.9))
    free = vojax.refit(U, y, DT, x0=0.0)
    assert inside.result == optx.RESULTS.successful and not inside.at_bound
    assert float(inside.order[0]) == pytest.approx(float(free.order[0]), abs=1e-8)
    low = _data(0.35, seed=0)
    with pytest.warns(vojax.RefitWarning, match="sits at a bound"):
        fit = vojax.refit(U, low, DT, x0=0.0, order_bounds=(0.5, 0.9))
    assert fit.at_bound and float(fit.order[0]) == pytest.approx(0.5, abs=1e-4)
    for name in ("order_lower", "order_upper", "order_stderr"):
        assert np.all(np.isfinite(np.asarray(getattr(fit, name)))), name
    assert 0.5 <= float(fit.order_lower[0]) <= float(fit.order[0]) <= float(fit.order_upper[0]) <= 0.9


def test_the_second_opinion_also_starts_inside_a_bound():
    """`refit_lbfgsb` from the default start 0.5 on the lower bound of (0.5, 0.9): its start's
    logit would be −∞ and its coefficients NaN; started inside, it finds the same order and
    coefficients as `refit` on the same record."""
    pytest.importorskip("jaxopt")
    from vojax._refit import refit_lbfgsb

    n = 400
    y = _data(0.62, seed=0)[:n]
    lm = vojax.refit(U[:n], y, DT, x0=0.0, order_bounds=(0.5, 0.9))
    beta, p = refit_lbfgsb(U[:n], y, DT, x0=0.0, order_bounds=(0.5, 0.9))
    assert np.all(np.isfinite(np.asarray(p)))
    assert abs(float(beta[0]) - float(lm.order[0])) < 0.1 * float(lm.order_stderr[0])
    assert np.max(np.abs(np.asarray(p) - np.asarray(lm.p)) / np.asarray(lm.p_stderr)) < 0.1


def _short_record():
    """A 40-sample record at 0.1 s (order 0.4, p 1, a small sine on top): ``(u, y)``. At a
    step of 1e-300 s its columns are ~1e-120."""
    t = 0.1 * np.arange(40)
    u = np.minimum(t, 1.0) + 0.1
    return u, np.asarray(vojax.simulate(u, 0.4, 1.0, 0.1)) + 1e-3 * np.sin(7 * t)


def test_the_second_opinion_checks_its_solver_settings_and_its_answer():
    """`refit_lbfgsb`'s `tol` and `max_steps` are checked (a text `tol` failed inside the
    solver with "'>' not supported between instances of 'DynamicJaxprTracer' and 'str'"),
    and an answer outside float64's range is refused, not returned as NaN: with an offset
    of 2**63 or a step of 1e-300 s (columns of ~1e-150) the solver steps out of it or stops
    at a finite answer, by the versions installed (the newest: the offset steps out); never
    NaN."""
    pytest.importorskip("jaxopt")
    from vojax._refit import refit_lbfgsb

    y = _data(0.62, seed=0)[:200]
    for tol in (None, "1e-9", -1.0, float("nan")):
        with pytest.raises((TypeError, ValueError), match="`tol` must be"):
            refit_lbfgsb(U[:200], y, DT, x0=0.0, tol=tol)
    for steps in (0, 2.5, True):
        with pytest.raises((TypeError, ValueError), match="`max_steps` must be"):
            refit_lbfgsb(U[:200], y, DT, x0=0.0, max_steps=steps)
    u, short = _short_record()
    for step, x0 in ((0.1, 2**63), (1e-300, 0.0)):
        try:
            answer = refit_lbfgsb(u, short, step, x0=x0, max_steps=30)
        except ValueError as e:
            assert "refit_lbfgsb reached no finite answer on these data" in str(e)
        else:
            assert all(np.all(np.isfinite(np.asarray(a))) for a in answer)
    order, p = refit_lbfgsb(u, short, 0.1, x0=0.0, max_steps=30)  # the same record, in seconds
    assert np.all(np.isfinite(np.asarray(order))) and np.all(np.isfinite(np.asarray(p)))


def _lbfgsb_warnings(*args, **kwargs):
    """`refit_lbfgsb`'s answer and the `RefitWarning` messages it gave."""
    import warnings

    from vojax._refit import refit_lbfgsb

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", vojax.RefitWarning)
        answer = refit_lbfgsb(*args, **kwargs)
    return answer, [str(w.message) for w in caught if w.category is vojax.RefitWarning]


def test_the_second_opinion_says_when_it_stopped_before_converging():
    """L-BFGS-B stopped by `max_steps` returns where it stopped: with 3 steps on a 40-sample
    record the projected gradient's norm is ~0.3 (converged, 8 steps, it is 2e-13), and on a
    step of 1e-300 s (columns of ~1e-120) the order stays at its start 0.5 with p ~1e149 after
    all 30 steps. Both are said (`RefitWarning`, the norm and `tol` named), or refused as no
    finite answer; the converged fit says nothing, and `warn=False` silences it."""
    pytest.importorskip("jaxopt")
    u, short = _short_record()
    (order, p), said = _lbfgsb_warnings(u, short, 0.1, x0=0.0)
    assert said == [] and abs(float(order[0]) - 0.4) < 1e-3 and abs(float(p[0]) - 1.0) < 1e-3
    (order, _), said = _lbfgsb_warnings(u, short, 0.1, x0=0.0, max_steps=3)
    assert len(said) == 1 and "did not converge (it took all 3 of `max_steps`" in said[0]
    assert "above `tol` 1e-12" in said[0]
    assert _lbfgsb_warnings(u, short, 0.1, x0=0.0, max_steps=3, warn=False)[1] == []
    try:
        _, said = _lbfgsb_warnings(u, short, 1e-300, x0=0.0, max_steps=30)
    except ValueError as e:
        assert "refit_lbfgsb reached no finite answer on these data" in str(e)
    else:
        assert len(said) == 1 and "did not converge" in said[0]
    from vojax._refit import refit_lbfgsb

    with pytest.raises((TypeError, ValueError), match="`warn` must be"):
        refit_lbfgsb(u, short, 0.1, x0=0.0, warn="yes")


@pytest.mark.parametrize("second_opinion", [False, True])
def test_a_start_outside_the_range_is_named_in_the_refits_own_words(second_opinion):
    """The message names `order0` and `order_bounds`, the arguments the caller gave (not the
    tracker's `alpha0` and `alpha_bounds`)."""
    if second_opinion:
        pytest.importorskip("jaxopt")
        from vojax._refit import refit_lbfgsb as fit
    else:
        fit = vojax.refit
    y = _data(0.62, seed=0)
    with pytest.raises(ValueError, match=r"`order0` must lie inside `order_bounds` \(0.1, 0.4\)"):
        fit(U, y, DT, x0=0.0, order0=0.5, order_bounds=(0.1, 0.4))
    with pytest.raises(ValueError, match="`order0` must be a positive finite number"):
        fit(U, y, DT, x0=0.0, order0=float("nan"))
