"""The user's wall clock for the default `vojax.identify` (the tracker): the first call of a
fresh process (compilation included), the second call, and the first call of a new process
with the persistent compilation cache (`vojax.use_compilation_cache`) empty and then warm;
and the cost per sample of a warm call at several record lengths; each with XLA's default
loops and with `vojax.use_fast_cpu_loops()` (what the command line uses).

Each case runs in its own fresh Python process; the record is a ramp-and-hold input driving
a slowly moving order with 1 % noise (white; and AR(1) with a correlation of 0.9 between
samples, for which the tracker also fits a coloured-noise model, kept or not by its evidence rule). Times are wall-clock seconds on this machine; the
table gives ratios measured in the same run.

    python scripts/bench_first_call.py [--samples 400] [--lengths 1000 10000 100000 1000000]
        [--out FILE]
"""

import argparse
import json
import os
import sys
import tempfile

from _bench import fresh_process, publish

CHILD = r"""
import json, resource, sys, time
started = time.perf_counter()
import jax
jax.config.update("jax_enable_x64", True)
import vojax
if sys.argv[3] == "fast":
    vojax.use_fast_cpu_loops()
imported = time.perf_counter()
cache = sys.argv[2]
if cache != "none":
    vojax.use_compilation_cache(cache)
n = int(sys.argv[1])
from _bench import ramp_hold_record
# AR(1) noise, 0.9 between samples, where asked for
u, y, dt = ramp_hold_record(n, correlation=0.9 if sys.argv[5] == "coloured" else 0.0)
prepared = time.perf_counter()
res = vojax.identify(u, y, dt, warn=False)
res.alpha.block_until_ready()
first = time.perf_counter()
res = vojax.identify(u, 1.001 * y, dt, warn=False)
res.alpha.block_until_ready()
second = time.perf_counter()
rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024  # the simulation and identify
law = recursion = float("nan")
if len(sys.argv) > 4 and sys.argv[4] == "law":  # one pass of the paper's law, given its gains
    import vojax._adaptive._estimator as ident
    run_law, spent = ident.run_law, []

    def timed_run_law(*args):  # the recursion alone, without the band computed after it
        begun = time.perf_counter()
        out = jax.block_until_ready(run_law(*args))
        spent.append(time.perf_counter() - begun)
        return out

    ident.run_law = timed_run_law
    for _ in range(2):  # the second call, warm
        begun = time.perf_counter()
        vojax.identify(u, y, dt, method="gradient", gamma=0.01, lam=0.9, warn=False
                       ).alpha.block_until_ready()
        law = time.perf_counter() - begun
    recursion = spent[-1]
rss_law = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024  # and the law's pass
print(json.dumps(dict(samples=n, imported=imported - started, first=first - prepared,
                      second=second - first, law=law, recursion=recursion, rss_mb=rss,
                      rss_law_mb=rss_law,
                      block=res.diagnostics.block, jax=jax.__version__,
                      device=f"{jax.default_backend()} ({jax.devices()[0].device_kind})",
                      coloured=res.diagnostics.noise_correlation == res.diagnostics.noise_correlation)))
"""


def run(n, cache="none", loops="default", law=False, noise="white"):
    result = fresh_process(CHILD, n, cache, loops, "law" if law else "-", noise,
                           drop=("XLA_FLAGS", "JAX_COMPILATION_CACHE_DIR"))
    print(f"{n} samples, cache {cache}, {loops} loops, {noise}: {json.dumps(result)}",
          file=sys.stderr, flush=True)  # progress, kept where a run is cut short
    return result


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--samples", type=int, default=400)
    parser.add_argument("--lengths", type=int, nargs="*", default=[1000, 10000, 100000, 1000000])
    parser.add_argument("--loops", nargs="+", choices=("default", "fast"), default=["default", "fast"],
                        help="XLA's default loops, vojax.use_fast_cpu_loops() (a CPU setting: a "
                        "GPU ignores it, so there run `--loops default`)")
    parser.add_argument("--law-max", type=int, default=None,
                        help="the law's pass only up to this many samples (on a GPU its "
                        "sample-by-sample loop costs a launch a step)")
    parser.add_argument("--out", default=None)
    args = parser.parse_args(argv)
    results = {}
    for loops in args.loops:
        cold = run(args.samples, loops=loops)
        with tempfile.TemporaryDirectory() as folder:
            empty = run(args.samples, folder, loops)
            warm = run(args.samples, folder, loops)
        coloured = run(args.samples, loops=loops, noise="coloured")
        results[loops] = dict(
            cold=cold, rows=[
                ("fresh process, no cache: first call", cold["first"]),
                ("same process: second call", cold["second"]),
                ("fresh process, empty cache: first call", empty["first"]),
                ("fresh process, warm cache: first call", warm["first"]),
                ("coloured noise (AR(1), 0.9): first call", coloured["first"]),
                ("coloured noise: second call", coloured["second"]),
            ],
            lengths=[run(n, loops=loops, law=args.law_max is None or n <= args.law_max)
                     for n in args.lengths],
            coloured=coloured["coloured"],
        )
    modes = list(results)
    both = modes == ["default", "fast"]
    label = {"default": "default", "fast": "fast loops"}
    first = results[modes[0]]["cold"]
    lines = [
        f"# bench_first_call: identify (default: the tracker), {args.samples} samples; "
        f"import of vojax and JAX {first['imported']:.2f} s; {first['device']}, "
        f"{os.cpu_count()} CPUs, JAX {first['jax']}; "
        + " and ".join({"default": "XLA's default loops", "fast": "vojax.use_fast_cpu_loops()"}[m]
                       for m in modes),
        "| case | " + " | ".join(f"{label[m]} s | ÷ second call ({label[m]})" for m in modes)
        + (" | default ÷ fast |" if both else " |"),
        "|---|" + "---|---|" * len(modes) + ("---|" if both else ""),
    ]
    for k, (name, _) in enumerate(results[modes[0]]["rows"]):
        row = [results[m]["rows"][k][1] for m in modes]
        lines.append(f"| {name} | " + " | ".join(
            f"{a:.2f} | {a / results[m]['cold']['second']:.1f}" for a, m in zip(row, modes))
            + (f" | {row[0] / row[1]:.1f} |" if both else " |"))
    kept = {m: "kept" if results[m]["coloured"] else "rejected by its evidence rule"
            for m in modes}
    lines += ["", "coloured noise: the tracker fits the white-noise model, then the AR(1) noise "
              "model (both timed); the AR(1) model was " + " and ".join(
                  f"{kept[m]} ({label[m]})" for m in modes)]
    lines += ["", "Longer records: the tracker fits at most `max_points` (default 1,000) block "
              "means; law: one pass of the paper's law at given gains (warm), the unit of cost: "
              "`identify(method=\"gradient\")`, its recursion and its band (the noise's spread "
              "through the recursion, by forward-mode derivatives of each step); recursion: the "
              "law's scan alone.",
              "", "| samples | block | " + " | ".join(
                  f"{'' if m == 'default' else 'fast loops: '}first call s | warm call s | "
                  "µs per sample" + (" (warm)" if m == "default" else "") + " | ÷ law pass | "
                  "÷ law recursion | peak RSS MB" for m in modes) + " |",
              "|---|---|" + "---|---|---|---|---|---|" * len(modes)]
    for k, n in enumerate(args.lengths):
        rs = [results[m]["lengths"][k] for m in modes]
        lines.append(f"| {n} | {rs[0]['block']} | " + " | ".join(
            f"{a['first']:.2f} | {a['second']:.2f} | {1e6 * a['second'] / n:.3g} | "
            f"{a['second'] / a['law']:.2g} | {a['second'] / a['recursion']:.2g} | "
            f"{a['rss_mb']:.0f}" for a in rs) + " |")
    for key, name in (("law", "law pass"), ("recursion", "law recursion")):
        lines += ["", f"{name} s ({', '.join(label[m] for m in modes)}): " + ", ".join(
            f"{n}: " + ", ".join(f"{results[m]['lengths'][k][key]:.3g}" for m in modes)
            for k, n in enumerate(args.lengths))]
    lines += ["", "peak RSS MB: the process's after the simulation and the two identify calls; "
              f"after the law's pass as well ({', '.join(label[m] for m in modes)}): " + ", ".join(
                  f"{n}: " + ", ".join(f"{results[m]['lengths'][k]['rss_law_mb']:.0f}"
                                       for m in modes) for k, n in enumerate(args.lengths))]
    publish(lines, args.out)

if __name__ == "__main__":
    main()
