"""The Mittag-Leffler table of the laws' responses (`vojax._models._ml_table`) against the
direct quadrature it tabulates, and the responses on clocks that are uniform only from some
sample on (a convolution there) against the direct sum over every lag."""

import math

import numpy as np
import pytest

import vojax
from vojax._models import _ml_table, _respond
from vojax._models._closed import ASYMPTOTIC_LIMIT, SERIES_LIMIT, mittag_leffler_pair

ORDERS = [0.01, 0.05, 0.2, 0.35, 0.5, 0.65, 0.8, 0.9, 0.95, 0.99, 0.999]


@pytest.mark.parametrize("alpha", ORDERS)
@pytest.mark.parametrize("base", [1.0, 2.0])
def test_the_table_equals_the_quadrature_to_rounding(alpha, base):
    """At 600 arguments drawn log-uniformly over 1e-3–1e5 (the table between the series,
    the series outside it) both functions of the pair agree with the direct evaluation to
    5e-14 absolute (measured: at most 1.5e-14, the quadrature's own rounding; with 12 points
    a panel instead of 24 it is 5e-11)."""
    rng = np.random.default_rng(int(alpha * 1000) + int(base))
    x = np.exp(rng.uniform(math.log(1e-3), math.log(1e5), 600))
    x[:2] = SERIES_LIMIT * (1 + 1e-15), ASYMPTOTIC_LIMIT * (1 - 1e-15)  # the table's ends
    assert np.count_nonzero((x > SERIES_LIMIT) & (x < ASYMPTOTIC_LIMIT)) > (
        _ml_table.PANELS * _ml_table.NODES)  # the table is used
    got, want = _ml_table.pair(alpha, x, base), mittag_leffler_pair(alpha, x, base)
    for g, w in zip(got, want):
        np.testing.assert_allclose(g, w, rtol=0, atol=5e-14)


def test_few_arguments_take_the_quadrature_itself():
    """Below the table's own cost the pair is the direct evaluation, bit for bit."""
    x = np.geomspace(0.1, 1e5, _ml_table.PANELS * _ml_table.NODES)
    for g, w in zip(_ml_table.pair(0.4, x, 2.0), mittag_leffler_pair(0.4, x, 2.0)):
        np.testing.assert_array_equal(g, w)


def _direct_sum(law, f, times, q, params, given):
    """The response as the direct sum over every lag, with the quadrature itself (no table,
    no convolution): the definition `_general` must reproduce."""
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(_respond, "pair", mittag_leffler_pair)  # the kernels without the table
        step, ramp = _respond.kernels(law, q, params, given)
        lag = np.maximum(times[:, None] - times[None, :], 0.0)
        values = ramp(lag)
        first = _respond._first_step(f[0], step, times - times[0])
    slopes = np.diff(f) / np.diff(times)
    return (values[:, :-1] - values[:, 1:]) @ slopes + first


LAWS = [(vojax.FractionalZener(), dict(eta=1.0, E0=0.5, E1=2.0)),
        (vojax.KelvinVoigt(), dict(eta=1.0, k=0.8))]


@pytest.mark.parametrize("law,params", LAWS, ids=["zener", "kelvin-voigt"])
@pytest.mark.parametrize("clock", ["block means", "origin", "log then uniform", "log"])
@pytest.mark.parametrize("chunk", [7, _respond.CHUNK])
def test_a_clock_uniform_from_a_sample_on_gives_the_direct_sum(law, params, clock, chunk,
                                                               monkeypatch):
    """Four clocks of 60 samples: uniform after a first sample 0.3 steps early (block
    means), after a start 2 steps before (an origin), after 20 log-spaced samples, and
    log-spaced throughout. The response equals the direct sum over every lag with the
    quadrature itself: to 1e-12 of its scale with the direct part's chunks cut to 7 lags
    (each then below the table's cost: the quadrature), to 5e-12 as shipped (the table:
    2.4e-12 at most measured, the table's 1.5e-14 grown by the differences of nearby ramps)."""
    monkeypatch.setattr(_respond, "CHUNK", chunk)
    h, n = 0.05, 60
    uniform = h * np.arange(n)
    times = {"block means": np.r_[-0.3 * h, uniform[1:]],
             "origin": np.r_[-2 * h, uniform[1:]],
             "log then uniform": np.r_[np.geomspace(1e-3, 0.5, 20), 0.5 + h * np.arange(1, n - 19)],
             "log": np.r_[0.0, np.geomspace(1e-3, 5.0, n - 1)]}[clock]
    head = {"block means": 1, "origin": 1, "log then uniform": 19, "log": n - 1}[clock]
    assert _respond._uniform_from(times) == head
    rng = np.random.default_rng(5)
    f = 1.0 + np.cumsum(rng.normal(size=n)) * 0.1
    for given in (_respond.STRESS, _respond.STRAIN):
        got = _respond._general(law, f, times, 0.6, params, given)
        want = _direct_sum(law, f, times, 0.6, params, given)
        if given == _respond.STRAIN and law.coefficients(**params)[2] == 0.0:
            got, want = got[1:], want[1:]  # a jump of strain: an infinite first stress
        tol = 1e-12 if chunk == 7 else 5e-12
        np.testing.assert_allclose(got, want, rtol=0, atol=tol * np.abs(want).max())


def test_a_clock_off_its_uniform_places_is_summed_directly():
    """A clock whose steps are equal but one sample sits 1e-6 of a step off its place is not
    taken as uniform (only from that sample's successor on); one off by 1e-12 is."""
    t = 0.01 * np.arange(50)
    off = t.copy()
    off[30] += 1e-8  # 1e-6 of the step
    assert _respond._uniform_from(off) == 31
    off[30] = t[30] + 1e-14
    assert _respond._uniform_from(off) == 0
