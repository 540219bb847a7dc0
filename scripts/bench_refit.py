"""Offline refit against a closed-form fit and against one identification, on real records.

    python scripts/bench_refit.py [--data DIR] [--repeats 5] [--cases …] [--code DIR]

Cases, each in a fresh process (compilation counted apart from the warm time):

- the rheometer creep record of ../shared/data (a 500 Pa step; its log-spaced samples are used
  on their own clock, `record.grid`; vojax before 2026-11-22 resampled them at the median
  step): `vojax.refit` (constant order, offset estimated) against `scipy.optimize.curve_fit`
  of the closed-form springpot creep ε(t) = c + σ₀ t^q / (η Γ(1+q)) on the same samples, and
  against one `vojax.identify`;
- the myocardium 0.1 s ramp-hold record (tension → stretch), likewise: `vojax.refit` to
  convergence; and the same record interpolated onto 60,000 uniform samples (a long record);
- `logspaced1e4-refit`: a synthetic creep of 10,000 samples log-spaced over 10 decades
  (1e-6 … 1e4 s) after a step at t = 0 (`t=`, `origin=0`): uniformly it would need 1e10 samples.

Prints the warm times (median of --repeats), the orders found and the ratios measured in the
same run.
"""

import argparse
import json
import subprocess
import sys
from pathlib import Path

DATA = Path(__file__).resolve().parents[2] / "shared" / "data"

CHILD = r"""
import json, sys, time, warnings
import numpy as np
import vojax
vojax.use_fast_cpu_loops()
import jax
jax.config.update("jax_enable_x64", True)
case, data, repeats = sys.argv[1], sys.argv[2], int(sys.argv[3])
with warnings.catch_warnings():
    warnings.simplefilter("ignore")
    if case.startswith("logspaced"):
        tt = np.geomspace(1e-6, 1e4, 10_000)
        u = np.full((tt.size, 1), 2.0)
        y = 0.01 + 2.0 * tt**0.3 / 1.5 / 0.8974706963062772
        y = y * (1 + 1e-3 * np.random.default_rng(0).standard_normal(tt.size))
        rec = type("R", (), dict(dt=float(np.median(np.diff(tt))), time=tt, grid={"t": tt}))()
    elif case.startswith("creep"):
        rec, = vojax.load_records(data + "/rheometer-creep-hermes/creep_experiment.csv",
                                  time="time_s", inputs=["stress_Pa"], output="strain")
        u, y = rec.inputs, rec.output
    else:
        rec, = vojax.load_records(data + "/myocardium-ramp-hold/AvgRelaxed_0.1s.csv",
                                  time="Time", inputs=["F"], output="L")
        u, y = rec.inputs, (rec.output - 0.95) / 0.95
        if case == "myocardium60k-refit":  # the same record on a 60,000-sample grid
            fine = np.linspace(rec.time[0], rec.time[-1], 60_000)
            u = np.interp(fine, rec.time, u[:, 0])[:, None]
            y = np.interp(fine, rec.time, y)
            rec = type("R", (), dict(dt=float(fine[1] - fine[0]), time=fine))()

def timed(fn):
    t0 = time.perf_counter(); out = fn(); jax.block_until_ready(out) if not isinstance(out, tuple) else None
    return time.perf_counter() - t0, out

grid = getattr(rec, "grid", {"dt": rec.dt})  # records on their own clock (vojax ≥ 2026-11-22)
extra = dict(origin=-1e-6) if case.startswith("logspaced") else {}  # the step at t = 0
if case.startswith("logspaced"):
    grid = {"t": rec.time - rec.time[0]}
result = dict(case=case, samples=int(y.size), dt=rec.dt, uniform="dt" in grid)
if case == "creep-curve_fit":
    from scipy.optimize import curve_fit
    from scipy.special import gamma as G
    t, s0 = rec.time, float(np.mean(u[:, 0]))
    def model(t, q, log_eta, c):
        return c + s0 * t**q / (np.exp(log_eta) * G(1 + q))
    fit = lambda: curve_fit(model, t, y, p0=(0.5, np.log(s0 / max(y[-1], 1e-300)), 0.0),
                            bounds=([0.01, -50, -1], [0.99, 50, 1]))
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter(); popt, pcov = fit(); times.append(time.perf_counter() - t0)
    result.update(warm=float(np.median(times)), order=float(popt[0]),
                  order_stderr=float(np.sqrt(pcov[0, 0])))
elif case == "creep-identify":
    t0 = time.perf_counter(); res = vojax.identify(u, y, **grid, warn=False, method="gradient"); res.alpha.block_until_ready()
    cold = time.perf_counter() - t0
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter(); res = vojax.identify(u, y, **grid, warn=False, method="gradient"); res.alpha.block_until_ready()
        times.append(time.perf_counter() - t0)
    result.update(cold=cold, warm=float(np.median(times)), order=float(res.alpha[-1]))
else:  # refit
    t0 = time.perf_counter(); fit = vojax.refit(u, y, **grid, **extra); fit.order.block_until_ready()
    cold = time.perf_counter() - t0
    times = []
    for _ in range(repeats if not case.startswith("myocardium60k") else 1):
        t0 = time.perf_counter(); fit = vojax.refit(u, y, **grid, **extra); fit.order.block_until_ready()
        times.append(time.perf_counter() - t0)
    import optimistix as optx
    result.update(cold=cold, warm=float(np.median(times)), order=float(fit.order[0]),
                  order_stderr=float(fit.order_stderr[0]),
                  converged=bool(fit.result == optx.RESULTS.successful))
print(json.dumps(result))
"""


CASES = ("creep-curve_fit", "creep-refit", "creep-identify", "myocardium-refit",
         "myocardium60k-refit", "logspaced1e4-refit")


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--data", default=str(DATA))
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--code", help="a checkout whose vojax the children import (before/after)")
    parser.add_argument("--cases", nargs="+", default=list(CASES))
    args = parser.parse_args()
    rows = {}
    for case in args.cases:
        proc = subprocess.run([sys.executable, "-c", CHILD, case, str(Path(args.data).resolve()),
                               str(args.repeats)], capture_output=True, text=True,
                              cwd=Path(args.code).resolve() if args.code else None)
        if proc.returncode != 0:
            print(case, "failed:", proc.stderr[-2000:])
            continue
        rows[case] = json.loads(proc.stdout.strip().splitlines()[-1])
        print(json.dumps(rows[case]), flush=True)
    print("\n| case | samples | cold (s) | warm (s) | order | converged |")
    print("|---|---|---|---|---|---|")
    for case, r in rows.items():
        cold = f"{r['cold']:.2f}" if "cold" in r else "–"
        order = f"{r['order']:.4f}" + (f" ± {r['order_stderr']:.4f}" if "order_stderr" in r else "")
        print(f"| {case} | {r['samples']} | {cold} | {r['warm']:.3f} | {order} | "
              f"{r.get('converged', '–')} |")
    if {"creep-refit", "creep-curve_fit", "creep-identify"} <= set(rows):
        refit = rows["creep-refit"]["warm"]
        print(f"\nrefit / curve_fit (warm): {refit / rows['creep-curve_fit']['warm']:.1f}×; "
              f"refit / identify (warm): {refit / rows['creep-identify']['warm']:.2f}×")


if __name__ == "__main__":
    main()
