"""Benchmark of the paper's law's recursion (`run_law`, what `identify(method="gradient")` runs
before it computes the law's band): time per sample, direct vs exponential memory (n = 2
inputs).

Each (N, memory) runs in its own process so that its peak resident memory is its own; the
scan is compiled ahead of time, so the times exclude compilation.

    python scripts/bench_identify.py [--sizes 1e3 1e4 1e5] [--exp-sizes 1e6] [--repeat 3]
        [--modes default fast]
"""

import sys
import time

from _bench import cases, dispatch, peak_rss_mb, print_header


def one(n: int, memory: str, repeat: int) -> dict:
    import jax

    jax.config.update("jax_enable_x64", True)
    import jax.numpy as jnp
    import numpy as np

    import vojax
    from vojax._adaptive._build import build_law, run_law

    dt = 300.0 / n
    t, u, alpha, p = vojax.study_signals(dt)
    u, alpha, p = u[:n], alpha[:n], p[:n]
    y = jnp.asarray(np.sum(u * p, axis=1))  # any output will do for timing
    law = build_law(
        dt,
        n,
        lam=0.9,
        gamma=0.01,
        alpha0=0.5,
        alpha_bounds=(0.05, 0.95),
        memory=memory,
        rule="trapezoid",
    )
    u = jnp.asarray(u)
    compiled = jax.jit(lambda u, y: run_law(law, u, y)).lower(u, y).compile()
    repeat = 1 if memory == "direct" and n >= 100_000 else repeat
    best = float("inf")
    for _ in range(repeat):
        start = time.perf_counter()
        jax.block_until_ready(compiled(u, y))
        best = min(best, time.perf_counter() - start)
    temp = compiled.memory_analysis().temp_size_in_bytes  # XLA's buffers beyond inputs/outputs
    return {"time": best, "peak_rss_mb": peak_rss_mb(), "temp_kb": temp / 1024}


def main():
    args, run = dispatch(__file__, one)

    print_header(
        "identify, n = 2, trapezoid",
        [
            "N",
            "mode",
            "exp µs/sample",
            "direct µs/sample",
            "direct/exp",
            "exp peak RSS (MB)",
            "direct peak RSS (MB)",
            "exp XLA temp (KB)",
        ],
    )
    for n, mode, with_direct in cases(args):
        exp = run(n, "exponential", mode)
        if with_direct:
            direct = run(n, "direct", mode)
            print(
                f"| {n:.0e} | {mode} | {exp['time'] / n * 1e6:.2f} "
                f"| {direct['time'] / n * 1e6:.1f} | {direct['time'] / exp['time']:.0f}× "
                f"| {exp['peak_rss_mb']:.0f} | {direct['peak_rss_mb']:.0f} "
                f"| {exp['temp_kb']:.1f} |"
            )
        else:
            print(
                f"| {n:.0e} | {mode} | {exp['time'] / n * 1e6:.2f} | | "
                f"| {exp['peak_rss_mb']:.0f} | | {exp['temp_kb']:.1f} |"
            )
        sys.stdout.flush()


if __name__ == "__main__":
    main()
