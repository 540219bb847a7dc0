"""The batch's settling test of a record (`settling_part`): the record averaged to at most
1,000 points and padded to one of a few lengths, so a batch compiles its design a few times
instead of once a record length. Its answer is `vojax.settling_test`'s on the averaged record
without padding, computed here."""

from types import SimpleNamespace

import numpy as np
import pytest

import vojax
from vojax._data._parts import SETTLING_LENGTHS, settling_part
from vojax._stats import noise_variance
from vojax._tracker._blocks import block_average


@pytest.mark.parametrize("num, size", [(150, 1), (2500, 3)])
def test_the_batch_settling_test_is_the_unpadded_one(num, size):
    dt = 0.1
    times = 5.0 + dt * np.arange(num)
    u = np.minimum((times - 5.0) / 4.0, 1.0)[:, None]
    rng = np.random.default_rng(num)
    y = 0.3 * u[:, 0] + 0.002 * rng.standard_normal(num)
    alpha = np.linspace(0.3, 0.4, num)
    p = np.column_stack([np.linspace(1.8, 2.0, num)])
    band_now = 0.21  # the tracker's band on the record as it is
    res = SimpleNamespace(alpha=alpha, p=p, diagnostics=SimpleNamespace(band_halfwidth=band_now))
    got = settling_part(u, y, res, times, "s")
    # by hand: the blocks, the median order and parameters over the second half, the noise
    t_b = block_average(times, size)
    assert t_b.size <= 1000 and t_b.size not in SETTLING_LENGTHS  # really padded
    u_b = block_average(u, size)
    noise = float(np.sqrt(noise_variance(y) / size))
    want = vojax.settling_test(u_b, float(np.median(alpha[num // 2:])),
                               [float(np.median(p[num // 2:]))], t=t_b - t_b[0], noise_std=noise)
    assert got["band"] == pytest.approx(want.band, rel=1e-9)
    assert got["band_without"] == pytest.approx(want.band_without, rel=1e-9)
    assert got["cycles"] == want.cycles and got["frequency"] == pytest.approx(want.frequency)
    assert got["start"] == pytest.approx(want.start + times[0])
    # the band the tracker is expected to give: its band now × the bound's narrowing^¼
    expected = band_now * (want.band / want.band_without) ** 0.25
    assert want.band < want.band_without and got["band_now"] == band_now
    assert got["expected"] == pytest.approx(expected, rel=1e-9)
    assert expected < band_now
    assert got["sentence"].endswith(f"the tracker, whose band also covers faster drift, "
                                    f"about ±{expected:.2g}")


@pytest.mark.parametrize("band_now", [np.inf, np.nan, 0.0])
def test_without_a_band_now_the_batch_settling_test_expects_nothing(band_now):
    """A tracker band that is not a positive finite number (a refusal with no band) scales
    to no expectation: `expected` is None and the sentence cautions instead."""
    dt, num = 0.1, 150
    times = dt * np.arange(num)
    u = np.minimum(times / 4.0, 1.0)[:, None]
    y = 0.3 * u[:, 0] + 0.002 * np.random.default_rng(0).standard_normal(num)
    res = SimpleNamespace(alpha=np.full(num, 0.35), p=np.full((num, 1), 1.9),
                          diagnostics=SimpleNamespace(band_halfwidth=band_now))
    got = settling_part(u, y, res, times, "s")
    assert got["expected"] is None and got["band"] < got["band_without"]
    assert got["sentence"].endswith("can be several times wider)")



@pytest.mark.parametrize("expected, words", [
    (None, "the test that would settle the order: "),
    (0.06, "the test that would settle the order: "),
    (0.1, "the test that would settle the order: "),
    (0.25, "the test that would narrow the order most: "),
])
def test_the_command_says_settle_only_where_the_tracker_is_expected_to_identify(expected, words):
    """The command's line: "settle" where the tracker's expected band with the oscillation is
    within ±0.1 (or unknown), else "narrow most", with why it would not settle it alone."""
    from vojax._cli._commands import settling_line

    line = settling_line("rec", {"expected": expected, "sentence": "an oscillation …"})
    assert line.startswith(f"vojax: rec: {words}an oscillation … (vojax.settling_test)")
    alone = "wider than ±0.1, it would not settle the order alone with the parameters free."
    assert line.endswith(alone) == (expected is not None and expected > 0.1)
