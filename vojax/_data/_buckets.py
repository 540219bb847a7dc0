"""The batch's buckets: records padded to a few common lengths, so that a few programs
are compiled."""


import numpy as np


def bucket_length(num: int) -> int:
    """The padded length of a record of `num` samples: the smallest ``m·2^k ≥ num`` with
    m ∈ {4, 6}. At most 50 % padding, and two lengths per octave, so that a batch compiles a
    few programs (each costs seconds; a padded sample costs a microsecond)."""
    k = 0
    while 6 * 2**k < num:
        k += 1
    return min(m * 2**k for m in (4, 6) if m * 2**k >= num)

# One more compiled length costs about as much wall time as this many padded samples: on the
# 2-core CPU a bucket compiles in ~7 s (the tuner, the law, the refit), and a padded sample
# costs ~5e-5 s of tuning and refitting per record (scripts/bench_batch.py, docs/benchmarks.md).
COMPILE_COST_SAMPLES = 100_000


def plan_buckets(lengths, compile_cost: float = COMPILE_COST_SAMPLES) -> dict:
    """``{length: padded length}`` for the records of one batch: the padded lengths are
    `bucket_length`'s (``m·2^k``), and neighbouring ones are merged (the shorter records padded
    to the longer length) where that saves more compilation than the padding costs, counting
    one compiled length as `compile_cost` samples. Dynamic programming over the sorted lengths
    gives the least total ``compile_cost · buckets + Σ padded samples``."""
    lengths = [int(n) for n in lengths]
    if compile_cost < 0 or not np.isfinite(compile_cost):
        raise ValueError(f"`compile_cost` must be a finite number ≥ 0, got {compile_cost}.")
    if any(n < 1 for n in lengths):
        raise ValueError(f"record lengths must be ≥ 1, got {min(lengths)}.")
    sizes = sorted({bucket_length(n) for n in lengths})
    counts = [sum(bucket_length(n) == s for n in lengths) for s in sizes]
    # best[j]: the least cost of the first j sizes; the last bucket of that plan is sizes[j-1]
    best, cut = [0.0], [0]
    for j in range(1, len(sizes) + 1):
        options = [
            (best[i] + compile_cost + sizes[j - 1] * sum(counts[i:j]), i) for i in range(j)
        ]
        cost, i = min(options)
        best.append(cost)
        cut.append(i)
    padded, j = {}, len(sizes)
    while j > 0:
        i = cut[j]
        for s in sizes[i:j]:
            padded[s] = sizes[j - 1]
        j = i
    return {n: padded[bucket_length(n)] for n in lengths}
