"""The laws' exact responses to a loading history (`strain_response`, `stress_response`) and
the Mittag-Leffler functions E_{α,2}, E_{α,1+α}, E_{α,2+α} they use: a step against the
closed forms G(t), J(t); a ramp and a ramp–hold against the convolution of J or G with the
loading rate by adaptive quadrature (an independent computation); E_{α,β} against mpmath's
series in high precision; the two clocks against each other; bad input refused."""

import math

import numpy as np
import pytest

from vojax import FractionalMaxwell, FractionalZener, KelvinVoigt, Springpot
from vojax._models import _closed
from vojax._models._closed import mittag_leffler

from .helpers import mittag_leffler_series

LAWS = [
    (Springpot(), dict(eta=2.0)),
    (KelvinVoigt(), dict(eta=2.0, k=3.0)),
    (FractionalMaxwell(), dict(eta=2.0, E=5.0)),
    (FractionalZener(), dict(eta=2.0, E0=1.5, E1=4.0)),
]
IDS = [type(m).__name__ for m, _ in LAWS]


@pytest.mark.parametrize("alpha", [0.1, 0.35, 0.6, 0.85, 0.99])
def test_mittag_leffler_two_parameters_against_the_series_in_high_precision(alpha):
    """E_{α,2}, E_{α,1+α}, E_{α,2+α} to 2e-15 relative over x from 1e-3 to where x^{1/α} =
    100, through all three of the series, the integral and the recurrence."""
    pytest.importorskip("mpmath")
    top = min(100.0**alpha, 1e3)
    for x in np.geomspace(1e-3, top, 10):
        for offset, plus in ((2, False), (1, True), (2, True)):
            beta = offset + (alpha if plus else 0.0)
            got = float(mittag_leffler(alpha, np.array([x]), beta)[0])
            want = mittag_leffler_series(alpha, x, offset, plus)
            assert got == pytest.approx(want, rel=2e-15, abs=0), (x, beta)


@pytest.mark.parametrize("alpha", [0.2, 0.5, 0.7, 0.9, 0.99, 0.999999])
def test_the_ramp_integral_agrees_with_the_asymptotic_series(alpha):
    """E_{α,2}'s integral against its asymptotic series from x = 2,000 (where the steep rise
    of θ lies beyond W_MAX for α near 1: the tail's own panels), and seamless at the switch."""
    x = np.array([2e3, 5e3, 9e3, 9999.0])
    np.testing.assert_allclose(_closed._integral(alpha, x, 2.0), _closed._asymptotic(alpha, x, 2.0),
                               rtol=3e-15, atol=0)
    below, above = mittag_leffler(alpha, np.array([1e4, np.nextafter(1e4, np.inf)]), 2.0)
    assert abs(below - above) < 1e-15 * below


def test_order_one_and_zero_argument():
    """α = 1: E_{1,2}(−x) = (1 − e^{−x})/x; at x = 0 every E_{α,β} is 1/Γ(β)."""
    x = np.linspace(0.01, 50, 500)
    np.testing.assert_allclose(mittag_leffler(1.0, x, 2.0), -np.expm1(-x) / x, rtol=1e-15)
    for beta in (2.0, 1.3, 2.3):
        assert mittag_leffler(0.3, np.zeros(1), beta)[0] == pytest.approx(1 / math.gamma(beta),
                                                                           rel=1e-15)


@pytest.mark.parametrize("law,params", LAWS, ids=IDS)
@pytest.mark.parametrize("q", [0.1, 0.5, 0.9])
def test_a_step_matches_the_closed_forms_at_every_sample(law, params, q):
    """A unit step of stress gives J(t), of strain G(t), at every sample after the first (at
    the first: the instantaneous compliance J(0⁺) = 1/E of a spring in series, else 0; and
    G's jump, inf without one), to 1e-14 relative — no start-up error at the t^q cusp."""
    h, n = 0.01, 400
    t = h * np.arange(n)
    strain = law.strain_response(np.ones(n), h, q=q, **params)
    np.testing.assert_allclose(strain[1:], law.creep_compliance(t[1:], q=q, **params),
                               rtol=1e-14, atol=0)
    stress = law.stress_response(np.ones(n), h, q=q, **params)
    np.testing.assert_allclose(stress[1:], law.relaxation_modulus(t[1:], q=q, **params),
                               rtol=1e-14, atol=0)
    # the springs in series: E of the Maxwell law, E0 + E1 of the Zener (none in the others)
    spring = params.get("E", params.get("E0", 0.0) + params.get("E1", 0.0))
    if spring:
        assert strain[0] == pytest.approx(1 / spring, rel=1e-15)
        assert stress[0] == pytest.approx(spring, rel=1e-15)
    else:
        assert strain[0] == 0.0 and stress[0] == math.inf


def _convolved(closed, rate, t_end, ramp_end):
    """∫_0^{min(t, ramp_end)} closed(t − τ) rate dτ by adaptive quadrature (the response to a
    ramp of `rate` from 0 that holds from `ramp_end`), an independent computation of the
    superposition; the t^{±q} end behaviour is given to `quad` as an algebraic weight."""
    from scipy.integrate import quad

    lo = max(t_end - ramp_end, 0.0)
    value, err = quad(lambda s: float(closed(np.array([s]))[0]) if s > 0 else 0.0, lo, t_end,
                      limit=400, epsabs=0, epsrel=1e-13)
    return rate * value


@pytest.mark.parametrize("law,params", LAWS, ids=IDS)
@pytest.mark.parametrize("q", [0.2, 0.7])
def test_a_ramp_and_hold_matches_the_convolution_of_the_closed_forms(law, params, q):
    """A stress (strain) rising linearly to 1 over 0.5 s, then held: the strain (stress) is
    ∫ J(t − τ) σ'(τ) dτ (with G), computed by `quad` from the closed forms, to 1e-10 relative,
    on a uniform step and on a log-spaced clock."""
    pytest.importorskip("scipy")
    ramp_end = 0.5
    for grid in (np.linspace(0.0, 2.0, 41), np.r_[0.0, np.geomspace(0.01, 2.0, 30)]):
        grid = np.unique(np.r_[grid, ramp_end])
        load = np.minimum(grid / ramp_end, 1.0)
        uniform = np.allclose(np.diff(grid), grid[1] - grid[0], rtol=1e-12)
        clock = dict(dt=grid[1] - grid[0]) if uniform else dict(t=grid)
        for respond, closed in ((law.strain_response, law.creep_compliance),
                                (law.stress_response, law.relaxation_modulus)):
            got = respond(load, **clock, q=q, **params)

            def kernel(s):
                return closed(s, q=q, **params)

            want = [_convolved(kernel, 1.0 / ramp_end, tk, ramp_end) for tk in grid[1:]]
            np.testing.assert_allclose(got[1:], want, rtol=1e-10, atol=0)
            assert got[0] == 0.0


@pytest.mark.parametrize("law,params", LAWS, ids=IDS)
def test_the_two_clocks_agree_and_the_response_is_linear(law, params):
    """The uniform path (a convolution) and the general one (every lag) give the same numbers
    on the same grid; the response of a sum is the sum of the responses."""
    rng = np.random.default_rng(3)
    n, h = 120, 0.05
    a, b = rng.normal(size=n), rng.normal(size=n)
    for respond in (law.strain_response, law.stress_response):
        if respond == law.stress_response and type(law).__name__ in ("Springpot", "KelvinVoigt"):
            a[0] = b[0] = 0.0  # a jump of strain is an infinite stress in these laws
        uniform = respond(a, h, q=0.4, **params)
        general = respond(a, t=h * np.arange(n), q=0.4, **params)
        np.testing.assert_allclose(general, uniform, rtol=1e-12, atol=1e-12 * np.abs(uniform).max())
        both = respond(a + 2.0 * b, h, q=0.4, **params)
        each = uniform + 2.0 * respond(b, h, q=0.4, **params)
        np.testing.assert_allclose(both, each, rtol=0, atol=1e-12 * np.abs(each).max())


def test_bad_input_is_refused_in_one_sentence():
    law, params = KelvinVoigt(), dict(eta=2.0, k=3.0)
    ones = np.ones(5)
    cases = [
        (dict(stress=ones), TypeError, "exactly one of `dt`"),
        (dict(stress=ones, dt=0.1, t=np.arange(5.0)), TypeError, "got both"),
        (dict(stress=ones, dt=-0.1), ValueError, "`dt` must be a positive"),
        (dict(stress=ones, t=np.array([0, 1, 1, 2, 3.0])), ValueError, "strictly increasing"),
        (dict(stress=ones, t=np.arange(4.0)), ValueError, "`t` must have shape"),
        (dict(stress=np.r_[1.0, np.nan, 1, 1, 1], dt=0.1), ValueError, "NaN or inf"),
        (dict(stress=np.ones((5, 2)), dt=0.1), ValueError, "shape (N,)"),
        (dict(stress=np.ones(1), dt=0.1), ValueError, "N ≥ 2"),
        (dict(stress="abc", dt=0.1), TypeError, "must be numbers"),
        (dict(stress=ones, dt=True), TypeError, "`dt` must be a number"),
    ]
    for kwargs, error, words in cases:
        with pytest.raises(error, match=words.replace("(", r"\(").replace(")", r"\)")):
            law.strain_response(**kwargs, q=0.5, **params)
    with pytest.raises(ValueError, match="the strain overflows double precision"):
        Springpot().strain_response(np.full(5, 1e10), 0.1, q=0.5, eta=1e-300)
    with pytest.raises(ValueError, match=r"`q` \(the order\) must lie in"):
        law.strain_response(ones, 0.1, q=1.0, **params)
    with pytest.raises(TypeError, match="takes the parameters eta, k"):
        law.strain_response(ones, 0.1, q=0.5, eta=2.0)
    with pytest.raises(ValueError, match="parameter k must be a number above 0"):
        law.strain_response(ones, 0.1, q=0.5, eta=2.0, k=-1.0)
    with pytest.raises(ValueError, match="beta must be 1, 2"):
        mittag_leffler(0.5, np.ones(2), 1.7)


@pytest.mark.parametrize("q", [0.15, 0.55, 0.95])
def test_a_springpot_response_equals_vojax_integral_kernel(q):
    """With no feedback of the strain, a springpot's exact response is the fractional integral
    of a history linear between samples — which is what `vojax.simulate`'s scan kernel (direct
    product integration, trapezoid rule) computes by other formulas: they agree to 1e-12, on a
    uniform step and on an irregular clock."""
    import jax

    import vojax

    jax.config.update("jax_enable_x64", True)
    rng = np.random.default_rng(7)
    n = 300
    stress = np.cumsum(rng.normal(size=n))
    law = Springpot()
    kernel = np.asarray(vojax.simulate(stress, q, np.array([0.5]), 0.02))
    exact = law.strain_response(stress, 0.02, q=q, eta=2.0)
    np.testing.assert_allclose(exact, kernel, rtol=0, atol=1e-12 * np.abs(kernel).max())
    t = np.cumsum(rng.uniform(0.005, 0.05, n)) - 0.005
    kernel = np.asarray(vojax.simulate(stress, q, np.array([0.5]), t=t))
    exact = law.strain_response(stress, t=t - t[0], q=q, eta=2.0)
    np.testing.assert_allclose(exact, kernel, rtol=0, atol=1e-12 * np.abs(kernel).max())
