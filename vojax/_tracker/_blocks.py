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

import math

import numpy as np

# block means of at least this many samples are this many times less noisy than the samples:
# the smoothings' posterior is sharper, they take about 3× the iterations of a record of as
# many samples, and the first pass's runs go to their cap together; there the tracker batches
# each pass's runs (`track(batched=True)`): warm 1.6 → 0.95 s at 1e4 samples, 2.3 → 1.7 s at
# 1e5 and 4.7 → 3.2 s at 1e6 with XLA's default loops, one more program compiled on a first
# call (+0.8 s). On a record of 1,000 samples the runs converge at their own pace and the
# batch saves 0.1 s of 0.8 s for +1.5 s on a first call, so shorter blocks run one by one
BATCHED_BLOCK = 10
# the memory's run over every sample of a blocked record, at the tracked and the constant
# order, steps this many samples per iteration of its compiled loop where XLA launches its
# kernels per step (`batch_pays`): at 1e6 samples with XLA's default loops 0.70 → 0.38 s warm
# (16: 0.40 s, compiling 0.5 s longer); under `use_fast_cpu_loops` unrolling costs (0.49 →
# 0.53 s), so there the loop steps one sample at a time
SCAN_UNROLL = 8


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


def to_samples(t_blocks, values, times):
    """Per-block `values` (M,) or (M, n) at every sample time: linear between block times
    (held beyond the last)."""
    values = np.asarray(values)
    if values.ndim == 1:
        return np.interp(times, t_blocks, values)
    return np.stack([np.interp(times, t_blocks, v) for v in values.T], axis=1)
