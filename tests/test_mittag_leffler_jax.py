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
    """The Maxwell law's G(t) = E E_q(−(E/η) t^q) over six decades (the NumPy route of
    `FractionalMaxwell.relaxation_modulus`), fitted for (q, log E, log η) by
    Levenberg–Marquardt through its JAX route from a start far off: the parameters come back
    to 1e-8."""
    t = np.logspace(-3, 3, 60)
    q, e, eta = 0.35, 5.0, 2.0
    data = vojax.FractionalMaxwell().relaxation_modulus(t, q=q, E=e, eta=eta)

    def residuals(theta, _):
        q_, log_e, log_eta = theta
        model = vojax.FractionalMaxwell().relaxation_modulus(
            t, q=q_, E=jnp.exp(log_e), eta=jnp.exp(log_eta))  # traced: the JAX route
        return model / data - 1.0

    sol = optx.least_squares(residuals, optx.LevenbergMarquardt(rtol=1e-12, atol=1e-12),
                             jnp.array([0.6, np.log(1.0), np.log(1.0)]), max_steps=200)
    q_fit, log_e, log_eta = np.asarray(sol.value)
    assert q_fit == pytest.approx(q, rel=1e-8)
    assert np.exp(log_e) == pytest.approx(e, rel=1e-8)
    assert np.exp(log_eta) == pytest.approx(eta, rel=1e-8)


def test_bad_input_is_refused_in_one_sentence():
    with pytest.raises(ValueError, match="beta must be 1 or 2, got 3"):
        vojax.mittag_leffler_jax(0.5, 1.0, 3)
    with pytest.raises(ValueError, match=r"the order\) must lie in \(0, 1\), got 1.0"):
        vojax.mittag_leffler_jax(1.0, 1.0)
    with pytest.raises(ValueError, match="must be finite and at least 0"):
        vojax.mittag_leffler_jax(0.5, [1.0, -1.0])
    with pytest.raises(ValueError, match="must be finite and at least 0"):
        vojax.mittag_leffler_jax(0.5, np.nan)
    with pytest.raises(ValueError, match="must be finite and at least 0"):
        vojax.mittag_leffler_jax(0.5, np.array([1.0 + 1e-3j]))  # not silently made real
    with pytest.raises(TypeError, match=r"the order\) must be a number, got True"):
        vojax.mittag_leffler_jax(True, 1.0)


LAWS = [(vojax.Springpot(), dict(eta=2.0)), (vojax.KelvinVoigt(), dict(eta=2.0, k=3.0)),
        (vojax.FractionalMaxwell(), dict(eta=2.0, E=5.0)),
        (vojax.FractionalZener(), dict(eta=2.0, E0=1.5, E1=4.0))]
FORMS = ("relaxation_modulus", "creep_compliance", "complex_modulus")


@pytest.mark.parametrize("form", FORMS)
@pytest.mark.parametrize("law, params", LAWS, ids=lambda v: type(v).__name__)
def test_the_laws_closed_forms_take_jax_values_and_differentiate(law, params, form):
    """Each law's G(t), J(t) and G*(ω) given JAX values: equal to the NumPy route to 1e-13,
    and their derivatives in q and in the first parameter equal central differences of the
    NumPy route (to 1e-6)."""
    grid = np.logspace(-3, 3, 31)
    q = 0.45
    f = getattr(law, form)
    want = f(grid, q=q, **params)
    got = jax.jit(lambda q_: f(jnp.asarray(grid), q=q_, **params))(q)
    assert np.max(np.abs(np.asarray(got) - want) / np.abs(want)) < 1e-13
    name = next(iter(params))
    h = 1e-6

    def part(values, q_):  # the real part: jax.grad wants a real scalar
        return jnp.sum(jnp.real(f(jnp.asarray(grid), q=q_, **values)))

    g_q, g_p = jax.grad(lambda q_, v: part(dict(params, **{name: v}), q_), argnums=(0, 1))(
        q, params[name])
    fd = lambda **kw: np.sum(np.real(f(grid, **kw)))  # noqa: E731
    fd_q = (fd(q=q + h, **params) - fd(q=q - h, **params)) / (2 * h)
    up, down = dict(params, **{name: params[name] * (1 + h)}), dict(params, **{name: params[name] * (1 - h)})
    fd_p = (fd(q=q, **up) - fd(q=q, **down)) / (2 * h * params[name])
    assert float(g_q) == pytest.approx(fd_q, rel=1e-6)
    assert float(g_p) == pytest.approx(fd_p, rel=1e-6)


def test_concrete_jax_values_are_checked_as_numbers_are():
    maxwell = vojax.FractionalMaxwell()
    with pytest.raises(ValueError, match=r"the order\) must lie in \(0, 1\)"):
        maxwell.relaxation_modulus(jnp.ones(3), q=1.0, eta=1.0, E=1.0)
    with pytest.raises(ValueError, match="the parameter E must be a number above 0"):
        maxwell.relaxation_modulus([1.0], q=0.5, eta=1.0, E=jnp.asarray(-1.0))
    with pytest.raises(ValueError, match="`t` must hold finite numbers above 0"):
        maxwell.creep_compliance(jnp.asarray([0.0, 1.0]), q=jnp.asarray(0.5), eta=1.0, E=1.0)
    with pytest.raises(TypeError, match="FractionalMaxwell takes the parameters E, eta"):
        maxwell.relaxation_modulus(jnp.ones(3), q=0.5, eta=1.0)
