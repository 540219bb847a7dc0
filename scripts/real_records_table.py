"""Verdicts and answers on the real recordings of ../shared/data, every dataset (beef and
silicone indentation, myocardium ramp–hold, adhesive shear, polymer creep, rheometer creep,
the AFM creep, relaxation and force-map files, LAOS), the first records of each in natural
order, each run as `vojax batch --method kalman+refit` runs it (a springpot, σ = η D^q ε
with the file's force or stress as input; the tracker with its defaults and the
constant-order refit). The AFM files are read raw, as `vojax.load_records` reads them: the
contact point and the indentation from nanite, the output the contact strain of a sphere (its
radius scales η, not q), from the contact on: the approach and the hold of a creep or
relaxation test, the approach of a force map's curve. The LAOS records (stress in,
strain out) have a check no other record has: a springpot's strain lags its stress by qπ/2,
so the first harmonic's phase gives the order independently (`phase_order`).

Prints one row a record: the tracker's verdict and answer, its breakdown drift, the refit's
order with its interval, convergence and residual correlation, whether the two bands are
disjoint (the batch's `disagreement`, which names the estimator the residuals support), and
the phase order where there is one. Otherwise no truth exists here; the table says what each
estimator claims, and that no record gets two confident answers that contradict each other.

    python scripts/real_records_table.py [--data DIR] [--per-dataset N] [--workers W] [--out FILE]
"""

import argparse
import multiprocessing
import os
import time
from pathlib import Path

import numpy as np

DATA = Path(__file__).resolve().parents[2] / "shared" / "data"

# each dataset: its files (globs inside its folder), the loader's keywords, and the refit's
# origin where the load was applied before the first sample (creep from a step at t = 0)
INDENTATION = dict(time="time_s", inputs=["force_N"], output="displacement_mm",
                   group_by="specimen", trim_column="force_N", trim_below=0.02)
# the raw AFM files: the contact strain of a sphere of 5 µm (the tip is not stated in the
# files; the radius scales η alone) against the force's rise from the contact on, over the
# approach and the hold of a creep or relaxation test, over the approach alone of a force
# map's curve (its retraction leaves the contact: the strain is zero over most of it)
AFM = dict(time="time_s", inputs=["force_rise_N"], output="contact_strain",
           tip=("sphere", 5e-6), segments=[0, 1])
AFM_MAP = dict(AFM, segments=[0])
DATASETS = {
    "beef indentation": ("beef-indentation-relaxation/beef_indentation_relaxation.csv",
                         INDENTATION, None),
    "silicone indentation": ("silicone-indentation-recovery/silicone_indentation_relax_recovery.csv",
                             INDENTATION, None),
    "myocardium ramp–hold": ("myocardium-ramp-hold/AvgRelaxed*.csv",
                             dict(time="Time", inputs=["F"], output="L"), None),
    "adhesive shear": ("oca-shear-staircase/oca_shear_relaxation_*.csv",
                       dict(time="time_s", inputs=["nominal_shear_stress_kPa"],
                            output="shear_strain"), None),
    "PP creep": ("pp-pvc-creep-vo/CreepDataPP.csv",
                 dict(time="Time_day", inputs=["Load_MPa"], output="Strain_dimensionless",
                      group_by="Load_MPa"), 0.0),
    "PVC creep": ("pp-pvc-creep-vo/CreepDataPVC.csv",
                  dict(time="Time_day", inputs=["Load_MPa"], output="Strain_dimensionless",
                       group_by="Load_MPa"), 0.0),
    "rheometer creep": ("rheometer-creep-hermes/creep_experiment.csv",
                        dict(time="time_s", inputs=["stress_Pa"], output="strain"), None),
    "AFM creep, relaxation": ("afm-brain-gel-creep/raw/*.jpk-force", AFM, None),
    "AFM force maps": ("afm-force-maps/raw/*.jpk-force-map", AFM_MAP, None),
    "LAOS": ("laos-mitlaos-reptate/raw/*.laos",
             dict(time="time_s", inputs=["stress"], output="strain"), None),
}


def load(data, per_dataset):
    """(dataset, record, origin, phase order or None) for the first `per_dataset` records of
    each dataset, and a row for each file or curve that could not be read. The records are
    read into memory: the CSVs written on the way are removed."""
    import tempfile

    with tempfile.TemporaryDirectory() as scratch:
        return _load(data, per_dataset, Path(scratch))


def _load(data, per_dataset, scratch):
    from vojax._data import load_records
    from vojax._data._errors import CurvesFailed, DataError
    from vojax._data._tables import natural_key

    out, failed = [], []
    for name, (pattern, loader, origin) in DATASETS.items():
        folder, _, glob = pattern.rpartition("/")
        records = []
        for path in sorted((data / folder).glob(glob), key=lambda p: natural_key(p.name)):
            phase = None
            if path.suffix == ".laos":  # a CSV of it, and its phase order
                path, phase = _laos(path, scratch)
            if loader.get("group_by") in loader["inputs"]:  # one series per load level
                path = _with_series(path, loader["group_by"], scratch)
                loader = dict(loader, group_by="series")
            try:
                read = load_records(path, **loader)
            except CurvesFailed as e:  # a force map's other curves go on
                read = e.records
                failed += [dict(dataset=name, record=c, error=why) for c, why in e.failures]
            except DataError as e:
                failed.append(dict(dataset=name, record=path.name, error=str(e)))
                continue
            records += [(r, phase) for r in read]
        records.sort(key=lambda rp: natural_key(rp[0].name))
        out += [(name, r, origin, phase) for r, phase in records[:per_dataset]]
    return out, failed


def phase_order(t, stress, strain, omega):
    """The order of a springpot from the first harmonic of a steady oscillation at angular
    frequency `omega`: ε = I^q σ / η lags σ by qπ/2, so q = 2Δφ/π with Δφ the stress's phase
    lead over the strain's first harmonic (each fitted by least squares as a sine, a cosine and
    a constant at `omega`), in [0, 2)."""
    basis = np.column_stack([np.sin(omega * t), np.cos(omega * t), np.ones_like(t)])

    def phase(v):
        (s, c, _), *_ = np.linalg.lstsq(basis, v, rcond=None)
        return np.arctan2(c, s)

    return float(2 / np.pi * ((phase(stress) - phase(strain)) % (2 * np.pi)))


def _laos(path, folder):
    """A CSV (time_s, strain, stress) in `folder` of a RepTate ``.laos`` file (a header line
    ``omega=…;gamma=…;``, then time, strain and stress), and its `phase_order`."""
    lines = Path(path).read_text().splitlines()
    omega = float(lines[0].split("omega=")[1].split(";")[0])
    rows = np.loadtxt(lines[1:], comments="#")
    target = folder / f"{path.stem}.csv"
    np.savetxt(target, rows, delimiter=",", header="time_s,strain,stress", comments="")
    return target, phase_order(rows[:, 0], rows[:, 2], rows[:, 1], omega)


def _with_series(path, column, folder):
    """A copy in `folder` of the CSV with a column `series` equal to `column` (a load level
    that is the input as well as what names the record)."""
    import csv

    target = folder / path.name
    with open(path, newline="") as f, open(target, "w", newline="") as g:
        rows = csv.reader(line for line in f if not line.startswith("#"))
        head = next(rows)
        w = csv.writer(g)
        w.writerow(head + ["series"])
        for row in rows:
            w.writerow(row + [f"{column} {row[head.index(column)]}"])
    return target


def run(job):
    import warnings

    import jax

    jax.config.update("jax_enable_x64", True)
    import vojax
    from vojax._data._pipeline import identify_record

    vojax.use_fast_cpu_loops()
    name, record, origin, phase = job
    started = time.perf_counter()
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            options = {} if origin is None else {"origin": origin}
            _, summary = identify_record(record, method="kalman+refit", threads=1, **options)
    except Exception as e:  # noqa: BLE001 - a record that fails is a row too
        return dict(dataset=name, record=record.name, error=str(e).splitlines()[0])
    k, r = summary["kalman"], summary["refit"]
    return dict(
        dataset=name, record=record.name, samples=record.time.size, verdict=k["verdict"],
        answer=k["answer"], breakdown=k.get("breakdown_drift"),
        refit=f"{r['order']:.3f} [{r['order_lower']:.3f}, {r['order_upper']:.3f}]",
        converged=r["converged"], lag1=r.get("residual_correlation"),
        disjoint=summary.get("disagreement", ""), seconds=time.perf_counter() - started,
        phase=phase,
    )


def table(rows):
    head = ("| dataset | record | samples | tracker: verdict and answer | breakdown drift | "
            "refit order [95 %] | refit converged, lag-1 | bands disjoint | phase order |")
    lines = [head, "|" + "---|" * 9]
    for row in rows:
        if "error" in row:
            lines.append(f"| {row['dataset']} | {row['record']} | | failed: {row['error']} "
                         "| | | | | |")
            continue
        drift = row["breakdown"]
        drift = "—" if drift is None or drift == float("inf") else f"{100 * drift:.0f} %"
        lag, phase = row["lag1"], row["phase"]
        lines.append(
            f"| {row['dataset']} | {row['record']} | {row['samples']} | {row['answer']} | "
            f"{drift} | {row['refit']} | {'yes' if row['converged'] else 'no'}, "
            f"{'—' if lag is None else f'{lag:.2f}'} | {'yes' if row['disjoint'] else 'no'} | "
            f"{'—' if phase is None else f'{phase:.3f}'} |"
        )
    return "\n".join(lines)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--data", type=Path, default=DATA)
    parser.add_argument("--per-dataset", type=int, default=4)
    parser.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    parser.add_argument("--out", type=Path)
    args = parser.parse_args()
    if not args.data.is_dir():
        raise SystemExit(f"no data folder at {args.data}: give --data DIR.")
    jobs, failed = load(args.data, args.per_dataset)
    started = time.perf_counter()
    with multiprocessing.get_context("spawn").Pool(args.workers) as pool:
        rows = pool.map(run, jobs, chunksize=1) + failed
    wall = time.perf_counter() - started
    verdicts = [r.get("verdict", "failed") for r in rows]
    counts = ", ".join(f"{v} {verdicts.count(v)}" for v in dict.fromkeys(verdicts))
    disjoint = sum(bool(r.get("disjoint")) for r in rows)
    text = (f"# real_records_table: {len(rows)} records of {len(DATASETS)} datasets, the first "
            f"{args.per_dataset} of each; {args.workers} workers, {wall:.0f} s wall, "
            f"{os.cpu_count()} CPUs\n# verdicts: {counts}; bands disjoint on {disjoint}\n"
            + table(rows) + "\n")
    print(text)
    if args.out:
        tmp = args.out.with_suffix(".tmp")
        tmp.write_text(text)
        tmp.replace(args.out)


if __name__ == "__main__":
    main()
