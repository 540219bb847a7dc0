"""The batch on Dask against the batch in one process, on the same machine and records: the
beef indentation records of ../shared/data, replicated with fresh measurement noise (seeded) to
the requested count, each case in a fresh process, compilation included.

    python scripts/bench_dask.py [--records 148] [--methods gradient kalman] [--workers 2]
                                 [--data DIR]

Prints, per method and count, the wall time of `run_batch` in one process and on a
`LocalCluster` of `--workers` worker processes (cluster start included), their ratio, and the
largest relative difference between the two runs' summary.csv numbers.
"""

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from _bench import largest_difference, summary_numbers

DATA = Path(__file__).resolve().parents[2] / "shared" / "data"

CHILD = r"""
import json, sys, time, warnings
import numpy as np
import vojax
vojax.use_fast_cpu_loops()
import jax
jax.config.update("jax_enable_x64", True)
from dataclasses import replace
from pathlib import Path
from vojax._data import load_records
from vojax._data._batch import dask_client, run_batch
path, count, method, workers, out = sys.argv[1], int(sys.argv[2]), sys.argv[3], int(sys.argv[4]), sys.argv[5]
with warnings.catch_warnings():
    warnings.simplefilter("ignore")
    base = load_records(path, time="time_s", inputs=["force_N"], output="displacement_mm",
                        group_by="specimen", trim_column="force_N", trim_below=0.02)
rng = np.random.default_rng(0)
recs = []
for k in range(count):
    r = base[k % len(base)]
    if k >= len(base):  # a replicate: the same test with fresh noise of 0.2 % of its range
        noise = 2e-3 * np.ptp(r.output) * rng.standard_normal(r.output.size)
        r = replace(r, name=f"{r.name}-{k // len(base)}", output=r.output + noise)
    recs.append(r)
started = time.perf_counter()
settings = dict(model="springpot", method=method, gamma="auto", lam=None, progress=False,
                record_figures=False)
if workers:
    with dask_client("local", workers) as client:
        ready = time.perf_counter()
        report = run_batch(recs, Path(out), client=client, **settings)
else:
    ready = started
    report = run_batch(recs, Path(out), **settings)
done = time.perf_counter()
print(json.dumps(dict(records=len(recs), failed=report.failed, cluster=ready - started,
                      batch=done - started)))
"""


def beef_records(data):
    """The beef indentation file under the data folder `data`; exits naming it if absent."""
    path = Path(data).resolve() / "beef-indentation-relaxation" / "beef_indentation_relaxation.csv"
    if not path.is_file():
        sys.exit(f"needs {path}")
    return path


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--records", type=int, nargs="+", default=[148])
    parser.add_argument("--methods", nargs="+", default=["gradient", "kalman"])
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--data", default=str(DATA))
    args = parser.parse_args()
    path = beef_records(args.data)
    table = []
    for method in args.methods:
        for count in args.records:
            runs = {}
            for workers in (0, args.workers):
                out = tempfile.mkdtemp(prefix="vojax-bench-dask-")
                t0 = time.perf_counter()
                proc = subprocess.run(
                    [sys.executable, "-c", CHILD, str(path), str(count), method, str(workers), out],
                    capture_output=True, text=True, cwd=out,  # not this checkout's vojax
                )
                if proc.returncode:
                    sys.exit(proc.stderr[-3000:])
                row = json.loads(proc.stdout.strip().splitlines()[-1])
                row.update(method=method, workers=workers, wall=time.perf_counter() - t0)
                print(json.dumps(row), flush=True)
                runs[workers] = (row, summary_numbers(out))
            (one, a), (many, b) = runs[0], runs[args.workers]
            diff = largest_difference(a, b)
            table.append((method, count, one["batch"], many["cluster"], many["batch"],
                          many["batch"] / one["batch"], diff, one["failed"], many["failed"]))
    print()
    print(f"| method | records | one process (s) | cluster start (s) | Dask, {args.workers} workers (s) "
          "| Dask / one process | max relative difference | failed (one / Dask) |")
    print("|---|---|---|---|---|---|---|---|")
    for m, n, one, start, many, ratio, diff, f1, f2 in table:
        print(f"| {m} | {n} | {one:.1f} | {start:.1f} | {many:.1f} | {ratio:.2f} | {diff:.1e} | {f1} / {f2} |")
    print(f"\n{os.cpu_count()} cores; every run in a fresh process, compilation included.")


if __name__ == "__main__":
    main()
