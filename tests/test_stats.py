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


def test_lag1_correlation_is_of_the_sequence_about_its_mean():
    """``c + (−1)^k`` over n samples: about its mean (c, n even) the lag-1 autocorrelation is
    −(n−1)/n exactly, whatever the offset c; a constant sequence has none (NaN)."""
    from vojax._stats import lag1_correlation

    n = 40
    alternating = (-1.0) ** np.arange(n)
    for c in (0.0, 5.0, -1e3):
        assert lag1_correlation(c + alternating) == pytest.approx(-(n - 1) / n, rel=1e-12)
    assert np.isnan(lag1_correlation(np.full(n, 3.0)))
