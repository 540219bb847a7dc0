"""What the tracker costs a record in a batch, and in which of its stages: `run_batch` with
the tracker in one process (bench_dask's records: the beef indentation tests replicated with
fresh noise), each stage's wall time summed over the records, for this checkout and for
other versions of vojax given as source folders (e.g. `git worktree add /tmp/old <commit>`),
each in a fresh process, compilation included.

    python scripts/bench_tracker_batch.py [--records 100] [--against /tmp/old ...] [--data DIR]

Prints one row a version: the batch's wall time, its ratio to this checkout's, and the
seconds of each stage (a stage a version lacks: –). The stages are the functions of
`vojax._tracker._fit` (and the batch's `settling_part`) that exist in the version run; a
stage's time includes the threads it waits for.
"""

import argparse
import json
import os
import subprocess
import sys
import tempfile

from bench_dask import CHILD, DATA, beef_records

STAGES = ["start", "tune", "coloured", "held_order", "mixture", "level_profile",
          "trade_interval", "moving_orders", "bands", "band", "assemble"]

TIMERS = r"""
import atexit, collections, functools, json, sys, time
import vojax._tracker._fit as _F, vojax._data._pipeline as _P
_T = collections.Counter()
def _wrap(mod, name):
    f = getattr(mod, name)
    @functools.wraps(f)
    def g(*a, **k):
        t0 = time.perf_counter()
        try:
            return f(*a, **k)
        finally:
            _T[name] += time.perf_counter() - t0
    setattr(mod, name, g)
for _n in STAGES:
    if hasattr(_F, _n) and callable(getattr(_F, _n)):
        _wrap(_F, _n)
if hasattr(_P, "settling_part"):
    _wrap(_P, "settling_part")
atexit.register(lambda: print("STAGES " + json.dumps(dict(_T))))
"""


def run(source, path, count):
    """The child's JSON row and stage times, vojax imported from `source` (None: installed;
    the child runs in an empty folder, so that `-c` does not import this checkout's)."""
    env = dict(os.environ)
    if source is not None:
        env["PYTHONPATH"] = str(source)
    code = f"STAGES = {STAGES!r}\n" + TIMERS + CHILD
    with tempfile.TemporaryDirectory(prefix="vojax-bench-tracker-") as out:
        proc = subprocess.run([sys.executable, "-c", code, str(path), str(count), "kalman", "0",
                               out], capture_output=True, text=True, env=env, cwd=out)
    if proc.returncode:
        sys.exit(proc.stderr[-3000:])
    lines = proc.stdout.strip().splitlines()
    row = json.loads(next(line for line in lines if line.startswith("{")))
    stages = json.loads(next(line for line in lines if line.startswith("STAGES "))[7:])
    return row, stages


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--records", type=int, default=100)
    parser.add_argument("--against", nargs="*", default=[],
                        help="source folders of other vojax versions")
    parser.add_argument("--data", default=str(DATA))
    args = parser.parse_args()
    path = beef_records(args.data)
    rows = []
    for source in [None, *args.against]:
        row, stages = run(source, path, args.records)
        name = "this checkout" if source is None else str(source)
        print(json.dumps(dict(version=name, **row, stages=stages)), flush=True)
        rows.append((name, row, stages))
    names = [s for s in STAGES + ["settling_part"] if any(s in st for _, _, st in rows)]
    base = rows[0][1]["batch"]
    print()
    print("| version | records | batch (s) | ÷ this checkout | " + " | ".join(names) + " |")
    print("|---" * (4 + len(names)) + "|")
    for name, row, stages in rows:
        cells = [f"{stages[s]:.1f}" if s in stages else "–" for s in names]
        print(f"| {name} | {row['records']} | {row['batch']:.1f} | {row['batch'] / base:.2f} | "
              + " | ".join(cells) + " |")
    print(f"\n{os.cpu_count()} cores; one process, each version in a fresh one, compilation "
          "included; a stage's seconds summed over the records (its threads included).")


if __name__ == "__main__":
    main()
