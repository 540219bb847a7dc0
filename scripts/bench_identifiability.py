"""How well does each method recover a known order from real excitation, and do its bands
cover the truth? Semi-synthetic records: the measured inputs of ../shared/data (beef force,
adhesive shear staircase, myocardium ramp-hold, rheometer creep step), resampled onto N uniform
samples and scaled to unit RMS, drive a known order trajectory (constant, ramp, step) with
p = 1; the truth comes from `vojax.reference` (plain NumPy direct sums, no JAX kernel) on a
grid twice as fine, then 1 % or 5 % Gaussian noise (of the output's standard deviation).

For each method: order RMS error over the second half and over the whole record, and the
fraction of samples whose ±2σ band contains the true order. Nothing is taken from the truth.

    python scripts/bench_identifiability.py [--samples 600] [--noise 0.01 0.05] [--data DIR]
"""

import argparse
import csv
import time
import warnings
import zlib
from pathlib import Path

import numpy as np

DATA = Path(__file__).resolve().parents[2] / "shared" / "data"


def _read(path, time_col, col, group=None, group_col=None):
    with open(path, newline="") as f:
        rows = [r for r in f if r.strip() and not r.startswith("#")]
    reader = csv.DictReader(rows)
    t, v = [], []
    for r in reader:
        if group is not None and r[group_col] != group:
            continue
        t.append(float(r[time_col]))
        v.append(float(r[col]))
    return np.array(t), np.array(v)


def inputs(data: Path):
    """Measured input signals (time, value) by name."""
    beef = data / "beef-indentation-relaxation" / "beef_indentation_relaxation.csv"
    out = {}
    if beef.is_file():
        out["beef force"] = _read(beef, "time_s", "force_N", "230327-RDG1 4", "specimen")
    oca = data / "oca-shear-staircase" / "oca_shear_relaxation_1.csv"
    out["adhesive stress"] = _read(oca, "time_s", "nominal_shear_stress_kPa")
    myo = data / "myocardium-ramp-hold" / "AvgRelaxed_10s.csv"
    t, v = _read(myo, "Time", "L")
    out["myocardium stretch"] = (t, v - v[0])
    creep = data / "rheometer-creep-hermes" / "creep_experiment.csv"
    out["rheometer creep stress"] = _read(creep, "time_s", "stress_Pa")
    return out


def orders(t):
    s = t / t[-1]
    return {
        "constant": np.full_like(t, 0.4),
        "ramp": 0.25 + 0.4 * s,
        "step": 0.3 + 0.3 * (1 + np.tanh((s - 0.5) / 0.03)) / 2,
    }


def truth(u, alpha, dt):
    """x = I^{α(t)} u by the reference's direct sums on a grid twice as fine."""
    from vojax import reference

    fine_t = np.arange(2 * u.size - 1) * dt / 2
    coarse_t = np.arange(u.size) * dt
    uf = np.interp(fine_t, coarse_t, u)
    af = np.interp(fine_t, coarse_t, alpha)
    return np.asarray(reference.fractional_integral(uf, af, dt / 2))[::2]


def main():
    import jax

    jax.config.update("jax_enable_x64", True)
    import vojax

    parser = argparse.ArgumentParser()
    parser.add_argument("--samples", type=int, default=600)
    parser.add_argument("--noise", type=float, nargs="+", default=[0.01, 0.05])
    parser.add_argument("--data", default=str(DATA))
    parser.add_argument("--only", nargs="*", help="input names to keep")
    parser.add_argument("--shapes", nargs="*", help="order shapes to keep")
    parser.add_argument("--methods", nargs="*", help="methods to run (default: all)")
    args = parser.parse_args()
    methods = {
        "law (auto gains)": lambda u, y, dt: vojax.identify(u, y, dt, warn=False, method="gradient"),
        "tracker filter": lambda u, y, dt: vojax.identify(
            u, y, dt, method="kalman", smooth=False, warn=False
        ),
        "tracker smoother": lambda u, y, dt: vojax.identify(u, y, dt, method="kalman", warn=False),
        # the truth's parameter is constant in the record's own unit (seconds): stated so
        "tracker, time_scale=1": lambda u, y, dt: vojax.identify(
            u, y, dt, method="kalman", warn=False, time_scale=1.0
        ),
        "refit constant": lambda u, y, dt: vojax.refit(u, y, dt),
        "refit 5 knots": lambda u, y, dt: vojax.refit(u, y, dt, order=5),
    }
    if args.methods:
        methods = {k: v for k, v in methods.items() if k in args.methods}
    rows = []
    n = args.samples
    for name, (t_raw, v_raw) in inputs(Path(args.data)).items():
        if args.only and name not in args.only:
            continue
        t = np.linspace(t_raw[0], t_raw[-1], n) - t_raw[0]
        dt = float(t[1] - t[0])
        u = np.interp(t + t_raw[0], t_raw, v_raw)
        u = u / np.sqrt(np.mean(u**2))
        for shape, alpha in orders(t).items():
            if args.shapes and shape not in args.shapes:
                continue
            x = truth(u, alpha, dt)
            for level in args.noise:
                # a stable seed per case (hash() of a str changes with every process)
                rng = np.random.default_rng(zlib.crc32(f"{name}/{shape}/{level}".encode()))
                y = x + level * np.std(x) * rng.standard_normal(n)
                for method, run in methods.items():
                    started = time.perf_counter()
                    try:
                        with warnings.catch_warnings():
                            warnings.simplefilter("ignore")
                            res = run(u, y, dt)
                    except ValueError as e:
                        print(f"{name}/{shape}/{level}: {method} failed: {e}")
                        continue
                    elapsed = time.perf_counter() - started
                    est = np.asarray(res.alpha if hasattr(res, "alpha") else res.order)
                    lower = np.asarray(getattr(res, "alpha_lower", getattr(res, "order_lower", est)))
                    upper = np.asarray(getattr(res, "alpha_upper", getattr(res, "order_upper", est)))
                    err = est - alpha
                    half = t > t[-1] / 2
                    rows.append(
                        dict(
                            input=name,
                            order=shape,
                            noise=level,
                            method=method,
                            rms_second_half=float(np.sqrt(np.mean(err[half] ** 2))),
                            rms_whole=float(np.sqrt(np.mean(err**2))),
                            coverage=float(np.mean((alpha >= lower) & (alpha <= upper))),
                            seconds=elapsed,
                            verdict=getattr(getattr(res, "diagnostics", None), "verdict", "-"),
                        )
                    )
                    r = rows[-1]
                    print(
                        f"{name:24s} {shape:8s} {level:4.2f} {method:18s} "
                        f"{r['rms_second_half']:.4f} {r['rms_whole']:.4f} {r['coverage']:5.2f} "
                        f"{elapsed:6.1f}s {r['verdict']}",
                        flush=True,
                    )
    print(f"\nmedians over {len(rows) // len(methods)} cases ({n} samples each)")
    print(
        "| method | order RMS, 2nd half | order RMS, whole | ±2σ coverage (median) "
        "| coverage (all samples) | time (s) | identified | identified, band misses the truth |"
    )
    print("|---|---|---|---|---|---|---|---|")
    for method in methods:
        sel = [r for r in rows if r["method"] == method]
        if not sel:
            continue
        med = {k: np.median([r[k] for r in sel]) for k in ("rms_second_half", "rms_whole", "coverage", "seconds")}
        pooled = np.mean([r["coverage"] for r in sel])  # equal lengths: the pooled fraction
        said = [r for r in sel if r["verdict"] == "identified"]
        wrong = sum(r["coverage"] < 0.5 for r in said)  # confidently wrong
        print(
            f"| {method} | {med['rms_second_half']:.4f} | {med['rms_whole']:.4f} | "
            f"{med['coverage']:.2f} | {pooled:.2f} | {med['seconds']:.1f} | "
            f"{len(said)}/{len(sel)} | {wrong} |"
        )


if __name__ == "__main__":
    main()
