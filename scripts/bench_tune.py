"""Time and peak memory of the gain tuning against one identification with fixed gains.

    python scripts/bench_tune.py [--sizes 1e4 1e5 1e6] [--code DIR]

Each case runs in a fresh process (its peak resident memory is its own), on a record of the
paper's two inputs with a slowly varying order and 1 % noise, dt = 0.01, with
`vojax.use_fast_cpu_loops()`. Cases:

- `identify`: `vojax.identify(u, y, dt, gamma=0.5, method="gradient")` (fixed gains: the law and its band);
- `tune_gains`: `vojax.tune_gains(u, y, dt)` (the 11 × 8 grid and the BFGS refinement);
- `tracker`: `vojax.identify(..., method="kalman")`, a smoother over the whole record
  iterated to convergence, whose noise intensities are tuned by likelihood (18 smoothings
  from 6 starting orders × 3 order drifts, then a BFGS refinement).

Times include compilation (one call per process: what a user's script pays). `--code DIR`
imports vojax from another checkout (a `git worktree` of an earlier commit) for before/after
tables measured in the same session. Prints one JSON line per case, then a table with the
ratio of each case's peak memory to `identify`'s at the same size.
"""

import argparse
import json
import subprocess
import sys
from pathlib import Path

CHILD = r"""
import json, resource, sys, time
import numpy as np
import vojax
vojax.use_fast_cpu_loops()
import jax
jax.config.update("jax_enable_x64", True)
case, n = sys.argv[1], int(float(sys.argv[2]))
dt = 0.01
t = np.arange(n) * dt
u = np.stack([np.sin(0.5 * t), np.cos(0.2 * t)], axis=1)
alpha = 0.4 + 0.1 * np.sin(2 * np.pi * t / t[-1])
x = np.asarray(vojax.simulate(u, alpha, np.array([1.0, -0.5]), dt, memory="exponential"))
y = x + 0.01 * np.std(x) * np.random.default_rng(0).standard_normal(n)
base = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
start = time.perf_counter()
if case == "identify":
    out = vojax.identify(u, y, dt, gamma=0.5, warn=False, method="gradient").alpha.block_until_ready()
elif case == "tune_gains":
    g = vojax.tune_gains(u, y, dt)
else:
    out = vojax.identify(u, y, dt, method="kalman", warn=False).alpha.block_until_ready()
seconds = time.perf_counter() - start
print(json.dumps(dict(case=case, samples=n, seconds=seconds, code=vojax.__file__,
                      peak_rss_mb=resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
                      before_mb=base)))
"""


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--sizes", nargs="+", type=float, default=[1e4, 1e5, 1e6])
    parser.add_argument("--code", help="a checkout whose vojax the children import")
    parser.add_argument("--cases", nargs="+", default=["identify", "tune_gains", "tracker"])
    args = parser.parse_args()
    cwd = Path(args.code).resolve() if args.code else None
    rows = []
    for n in (int(s) for s in args.sizes):
        for case in args.cases:
            proc = subprocess.run([sys.executable, "-c", CHILD, case, str(n)], cwd=cwd,
                                  capture_output=True, text=True)
            if proc.returncode != 0:
                print(case, n, "failed:", proc.stderr[-1500:], flush=True)
                continue
            rows.append(json.loads(proc.stdout.strip().splitlines()[-1]))
            print(json.dumps(rows[-1]), flush=True)
    print("\n| samples | case | time (s) | peak RSS (MB) | peak / identify's |")
    print("|---|---|---|---|---|")
    base = {r["samples"]: r["peak_rss_mb"] for r in rows if r["case"] == "identify"}
    for r in rows:
        ratio = r["peak_rss_mb"] / base[r["samples"]] if r["samples"] in base else float("nan")
        print(f"| {r['samples']:.0e} | {r['case']} | {r['seconds']:.2f} | "
              f"{r['peak_rss_mb']:.0f} | {ratio:.2f} |")


if __name__ == "__main__":
    main()
