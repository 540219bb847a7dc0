"""Long records for the tracker: block means by hand, the estimates back at every sample, the
blocked fit against the fit of every sample, and the coarse clock's model error."""

import dataclasses

import numpy as np
import pytest

import vojax
from vojax import reference
from vojax._tracker._blocks import block_average, block_means, block_size, to_samples


def test_block_means_by_hand():
    """Sample 0 alone, then blocks of 3 (the last one shorter); the output's mean over the
    fitted samples only, a block with none of them masked out."""
    times = np.arange(9.0) ** 2
    u = np.stack([np.arange(9.0), -np.arange(9.0)], axis=1)
    y = 10.0 + np.arange(9.0)
    mask = np.array([1, 1, 0, 1, 0, 0, 0, 1, 1], float)
    t_b, u_b, y_b, m_b = block_means(times, u, y, mask, 3)
    # blocks: [0], [1, 2, 3], [4, 5, 6], [7, 8]
    np.testing.assert_allclose(t_b, [0.0, (1 + 4 + 9) / 3, (16 + 25 + 36) / 3, (49 + 64) / 2])
    np.testing.assert_allclose(u_b[:, 0], [0.0, 2.0, 5.0, 7.5])
    np.testing.assert_allclose(u_b[:, 1], -u_b[:, 0])
    np.testing.assert_allclose(y_b[[0, 1, 3]], [10.0, (11 + 13) / 2, (17 + 18) / 2])
    np.testing.assert_array_equal(m_b, [1, 1, 0, 1])
    np.testing.assert_allclose(block_average(y, 3), [10.0, 12.0, 15.0, 17.5])


@pytest.mark.parametrize("max_points", [100, 101, 5000])
def test_block_size_is_the_smallest_that_fits(max_points):
    for num in (2, 99, 100, 101, 4999, 5000, 5001, 12_345, 10**6):
        size = block_size(num, max_points)
        points = lambda b: 1 + -(-(num - 1) // b)  # noqa: E731
        assert points(size) <= max(max_points, num if size == 1 else 0)
        if num <= max_points:
            assert size == 1
        else:
            assert points(size - 1) > max_points


def test_to_samples_is_linear_between_block_times_and_held_after():
    t_b = np.array([0.0, 1.0, 3.0])
    v = np.array([[0.0, 1.0], [2.0, 1.0], [6.0, 0.0]])
    out = to_samples(t_b, v, np.array([0.5, 2.0, 4.0]))
    np.testing.assert_allclose(out, [[1.0, 1.0], [4.0, 0.5], [6.0, 0.0]])


def _record(num, dt, level, seed=0, alpha=None):
    """A variable-order record computed by direct sums (`vojax.reference`), white noise at
    `level` of the output's range."""
    t = dt * np.arange(num)
    u = 1.0 + 0.5 * np.sin(2 * np.pi * t / (0.7 * t[-1])) + (t > 0.3 * t[-1])
    if alpha is None:
        alpha = 0.45 + 0.15 * np.tanh((t - 0.5 * t[-1]) / (0.15 * t[-1]))
    x = np.asarray(reference.fractional_integral(u, alpha, dt))
    rng = np.random.default_rng(seed)
    return t, u, x + level * np.ptp(x) * rng.standard_normal(num), alpha, x


@pytest.fixture(scope="module")
def long_record():
    t, u, y, alpha, x = _record(3000, 0.01, 0.01)
    # p is constant in seconds (the record's clock), so the statement is made in seconds
    # (the default unit, the span of 30 s, would make it drift as 30^(-α(t)))
    kw = dict(parameters="constant", time_scale=1.0, warn=False)
    blocked = vojax.identify(u, y, 0.01, max_points=500, **kw)
    full = vojax.identify(u, y, 0.01, max_points=5000, **kw)
    return t, u, y, alpha, x, blocked, full


def test_a_blocked_fit_gives_every_sample_and_its_output_by_direct_sums(long_record):
    """Everything has the record's length; ``y_hat`` is x0 + pᵀφ(α̂) of the whole record,
    here recomputed by the direct sums of `vojax.reference` at the reported order."""
    t, u, y, alpha, x, res, _ = long_record
    num = y.shape[0]
    assert res.diagnostics.block == 7  # blocks of 6 would make 501 points
    for name in ("alpha", "alpha_std", "alpha_lower", "alpha_upper", "y_hat", "y_pred"):
        assert np.asarray(getattr(res, name)).shape == (num,), name
    assert np.asarray(res.p).shape == (num, 1)
    phi = np.asarray(reference.fractional_integral(u, np.asarray(res.alpha), 0.01))
    expected = float(res.x0) + np.asarray(res.p)[:, 0] * phi
    np.testing.assert_allclose(np.asarray(res.y_hat), expected, rtol=0, atol=1e-8 * np.ptp(y))


def test_the_blocked_order_agrees_with_the_fit_of_every_sample(long_record):
    """Over the second half the blocked tracker's order stays inside the band of the tracker
    run on every sample, and both hold the true order (a shifted block clock, a block mean
    read at the wrong time or a misplaced first sample move the order out of these)."""
    t, u, y, alpha, x, blocked, full = long_record
    half = t > t[-1] / 2
    a_b = np.asarray(blocked.alpha)[half]
    lo, hi = np.asarray(full.alpha_lower)[half], np.asarray(full.alpha_upper)[half]
    assert np.all((a_b >= lo) & (a_b <= hi))
    for res in (blocked, full):
        inside = (alpha >= np.asarray(res.alpha_lower)) & (alpha <= np.asarray(res.alpha_upper))
        assert np.mean(inside[half]) >= 0.95
        assert np.sqrt(np.mean((np.asarray(res.alpha) - alpha)[half] ** 2)) < 0.02
    # the blocks add no refusal of their own: the verdict is the every-sample fit's (here
    # both refused: with the parameters constant, p held at 0.71 × its value fits too), and
    # the block means represent the record
    assert blocked.diagnostics.identified == full.diagnostics.identified
    assert blocked.diagnostics.block_error < 0.1
    assert "blocks" not in blocked.diagnostics.message
    assert full.diagnostics.block == 1 and np.isnan(full.diagnostics.block_error)


def test_blocks_that_misrepresent_the_record_are_reported():
    """A staircase that steps inside blocks of 11 samples at a noise of 0.1 %: the block means
    blur the steps by more than the noise of a block mean, and the order is not reported
    identified, the message naming the blocks; finer blocks of 3 samples at 1 % noise pass."""
    num, dt = 2000, 0.01
    t = dt * np.arange(num)
    u = 1.0 + np.floor(t / 0.37) % 2
    x = np.asarray(reference.fractional_integral(u, np.full(num, 0.5), dt))
    rng = np.random.default_rng(3)
    coarse = vojax.identify(
        u, x + 1e-3 * np.ptp(x) * rng.standard_normal(num), dt, max_points=200,
        parameters="constant", warn=False,
    )
    d = coarse.diagnostics
    assert d.block == 11 and d.block_error > 2.0 and not d.identified
    assert "averaged in blocks of 11 samples" in d.message
    fine = vojax.identify(
        u, x + 1e-2 * np.ptp(x) * rng.standard_normal(num), dt, max_points=1000,
        parameters="constant", warn=False,
    )
    assert fine.diagnostics.block == 3 and fine.diagnostics.block_error < 0.5


def test_the_block_error_of_an_output_flat_over_most_of_the_record():
    """An output exactly zero over the first two thirds of the record (an AFM contact strain
    before the contact), a springpot's creep at 1 % noise after it, fitted in blocks:
    the block error is measured against the noise of the samples that move, and the smooth
    creep's blocks represent it (the noise of all the second differences, most of them
    exactly zero, was 0, and the error over 1e100 times it)."""
    num, dt, rest = 3000, 0.01, 2000
    u = np.where(np.arange(num) >= rest, 1.0, 0.0)
    x = np.asarray(reference.fractional_integral(u, np.full(num, 0.4), dt))
    rng = np.random.default_rng(5)
    y = np.where(np.arange(num) >= rest, x + 1e-2 * np.ptp(x) * rng.standard_normal(num), 0.0)
    d = vojax.identify(u, y, dt, max_points=500, parameters="constant", warn=False).diagnostics
    assert d.block > 1 and 0 < d.block_error < 0.5
    assert "blocks" not in d.message


def test_blocks_on_a_non_uniform_clock_and_with_padding():
    """On sample times (`t=`) the blocks take the mean times; padding after the last fitted
    sample (the batch's buckets) changes nothing within the solvers' tolerances."""
    t, u, y, alpha, x = _record(1500, 0.01, 0.01, seed=1)
    ref = vojax.identify(u, y, 0.01, max_points=300, parameters="constant", warn=False)
    on_times = vojax.identify(u, y, t=t, max_points=300, parameters="constant", warn=False)
    np.testing.assert_allclose(np.asarray(on_times.alpha), np.asarray(ref.alpha), atol=1e-6)
    extra = 300
    up = np.concatenate([u, np.zeros(extra)])
    yp = np.concatenate([y, np.full(extra, y[-1])])
    mask = np.r_[np.ones(1500), np.zeros(extra)]
    padded = vojax.identify(up, yp, 0.01, max_points=300, mask=mask, parameters="constant",
                            warn=False)
    assert padded.diagnostics.block == ref.diagnostics.block
    np.testing.assert_allclose(np.asarray(padded.alpha)[:1500], np.asarray(ref.alpha), atol=1e-6)


def test_block_means_padded_to_a_bucket_by_hand():
    """`pad_points`: points added a median step apart after the last, with its input and
    output, masked out; a count no larger than the points' leaves them as they are."""
    from vojax._tracker._blocks import pad_points

    times = np.array([0.0, 1.0, 3.0, 5.0, 6.0])  # steps 1, 2, 2, 1: the median 1.5
    u = np.arange(10.0).reshape(5, 2)
    y = np.array([1.0, 2.0, 3.0, 4.0, 5.0])
    mask = np.array([1.0, 1.0, 0.0, 1.0, 1.0])
    t_p, u_p, y_p, m_p = pad_points(times, u, y, mask, 8)
    np.testing.assert_array_equal(t_p, [0.0, 1.0, 3.0, 5.0, 6.0, 7.5, 9.0, 10.5])
    np.testing.assert_array_equal(u_p[5:], [[8.0, 9.0]] * 3)
    np.testing.assert_array_equal(u_p[:5], u)
    np.testing.assert_array_equal(y_p, [1.0, 2.0, 3.0, 4.0, 5.0, 5.0, 5.0, 5.0])
    np.testing.assert_array_equal(m_p, [1, 1, 0, 1, 1, 0, 0, 0])
    assert all(a is b for a, b in zip(pad_points(times, u, y, mask, 5), (times, u, y, mask)))


def test_block_counts_in_one_bucket_share_the_program_and_the_padding_changes_nothing(
        monkeypatch):
    """Records of 2,000 and 2,050 samples at `max_points` 100 are fitted as 97 and 99 block
    means, both padded to 128 points (`POINT_BUCKET` 32): the second traces no smoother of
    its own. Padded, the first gives the answer of its 97 points fitted alone (the bucket
    set to 1) to the smoother's tolerance, its band to the tolerance of the band's flat
    directions (as for a record padded by the user, `tests/test_tracker.py`)."""
    from vojax._tracker import _blocks
    from vojax._tracker._smoother import TRACES

    kw = dict(max_points=100, parameters="constant", time_scale=1.0, warn=False)
    t, u, y, alpha, x = _record(2000, 0.01, 0.01)
    padded = vojax.identify(u, y, 0.01, **kw)
    assert padded.diagnostics.block == 21
    before = TRACES["smoother"]
    t2, u2, y2, *_ = _record(2050, 0.01, 0.01, seed=2)
    other = vojax.identify(u2, y2, 0.01, **kw)
    assert other.diagnostics.block == 21  # 1 + ⌈2049/21⌉ = 99 points
    assert TRACES["smoother"] == before
    monkeypatch.setattr(_blocks, "POINT_BUCKET", 1)
    alone = vojax.identify(u, y, 0.01, **kw)
    assert TRACES["smoother"] > before  # 97 points: programs of their own
    for name in ("alpha", "p", "y_hat", "y_pred"):
        np.testing.assert_allclose(np.asarray(getattr(padded, name)),
                                   np.asarray(getattr(alone, name)), rtol=1e-7, atol=1e-8)
    np.testing.assert_allclose(np.asarray(padded.alpha_std), np.asarray(alone.alpha_std),
                               rtol=3e-3)
    assert padded.diagnostics.verdict == alone.diagnostics.verdict
    assert padded.diagnostics.block_error == pytest.approx(alone.diagnostics.block_error,
                                                           rel=1e-9)


@pytest.mark.parametrize(
    "value, error, match",
    [
        (99, ValueError, "`max_points` must be from 100 to 50,000, got 99"),
        (50_001, ValueError, "`max_points` must be from 100 to 50,000, got 50,001"),
        (1000.0, TypeError, "`max_points` must be a whole number"),
        (True, TypeError, "`max_points` must be a whole number"),
    ],
)
def test_max_points_is_checked(value, error, match):
    t, u, y, alpha, x = _record(200, 0.01, 0.01)
    with pytest.raises(error, match=match):
        vojax.identify(u, y, 0.01, max_points=value)


def test_max_points_with_the_law_is_an_error_not_ignored():
    t, u, y, alpha, x = _record(200, 0.01, 0.01)
    with pytest.raises(ValueError, match="`max_points` sets the tracker"):
        vojax.identify(u, y, 0.01, method="gradient", max_points=1000)


@pytest.mark.slow
@pytest.mark.parametrize("parameters", ["drifting", "constant"])
def test_a_long_record_on_the_level_ridge_is_not_confidently_wrong(parameters):
    """1e5 samples (1,000 block means of 101) of a ramp-and-hold with a rising order and a
    constant parameter, 1 % white noise: a higher order with a parameter 2.4× smaller and an
    offset fits as well as the truth (residuals at the noise level). The band must cover the
    truth over the second half, or the order must not be reported identified. With the level
    profile stopping at 2× (and run only with the parameters stated constant) both settings
    reported an order 0.11 off with the truth outside a ±0.09 band."""
    n, dt = 100_000, 0.05
    t = dt * np.arange(n)
    u = np.minimum(t / (0.2 * t[-1]), 1.0) + 0.05 * np.sin(t)
    alpha = 0.35 + 0.2 * t / t[-1]
    x = np.asarray(vojax.simulate(u, alpha, np.array([2.0]), dt, memory="exponential"))
    y = x + 0.01 * np.ptp(x) * np.random.default_rng(0).standard_normal(n)
    # p constant in seconds: the statement made in seconds
    res = vojax.identify(u, y, dt, parameters=parameters, time_scale=1.0, warn=False)
    half = slice(n // 2, None)
    inside = (alpha[half] >= np.asarray(res.alpha_lower)[half]) & (
        alpha[half] <= np.asarray(res.alpha_upper)[half])
    assert res.diagnostics.block == 101
    assert not res.diagnostics.identified or np.mean(inside) > 0.5
    assert np.mean(inside) > 0.95  # and here the band covers it


def test_the_second_clocks_quick_look_runs_no_memory_over_every_sample(monkeypatch):
    """The default fits a blocked record on the span's clock and on the data's unit of time;
    only the span's answer is reported at every sample, so the whole record's memory runs
    (the output and the coarse clock's model error) belong to it alone: one run of the two
    orders over every sample and one block run, not two of each. The output is still the
    reported order's, by direct sums."""
    import vojax._integral as integral

    calls = {"orders": 0, "blocks": 0}

    def counted(key, run):
        def wrapped(*args, **kwargs):
            calls[key] += 1
            return run(*args, **kwargs)
        return wrapped

    monkeypatch.setattr(integral, "scan_memory_orders",
                        counted("orders", integral.scan_memory_orders))
    monkeypatch.setattr(integral, "scan_memory", counted("blocks", integral.scan_memory))
    t, u, y, alpha, x = _record(1200, 0.01, 0.01)
    res = vojax.identify(u, y, 0.01, max_points=300, warn=False)  # span 12 s: two clocks
    assert res.diagnostics.block == 5  # blocks of 4 would make 301 points
    assert calls == {"orders": 1, "blocks": 1}
    phi = np.asarray(reference.fractional_integral(u, np.asarray(res.alpha), 0.01))
    expected = float(res.x0) + np.asarray(res.p)[:, 0] * phi
    np.testing.assert_allclose(np.asarray(res.y_hat), expected, rtol=0, atol=1e-8 * np.ptp(y))


@pytest.mark.parametrize("reasons, settings, sizes", [
    (("correlated",), {}, [21, 7]),  # refitted on up to 3 × 100 points: blocks of 7
    (("correlated", "wide_band"), {"block_refine": 2}, [21, 11]),
    (("wide_band",), {}, [21]),  # refused for another reason: not refitted
    (("correlated",), {"block_refine": 1}, [21]),
    (("correlated",), {"block_refine_from": 22}, [21]),  # blocks too short to refit
])
def test_long_blocks_whose_prediction_errors_correlate_are_fitted_again_on_shorter_ones(
        monkeypatch, reasons, settings, sizes):
    """A record of 2,000 samples at `max_points` 100 is fitted in blocks of 21. Where the
    fit's reasons hold correlated prediction errors and its blocks hold at least
    `block_refine_from` samples, the record is fitted once more on up to `block_refine` ×
    `max_points` points, and that fit is the answer (its block size, its order); else the
    first fit is. The reasons of the first fit are set here (the fit itself is real, run to
    its end: the early stop on correlated errors, tested below, is turned off)."""
    import vojax._stats

    monkeypatch.setattr(vojax._stats, "errors_correlate", lambda *args: False)
    seen = _fits_seen(monkeypatch, first_reasons=reasons)
    t, u, y, alpha, x = _record(2000, 0.01, 0.01)
    s = vojax.TrackerSettings(**settings)
    res = vojax.identify(u, y, 0.01, max_points=100, parameters="constant", settings=s,
                         warn=False)
    assert [size for size, _ in seen] == sizes
    assert res.diagnostics.block == sizes[-1]
    # the answer is that of a fit on those blocks alone (never refitted)
    points = {21: 100, 11: 200, 7: 300}[sizes[-1]]
    alone = vojax.identify(u, y, 0.01, max_points=points, parameters="constant", warn=False,
                           settings=vojax.TrackerSettings(block_refine=1))
    assert alone.diagnostics.block == sizes[-1]
    np.testing.assert_array_equal(np.asarray(res.alpha), np.asarray(alone.alpha))


def _fits_seen(monkeypatch, first_reasons=None):
    """Spies on the tracker's fits of one block size: ``(size, reasons)`` per fit, reasons
    None where the fit stopped early; `first_reasons` (a tuple) replaces the first fit's."""
    from vojax._tracker._estimator import Tracker

    seen, real = [], Tracker._fit_sized

    def spied(self, *args):
        out = real(self, *args)
        if out is not None and first_reasons is not None and not seen:
            out = (*out[:2], dataclasses.replace(out[2], reasons=first_reasons))
        seen.append((args[6], None if out is None else set(map(str, out[2].reasons))))
        return out

    monkeypatch.setattr(Tracker, "_fit_sized", spied)
    return seen


@pytest.mark.parametrize("ar, refitted", [(0.0, True), (0.9, False)])
def test_the_first_fit_stops_once_its_prediction_errors_correlate_and_the_answer_is_the_same(
        monkeypatch, ar, refitted):
    """Blocks of 21 (2,000 samples at `max_points` 100, the parameters stated constant):
    with white noise (`ar` 0) the first fit's prediction errors correlate, and it stops after
    its tuning (None) before the record is fitted again on blocks of 7; with this AR(1)
    noise they do not, and it is the answer. Run to its end (the early stop turned off), the
    first fit's diagnostics name `correlated` exactly where it stopped early, and the
    answer is the same to the last bit."""
    import vojax._stats

    t, u, y, alpha, x = _record(2000, 0.01, 0.01)
    if ar:
        e = np.random.default_rng(0).standard_normal(2000)
        for k in range(1, 2000):
            e[k] += ar * e[k - 1]
        y = x + 0.01 * np.ptp(x) * e
    seen = _fits_seen(monkeypatch)
    kw = dict(max_points=100, parameters="constant", warn=False)
    early = vojax.identify(u, y, 0.01, **kw)
    assert [size for size, _ in seen] == ([21, 7] if refitted else [21])
    assert (seen[0][1] is None) == refitted
    seen.clear()
    monkeypatch.setattr(vojax._stats, "errors_correlate", lambda *args: False)
    whole = vojax.identify(u, y, 0.01, **kw)
    assert [size for size, _ in seen] == ([21, 7] if refitted else [21])
    assert ("correlated" in seen[0][1]) == refitted
    for field in ("alpha", "alpha_lower", "alpha_upper", "p", "y_hat"):
        np.testing.assert_array_equal(np.asarray(getattr(early, field)),
                                      np.asarray(getattr(whole, field)))
    assert early.diagnostics.verdict == whole.diagnostics.verdict
