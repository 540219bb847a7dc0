"""The tracker next to the refit on real recordings (springpot σ = η D^{q(t)} ε): the beef
indentation relaxation (one specimen), the adhesive shear staircase and the myocardium
ramp-hold of ../shared/data. Prints, per record, the tracker's order over the second half
with its ±2σ band and diagnostics, and the constant and 5-knot refits with their intervals.
No truth exists here: the point is what each method claims and how sure it says it is.

    python scripts/real_records.py [--data DIR]
"""

import argparse
import time
import warnings
from pathlib import Path

import numpy as np

DATA = Path(__file__).resolve().parents[2] / "shared" / "data"

RECORDS = {
    "beef 230327-RDG1 4": dict(
        file="beef-indentation-relaxation/beef_indentation_relaxation.csv",
        time="time_s", inputs=["force_N"], output="displacement_mm", group_by="specimen",
        trim_column="force_N", trim_below=0.02, pick="230327-RDG1 4",
    ),
    "adhesive shear": dict(
        file="oca-shear-staircase/oca_shear_relaxation_1.csv",
        time="time_s", inputs=["nominal_shear_stress_kPa"], output="shear_strain",
    ),
    "myocardium 10 s": dict(
        file="myocardium-ramp-hold/AvgRelaxed_10s.csv", time="Time", inputs=["F"], output="L",
    ),
}


def main():
    import jax

    jax.config.update("jax_enable_x64", True)
    import vojax
    from vojax._data import load_records
    from vojax._data._pipeline import nrmse

    parser = argparse.ArgumentParser()
    parser.add_argument("--data", default=str(DATA))
    args = parser.parse_args()
    print("| record | N | tracker q, 2nd half [band] | band ± | identified | tracker NRMSE "
          "| refit q ± SE | 5-knot q range | refit NRMSE | tracker s |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for label, spec in RECORDS.items():
        spec = dict(spec)
        path = Path(args.data) / spec.pop("file")
        pick = spec.pop("pick", None)
        if not path.is_file():
            print(f"| {label} | (missing: {path}) |")
            continue
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            recs = load_records(path, **spec)
        rec = next(r for r in recs if pick is None or r.name == pick)
        u, y, dt = rec.inputs, rec.output, rec.dt
        started = time.perf_counter()
        res = vojax.identify(u, y, dt, method="kalman", warn=False)
        took = time.perf_counter() - started
        fit = vojax.refit(u, y, dt)
        knots = vojax.refit(u, y, dt, order=5)
        half = slice(y.size // 2, None)
        a = np.asarray(res.alpha)[half]
        lo = np.asarray(res.alpha_lower)[half]
        hi = np.asarray(res.alpha_upper)[half]
        d = res.diagnostics
        k = np.asarray(knots.order)
        print(
            f"| {label} | {y.size} | {np.median(a):.3f} [{np.median(lo):.3f}, {np.median(hi):.3f}]"
            f" | {d.band_halfwidth:.3f} | {d.identified}{' — ' + d.message if d.message else ''}"
            f" | {nrmse(y, res.y_hat):.4f} | {float(fit.order[0]):.4f} ± "
            f"{float(fit.order_stderr[0]):.4f}{' (at bound)' if fit.at_bound else ''}"
            f" | {k.min():.3f}–{k.max():.3f} | {nrmse(y, fit.y_hat):.4f} | {took:.1f} |",
            flush=True,
        )


if __name__ == "__main__":
    main()
