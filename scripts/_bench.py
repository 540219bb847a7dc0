"""Shared by the benchmark scripts: one measurement per process, so peak memory is its own.

Every case is measured twice, in separate processes: under XLA:CPU's default runtime and with
`vojax.use_fast_cpu_loops()` (each vojax scan compiled as one kernel), so the table shows both.
"""

import argparse
import json
import os
import platform
import resource
import subprocess
import sys
from pathlib import Path

MODES = ("default", "fast")


def summary_numbers(out) -> dict:
    """The numbers of a batch's ``out/summary.csv``, by ``(record, column)``."""
    import csv

    with open(Path(out) / "summary.csv", newline="") as f:
        rows = {r["record"]: r for r in csv.DictReader(f)}
    values = {}
    for name, row in rows.items():
        for k, v in row.items():
            try:
                values[name, k] = float(v)
            except ValueError:
                pass
    return values


def largest_difference(a: dict, b: dict) -> float:
    """The largest relative difference between two runs' `summary_numbers`, over the finite,
    non-zero numbers of `a` that `b` has too."""
    import math

    return max((abs(b[k] - v) / abs(v) for k, v in a.items()
                if math.isfinite(v) and v != 0 and k in b), default=0.0)


def peak_rss_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def parse_args():
    """``--sizes`` (both memories), ``--exp-sizes`` (exponential only), ``--repeat``, ``--one``."""
    parser = argparse.ArgumentParser()
    parser.add_argument("--sizes", nargs="+", type=float, default=[1e3, 1e4, 1e5])
    parser.add_argument("--exp-sizes", nargs="+", type=float, default=[1e6])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--modes", nargs="+", choices=MODES, default=list(MODES))
    parser.add_argument(
        "--one", nargs=3, metavar=("N", "MEMORY", "MODE"), help="measure one case here"
    )
    return parser.parse_args()


def dispatch(script: str, one):
    """Runs ``one(n, memory, repeat)`` here when asked to (``--one``); otherwise returns the
    parsed arguments and a function that measures ``(n, memory, mode)`` in a fresh process."""
    args = parse_args()
    if args.one:
        n, memory, mode = args.one
        if mode == "fast":
            import vojax

            vojax.use_fast_cpu_loops()
        print(json.dumps(one(int(float(n)), memory, args.repeat)))
        sys.exit(0)

    def run(n: int, memory: str, mode: str) -> dict:
        cmd = [sys.executable, script, "--one", str(n), memory, mode, "--repeat", str(args.repeat)]
        return json.loads(subprocess.run(cmd, check=True, capture_output=True, text=True).stdout)

    return args, run


def print_header(title: str, columns: list[str]) -> None:
    """The table's preamble (machine, what the modes are) and its column header."""
    print(f"# {platform.machine()}, python {platform.python_version()}; {title}")
    print("# mode: XLA:CPU default runtime, or vojax.use_fast_cpu_loops() (one kernel per scan)")
    print("| " + " | ".join(columns) + " |")
    print("|" + "---|" * len(columns))


def cases(args):
    """``(n, mode, with_direct)`` in table order: every size, each in the modes asked for;
    the direct memory only for the sizes of ``--sizes``."""
    sizes = [int(s) for s in args.sizes]
    for n in sizes + [int(s) for s in args.exp_sizes]:
        for mode in args.modes:
            yield n, mode, n in sizes


# messages that come from Python's or NumPy's internals, never from vojax's checks: they
# name no argument, so a user cannot tell what was wrong (the fuzzers count them as dirty)
LEAKS = ("not supported between instances", "could not convert string to float",
         "only 0-dimensional arrays", "float() argument must be", "object is not iterable",
         "truth value of an array", "setting an array element with a sequence",
         "is not a valid value for jnp.array", "cannot reshape array", "has no attribute",
         "unhashable type", "object is not subscriptable", "index out of")


def leaks(message) -> bool:
    """Whether an error's message is one of Python's or NumPy's own (`LEAKS`)."""
    return any(words in message for words in LEAKS)


def publish(lines, out=None) -> None:
    """Prints a script's report (its lines) and writes it to the file `out` when one is named."""
    text = "\n".join(lines)
    print(text)
    if out:
        Path(out).write_text(text + "\n")


def ramp_hold_record(n: int, dt: float = 0.05, correlation: float = 0.0):
    """The record of the first-call benchmarks: a ramp-and-hold input (with a small sine on
    it) driving an order that rises from 0.35 to 0.55, the parameter 2, and noise of 1 % of
    the output's range, white or AR(1) with `correlation` between samples (seed 0). Returns
    ``(u, y, dt)``."""
    import numpy as np

    import vojax

    t = dt * np.arange(n)
    u = np.minimum(t / (0.2 * t[-1]), 1.0) + 0.05 * np.sin(t)
    x = np.asarray(vojax.simulate(u, 0.35 + 0.2 * t / t[-1], np.array([2.0]), dt,
                                  memory="exponential"))
    noise = np.random.default_rng(0).standard_normal(n)
    if correlation:
        for k in range(1, n):
            noise[k] = correlation * noise[k - 1] + np.sqrt(1 - correlation**2) * noise[k]
    return u, x + 0.01 * np.ptp(x) * noise, dt


def fresh_process(code: str, *args, xla_flags: str | None = None, drop=("XLA_FLAGS",)) -> dict:
    """Runs `code` with ``python -c`` and `args` in a fresh process that can import this
    module, without the environment variables `drop` (and with ``XLA_FLAGS`` set to
    `xla_flags` where given); returns the JSON object its last line of output prints."""
    env = {k: v for k, v in os.environ.items() if k not in drop}
    if xla_flags is not None:
        env["XLA_FLAGS"] = xla_flags
    here = f"import sys; sys.path.insert(0, {str(Path(__file__).resolve().parent)!r})\n"
    out = subprocess.run([sys.executable, "-c", here + code, *map(str, args)],
                         capture_output=True, text=True, env=env, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])
