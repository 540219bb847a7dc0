"""vojax's Mittag-Leffler functions against `pymittagleffler` (Garrappa's algorithm, MIT;
the reference the field uses, an independent computation) over the orders and arguments of
the laws' closed forms: E_{α,β}(−x) for α from 0.05 to 0.99 and x from 1e-6 to 1e6, the
argument (t/τ)^α of a law over twelve decades of t/τ. Within 1e-10 relative everywhere
(`scripts/check_mittag_leffler.py` measures at most 7.6e-13, and at the largest
differences mpmath's series sides with vojax)."""

import numpy as np
import pytest

import vojax

pml = pytest.importorskip("pymittagleffler")

ALPHAS = (0.05, 0.1, 0.2, 0.3, 0.5, 0.7, 0.9, 0.99)
X = np.geomspace(1e-6, 1e6, 121)


def reference(alpha, x, beta):
    return np.real(np.asarray(pml.mittag_leffler(-np.asarray(x) + 0j, alpha, beta)))


@pytest.mark.parametrize("alpha", ALPHAS)
@pytest.mark.parametrize("offset, plus_alpha", [(1, False), (2, False), (1, True), (2, True)])
def test_the_numpy_function_equals_the_reference(alpha, offset, plus_alpha):
    beta = offset + (alpha if plus_alpha else 0.0)
    np.testing.assert_allclose(vojax.mittag_leffler(alpha, X, beta), reference(alpha, X, beta),
                               rtol=1e-10, atol=0)


@pytest.mark.parametrize("alpha", ALPHAS)
@pytest.mark.parametrize("beta", [1, 2])
def test_the_jax_function_equals_the_reference(alpha, beta):
    np.testing.assert_allclose(np.asarray(vojax.mittag_leffler_jax(alpha, X, beta)),
                               reference(alpha, X, beta), rtol=1e-10, atol=0)


@pytest.mark.parametrize("q", [0.1, 0.5, 0.9])
def test_a_laws_creep_and_relaxation_equal_the_reference(q):
    """Through the closed forms: the fractional Zener's relaxation modulus and the
    Kelvin–Voigt creep compliance, written out with the reference's E_q."""
    t = np.geomspace(1e-4, 1e4, 81)
    e0, e1, eta, k = 2.0, 3.0, 1.5, 4.0
    zener = vojax.FractionalZener().relaxation_modulus(t, q=q, E0=e0, E1=e1, eta=eta)
    np.testing.assert_allclose(zener, e0 + e1 * reference(q, e1 / eta * t**q, 1.0),
                               rtol=1e-10, atol=0)
    kv = vojax.KelvinVoigt().creep_compliance(t, q=q, eta=eta, k=k)
    np.testing.assert_allclose(kv, (1 - reference(q, k / eta * t**q, 1.0)) / k,
                               rtol=1e-10, atol=1e-300)
