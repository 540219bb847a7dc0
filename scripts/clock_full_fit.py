"""What covering the data unit's whole account would cost: on the records the default tracker
identifies (rows of `bench_calibration.py`'s JSON files), the default fit against the fit with
the parameters constant in the data's unit of time and its alternatives (`time_scale=1`).

The default fits the data's unit only as a quick look (its tuned smoothing's own band) and
covers that band where its order lies outside the span's. On clock draw 19 the span's answer
is confidently wrong while the data unit's whole fit covers the truth. For each record this
prints both answers, their evidence apart (the span's tuned log-likelihood over the data
unit's, per fitted point: `vojax._tracker._clock.evidence_apart`) and the union of the two
bands; the summary counts, for the records within each evidence margin, how many the union
would refuse and how many confidently wrong answers it would cover.

The accounts the two clocks give differ only where the order moves: with a constant order
they are one model (the parameters differ by a constant factor), and their evidence ties
whatever the data. Each record's `differ` is the drift on the span's clock of parameters
constant in the data's unit at the data unit's order (`vojax._tracker._clock.clock_drift`),
and the summary counts the records that tie and differ by more than each of `--differ`.
`--families` runs those draws (`--first`, `--count`) whatever the default answers, instead
of the identified rows of `--rows`.

    python scripts/clock_full_fit.py [--rows FILE ...] [--families F ... --first 24
        --count 24] [--margins 0.001 0.01 0.2] [--differ 0.05] [--workers 2] [--out FILE]
"""

import argparse
import json
import sys
import warnings
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np
from _bench import publish

HERE = Path(__file__).resolve().parent
ROWS = [HERE / "results" / "bench_calibration_held_out.json",
        HERE / "results" / "bench_calibration_clock.json"]


def _record(job):
    family, index = job
    import jax

    jax.config.update("jax_enable_x64", True)
    from calibration_suite import DATA, draw_case, real_signals

    import vojax
    from vojax._tracker._clock import clock_drift

    vojax.use_fast_cpu_loops()
    case = draw_case(family, index, real_signals(Path(DATA)))
    grid = dict(t=case["t"]) if case["irregular"] else dict(dt=float(case["t"][1] - case["t"][0]))
    fits, half = {}, slice(len(case["y"]) // 2, None)  # the second half of the samples
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for name, options in (("span", {}), ("unit", dict(time_scale=1.0))):
            res = vojax.identify(case["u"], case["y"], method="kalman", warn=False, **grid,
                                 **options)
            fits[name] = dict(verdict=res.diagnostics.verdict,
                              lower=np.asarray(res.alpha_lower)[half],
                              upper=np.asarray(res.alpha_upper)[half],
                              ll=float(res.tuning.log_likelihood), block=res.diagnostics.block,
                              alpha=np.asarray(res.alpha))
    truth = case["alpha"][half]

    def scored(lower, upper):  # median half-width, coverage of the second half
        return (float(np.median(upper - lower) / 2),
                float(np.mean((truth >= lower) & (truth <= upper))))

    span, unit = fits["span"], fits["unit"]
    points = len(case["y"]) / span["block"]
    differ = clock_drift(unit["alpha"], float(case["t"][-1] - case["t"][0]))
    return dict(family=family, index=index, apart=(span["ll"] - unit["ll"]) / points,
                differ=differ,
                span=(span["verdict"], *scored(span["lower"], span["upper"])),
                unit=(unit["verdict"], *scored(unit["lower"], unit["upper"])),
                union=scored(np.minimum(span["lower"], unit["lower"]),
                             np.maximum(span["upper"], unit["upper"])))


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--rows", nargs="*", default=[str(p) for p in ROWS])
    parser.add_argument("--families", nargs="*", default=None)
    parser.add_argument("--first", type=int, default=24)
    parser.add_argument("--count", type=int, default=24)
    parser.add_argument("--margins", type=float, nargs="*", default=[0.001, 0.01, 0.2])
    parser.add_argument("--differ", type=float, nargs="*", default=[0.05])
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--out", default=None)
    args = parser.parse_args(argv)
    if args.families:
        jobs = [(f, i) for f in args.families for i in range(args.first, args.first + args.count)]
        source = f"{', '.join(args.families)}: draws {args.first}-{args.first + args.count - 1}"
    else:
        jobs = [(r["family"], r["index"]) for path in args.rows
                for r in json.loads(Path(path).read_text())
                if r["method"] == "tracker" and r["identified"]]
        source = "the identified rows of " + ", ".join(Path(p).name for p in args.rows)
    with ProcessPoolExecutor(args.workers) as pool:
        rows = sorted(pool.map(_record, jobs), key=lambda r: r["apart"])
    lines = [f"# clock_full_fit: {len(rows)} records ({source})",
             "| family | draw | evidence apart (nats a point) | differ | span: verdict, half-width, "
             "coverage | data unit with alternatives | union: half-width, coverage |",
             "|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['family']} | {r['index']} | {r['apart']:+.4f} | {r['differ']:.3f} | "
                     f"{r['span'][0]}, "
                     f"{r['span'][1]:.3f}, {r['span'][2]:.2f} | {r['unit'][0]}, {r['unit'][1]:.3f}, "
                     f"{r['unit'][2]:.2f} | {r['union'][0]:.3f}, {r['union'][1]:.2f} |")
    lines += ["", "| identified by the default: evidence apart at most (either way) | differing by "
              "more than | records | the union refuses (±0.1) | confidently wrong covered |",
              "|---|---|---|---|---|"]
    identified = [r for r in rows if r["span"][0] == "identified"]
    for margin in args.margins:
        for differ in [None, *args.differ]:  # None: however little they differ
            near = [r for r in identified if abs(r["apart"]) <= margin
                    and (differ is None or r["differ"] > differ)]
            refused = sum(r["union"][0] > 0.1 for r in near)
            covered = sum(r["span"][2] < 0.5 <= r["union"][1] for r in near)
            lines.append(f"| {margin:g} | {'any' if differ is None else f'{differ:g}'} | "
                         f"{len(near)} | {refused} | {covered} |")
    publish(lines, args.out)


if __name__ == "__main__":
    sys.exit(main())
