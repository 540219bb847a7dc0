"""The Mittag-Leffler function in JAX (`vojax.mittag_leffler_jax`): its values against the
NumPy function (itself checked against mpmath in test_closed_forms), its derivatives in the
order and the argument against mpmath's differentiated series (a second, independent
computation), and a least-squares fit of a relaxation modulus through it by gradient."""

import jax
import jax.numpy as jnp
import numpy as np
import optimistix as optx
import pytest

import vojax

jax.config.update("jax_enable_x64", True)

ORDERS = (0.05, 0.2, 0.5, 0.7, 0.9, 0.99)


def _series_derivatives(alpha, x, beta):
    """``(∂/∂α, ∂/∂x)`` of E_{α,β}(−x) by mpmath's power series differentiated term by term:
    ``Σ (−x)^k (−k ψ(αk + β))/Γ(αk + β)`` and ``Σ −k (−x)^{k−1}/Γ(αk + β)``, at enough digits
    to absorb the cancellation (as `tests.helpers.mittag_leffler_series`)."""
    import mpmath

    digits = 30 + int(x ** (1 / alpha) / 2.3)
    with mpmath.workdps(digits):
        xs, a = mpmath.mpf(float(x)), mpmath.mpf(alpha)
        d_alpha = d_x = mpmath.mpf(0)
        k = 0
        while True:
            z = a * k + beta
            term = (-xs) ** k * mpmath.rgamma(z)
            d_alpha += -k * mpmath.digamma(z) * term
            if k > 0:
                d_x += -k * (-xs) ** (k - 1) * mpmath.rgamma(z)
            if k > 10 and abs(term) * (k + abs(mpmath.digamma(z))) < mpmath.mpf(10) ** (-digits):
                return float(d_alpha), float(d_x)
            k += 1


@pytest.mark.parametrize("beta", [1, 2])
@pytest.mark.parametrize("alpha", ORDERS)
def test_values_equal_the_numpy_function(alpha, beta):
    x = np.concatenate([[0.0], np.logspace(-6, 6, 121)])  # every region and both limits
    got = np.asarray(vojax.mittag_leffler_jax(alpha, x, beta))
    want = vojax.mittag_leffler(alpha, x, float(beta))
    assert np.max(np.abs(got - want) / np.abs(want)) < 1e-13


@pytest.mark.parametrize("beta", [1, 2])
@pytest.mark.parametrize("alpha", [0.2, 0.5, 0.8])
def test_gradients_equal_the_differentiated_series(alpha, beta):
    pytest.importorskip("mpmath")
    f = lambda a, x: vojax.mittag_leffler_jax(a, x, beta)  # noqa: E731
    # the power series' region, then the integral's (x^{1/α} kept moderate: mpmath needs
    # about x^{1/α}/2.3 digits and as many terms)
    for x in (0.1, 0.7, 2.0) + ((5.0,) if alpha >= 0.5 else ()):
        want_a, want_x = _series_derivatives(alpha, x, beta)
        got_a, got_x = jax.grad(f, argnums=(0, 1))(alpha, x)
        assert float(got_a) == pytest.approx(want_a, rel=1e-9, abs=1e-14), (x, "alpha")
        assert float(got_x) == pytest.approx(want_x, rel=1e-9, abs=1e-14), (x, "x")


@pytest.mark.parametrize("alpha", [0.3, 0.8])
def test_gradients_in_the_asymptotic_region_equal_differences_of_the_numpy_function(alpha):
    for x in (2e4, 3e5):
        got_a, got_x = jax.grad(lambda a, x: vojax.mittag_leffler_jax(a, x), argnums=(0, 1))(
            alpha, x)
        h = 1e-5
        fd_a = (vojax.mittag_leffler(alpha + h, x) - vojax.mittag_leffler(alpha - h, x)) / (2 * h)
        fd_x = (vojax.mittag_leffler(alpha, x * (1 + h)) - vojax.mittag_leffler(
            alpha, x * (1 - h))) / (2 * h * x)
        assert float(got_a) == pytest.approx(float(fd_a[()]), rel=1e-6)
        assert float(got_x) == pytest.approx(float(fd_x[()]), rel=1e-6)


def test_a_relaxation_modulus_is_fitted_through_it_by_gradient():
    """The Maxwell law's G(t) = E E_q(−(E/η) t^q) (`FractionalMaxwell.relaxation_modulus`,
    NumPy) over six decades, fitted for (q, log E, log η) by Levenberg–Marquardt through the
    JAX function from a start far off: the parameters come back to 1e-8."""
    t = np.logspace(-3, 3, 60)
    q, e, eta = 0.35, 5.0, 2.0
    data = vojax.FractionalMaxwell().relaxation_modulus(t, q=q, E=e, eta=eta)

    def residuals(theta, _):
        q_, log_e, log_eta = theta
        e_, eta_ = jnp.exp(log_e), jnp.exp(log_eta)
        return e_ * vojax.mittag_leffler_jax(q_, e_ / eta_ * t**q_) / data - 1.0

    sol = optx.least_squares(residuals, optx.LevenbergMarquardt(rtol=1e-12, atol=1e-12),
                             jnp.array([0.6, np.log(1.0), np.log(1.0)]), max_steps=200)
    q_fit, log_e, log_eta = np.asarray(sol.value)
    assert q_fit == pytest.approx(q, rel=1e-8)
    assert np.exp(log_e) == pytest.approx(e, rel=1e-8)
    assert np.exp(log_eta) == pytest.approx(eta, rel=1e-8)


def test_bad_input_is_refused_in_one_sentence():
    with pytest.raises(ValueError, match="beta must be 1 or 2, got 3"):
        vojax.mittag_leffler_jax(0.5, 1.0, 3)
    with pytest.raises(ValueError, match=r"the order alpha must be a number in \(0, 1\)"):
        vojax.mittag_leffler_jax(1.0, 1.0)
    with pytest.raises(ValueError, match="must be finite and at least 0"):
        vojax.mittag_leffler_jax(0.5, [1.0, -1.0])
    with pytest.raises(ValueError, match="must be finite and at least 0"):
        vojax.mittag_leffler_jax(0.5, np.nan)
    with pytest.raises(ValueError, match="must be finite and at least 0"):
        vojax.mittag_leffler_jax(0.5, np.array([1.0 + 1e-3j]))  # not silently made real
    with pytest.raises(ValueError, match=r"must be a number in \(0, 1\)"):
        vojax.mittag_leffler_jax(True, 1.0)
