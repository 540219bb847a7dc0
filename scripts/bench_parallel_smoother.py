"""The tracker's Kalman filter and RTS smoother by schedule: the sequential scans (the CPU's
default) against the parallel-in-time prefix sums of `vojax._tracker._parallel` (a GPU's
default: `associative`; and `chunked`): alone (N = 1,000 samples, 3 states) and inside the
tracker (`vojax.identify` on 400 and 1,000 samples, every filter and smoother of its smoothings
and of its likelihood's gradient on that schedule), under XLA's default loops and, on a CPU,
with `vojax.use_fast_cpu_loops()`.

`associative` is `lax.associative_scan` (about 2·log₂N vectorised sweeps, no loop); `chunked`
runs two loops of about √N steps over all chunks at once, then one vectorised step. The
script checks that both equal the sequential scans to rounding, then times each case in a
fresh process.

    python scripts/bench_parallel_smoother.py [--cases alone 400 1000] [--loops default fast]
        [--out FILE]
"""

import argparse
import functools
import json
import os
import subprocess
import sys
import time

import jax
import jax.numpy as jnp
from _bench import publish, ramp_hold_record


def child(case, schedule, loops):
    """One measurement in this (fresh) process; prints one JSON line."""
    import numpy as np

    jax.config.update("jax_enable_x64", True)
    import vojax
    from vojax._tracker._kalman import kalman_filter, rts_smoother
    from vojax._tracker._parallel import parallel_filter, parallel_smoother

    if loops == "fast":
        vojax.use_fast_cpu_loops()
    filt, smooth = (kalman_filter, rts_smoother) if schedule == "sequential" else (
        functools.partial(parallel_filter, schedule=schedule),
        functools.partial(parallel_smoother, schedule=schedule))
    if case == "alone":
        rng = np.random.default_rng(1)
        num, d = 1000, 3
        h, z = rng.standard_normal((num, d)), rng.standard_normal(num)
        q = np.abs(rng.standard_normal((num, d))) * 1e-3
        q[:, -1] = 0.0  # the offset's
        mask = (rng.random(num) > 0.1).astype(float)
        anchor = rng.standard_normal((num, d))
        f = np.where(np.arange(d) == 0, 0.9, 1.0) * np.ones((num, d))
        m0, p0 = np.zeros(d), 2.0 * np.eye(d)

        @jax.jit
        def run(z):
            fl = filt(h, z, 0.1, q, m0, p0, mask, anchor, 0.5, f)
            return fl, smooth(fl, q, f)

        begun = time.perf_counter()
        out = jax.block_until_ready(run(z))
        first = time.perf_counter() - begun
        begun = time.perf_counter()
        for k in range(20):
            jax.block_until_ready(run(z * (1.0 + 1e-3 * k)))
        warm = (time.perf_counter() - begun) / 20
        ref = jax.jit(lambda z: (lambda fl: (fl, rts_smoother(fl, q, f)))(
            kalman_filter(h, z, 0.1, q, m0, p0, mask, anchor, 0.5, f)))(z)
        err = max(float(jnp.max(jnp.abs(a - b)) / jnp.max(jnp.abs(a))) for a, b in
                  zip(jax.tree_util.tree_leaves(ref), jax.tree_util.tree_leaves(out)))
        print(json.dumps(dict(first=first, warm=warm, err=err)))
        return
    # bench_first_call's record: a ramp and hold, a slowly moving order, 1 % white noise
    u, y, dt = ramp_hold_record(int(case))
    # every filter and smoother of the tracker's smoothings and of its likelihood's gradient
    settings = vojax.TrackerSettings(schedule=schedule)
    begun = time.perf_counter()
    res = vojax.identify(u, y, dt, warn=False, settings=settings)
    res.alpha.block_until_ready()
    first = time.perf_counter() - begun
    begun = time.perf_counter()
    res = vojax.identify(u, 1.001 * y, dt, warn=False, settings=settings)
    res.alpha.block_until_ready()
    second = time.perf_counter() - begun
    print(json.dumps(dict(first=first, warm=second, alpha=np.asarray(res.alpha).tolist())))


def measure(case, schedule, loops):
    env = {k: v for k, v in os.environ.items() if k != "XLA_FLAGS"}
    out = subprocess.run([sys.executable, __file__, "--child", case, schedule, loops],
                         capture_output=True, text=True, env=env, check=True)
    result = json.loads(out.stdout.strip().splitlines()[-1])
    print(f"{case}, {schedule}, {loops} loops: first {result['first']:.2f} s, warm "
          f"{result['warm']:.4f} s", file=sys.stderr, flush=True)  # progress
    return result


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--child", nargs=3, help=argparse.SUPPRESS)
    parser.add_argument("--cases", nargs="+", default=["alone", "400", "1000"],
                        help="'alone' (the filter and smoother on 1,000 samples) and record "
                        "lengths for identify")
    parser.add_argument("--loops", nargs="+", choices=("default", "fast"), default=["default", "fast"],
                        help="XLA's default loops, vojax.use_fast_cpu_loops() (a CPU setting: a "
                        "GPU ignores it, so there run `--loops default`)")
    parser.add_argument("--out", default=None)
    args = parser.parse_args(argv)
    if args.child:
        return child(*args.child)
    schedules = ("sequential", "associative", "chunked")
    device = f"{jax.default_backend()} ({jax.devices()[0].device_kind})"
    lines = [f"# bench_parallel_smoother: {device}, {os.cpu_count()} CPUs, JAX {jax.__version__}; "
             "every case in a fresh process; first: compile and run; warm: one more run",
             "| case | loops | schedule | first s | warm ms | warm ÷ sequential | "
             "first − sequential s | max difference |", "|---|---|---|---|---|---|---|---|"]
    for case in args.cases:
        for loops in args.loops:
            rows = {s: measure(case, s, loops) for s in schedules}
            base = rows["sequential"]
            for s, r in rows.items():
                if case == "alone":
                    diff = f"{r['err']:.1e} (relative)"
                else:
                    diff = f"{max(abs(a - b) for a, b in zip(r['alpha'], base['alpha'])):.1e} (order)"
                lines.append(
                    f"| {'filter + smoother alone, 1000 × 3' if case == 'alone' else 'identify, ' + case + ' samples'} "
                    f"| {loops} | {s} | {r['first']:.2f} | {1e3 * r['warm']:.2f} | "
                    f"{r['warm'] / base['warm']:.2f} | {r['first'] - base['first']:+.2f} | {diff} |")
    publish(lines, args.out)


if __name__ == "__main__":
    main()
