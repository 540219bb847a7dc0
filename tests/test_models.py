"""Viscoelastic laws in the form of eq. (11), identified back from simulated tests."""

import numpy as np
import optimistix as optx
import pytest

import vojax

DT = 0.02
T = np.arange(1201) * DT


def test_stress_strain_conversion_eq35():
    sigma, eps = vojax.stress_strain(np.array([0.0, 2.0, 4.0]), np.array([0.0, 0.1, 0.3]), 4.0, 0.5)
    np.testing.assert_allclose(sigma, [0.0, 0.5, 1.0], rtol=0, atol=1e-15)
    np.testing.assert_allclose(eps, [0.0, 0.2, 0.6], rtol=0, atol=1e-15)
    with pytest.raises(ValueError, match="`area` must be a positive"):
        vojax.stress_strain(np.ones(3), np.ones(3), 0.0, 1.0)
    with pytest.raises(ValueError, match="same shape"):
        vojax.stress_strain(np.ones(3), np.ones(4), 1.0, 1.0)


def test_springpot_refit_recovers_eta_and_q():
    model = vojax.Springpot()
    stress = 1.0 - np.exp(-T) + 0.2 * np.sin(2.0 * T)  # a ramp to a hold, with a wobble
    strain = np.asarray(vojax.simulate(model.inputs(stress), 0.3, model.regression(eta=5.0), DT))
    fit = vojax.refit(model.inputs(stress), strain, DT, x0=0.0)
    assert fit.result == optx.RESULTS.successful
    assert abs(float(fit.order[0]) - 0.3) < 1e-8
    assert abs(float(model.parameters(fit.p)["eta"]) - 5.0) < 1e-7


def test_kelvin_voigt_refit_recovers_eta_k_q():
    model = vojax.KelvinVoigt()
    eta, k, q = 4.0, 1.5, 0.45
    # σ = kε + η D^q ε  ⇔  D^q ε = σ/η − (k/η) ε: written here, not taken from the model
    p = np.array([1.0 / eta, -k / eta])
    stress = np.tanh(T) + 0.3 * np.sin(1.3 * T)
    # the strain solves ε = I^q[(σ − kε)/η] (implicit): fixed-point iteration on the same quadrature
    strain = np.zeros_like(T)
    for _ in range(200):
        new = np.asarray(vojax.simulate(np.stack([stress, strain], 1), q, p, DT))
        if np.max(np.abs(new - strain)) < 1e-15:
            break
        strain = new
    fit = vojax.refit(model.inputs(stress, strain), strain, DT, x0=0.0)
    phys = model.parameters(fit.p)
    assert abs(float(fit.order[0]) - q) < 1e-6
    assert abs(float(phys["eta"]) - eta) < 1e-5 * eta
    assert abs(float(phys["k"]) - k) < 1e-5 * k
    assert model.parameters(model.regression(eta=eta, k=k))["k"] == pytest.approx(k, rel=1e-15)


def test_parameters_stderr_is_the_delta_method_closed_form():
    """η = 1/p₁, k = −p₂/p₁: J = [[−1/p₁², 0], [p₂/p₁², −1/p₁]], se = sqrt(diag(J C Jᵀ))."""
    p = np.array([0.5, -3.0])
    cov = np.array([[4e-4, -1e-4], [-1e-4, 9e-4]])
    jac = np.array([[-1 / p[0] ** 2, 0.0], [p[1] / p[0] ** 2, -1 / p[0]]])
    expected = np.sqrt(np.diag(jac @ cov @ jac.T))
    se = vojax.KelvinVoigt().parameters_stderr(p, cov)
    np.testing.assert_allclose([se["eta"], se["k"]], expected, rtol=1e-12)
    se = vojax.Springpot().parameters_stderr(p[:1], cov[:1, :1])
    np.testing.assert_allclose(se["eta"], 0.02 / 0.25, rtol=1e-12)
    with pytest.raises(ValueError, match="`cov` must have shape"):
        vojax.Springpot().parameters_stderr(p[:1], cov)


def test_fractional_maxwell_creep_closed_form_on_a_log_grid():
    """A step load at t = 0 sampled on a log-spaced clock: ε = σ0/E + σ0 t^q/(η Γ(1+q)), the
    closed form, refitted with the true origin (x0 = 0: strain before loading) gives E, η and q
    back; the spring is the order-0 regressor."""
    import math

    model = vojax.FractionalMaxwell()
    eta, e, q, s0 = 40.0, 2.5, 0.3, 1.7
    t = np.geomspace(1e-2, 1e4, 200)
    stress = np.full(t.size, s0)
    strain = s0 / e + s0 * t**q / (eta * math.gamma(1 + q))
    fit = vojax.refit(
        model.inputs(stress), strain, t=t, origin=0.0, x0=0.0, direct=model.direct(stress),
        p_signs=model.p_signs,
    )
    phys = model.parameters(fit.p)
    assert abs(float(fit.order[0]) - q) < 1e-7
    assert abs(float(phys["eta"]) - eta) < 1e-6 * eta
    assert abs(float(phys["E"]) - e) < 1e-7 * e
    back = model.parameters(model.regression(eta=eta, E=e))
    assert back["E"] == pytest.approx(e, rel=1e-15) and back["eta"] == pytest.approx(eta, rel=1e-15)


def test_fractional_zener_refit_recovers_its_three_moduli():
    """σ + (η/E1) D^q σ = E0 ε + η(E0+E1)/E1 D^q ε, written here as its integral equation and
    solved for ε by fixed-point iteration; the fit with the model's regressors and signs
    returns η, E0, E1 and q."""
    model = vojax.FractionalZener()
    eta, e0, e1, q = 3.0, 2.0, 5.0, 0.4
    total = e0 + e1
    stress = np.tanh(T) + 0.3 * np.sin(1.3 * T)
    strain = np.zeros_like(T)
    for _ in range(300):
        drive = np.stack([stress, strain], 1)
        integral = np.asarray(vojax.simulate(drive, q, np.array([e1, -e0 * e1]) / (eta * total), DT))
        new = integral + stress / total
        if np.max(np.abs(new - strain)) < 1e-15:
            break
        strain = new
    fit = vojax.refit(
        model.inputs(stress, strain), strain, DT, x0=0.0, direct=model.direct(stress),
        p_signs=model.p_signs,
    )
    assert fit.p_at_bound == (False, False, False)
    phys = model.parameters(fit.p)
    assert abs(float(fit.order[0]) - q) < 1e-6
    for name, value in (("eta", eta), ("E0", e0), ("E1", e1)):
        assert abs(float(phys[name]) - value) < 1e-5 * value, name
    back = model.parameters(model.regression(eta=eta, E0=e0, E1=e1))
    for name, value in (("eta", eta), ("E0", e0), ("E1", e1)):
        assert back[name] == pytest.approx(value, rel=1e-14)
    se = model.parameters_stderr(fit.p, fit.p_cov)
    assert set(se) == {"eta", "E0", "E1"} and all(np.isfinite(v) for v in se.values())
