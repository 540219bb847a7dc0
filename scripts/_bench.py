"""Shared by the benchmark scripts: one measurement per process, so peak memory is its own."""

import argparse
import json
import resource
import subprocess
import sys


def peak_rss_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def parse_args():
    """``--sizes`` (both memories), ``--exp-sizes`` (exponential only), ``--repeat``, ``--one``."""
    parser = argparse.ArgumentParser()
    parser.add_argument("--sizes", nargs="+", type=float, default=[1e3, 1e4, 1e5])
    parser.add_argument("--exp-sizes", nargs="+", type=float, default=[1e6])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--one", nargs=2, metavar=("N", "MEMORY"), help="measure one case here")
    return parser.parse_args()


def dispatch(script: str, one):
    """Runs ``one(n, memory, repeat)`` here when asked to (``--one``); otherwise returns the
    parsed arguments and a function that measures ``(n, memory)`` in a fresh process."""
    args = parse_args()
    if args.one:
        print(json.dumps(one(int(float(args.one[0])), args.one[1], args.repeat)))
        sys.exit(0)

    def run(n: int, memory: str) -> dict:
        cmd = [sys.executable, script, "--one", str(n), memory, "--repeat", str(args.repeat)]
        return json.loads(subprocess.run(cmd, check=True, capture_output=True, text=True).stdout)

    return args, run
