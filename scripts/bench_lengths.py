"""Records of many lengths in one process (a folder of tests, a notebook's loop): the wall
clock of each `vojax.identify` (the tracker, fast loops) on long records fitted as block
means, with the block means padded to a multiple of `POINT_BUCKET` points (the shipped
path) and unpadded (the bucket set to 1). Compiled programs depend on the number of points,
so unpadded every new block count compiles again; padded, the counts of one bucket share
them.

Each setting runs in its own fresh Python process, the records one after the other (the
ramp-and-hold record of `bench_first_call.py` at each length). Times are wall-clock seconds
on this machine; the table gives their ratio, measured in the same run.

    python scripts/bench_lengths.py [--lengths 20000 20015 20100 20400 21000 20000] [--out FILE]
"""

import argparse

from _bench import fresh_process, publish

CHILD = r"""
import json, sys, time
import jax
import numpy as np
jax.config.update("jax_enable_x64", True)
import vojax
from vojax._tracker import _blocks
vojax.use_fast_cpu_loops()
if sys.argv[1] == "unpadded":
    _blocks.POINT_BUCKET = 1
from _bench import ramp_hold_record
rows = []
for n in map(int, sys.argv[2:]):
    u, y, dt = ramp_hold_record(n)
    started = time.perf_counter()
    res = vojax.identify(u, y, dt, warn=False)
    res.alpha.block_until_ready()
    size = res.diagnostics.block
    points = _blocks.block_average(np.zeros(n), size).shape[0]  # the block means
    rows.append(dict(samples=n, block=size, points=points,
                     seconds=time.perf_counter() - started))
print(json.dumps(rows))
"""


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--lengths", type=int, nargs="+",
                        default=[20000, 20015, 20100, 20400, 21000, 20000])
    parser.add_argument("--out")
    args = parser.parse_args(argv)
    from vojax._tracker._blocks import POINT_BUCKET, bucket_points

    runs = {mode: fresh_process(CHILD, mode, *args.lengths) for mode in ("padded", "unpadded")}
    lines = [
        f"# bench_lengths: identify (the tracker, fast loops) on records of {len(args.lengths)} "
        f"lengths one after the other in one fresh process each; padded: the block means "
        f"padded to a multiple of {POINT_BUCKET} points (shipped), unpadded: the bucket set to 1",
        "| call | samples | block | block means | fitted as (padded) | padded s | unpadded s "
        "| unpadded ÷ padded |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for k, (a, b) in enumerate(zip(runs["padded"], runs["unpadded"]), 1):
        lines.append(f"| {k} | {a['samples']:,} | {a['block']} | {a['points']} | "
                     f"{bucket_points(a['points'])} | "
                     f"{a['seconds']:.2f} | {b['seconds']:.2f} | "
                     f"{b['seconds'] / a['seconds']:.2f} |")
    total = [sum(r["seconds"] for r in runs[m]) for m in ("padded", "unpadded")]
    lines.append(f"\nall calls: padded {total[0]:.1f} s, unpadded {total[1]:.1f} s "
                 f"({total[1] / total[0]:.2f}×); the first call compiles in both")
    publish(lines, args.out)


if __name__ == "__main__":
    main()
