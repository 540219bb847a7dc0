"""Wall-clock time of a whole batch, compilation included: the beef indentation records of
../shared/data (148 specimens, 120–180 samples each, about 60 distinct lengths), each case in a
fresh process, with and without length buckets (records padded to a few lengths and masked).

    python scripts/bench_batch.py [--records 10 40] [--methods kalman refit] [--data DIR]
                                  [--buckets on|off|compare] [--code DIR]
                                  [--figures records|overview] [--cache]

`--code DIR` runs the children on another checkout of vojax (e.g. a `git worktree` of an
earlier commit), for before/after tables measured in the same session. `--figures overview`
draws no record figures (`vojax batch --figures overview`); `--cache` runs each case twice
with a persistent compilation cache, empty and then warm (a second `vojax batch`).

Prints, per case, the wall time of `run_batch` (loading excluded, reported apart) and the
ratios between cases measured in the same run.
"""

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

DATA = Path(__file__).resolve().parents[2] / "shared" / "data"

CHILD = r"""
import json, sys, time, warnings
started = time.perf_counter()
import vojax
vojax.use_fast_cpu_loops()
import jax
jax.config.update("jax_enable_x64", True)
from vojax._data import load_records
from vojax._data._batch import run_batch
path, count, method, buckets, out = sys.argv[1], int(sys.argv[2]), sys.argv[3], sys.argv[4] == "1", sys.argv[5]
figures, cache = sys.argv[6], sys.argv[7]
if cache != "-":
    vojax.use_compilation_cache(cache)
with warnings.catch_warnings():
    warnings.simplefilter("ignore")
    recs = load_records(path, time="time_s", inputs=["force_N"], output="displacement_mm",
                        group_by="specimen", trim_column="force_N", trim_below=0.02)
recs = recs[:count]
loaded = time.perf_counter()
from pathlib import Path
extra = {} if figures == "records" else dict(record_figures=False)
report = run_batch(recs, Path(out), model="springpot", method=method, gamma="auto", lam=None,
                   progress=False, buckets=buckets, **extra)
done = time.perf_counter()
print(json.dumps(dict(code=vojax.__file__, records=len(recs), lengths=len({r.time.size for r in recs}),
                      load=loaded - started, batch=done - loaded, failed=report.failed)))
"""


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--records", type=int, nargs="+", default=[10, 40])
    parser.add_argument("--methods", nargs="+", default=["kalman", "refit"])
    parser.add_argument("--data", default=str(DATA))
    parser.add_argument("--buckets", choices=("on", "off", "compare"), default="compare")
    parser.add_argument("--code", help="a checkout whose vojax the children import")
    parser.add_argument("--figures", choices=("records", "overview"), default="records",
                        help="records: a figure per record (the default of `vojax batch`)")
    parser.add_argument("--cache", action="store_true",
                        help="each case twice with a persistent compilation cache: empty, then "
                        "as the first run left it (what a second `vojax batch` pays)")
    args = parser.parse_args()
    path = Path(args.data).resolve() / "beef-indentation-relaxation" / "beef_indentation_relaxation.csv"
    if not path.is_file():
        sys.exit(f"needs {path}")
    env = dict(os.environ)
    if args.code:
        env["PYTHONPATH"] = str(Path(args.code).resolve()) + os.pathsep + env.get("PYTHONPATH", "")
    rows = []
    for method in args.methods:
        for count in args.records:
            modes = {"on": (True,), "off": (False,), "compare": (False, True)}[args.buckets]
            for buckets in modes:
                cache_dir = tempfile.mkdtemp() if args.cache else None
                for cached in (False, True) if args.cache else (False,):
                    with tempfile.TemporaryDirectory() as out:
                        started = time.perf_counter()
                        proc = subprocess.run(
                            [sys.executable, "-c", CHILD, str(path), str(count), method,
                             "1" if buckets else "0", out, args.figures, cache_dir or "-"],
                            capture_output=True, text=True, env=env, cwd=args.code or None,
                        )
                        wall = time.perf_counter() - started
                    if proc.returncode != 0:
                        print(proc.stderr[-2000:])
                        continue
                    r = json.loads(proc.stdout.strip().splitlines()[-1])
                    r.update(method=method, buckets=buckets, wall=wall, figures=args.figures,
                             cache="warm" if cached else ("empty" if args.cache else "none"))
                    rows.append(r)
                    print(json.dumps(r), flush=True)
                if cache_dir:
                    shutil.rmtree(cache_dir, ignore_errors=True)
    print("\n| method | records | distinct lengths | buckets | figures | compilation cache "
          "| batch (s) | process wall (s) | no buckets / buckets |")
    print("|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        other = [o for o in rows if o["method"] == r["method"] and o["records"] == r["records"]
                 and not o["buckets"] and o["cache"] == r["cache"]]
        ratio = f"{other[0]['batch'] / r['batch']:.1f}×" if r["buckets"] and other else "–"
        print(f"| {r['method']} | {r['records']} | {r['lengths']} | {r['buckets']} | "
              f"{r['figures']} | {r['cache']} | {r['batch']:.1f} | {r['wall']:.1f} | {ratio} |")
    for method in args.methods:
        sel = {r["records"]: r for r in rows if r["method"] == method and r["buckets"]
               and r["cache"] != "warm"}
        if len(sel) >= 2:
            lo, hi = min(sel), max(sel)
            print(f"{method}, buckets: {hi} records / {lo} records = "
                  f"{sel[hi]['batch'] / sel[lo]['batch']:.2f}× the time")


if __name__ == "__main__":
    main()
