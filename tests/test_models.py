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
