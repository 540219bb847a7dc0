"""The strain of a fitted law solved exactly (`AbstractViscoelasticModel.fitted_strain`): equal
to the closed form ``x0 E_q(b τ^q) + σ0 J(τ)`` under a step of stress, to the refit's own
``y_hat`` where the law does not feed its strain back, and the residual the record's summary
reports for a law that does."""

import jax
import numpy as np
import pytest

import vojax
from vojax._data._pipeline import identify_record
from vojax._models._respond import DIRECT_PRODUCTS, _convolve

jax.config.update("jax_enable_x64", True)


def _myocardium():
    (rec,) = vojax.io.load_records(vojax.io.example_file("myocardium"), time="Time",
                                   inputs=["F"], output="L")
    return rec, rec.inputs[:, 0], (rec.output - 0.95) / 0.95


@pytest.mark.parametrize("model", [vojax.Springpot(), vojax.FractionalMaxwell()])
def test_a_law_without_feedback_solves_to_the_refits_own_fit(model):
    """Two computations of ``x0 + c σ + I^q(a σ)`` on the myocardium's log-spaced clock: the
    refit's product-trapezoid integral and the closed-form ramp responses."""
    rec, stress, strain = _myocardium()
    fit = vojax.refit(model.inputs(stress, strain), strain, **rec.grid,
                      direct=model.direct(stress, strain), p_signs=model.p_signs, warn=False)
    solved = model.fitted_strain(fit, stress, **rec.grid)
    assert np.max(np.abs(solved - np.asarray(fit.y_hat))) < 1e-10 * np.ptp(strain)


def _step_record(model, truth, q, x0, dt=0.01, num=400, sigma0=2.0, origin=None):
    """A step of stress σ0 held from the test's start (`origin`, or the first sample) and the
    law's strain in closed form, ``x0 E_q(b τ^q) + σ0 J(τ)`` (J(0) = c, the spring's jump)."""
    t = dt * np.arange(num)
    start = t[0] if origin is None else origin
    tau = t - start
    _, b, c = model.coefficients(**truth)
    compliance = np.where(tau > 0, model.creep_compliance(np.where(tau > 0, tau, 1.0), q=q,
                                                          **truth), c)
    ml = vojax.mittag_leffler(q, -b * tau**q) if b != 0 else np.ones_like(tau)
    return t, np.full(num, sigma0), x0 * ml + sigma0 * compliance


@pytest.mark.parametrize("origin", [None, -0.25])
@pytest.mark.parametrize("model, truth", [
    (vojax.KelvinVoigt(), dict(eta=2.0, k=3.0)),
    (vojax.FractionalZener(), dict(eta=2.0, E0=3.0, E1=5.0)),
])
def test_a_step_through_a_law_with_feedback_solves_to_the_closed_form(model, truth, origin):
    """The refit of the law's noiseless strain gives coefficients near the truth; the fitted
    law, solved, equals the closed form *at the fitted coefficients* to rounding: the offset's
    own relaxation ``x0 E_q(b τ^q)`` (gone if the offset were simply added) included."""
    q, x0 = 0.4, 0.05
    t, stress, strain = _step_record(model, truth, q, x0, origin=origin)
    # x0 given: under a step the spring's jump c σ0 is a constant, as an estimated offset is
    fit = vojax.refit(model.inputs(stress, strain), strain, dt=0.01, origin=origin, x0=x0,
                      direct=model.direct(stress, strain), p_signs=model.p_signs, warn=False)
    fitted = model.parameters(np.asarray(fit.p))
    if origin is None:  # with an origin the refit holds the strain regressor at its first
        # value before the first sample, where the law's strain creeps: its fit is biased
        assert float(fit.order[0]) == pytest.approx(q, abs=0.02)
        for name, value in truth.items():
            assert float(fitted[name]) == pytest.approx(value, rel=0.1)
    _, _, expected = _step_record(model, {k: float(v) for k, v in fitted.items()},
                                  float(fit.order[0]), float(fit.x0), origin=origin)
    solved = model.fitted_strain(fit, stress, 0.01, origin=origin)
    assert np.max(np.abs(solved - expected)) < 1e-11 * np.ptp(strain)
    if origin is None:  # noiseless data, a good fit: its law reproduces the record
        assert np.max(np.abs(solved - strain)) < 0.02 * np.ptp(strain)


def test_a_held_spring_solves_the_law_it_leaves():
    """Kelvin–Voigt with k held at 0 is a springpot: its solved strain has no relaxation of
    the offset (b = 0) and equals the springpot's response plus x0."""
    rec, stress, strain = _myocardium()
    kv = vojax.KelvinVoigt()
    fit = vojax.refit(kv.inputs(stress, strain), strain, **rec.grid, p_signs=kv.p_signs,
                      warn=False)
    assert fit.p_at_bound == (False, True)
    expected = float(fit.x0) + vojax.Springpot().strain_response(
        stress, t=rec.grid["t"], q=float(fit.order[0]), eta=1.0 / float(fit.p[0]))
    assert np.max(np.abs(kv.fitted_strain(fit, stress, **rec.grid) - expected)) < 1e-14


def test_a_fit_whose_memory_terms_are_both_zero_is_a_spring():
    """A Zener refit of a spring's strain, ``ε = x0 + c σ`` on the myocardium's stress and
    clock, as `vojax run --model zener` fits it: both memory terms 0 (the order moves
    nothing), the law left is the spring ``ε = x0 + c σ``, the refit's own fit and the
    spring itself."""
    import dataclasses

    from vojax._data._regressors import refit_options, regressors

    rec, stress, _ = _myocardium()
    spring = 0.02 + 0.4 * stress / np.max(stress)
    rec = dataclasses.replace(rec, output=spring)
    zener = vojax.FractionalZener()
    u, y, _, _ = regressors(rec, "zener")
    fit = vojax.refit(u, y, **rec.grid, **refit_options(rec, "zener"), warn=False)
    assert np.asarray(fit.p)[0] == 0.0 and np.asarray(fit.p)[1] == 0.0
    solved = zener.fitted_strain(fit, stress, **rec.grid)
    assert np.max(np.abs(solved - np.asarray(fit.y_hat))) < 1e-12 * np.ptp(spring)
    assert np.max(np.abs(solved - spring)) < 1e-12 * np.ptp(spring)


def test_the_record_summary_reports_the_solved_laws_residual():
    """A Kelvin–Voigt record with noise on the strain: the refit's regression carries the
    noisy strain inside the integral, so its residual is not the fitted law's. The summary's
    ``nrmse`` is the solved law's (computed here again), ``nrmse_regression`` the fit's own."""
    model, truth, q = vojax.KelvinVoigt(), dict(eta=2.0, k=3.0), 0.4
    t = 0.02 * np.arange(300)
    stress = np.minimum(t / 1.0, 1.0) + 0.2 * np.sin(2.0 * t)
    clean = model.strain_response(stress, 0.02, q=q, **truth)
    noisy = clean + 0.01 * np.ptp(clean) * np.random.default_rng(3).normal(size=t.size)
    rec = vojax.io.Record("kv", "kv.csv", t, stress[:, None], noisy, ("stress",), "strain", 0.02)
    _, summary = identify_record(rec, model="kelvin-voigt", method="refit")
    block = summary["refit"]
    fit = vojax.refit(model.inputs(stress, noisy), noisy, dt=0.02, p_signs=model.p_signs,
                      warn=False)
    solved = model.fitted_strain(fit, stress, 0.02)
    span = np.ptp(noisy)
    assert block["nrmse_of"] == "the fitted law solved"
    assert block["nrmse"] == pytest.approx(np.sqrt(np.mean((solved - noisy) ** 2)) / span,
                                           rel=1e-6)
    assert block["nrmse_regression"] == pytest.approx(
        np.sqrt(np.mean(np.asarray(fit.residuals) ** 2)) / span, rel=1e-6)
    assert abs(block["nrmse"] - block["nrmse_regression"]) > 1e-4


def test_a_long_convolution_by_fft_equals_the_direct_sum():
    rng = np.random.default_rng(0)
    a, b = rng.normal(size=4096), np.cumsum(rng.random(4096))[::-1]
    assert a.size * b.size > DIRECT_PRODUCTS
    direct = np.convolve(a, b)
    assert np.max(np.abs(_convolve(a, b) - direct)) < 1e-14 * np.max(np.abs(direct))


def test_fitted_strain_says_what_is_wrong():
    rec, stress, strain = _myocardium()
    kv = vojax.KelvinVoigt()
    fit = vojax.refit(kv.inputs(stress, strain), strain, **rec.grid, p_signs=kv.p_signs,
                      warn=False)
    with pytest.raises(TypeError, match="exactly one of"):
        kv.fitted_strain(fit, stress)
    with pytest.raises(TypeError, match="vojax.Refit"):
        kv.fitted_strain(object(), stress, **rec.grid)
    with pytest.raises(ValueError, match="coefficients"):
        vojax.FractionalZener().fitted_strain(fit, stress, **rec.grid)
    with pytest.raises(ValueError, match="before the first sample"):
        kv.fitted_strain(fit, stress, **rec.grid, origin=rec.grid["t"][0])
    free = vojax.refit(kv.inputs(stress, strain), strain, **rec.grid, warn=False)
    assert float(free.p[1]) > 0  # k < 0: the free fit breaks the sign
    with pytest.raises(ValueError, match="not physical"):
        kv.fitted_strain(free, stress, **rec.grid)
    varying = vojax.refit(kv.inputs(stress, strain), strain, **rec.grid, order=3,
                          p_signs=kv.p_signs, warn=False)
    with pytest.raises(ValueError, match="varies along the record"):
        kv.fitted_strain(varying, stress, **rec.grid)


def test_the_record_summary_keeps_the_regressions_residual_where_a_solve_is_too_costly(
        monkeypatch):
    """The same Kelvin–Voigt record on a clock uniform nowhere (jittered by 0.5 % of a step):
    solved while its lags, (N − 1)·N, are within `EXACT_SOLVE_LAGS`; above it, ``nrmse`` is
    the regression's and ``nrmse_of`` says so."""
    from vojax._models import _fitted

    model, truth, q = vojax.KelvinVoigt(), dict(eta=2.0, k=3.0), 0.4
    t = 0.02 * np.arange(200) + 1e-4 * np.random.default_rng(1).uniform(size=200)
    stress = np.minimum(t / 1.0, 1.0)
    clean = model.strain_response(stress, t=t, q=q, **truth)
    noisy = clean + 0.01 * np.ptp(clean) * np.random.default_rng(3).normal(size=t.size)
    rec = vojax.io.Record("kv", "kv.csv", t, stress[:, None], noisy, ("stress",), "strain",
                          0.02, uniform=False)
    assert _fitted.too_costly(t) is None and _fitted.too_costly(None) is None
    _, summary = identify_record(rec, model="kelvin-voigt", method="refit")
    assert summary["refit"]["nrmse_of"] == "the fitted law solved"
    monkeypatch.setattr(_fitted, "EXACT_SOLVE_LAGS", 199 * 200 - 1)
    assert "199 of its 200 samples" in _fitted.too_costly(t)
    _, summary = identify_record(rec, model="kelvin-voigt", method="refit")
    block = summary["refit"]
    assert block["nrmse_of"] == "regression" and block["nrmse"] == block["nrmse_regression"]
