"""What `vojax.compare` concludes on recorded tests: the adhesive shear staircase and the
myocardium ramp–hold shipped with vojax, and three beef indentation relaxations of
../shared/data (skipped where it is absent; from contact on, the force above 0.02 N, as
`scripts/real_records.py` loads them), each resampled to at most 600 samples over its
duration. Prints, per record, the laws by evidence (log evidence relative to the best), the
verdict, and the best law's residual lag-1 autocorrelation. No truth exists here.

    python scripts/compare_real_records.py [--data DIR] [--out FILE]

The polypropylene creep records of ../shared/data start before their first sample (a step
load at t = 0, the first sample at 10 s): `compare` fits records from the start of their
loading only, so they are not compared here (`scripts/compare_pp_creep.py` refits them with
`origin=0`).
"""

import argparse
import time
import warnings
from pathlib import Path

import numpy as np

DATA = Path(__file__).resolve().parents[2] / "shared" / "data"
BEEF = ("230327-RDG1 4", "230403-FF2A", "230327-FF1 1A")
MAX_SAMPLES = 600


def records(data):
    from vojax.io import example_file, load_records

    (adh,) = load_records(example_file("adhesive"), time="time_s",
                          inputs=["nominal_shear_stress_kPa"], output="shear_strain")
    (myo,) = load_records(example_file("myocardium"), time="Time", inputs=["F"], output="L")
    out = [("adhesive staircase (shipped)", adh), ("myocardium ramp–hold (shipped)", myo)]
    path = Path(data) / "beef-indentation-relaxation" / "beef_indentation_relaxation.csv"
    if path.is_file():
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            beef = load_records(path, time="time_s", inputs=["force_N"],
                                output="displacement_mm", group_by="specimen",
                                trim_column="force_N", trim_below=0.02)
        out += [(f"beef {r.name}", r) for r in beef if r.name in BEEF]
    return out


def main():
    import jax

    jax.config.update("jax_enable_x64", True)
    import vojax

    parser = argparse.ArgumentParser()
    parser.add_argument("--data", default=str(DATA))
    parser.add_argument("--out", help="also write the table to this file")
    args = parser.parse_args()
    lines = [f"# python scripts/compare_real_records.py; each record resampled to at most "
             f"{MAX_SAMPLES} samples over its duration", "",
             "| record | N | ranking (log evidence below the best) | best's lag-1 | verdict |",
             "|---|---|---|---|---|"]
    for label, rec in records(args.data):
        t = np.asarray(rec.time, float)
        n = min(t.size, MAX_SAMPLES)
        grid = np.linspace(t[0], t[-1], n)
        stress = np.interp(grid, t, np.asarray(rec.inputs)[:, 0])
        strain = np.interp(grid, t, np.asarray(rec.output))
        started = time.perf_counter()
        c = vojax.compare(stress, strain, grid[1] - grid[0])
        took = time.perf_counter() - started
        top = c.rows[0]["log_evidence"]
        ranking = ", ".join(
            f"{r['model']}" + ("" if k == 0 else f" (−{top - r['log_evidence']:.1f})")
            for k, r in enumerate(c.rows)
        )
        lines.append(f"| {label} | {n} | {ranking} | {c.rows[0]['lag1']:.2f} | {c.verdict} |")
        print(lines[-1], f"({took:.1f} s)", flush=True)
    text = "\n".join(lines)
    if args.out:
        Path(args.out).write_text(text + "\n")


if __name__ == "__main__":
    main()
