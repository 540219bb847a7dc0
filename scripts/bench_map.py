"""A force map of many curves through `vojax batch`, end to end, in one process and on Dask.

The map is built from the four curves of the QI map shipped with the tests
(``tests/data/afm/qi_map.jpk-qi-data``, 600 samples each, approach and retract): curve ``k``
is curve ``k mod 4`` with fresh measurement noise on its force (seeded; a standard deviation
of `--noise` times the spread of the force's first 50 samples, the baseline before contact)
at grid index ``(k mod W, k div W)`` of a ``W × W`` grid, written with afmformats into one
HDF5 file (afmformats' own format, which vojax reads as a map). Each curve is then what the
map command does to a measured one: nanite's contact point and Hertz modulus (sphere, 5 µm),
the approach as a record, the tracker's order, band and verdict, `summary.csv`, and
`maps.png` over the grid.

Each mode runs the ``vojax`` command in a fresh process (compilation included, the
compilation cache off): ``--workers 0`` in one process, then on a local Dask cluster of
`--workers` processes (cluster start included). Prints the wall time, the curves per second,
the ratio between the two, the curves that failed, and the largest relative difference
between the two runs' numbers in summary.csv.

    python scripts/bench_map.py [--curves 64 256] [--workers 2] [--method kalman]
        [--noise 1.0] [--out scripts/results/bench_map.txt]
"""

import argparse
import csv
import math
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from _bench import largest_difference, publish, summary_numbers

ROOT = Path(__file__).resolve().parents[1]
QI = ROOT / "tests" / "data" / "afm" / "qi_map.jpk-qi-data"


def build_map(path: Path, count: int, noise: float, seed: int = 0) -> int:
    """Writes `count` curves (the QI map's, with fresh noise) on a square grid into `path`;
    returns the grid's width."""
    import afmformats
    import h5py

    base = afmformats.load_data(QI)
    width = math.isqrt(count - 1) + 1
    rng = np.random.default_rng(seed)
    with h5py.File(path, "w") as h5:
        for k in range(count):
            src = base[k % len(base)]
            data = {c: np.array(src[c], copy=True) for c in src.columns if c != "index"}
            sd = noise * float(np.std(data["force"][:50]))
            data["force"] = data["force"] + sd * rng.standard_normal(data["force"].size)
            meta = dict(src.metadata)
            meta.update({"grid index x": k % width, "grid index y": k // width,
                         "grid shape x": width, "grid shape y": width, "enum": k,
                         "curve id": f"{meta.get('curve id', 'qi')}-{k}"})
            curve = afmformats.AFMForceDistance(data, meta, diskcache=False)
            curve.export_data(h5, fmt="hdf5")
    return width


def run(path: Path, out: Path, workers: int, method: str) -> dict:
    env = dict(os.environ, VOJAX_COMPILATION_CACHE="off")
    cmd = [sys.executable, "-m", "vojax", "batch", str(path), "--time", "time_s", "--input",
           "force_rise_N", "--output", "contact_strain", "--tip", "sphere:5e-6",
           "--segments", "0", "--method", method, "--figures", "overview", "--quiet",
           "--out", str(out)]
    if workers:
        cmd += ["--scheduler", "local", "--workers", str(workers)]
    started = time.perf_counter()
    done = subprocess.run(cmd, capture_output=True, text=True, env=env)
    wall = time.perf_counter() - started
    if done.returncode not in (0, 2):  # 2: some curves failed, each in failures.csv
        sys.exit(f"vojax batch exited {done.returncode}:\n{done.stderr[-3000:]}")
    failed = 0
    if (out / "failures.csv").is_file():
        with open(out / "failures.csv", newline="") as f:
            failed = sum(1 for _ in csv.DictReader(f))
    return dict(wall=wall, numbers=summary_numbers(out), maps=(out / "maps.png").is_file(), failed=failed)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--curves", type=int, nargs="+", default=[64])
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--method", default="kalman")
    parser.add_argument("--noise", type=float, default=1.0)
    parser.add_argument("--out", default=None)
    args = parser.parse_args()
    lines = [f"| curves | grid | one process (s) | curves/s | Dask, {args.workers} workers (s) "
             "| curves/s | Dask / one process | failed (one / Dask) | maps.png | "
             "max relative difference |", "|---|---|---|---|---|---|---|---|---|---|"]
    for count in args.curves:
        with tempfile.TemporaryDirectory(prefix="vojax-bench-map-") as tmp:
            tmp = Path(tmp)
            width = build_map(tmp / "map.h5", count, args.noise)
            one = run(tmp / "map.h5", tmp / "one", 0, args.method)
            print(f"# {count} curves, one process: {one['wall']:.1f} s", flush=True)
            many = run(tmp / "map.h5", tmp / "dask", args.workers, args.method)
        lines.append(
            f"| {count} | {width}×{width} | {one['wall']:.1f} | {count / one['wall']:.2f} "
            f"| {many['wall']:.1f} | {count / many['wall']:.2f} "
            f"| {many['wall'] / one['wall']:.2f} | {one['failed']} / {many['failed']} "
            f"| {one['maps']} / {many['maps']} | {largest_difference(one['numbers'], many['numbers']):.1e} |")
        print(lines[-1], flush=True)
    lines.append(f"\n{os.cpu_count()} cores; method {args.method}; every run a fresh `vojax "
                 "batch` process, compilation included, the compilation cache off.")
    publish([f"# python scripts/bench_map.py {' '.join(sys.argv[1:])}", *lines], args.out)


if __name__ == "__main__":
    main()
