"""Long records for the tracker: block means on a coarser clock, and the estimates brought
back to every sample.

The order of a fractional system changes slowly against the sampling of a long record (an
AFM or rheometer test at kHz rates). The tracker fits at most `max_points` points: a longer
record is cut into blocks of ``B`` consecutive samples and each block is replaced by its mean
time, mean input and mean output. The first sample stays a point of its own, so that the
fractional integral still starts at the record's first time. The block means are a record on
a non-uniform clock that the tracker takes as it is; the measurement noise of a block mean is
the samples' noise over ``B``, which the tracker's own noise estimate sees. The model error
of the coarse clock (the input linear between block means, a block's mean output read as
the output at its mean time) is measured on the record at the constant-order fit and reported
against the noise of a block mean (`model_error`).
"""

import dataclasses
import math

import numpy as np

# the memory's run over every sample of a blocked record, at the tracked and the constant
# order, steps this many samples per iteration of its compiled loop where XLA launches its
# kernels per step (`batch_pays`): at 1e6 samples with XLA's default loops 0.70 → 0.38 s warm
# (16: 0.40 s, compiling 0.5 s longer); under `use_fast_cpu_loops` unrolling costs (0.49 →
# 0.53 s), so there the loop steps one sample at a time
SCAN_UNROLL = 8
# the block means are padded to a multiple of this many points by masked points after the
# last, so that records whose block counts differ a little share their compiled programs: a
# new count compiles for about 3 s with fast loops (a 20,000-sample record: 1.6 s warm), and a
# padded point costs about what a fitted one does (at the default `max_points`, 501–1,000
# block means: at most 6 % more points)
POINT_BUCKET = 32


def block_size(num: int, max_points: int) -> int:
    """The samples per block so that ``1 + ceil((num − 1)/B) ≤ max_points``; 1 when the record
    is short enough already."""
    if num <= max_points:
        return 1
    return math.ceil((num - 1) / (max_points - 1))


def block_means(times, u, y, mask, size: int):
    """``(times, u, y, mask)`` of the blocked record: sample 0 alone, then blocks of `size`
    consecutive samples (the last one shorter). A block's time and input are the means over
    all its samples, its output the mean over its fitted samples (``mask > 0``); its mask is 1
    if any of them is fitted. NumPy arrays in, NumPy arrays out."""
    u, y = np.asarray(u), np.asarray(y)
    mask = np.ones(y.shape, u.dtype) if mask is None else np.asarray(mask, u.dtype)
    fitted = block_average(mask, size)  # the fitted fraction of each block
    y_b = block_average(y * mask, size) / np.where(fitted > 0, fitted, 1.0)
    return (
        block_average(np.asarray(times, float), size),
        block_average(u, size).astype(u.dtype),
        y_b.astype(u.dtype),
        (fitted > 0).astype(u.dtype),
    )


def block_average(values, size: int):
    """The block means of per-sample `values` (N, …): sample 0 alone, then blocks of `size`
    consecutive samples (the last one shorter)."""
    values = np.asarray(values)
    starts = np.concatenate([[0], np.arange(1, values.shape[0], size)])
    counts = np.diff(np.concatenate([starts, [values.shape[0]]]))
    shape = (-1,) + (1,) * (values.ndim - 1)
    return np.add.reduceat(values, starts, axis=0) / counts.reshape(shape)


def bucket_points(points: int) -> int:
    """The number of points `points` block means are fitted as: the next multiple of
    `POINT_BUCKET`."""
    return POINT_BUCKET * math.ceil(points / POINT_BUCKET)


def pad_points(times, u, y, mask, count: int):
    """The block means ``(times, u, y, mask)`` (NumPy) padded to `count` points: each added
    point a median step after the one before, with the last block's input and output, and
    masked out (not fitted). Masked points after the last fitted one change no estimate
    before them (the filter's predictions there see no data), to the smoother's tolerance."""
    extra = count - times.shape[0]
    if extra <= 0:
        return times, u, y, mask
    step = float(np.median(np.diff(times))) if times.shape[0] > 1 else 1.0
    return (
        np.concatenate([times, times[-1] + step * np.arange(1, extra + 1)]),
        np.concatenate([u, np.repeat(u[-1:], extra, axis=0)]),
        np.concatenate([y, np.repeat(y[-1:], extra)]),
        np.concatenate([mask, np.zeros(extra, mask.dtype)]),
    )


def to_samples(t_blocks, values, times):
    """Per-block `values` (M,) or (M, n) at every sample time: linear between block times
    (held beyond the last)."""
    values = np.asarray(values)
    if values.ndim == 1:
        return np.interp(times, t_blocks, values)
    return np.stack([np.interp(times, t_blocks, v) for v in values.T], axis=1)


def fit_blocks(tracker, u2, y, dt, t, mask, size, span, time_scale=1.0, times=None,
               weigh=True, refine=False):
    """The `tracker` on the means of blocks of `size` samples of the record's first `span`
    samples (padding after them is not the record's), its estimates brought back to every
    sample: the order, its band and the parameters linear between block times, the output
    ``y_hat`` from one memory run over the whole record at that order. Returns
    ``(TrackResult, fit)``, `fit` what the tracker fitted, for the diagnostics, with the
    coarse clock's model error (`block_error`). `dt`, `t` are on the tracker's clock (the
    user's time over `time_scale`); `times` the sample times on that clock (from `dt` when
    None). ``weigh=False`` (the second clock's quick look, which only its order and band
    serve): the order, its band and the parameters at every sample, no ``y_hat`` (None), and
    a `fit` of the fitted points' order and band only (no `block_error`), so no memory run
    over every sample. The block means are fitted padded to a multiple of `POINT_BUCKET`
    points (`pad_points`), and the estimates cut back to them. `refine`: None where the
    tuned smoothing's prediction errors correlate (the reason `correlated`; the caller fits
    again on shorter blocks), before the band's passes and the memory runs over every
    sample."""
    from .._integral import make_memory, scan_memory, scan_memory_orders
    from .._stats import errors_correlate, noise_variance
    from .._xla import cut_padding, to_device
    from ._fit import fit_points
    from ._smoother import batch_pays
    from ._start import least_squares

    s, bounds, x0, noise = tracker.settings, tracker.alpha_bounds, tracker.x0, tracker.noise
    num = u2.shape[0]
    dtype = np.dtype(u2.dtype)
    if times is None:
        times = np.asarray(t, float) if t is not None else float(dt) * np.arange(num)
    u_np, y_np = np.asarray(u2), np.asarray(y)
    mask_np = None if mask is None else np.asarray(mask)[:span]
    t_b, u_b, y_b, mask_b = block_means(times[:span], u_np[:span], y_np[:span], mask_np, size)
    if noise is not None:  # the noise of a block mean
        noise = dict(noise, noise_std=float(noise["noise_std"]) / np.sqrt(size))
    points = t_b.shape[0]
    t_p, u_p, y_p, mask_p = pad_points(t_b, u_b, y_b, mask_b, bucket_points(points))
    mem_b = make_memory(tracker.memory, None, t_p.shape[0], rule=tracker.rule, tol=tracker.tol,
                        order_range=bounds, times=t_p)
    res = fit_points(
        mem_b, to_device(u_p), to_device(y_p), None, bounds, s, smooth=tracker.smooth,
        noise=noise, mask=to_device(mask_p), times=t_p, parameters=tracker.parameters, x0=x0,
        batched=size >= s.batched_block, time_scale=time_scale, weigh=weigh,
        give_up=(lambda y_pred: errors_correlate(y_b, y_pred[:points], mask_b > 0))
        if refine else None,
    )
    if res is None:
        return None
    res = cut_padding(res, points, t_p.shape[0], device=True)
    # everything at every sample: linear between block times; the output from the reported
    # parameters brought to the tracker's clock (× time_scale^α at each sample's order)
    at_samples = lambda v: to_samples(t_b, np.asarray(v), times)  # noqa: E731
    alpha = at_samples(res.alpha)
    p_user = at_samples(res.p)
    if not weigh:
        return _at_samples(res, at_samples, alpha, p_user, None), dict(
            alpha=res.alpha, lower=res.alpha_lower, upper=res.alpha_upper,
            span=t_b.shape[0], mask=None if mask is None else mask_b)
    mem = make_memory(tracker.memory, dt, num, rule=tracker.rule, tol=tracker.tol,
                      order_range=bounds, times=t)
    p = p_user * time_scale ** alpha[:, None]
    # the two runs over every sample, at the constant-order fit and at the tracked order, as
    # one batched scan
    constant = np.full((num,), res.constant_order, dtype)
    phi_c, phi = np.asarray(scan_memory_orders(mem, u2, to_device(
        np.stack([constant, alpha.astype(dtype)])), SCAN_UNROLL if batch_pays() else 1))
    # the coarse clock's model error at the constant-order fit, against a block mean's noise
    # (from the samples' own second differences: on the coarse clock those see more of the
    # signal)
    phi_b = np.asarray(scan_memory(mem_b, to_device(u_p), to_device(
        np.full((t_p.shape[0],), res.constant_order, dtype)), False))[:points]
    coef = least_squares(phi_b, y_b - (x0 or 0.0), mask_b, offset=x0 is None)[1]
    error = (block_average(phi_c[:span], size) - phi_b) @ coef[:-1]
    fitted = np.ones(span, bool) if mask_np is None else mask_np > 0
    block_noise = max(noise_variance(y_np[:span][fitted]) / size, 1e-300)
    block_error = float(np.sqrt(np.mean(error[mask_b > 0][1:] ** 2) / block_noise))
    full = _at_samples(res, at_samples, alpha, p_user,
                       to_device(float(np.asarray(res.x0)) + np.sum(p * phi, axis=1)))
    fit = dict(alpha=res.alpha, lower=res.alpha_lower, upper=res.alpha_upper,
               held=res.alpha_held, y=y_b, y_pred=res.y_pred, span=t_b.shape[0],
               mask=None if mask is None else mask_b, block_error=block_error,
               conditional=res.conditional)
    return full, fit


def _at_samples(res, at_samples, alpha, p_user, y_hat):
    """The blocks' result `res` at every sample (`at_samples`: linear between block times),
    with the order `alpha` and the parameters `p_user` already there, and the output
    `y_hat`."""
    from .._xla import to_device

    return dataclasses.replace(
        res,
        alpha=to_device(alpha),
        alpha_std=to_device(at_samples(res.alpha_std)),
        alpha_lower=to_device(at_samples(res.alpha_lower)),
        alpha_upper=to_device(at_samples(res.alpha_upper)),
        p=to_device(p_user),
        p_std=to_device(at_samples(res.p_std)),
        y_hat=y_hat,
        y_pred=to_device(at_samples(res.y_pred)),
        alpha_held=None if res.alpha_held is None else to_device(at_samples(res.alpha_held)),
        conditional=None if res.conditional is None else tuple(
            to_device(at_samples(a)) for a in res.conditional),
    )
