"""Benchmark of the memory kernels: φ and ∂φ/∂β, direct vs exponential memory (n = 2 inputs).

Each (N, memory) runs in its own process so that the peak resident memory it reports is its
own. Times exclude compilation (one warm-up call first) and are the best of `--repeat` runs.

    python scripts/bench_memory.py [--sizes 1e3 1e4 1e5] [--exp-sizes 1e6] [--repeat 3]
        [--modes default fast]
"""

import sys
import time

from _bench import cases, dispatch, peak_rss_mb, print_header


def one(n: int, memory: str, repeat: int) -> dict:
    import jax

    jax.config.update("jax_enable_x64", True)
    import numpy as np

    dt = 300.0 / n
    t = np.arange(n) * dt
    u = np.stack([np.sin(0.5 * t), np.cos(0.2 * t)], axis=1)
    alpha = 0.15 * np.exp(-0.02 * t) * (np.cos(0.2 * t) + 2) + 0.4
    import jax.numpy as jnp

    from vojax._integral import make_memory, scan_memory

    mem = make_memory(memory, dt, n)
    u, alpha = jnp.asarray(u), jnp.asarray(alpha)
    # the direct memory is O(N²): at N ≥ 1e5 one timed run is all there is time for
    repeat = 1 if memory == "direct" and n >= 100_000 else repeat
    out = {}
    for name, sensitivity in (("phi", False), ("dphi", True)):
        # compile ahead of time so that the timed calls exclude compilation without a warm-up run
        compiled = (
            jax.jit(lambda u, a: scan_memory(mem, u, a, sensitivity)).lower(u, alpha).compile()
        )
        best = float("inf")
        for _ in range(repeat):
            start = time.perf_counter()
            value = jax.block_until_ready(compiled(u, alpha))
            best = min(best, time.perf_counter() - start)
        out[name] = best
        out[f"{name}_temp_kb"] = compiled.memory_analysis().temp_size_in_bytes / 1024
        value = value[1] if sensitivity else value
        np.save(f"/tmp/bench_memory_{name}_{memory}_{n}.npy", np.asarray(value))
    out["peak_rss_mb"] = peak_rss_mb()
    return out


def temp(case: dict) -> str:
    return f"{case['phi_temp_kb']:.1f} / {case['dphi_temp_kb']:.1f}"


def main():
    args, run = dispatch(__file__, one)
    import numpy as np

    print_header(
        "memory kernels, n = 2",
        [
            "N",
            "mode",
            "memory",
            "φ time (s)",
            "∂φ time (s)",
            "direct/exp φ",
            "direct/exp ∂φ",
            "max rel diff φ",
            "max rel diff ∂φ",
            "peak RSS (MB)",
            "XLA temp φ / ∂φ (KB)",
        ],
    )
    for n, mode, with_direct in cases(args):
        exp = run(n, "exponential", mode)
        if not with_direct:
            print(
                f"| {n:.0e} | {mode} | exponential | {exp['phi']:.4g} | {exp['dphi']:.4g} "
                f"| | | | | {exp['peak_rss_mb']:.0f} | {temp(exp)} |"
            )
            sys.stdout.flush()
            continue
        direct = run(n, "direct", mode)
        diffs = []
        for name in ("phi", "dphi"):
            a = np.load(f"/tmp/bench_memory_{name}_exponential_{n}.npy")
            b = np.load(f"/tmp/bench_memory_{name}_direct_{n}.npy")
            diffs.append(np.max(np.abs(a - b)) / np.max(np.abs(b)))
        print(
            f"| {n:.0e} | {mode} | direct | {direct['phi']:.4g} | {direct['dphi']:.4g} "
            f"| | | | | {direct['peak_rss_mb']:.0f} | {temp(direct)} |"
        )
        print(
            f"| {n:.0e} | {mode} | exponential | {exp['phi']:.4g} | {exp['dphi']:.4g} | "
            f"{direct['phi'] / exp['phi']:.0f}× | {direct['dphi'] / exp['dphi']:.0f}× | "
            f"{diffs[0]:.1e} | {diffs[1]:.1e} | {exp['peak_rss_mb']:.0f} | {temp(exp)} |"
        )
        sys.stdout.flush()


if __name__ == "__main__":
    main()
