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
    got = settling_part(u, y, SimpleNamespace(alpha=alpha, p=p), times, "s")
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
