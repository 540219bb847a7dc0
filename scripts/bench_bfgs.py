"""The tracker's refinement of its noise intensities (BFGS on the likelihood of a smoothing
linearised at its mode) with vojax's own BFGS (`vojax._tracker._bfgs`, what the tracker runs)
and with `optimistix.BFGS` (the same algorithm, through optimistix's general machinery): the
time to trace and lower each program, to compile it, and to run it warm, and the largest
difference between their results. Each program is compiled once in this process (no
persistent cache); ratios are vojax ÷ optimistix, measured in the same run.

    python scripts/bench_bfgs.py [--samples 400 1000] [--repeats 5] [--out FILE]
"""

import argparse
import os
import time

import jax
import jax.numpy as jnp
import numpy as np
import optimistix as optx

from _bench import publish

jax.config.update("jax_enable_x64", True)

import vojax  # noqa: E402
from vojax._integral import make_memory  # noqa: E402
from vojax._tracker import Hyper, _track  # noqa: E402
from vojax._tracker._smoother import linearised_log_likelihood  # noqa: E402


def _problem(n):
    """A smoothing of a ramp-and-hold record of `n` samples (1 % noise), as `track` makes it."""
    dt = 0.05
    t = dt * np.arange(n)
    u = (np.minimum(t / (0.2 * t[-1]), 1.0) + 0.05 * np.sin(t))[:, None]
    x = np.asarray(vojax.simulate(u, 0.35 + 0.2 * t / t[-1], np.array([2.0]), dt))
    y = x + 0.01 * np.ptp(x) * np.random.default_rng(0).standard_normal(n)
    bounds = (0.01, 0.99)
    memory = make_memory("exponential", dt, n, order_range=bounds)
    mask, steps, horizon = jnp.ones(n), jnp.full(n, dt), jnp.asarray(dt * (n - 1))
    scales = _track.data_scales(jnp.asarray(u), jnp.asarray(y), mask)
    un = jnp.asarray(u / np.asarray(scales.u_scale))
    yn = jnp.asarray((y - scales.y_ref) / scales.y_scale)
    m0, p0 = _track.prior(1, un.dtype)
    starts = _track.starting_trajectories(memory, un, yn, mask, bounds, 0.5)
    hyper = Hyper(*(jnp.log(jnp.asarray(v)) for v in (0.05, 1e-5, 1e-2)))
    sm = _track.smooth_from(memory, un, yn, mask, steps, horizon, hyper, m0, p0, starts[0],
                            bounds)
    limits = _track.box(1e-4)
    lo = jnp.asarray([v[0] for v in limits.values()])
    hi = jnp.asarray([v[1] for v in limits.values()])
    x0 = jnp.asarray(_track._host_hyper(hyper))
    return (x0, sm.jacobian, sm.pseudo, mask, steps, horizon, m0, p0, lo, hi)


@jax.jit
def _with_optimistix(x0, jac, z, mask, steps, horizon, m0, p0, lo, hi):
    """`_track._refine_compiled`'s problem solved by `optimistix.BFGS`."""
    count = jnp.sum(mask)

    def loss(zeta, _):
        x = lo + (hi - lo) * jax.nn.sigmoid(zeta)
        return -linearised_log_likelihood(Hyper.from_array(x), jac, z, mask, steps, horizon,
                                          m0, p0) / count

    margin = jnp.minimum(1e-3, (hi - lo) / 2)
    x0 = jnp.clip(x0, lo + margin, hi - margin)
    zeta0 = jnp.where(hi > lo, jnp.log((x0 - lo) / jnp.where(hi > lo, hi - x0, 1.0)), 0.0)
    sol = optx.minimise(loss, optx.BFGS(rtol=1e-7, atol=1e-9), zeta0, max_steps=60,
                        throw=False)
    return Hyper.from_array(lo + (hi - lo) * jax.nn.sigmoid(sol.value))


def _vojax(*args):
    return _track._refine_compiled(*args, 60)


def _measure(fn, args, lower, repeats):
    began = time.perf_counter()
    lowered = lower(*args)
    traced = time.perf_counter()
    lowered.compile()
    compiled = time.perf_counter()
    out = jax.block_until_ready(fn(*args))  # the call's own compilation is the one above
    runs = []
    for _ in range(repeats):
        started = time.perf_counter()
        jax.block_until_ready(fn(*args))
        runs.append(time.perf_counter() - started)
    return dict(trace=traced - began, compile=compiled - traced, run=float(np.median(runs)),
                out=np.asarray(jax.tree_util.tree_leaves(out)))


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--samples", type=int, nargs="+", default=[400, 1000])
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--out", default=None)
    args = parser.parse_args(argv)
    lines = [
        f"# bench_bfgs: the tracker's refinement of its three log-intensities (max 60 "
        f"evaluations), {os.cpu_count()} CPUs, JAX {jax.__version__}, optimistix "
        f"{optx.__version__}; trace: tracing and lowering; run: warm, median of "
        f"{args.repeats}",
        "| samples | optimistix trace s | compile s | run ms | vojax trace s | compile s | "
        "run ms | trace ÷ | compile ÷ | run ÷ | max difference |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for n in args.samples:
        problem = _problem(n)
        ref = _measure(_with_optimistix, problem, _with_optimistix.lower, args.repeats)
        own = _measure(_vojax, problem, lambda *a: _track._refine_compiled.lower(*a, 60),
                       args.repeats)
        diff = float(np.max(np.abs(own["out"] - ref["out"])))
        lines.append(
            f"| {n} | {ref['trace']:.2f} | {ref['compile']:.2f} | {1e3 * ref['run']:.1f} | "
            f"{own['trace']:.2f} | {own['compile']:.2f} | {1e3 * own['run']:.1f} | "
            f"{own['trace'] / ref['trace']:.2f} | {own['compile'] / ref['compile']:.2f} | "
            f"{own['run'] / ref['run']:.2f} | {diff:.1e} |")
    publish(lines, args.out)


if __name__ == "__main__":
    main()
