"""The README's two commands on this machine's wall clock: `vojax demo` (the paper's study and
its figures) in a fresh process with the compilation cache empty, then warm; and, with
`--tests`, the default test tier (`python -m pytest`). The installs are not timed (they
depend on the network). Prints the machine (cores, CPU, Python, jax) with the times, so that
the README's figures can be checked against a machine of the CI's size (2 cores).

    python scripts/bench_readme.py [--tests] [--out FILE]
"""

import argparse
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from _bench import publish

ROOT = Path(__file__).resolve().parents[1]


def _timed(command, cwd, env=None) -> float:
    started = time.perf_counter()
    subprocess.run(command, cwd=cwd, env=env, check=True, stdout=subprocess.DEVNULL,
                   stderr=subprocess.DEVNULL)
    return time.perf_counter() - started


def _machine() -> str:
    import jax

    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    return (f"{cores} cores ({cpu}), Python {platform.python_version()}, jax {jax.__version__}, "
            f"{platform.system()}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tests", action="store_true", help="also time `python -m pytest`")
    parser.add_argument("--out", help="file to write the table to")
    args = parser.parse_args()
    vojax = str(Path(sys.executable).with_name("vojax"))
    rows = []
    with tempfile.TemporaryDirectory() as cache, tempfile.TemporaryDirectory() as here:
        env = dict(os.environ, VOJAX_COMPILATION_CACHE=cache)
        rows.append(("vojax demo, compilation cache empty", _timed([vojax, "demo", "--out", "a"],
                                                                   here, env)))
        rows.append(("vojax demo, compilation cache warm", _timed([vojax, "demo", "--out", "b"],
                                                                  here, env)))
    if args.tests:
        rows.append(("python -m pytest (the default tier)",
                     _timed([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider"],
                            ROOT)))
    lines = [f"# The README's commands, wall clock on {_machine()}", "",
             "| command | wall s | min |", "|---|---|---|"]
    lines += [f"| {name} | {s:.1f} | {s / 60:.1f} |" for name, s in rows]
    publish(lines, args.out)


if __name__ == "__main__":
    main()
