"""How XLA:CPU's small-loop threshold sets the tracker's cost, and whether one program can
carry it.

`vojax.use_fast_cpu_loops()` raises ``xla_cpu_small_while_loop_byte_threshold`` (XLA's default:
1 KiB of bytes touched per iteration) so that XLA compiles a loop as one kernel. Here each
threshold runs in its own fresh process (the flag is read once, when JAX creates its CPU
backend): the first and second `identify` of a 400-sample record, a warm `identify` of a
1e5-sample record (1,000 block means), and a warm pass of the paper's law at given gains on
1e4 samples. The table gives seconds and ratios to XLA's default, measured in the same run.

It also asks XLA to take the threshold for one program only, as a compile option of
`jax.jit` (``compiler_options``), and prints XLA's answer: a per-program setting would let
`identify` run its loops as single kernels without a process-wide flag.

    python scripts/bench_loop_threshold.py [--thresholds 4096 16384 65536 1048576]
        [--repeat 2] [--out FILE]
"""

import argparse
import json
import os
import statistics
import subprocess
import sys

from _bench import fresh_process, publish

CHILD = r"""
import json, sys, time
import jax
jax.config.update("jax_enable_x64", True)
import vojax
from _bench import ramp_hold_record as record


def timed(call):
    begun = time.perf_counter()
    jax.block_until_ready(call().alpha)
    return time.perf_counter() - begun


u, y, dt = record(400)
first = timed(lambda: vojax.identify(u, y, dt, warn=False))
second = timed(lambda: vojax.identify(u, 1.001 * y, dt, warn=False))
u, y, dt = record(100_000)
timed(lambda: vojax.identify(u, y, dt, warn=False))
long = timed(lambda: vojax.identify(u, 1.001 * y, dt, warn=False))
u, y, dt = record(10_000)
law = [timed(lambda: vojax.identify(u, y, dt, method="gradient", gamma=0.01, lam=0.9,
                                    warn=False)) for _ in range(2)][1]
print(json.dumps(dict(first=first, second=second, long=long, law=law)))
"""

PROBE = r"""
import sys
import jax
from jax import lax
# the threshold, and the option that once selected XLA:CPU's whole-program runtime
options = {"threshold": {"xla_backend_extra_options":
                         "xla_cpu_small_while_loop_byte_threshold=1048576"},
           "former runtime": {"xla_cpu_use_thunk_runtime": False}}
f = jax.jit(lambda x: lax.scan(lambda c, v: (c + v, c), 0.0, x)[1],
            compiler_options=options[sys.argv[1]])
try:
    f(jax.numpy.ones(8)).block_until_ready()
    print("accepted")
except Exception as e:  # XLA's answer, printed as it is
    print(f"refused: {str(e).splitlines()[0]}")
"""


def run(threshold):
    flags = None if threshold is None else (
        f"--xla_backend_extra_options=xla_cpu_small_while_loop_byte_threshold={threshold}"
    )
    result = fresh_process(CHILD, xla_flags=flags)
    print(f"threshold {threshold}: {json.dumps(result)}", file=sys.stderr, flush=True)
    return result


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--thresholds", type=int, nargs="*",
                        default=[4096, 16384, 65536, 1048576])
    parser.add_argument("--repeat", type=int, default=2)
    parser.add_argument("--out", default=None)
    args = parser.parse_args(argv)
    cases = [None, *args.thresholds]
    runs = {c: [] for c in cases}
    for _ in range(args.repeat):  # the thresholds in turn, so that a slow spell hits them all
        for c in cases:
            runs[c].append(run(c))
    keys = ("first", "second", "long", "law")
    med = {c: {k: statistics.median(r[k] for r in runs[c]) for k in keys} for c in cases}
    import jax

    env = {k: v for k, v in os.environ.items() if k != "XLA_FLAGS"}
    probes = {name: subprocess.run([sys.executable, "-c", PROBE, name], capture_output=True,
                                   text=True, env=env) for name in ("threshold", "former runtime")}
    lines = [
        f"# bench_loop_threshold: medians of {args.repeat} fresh processes per threshold, "
        f"the thresholds in turn; {os.cpu_count()} CPUs, JAX {jax.__version__}",
        "| threshold (bytes) | first call, 400 samples s | second call s | warm call, 1e5 "
        "samples s | law pass, 1e4 samples s | ÷ default: first | second | 1e5 | law |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    base = med[None]
    for c in cases:
        m = med[c]
        lines.append(
            f"| {'XLA default (1024)' if c is None else c} | "
            + " | ".join(f"{m[k]:.3g}" for k in keys) + " | "
            + " | ".join(f"{m[k] / base[k]:.2f}" for k in keys) + " |"
        )
    answers = {name: p.stdout.strip() or (p.stderr.strip().splitlines() or ["no answer"])[-1]
               for name, p in probes.items()}
    lines += ["", "as compile options of one program (`jax.jit(..., compiler_options=...)`): the "
              f"threshold (`xla_backend_extra_options`): {answers['threshold']}; the former "
              f"whole-program runtime (`xla_cpu_use_thunk_runtime=False`): "
              f"{answers['former runtime']}"]
    publish(lines, args.out)


if __name__ == "__main__":
    main()
