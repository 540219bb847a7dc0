"""Statistics from the data alone (`vojax._stats`), shared by the law's bands and the
tracker: the noise variance from second differences, the lag-1 autocorrelation."""

import numpy as np
import pytest


def test_noise_variance_estimate():
    """White noise of variance 0.09 on a slow sine (4,000 samples): the median of the
    second differences gives it within 8 %."""
    from vojax._stats import noise_variance

    t = np.linspace(0, 10, 4000)
    y = np.sin(t) + 0.3 * np.random.default_rng(0).standard_normal(t.size)
    assert noise_variance(y) == pytest.approx(0.09, rel=0.08)


def test_noise_variance_of_an_output_flat_over_most_of_the_record():
    """An output exactly zero over 70 % of the record (a contact strain before the contact),
    white noise of variance 0.04 on the rest: the noise is that of the samples that move
    (within 8 %; the median of every second difference would be 0). With 30 % flat, the
    median of all is used, unchanged; a constant output has no noise."""
    import math

    from vojax._stats import noise_variance

    rng = np.random.default_rng(1)
    moving = 0.2 * rng.standard_normal(3000)
    y = np.concatenate([np.zeros(7000), moving])
    assert noise_variance(y) == pytest.approx(0.04, rel=0.08)
    few = np.concatenate([np.zeros(3000), 0.2 * rng.standard_normal(7000)])
    d2 = np.abs(np.diff(few, 2))
    assert noise_variance(few) == (1.4826 * np.median(d2)) ** 2 / math.comb(4, 2)
    assert noise_variance(np.full(50, 2.5)) == 0.0


def test_lag1_correlation_is_of_the_sequence_about_its_mean():
    """``c + (−1)^k`` over n samples: about its mean (c, n even) the lag-1 autocorrelation is
    −(n−1)/n exactly, whatever the offset c; a constant sequence has none (NaN)."""
    from vojax._stats import lag1_correlation

    n = 40
    alternating = (-1.0) ** np.arange(n)
    for c in (0.0, 5.0, -1e3):
        assert lag1_correlation(c + alternating) == pytest.approx(-(n - 1) / n, rel=1e-12)
    assert np.isnan(lag1_correlation(np.full(n, 3.0)))
