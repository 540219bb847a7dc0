"""Would the batch gain from vmapping the tracker and the refit over a bucket's records, as it
does the paper's law? The beef indentation records of ../shared/data padded to 256 samples:
the tracker's first pass (`smoother_batch` at the constant fit's misfit, 18 runs of at most
60 iterations) and the refit's compiled Levenberg–Marquardt fit (`_fit`), each run one record
at a time and vmapped over B records, warm, in the same process.

    python scripts/bench_vmap.py [--records 16 64] [--data DIR]

Prints per-record times, their ratio, and the vmapped program's first call (compilation).
"""

import argparse
import sys
import time
import warnings
from pathlib import Path

import numpy as np

DATA = Path(__file__).resolve().parents[2] / "shared" / "data"
PAD, DT, BOUNDS = 256, 0.1, (0.01, 0.99)


def tracker_args(records, memory):
    import jax.numpy as jnp

    from vojax import TrackerSettings
    from vojax._tracker._problem import Problem, data_scales, prior
    from vojax._tracker._start import constant_fit, starting_trajectories
    from vojax._tracker._threads import stack_hypers

    s = TrackerSettings()
    m0, p0 = prior(1, jnp.float64, s)
    out = []
    for r in records:
        n = r.time.size
        u, y, mask = np.zeros((PAD, 1)), np.full(PAD, r.output[-1]), np.zeros(PAD)
        u[:n], y[:n], mask[:n] = r.inputs, r.output, 1.0
        u, y, mask = jnp.asarray(u), jnp.asarray(y), jnp.asarray(mask)
        sc = data_scales(u, y, mask)
        un, yn = u / jnp.asarray(sc.u_scale), (y - sc.y_ref) / sc.y_scale
        alpha_c, _, rss, rms_phi = constant_fit(memory, un, yn, mask, BOUNDS, s)
        un = un / jnp.asarray(rms_phi)
        steps, horizon = jnp.full((PAD,), DT), jnp.asarray(DT * (n - 1))
        problem = Problem(memory, un, yn, mask, steps, horizon, m0, p0, BOUNDS,
                          DT * np.arange(PAD), n - 1, s)
        starts = starting_trajectories(problem, alpha_c)
        misfit = max(rss / (n - 3), s.noise_min)
        rows = [(qo, s.constant_drift, misfit) for _ in starts for qo in s.grid_order]
        first = jnp.asarray(np.repeat(starts, len(s.grid_order), axis=0))
        out.append((un, yn, mask, steps, horizon, stack_hypers(rows), first))
    return out


def compare(name, one, batched, args):
    import jax

    jax.block_until_ready(one(args[0]))
    started = time.perf_counter()
    for a in args:
        jax.block_until_ready(one(a))
    alone = (time.perf_counter() - started) / len(args)
    stacked = jax.tree_util.tree_map(lambda *x: jax.numpy.stack(x), *args)
    started = time.perf_counter()
    jax.block_until_ready(batched(stacked))
    first = time.perf_counter() - started
    started = time.perf_counter()
    jax.block_until_ready(batched(stacked))
    vmapped = (time.perf_counter() - started) / len(args)
    print(f"| {name} | {len(args)} | {alone * 1e3:.1f} | {vmapped * 1e3:.1f} | "
          f"{vmapped / alone:.2f} | {first:.1f} |", flush=True)


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--records", type=int, nargs="+", default=[16, 64])
    parser.add_argument("--data", default=str(DATA))
    args = parser.parse_args()
    path = Path(args.data) / "beef-indentation-relaxation" / "beef_indentation_relaxation.csv"
    if not path.is_file():
        sys.exit(f"needs {path}")
    import jax

    jax.config.update("jax_enable_x64", True)
    import vojax

    vojax.use_fast_cpu_loops()
    from vojax import TrackerSettings, _refit_active
    from vojax._data import load_records
    from vojax._data._pipeline import identify_record
    from vojax._integral import make_memory
    from vojax._tracker._problem import prior
    from vojax._tracker._smoother import smoother_batch

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        records = load_records(path, time="time_s", inputs=["force_N"], output="displacement_mm",
                               group_by="specimen", trim_column="force_N", trim_below=0.02)
    memory = make_memory("exponential", DT, PAD, order_range=BOUNDS)
    settings = TrackerSettings()
    m0, p0 = prior(1, jax.numpy.float64, settings)
    print("| program | records | one at a time (ms a record) | vmapped (ms a record) | "
          "vmapped / one | vmapped first call (s) |")
    print("|---|---|---|---|---|---|")
    for count in args.records:
        def first_pass(a):
            return smoother_batch(memory, *a[:5], a[5], m0, p0, a[6], BOUNDS,
                                  settings.grid_max_iter)

        compare("tracker's first pass", first_pass, jax.jit(jax.vmap(first_pass)),
                tracker_args(records[:count], memory))
        # the refit's arguments, captured from `identify_record` as the batch calls it
        calls, fit = [], _refit_active._fit
        _refit_active._fit = lambda *a: calls.append(a) or fit(*a)
        try:
            for r in records[:count]:
                identify_record(r, model="springpot", method="refit", pad_to=PAD)
        finally:
            _refit_active._fit = fit
        c0 = calls[0]
        dynamic = (1, 2, 3, 4, 5, 6, 10, 11)  # the arrays; the rest is static and shared

        def refit_one(a):
            full = list(c0)
            for i, x in zip(dynamic, a):
                full[i] = x
            return fit(*full)

        compare("refit's fit", refit_one, jax.jit(jax.vmap(refit_one)),
                [tuple(c[i] for i in dynamic) for c in calls])


if __name__ == "__main__":
    main()
