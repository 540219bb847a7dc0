"""The Mittag-Leffler function E_α(−x) and the closed forms G(t), J(t), G*(ω) of the
constant-order laws: against closed forms (α = 1: e^{−x}; α = 1/2: e^{x²} erfc x), against
each other where two of the three methods are accurate, against the defining Laplace
transform, and the laws' three functions against one another through theirs."""

import math

import numpy as np
import pytest

from vojax import FractionalMaxwell, FractionalZener, KelvinVoigt, Springpot
from vojax._models import _closed
from vojax._models._closed import mittag_leffler

from .helpers import mittag_leffler_series


def test_order_one_is_the_exponential_and_one_half_is_erfcx():
    x = np.linspace(0, 700, 7001)
    np.testing.assert_allclose(mittag_leffler(1.0, x), np.exp(-x), rtol=2e-16, atol=0)
    x = np.r_[np.linspace(0, 2, 201), np.linspace(2, 26, 241)]
    want = np.array([math.exp(v * v) * math.erfc(v) for v in x])
    # the reference's own error: e^{x²} carries x²'s rounding, about x² ulps
    assert np.all(np.abs(mittag_leffler(0.5, x) - want) <= (2e-15 + 2.3e-16 * x**2) * want)


@pytest.mark.parametrize("alpha", [0.15, 0.35, 0.6, 0.85, 0.97])
def test_against_the_series_in_high_precision(alpha):
    """mpmath's sum of the power series at enough digits to absorb its cancellation (the
    largest term is about e^{x^{1/α}}; α·k is formed in mpmath, since a double's rounding
    of it, amplified by the cancellation, would cost the reference 1e-9): E_α(−x) to 1e-15
    relative over x from 1e-3 to where x^{1/α} = 100."""
    pytest.importorskip("mpmath")
    top = min(100.0**alpha, 1e3)
    for x in np.geomspace(1e-3, top, 12):
        want = mittag_leffler_series(alpha, x)
        got = float(mittag_leffler(alpha, np.array([x]))[0])
        assert got == pytest.approx(want, rel=1e-15, abs=0), x


@pytest.mark.parametrize("alpha", [0.2, 0.5, 0.7, 0.9, 0.99, 0.999999])
def test_the_integral_agrees_with_both_series_where_they_hold(alpha):
    """The integral (used for 0.5 < x < 1e4) against the power series where its sum of
    moduli E_α(x) stays below 4 (so that it is accurate to about 1e-15), and against the
    asymptotic series from x = 2,000 (its terms fall by about k/x each)."""
    x = np.linspace(0.3, 3.0, 28)
    mod = _closed._series(alpha, -x)  # Σ x^k/Γ(αk+1) = E_α(x)
    x = x[mod < 4]
    assert x.size >= 3
    np.testing.assert_allclose(_closed._integral(alpha, x), _closed._series(alpha, x),
                               rtol=1e-14, atol=0)
    x = np.array([2e3, 5e3, 9e3, 9999.0])
    np.testing.assert_allclose(_closed._integral(alpha, x), _closed._asymptotic(alpha, x),
                               rtol=3e-15, atol=0)
    # the switches between the methods are seamless
    for edge in (_closed.SERIES_LIMIT, _closed.ASYMPTOTIC_LIMIT):
        below, above = mittag_leffler(alpha, np.array([edge, np.nextafter(edge, np.inf)]))
        assert abs(below - above) < 1e-15 * below


def _laplace(f, s, lo=-60.0, hi=12.0, step=0.01):
    """∫_0^∞ e^{−st} f(t) dt by the trapezoid rule in y = ln t (spectrally accurate for the
    smooth, exponentially decaying integrands here)."""
    y = np.arange(lo, hi + step, step)
    t = np.exp(y)
    return step * np.sum(np.exp(-s * t) * f(t) * t)


@pytest.mark.parametrize("alpha", [0.3, 0.7, 0.95])
def test_the_laplace_transform_of_e_alpha(alpha):
    """The definition: ∫_0^∞ e^{−st} E_α(−t^α) dt = s^{α−1}/(s^α + 1)."""
    for s in (0.1, 1.0, 10.0):
        got = _laplace(lambda t: mittag_leffler(alpha, t**alpha), s)
        assert got == pytest.approx(s ** (alpha - 1) / (s**alpha + 1), rel=1e-10)


LAWS = [
    (Springpot(), dict(eta=2.0)),
    (KelvinVoigt(), dict(eta=2.0, k=3.0)),
    (FractionalMaxwell(), dict(eta=2.0, E=5.0)),
    (FractionalZener(), dict(eta=2.0, E0=1.5, E1=4.0)),
]


def _modulus(name, p, sq):
    """Each law's modulus as a function of ``sq`` = s^q (Laplace) or (iω)^q (frequency),
    written out here from the laws' equations."""
    if name == "Springpot":
        return p["eta"] * sq
    if name == "KelvinVoigt":
        return p["k"] + p["eta"] * sq
    if name == "FractionalMaxwell":
        return 1 / (1 / p["E"] + 1 / (p["eta"] * sq))
    return (p["E0"] * p["E1"] + p["eta"] * (p["E0"] + p["E1"]) * sq) / (p["E1"] + p["eta"] * sq)


@pytest.mark.parametrize("law, params", LAWS, ids=[type(m).__name__ for m, _ in LAWS])
@pytest.mark.parametrize("q", [0.25, 0.6, 0.9])
def test_relaxation_and_creep_are_the_modulus_through_laplace(law, params, q):
    """For each law, with Ĝ(s) its modulus in the Laplace domain: ∫ e^{−st} G(t) dt =
    Ĝ(s)/s and ∫ e^{−st} J(t) dt = 1/(s Ĝ(s)) (G and J derived separately)."""
    for s in (0.3, 3.0):
        g_of_s = _modulus(type(law).__name__, params, s**q)
        # G(t) ~ t^{−q} near 0: the integrand t·G falls as e^{(1−q)y}, slowly for q near 1
        got = _laplace(lambda t: law.relaxation_modulus(t, q=q, **params), s,
                       lo=min(-60.0, -40.0 / (1 - q)))
        assert got == pytest.approx(g_of_s / s, rel=1e-9)
        got = _laplace(lambda t: law.creep_compliance(t, q=q, **params), s)
        assert got == pytest.approx(1 / (s * g_of_s), rel=1e-9)


@pytest.mark.parametrize("law, params", LAWS, ids=[type(m).__name__ for m, _ in LAWS])
def test_the_complex_modulus_is_the_laws_equation_at_i_omega(law, params):
    """G*(ω) against each law's modulus at s = iω, and the limits a rheologist checks: a
    springpot's phase angle qπ/2 at every ω, Maxwell's G* → E and Zener's → E0 + E1 at high
    ω, Zener's → E0 at low ω."""
    q, p, name = 0.4, params, type(law).__name__
    omega = np.logspace(-6, 6, 25)
    got = law.complex_modulus(omega, q=q, **params)
    np.testing.assert_allclose(got, _modulus(name, p, (1j * omega) ** q), rtol=1e-14)
    if name == "Springpot":
        np.testing.assert_allclose(np.angle(got), q * np.pi / 2, rtol=1e-14)
    if name == "FractionalMaxwell":
        assert abs(got[-1] - p["E"]) < 0.01 * p["E"]
    if name == "FractionalZener":
        assert abs(got[-1] - (p["E0"] + p["E1"])) < 0.01 * p["E1"]
        assert abs(got[0] - p["E0"]) < 0.01 * p["E0"]


def test_limits_of_relaxation_and_creep():
    """Zener: G(0⁺) = E0 + E1 and G(∞) = E0, J(0⁺) = 1/(E0 + E1) and J(∞) = 1/E0; Maxwell:
    G(0⁺) = E, J = 1/E + t^q/(η Γ(1+q)); Kelvin–Voigt: J(∞) = 1/k; and G·J ≤ 1 for a solid
    whose G decreases (∫G dJ = t)."""
    z = FractionalZener()
    t = np.array([1e-14, 1e14])
    g = z.relaxation_modulus(t, q=0.5, eta=2.0, E0=1.5, E1=4.0)
    j = z.creep_compliance(t, q=0.5, eta=2.0, E0=1.5, E1=4.0)
    assert g[0] == pytest.approx(5.5, rel=1e-6) and g[1] == pytest.approx(1.5, rel=1e-6)
    assert j[0] == pytest.approx(1 / 5.5, rel=1e-6) and j[1] == pytest.approx(1 / 1.5, rel=1e-6)
    m = FractionalMaxwell()
    assert m.relaxation_modulus(np.array([1e-14]), q=0.5, eta=2.0, E=5.0)[0] == pytest.approx(
        5.0, rel=1e-5)
    tt = np.array([0.5, 2.0])
    np.testing.assert_allclose(m.creep_compliance(tt, q=0.3, eta=2.0, E=5.0),
                               0.2 + tt**0.3 / (2.0 * math.gamma(1.3)), rtol=1e-15)
    kv = KelvinVoigt()
    assert kv.creep_compliance(np.array([1e14]), q=0.5, eta=2.0, k=3.0)[0] == pytest.approx(
        1 / 3.0, rel=1e-5)


def test_bad_arguments_are_refused_in_one_line():
    m = FractionalMaxwell()
    with pytest.raises(ValueError, match=r"the order\) must lie in \(0, 1\), got 1.0"):
        m.relaxation_modulus([1.0], q=1.0, eta=1.0, E=1.0)
    with pytest.raises(TypeError, match="FractionalMaxwell takes the parameters E, eta"):
        m.relaxation_modulus([1.0], q=0.5, eta=1.0)
    with pytest.raises(ValueError, match="the parameter E must be a number above 0"):
        m.creep_compliance([1.0], q=0.5, eta=1.0, E=-1.0)
    with pytest.raises(ValueError, match="`t` must hold finite numbers above 0"):
        m.creep_compliance([0.0, 1.0], q=0.5, eta=1.0, E=1.0)
    with pytest.raises(ValueError, match="`omega` must hold finite numbers above 0"):
        m.complex_modulus([np.nan], q=0.5, eta=1.0, E=1.0)
    with pytest.raises(ValueError, match="must be finite and at least 0"):
        mittag_leffler(0.5, [-1.0])
    with pytest.raises(ValueError, match=r"the order\) must lie in \(0, 1\], got 0.0"):
        mittag_leffler(0.0, [1.0])
    with pytest.raises(TypeError, match=r"the order\) must be a number"):
        mittag_leffler(True, [1.0])
