"""How much parameter drift the trade-off's alternatives need, on the calibration suite's
records whose parameters are constant.

With one input a constant order and a drifting parameter can explain what a moving order
explains; the default tracker's band covers the constant orders that a parameter drifting on
hat functions fits as well as the best such fit (its trade-off profile). For every record of
the families named (the suite's draws), this runs the default `identify` and, at each grid
order inside the reported trade-off interval, fits that drifting parameter again (as a gain
on the memory term, on the profile's coarse and fine knots) and measures its drift over the
fitted span, ``(max p − min p) / |mean p|``. The least drift among those fits is how far the
parameter must move for the alternative to hold: a bound on the drift below it would exclude
the alternative. Prints one row per record and a summary of the refused ones.

    python scripts/trade_drift.py [--first 0] [--families white noisy irregular lengths]
        [--workers 2] [--out FILE]
"""

import argparse
import json
import multiprocessing as mp
import sys
from pathlib import Path

import numpy as np
from _bench import publish


def _record(job):
    family, index, data = job
    import jax

    jax.config.update("jax_enable_x64", True)
    import bench_calibration as bc

    from vojax._tracker import _estimator, _fit
    from vojax._tracker._start import least_squares, phi_columns
    from vojax._tracker._trade import hat_basis, refinement

    seen = {}
    trade_interval, fit_points = _fit.trade_interval, _estimator.fit_points

    def watched_trade_interval(*args, **kwargs):  # its arguments, to fit the profile again
        seen["args"], seen["kwargs"] = args, kwargs
        return trade_interval(*args, **kwargs)

    def watched_fit(*args, **kwargs):  # the tracker's own result (its `trade`)
        seen["result"] = fit_points(*args, **kwargs)
        return seen["result"]

    _fit.trade_interval, _estimator.fit_points = watched_trade_interval, watched_fit
    try:
        signals = bc._SIGNALS.get(data)
        if signals is None:
            signals = bc._SIGNALS[data] = bc.real_signals(Path(data))
        case = bc.draw_case(family, index, signals)
        scored = bc.score(case, bc.run_method("tracker", case))
    finally:
        _fit.trade_interval, _estimator.fit_points = trade_interval, fit_points
    res = seen["result"]
    row = dict(family=family, index=index, samples=case["samples"],
               identified=scored["identified"], rms=scored["rms"],
               trade=None if res.trade is None else [float(v) for v in res.trade],
               least_drift=None)
    if res.trade is None:
        return row
    problem, _, whiten = seen["args"]
    offset = seen["kwargs"].get("offset", True)
    s, last, bounds = problem.settings, problem.last, problem.bounds
    u, y, mask = (np.asarray(a) for a in (problem.u, problem.y, problem.mask))
    fine = hat_basis(problem.times, last, s.trade_knots_fine)
    coarse = fine @ refinement(s.trade_knots)
    alphas = np.linspace(*bounds, s.trade_orders + 2)[1:-1]
    drifts = []
    for alpha in alphas[(alphas >= res.trade[0] - 1e-9) & (alphas <= res.trade[1] + 1e-9)]:
        phi = phi_columns(problem.memory, u, alpha, s.phi_block)
        for basis in (coarse, fine):
            columns = (phi[:, :, None] * basis[:, None, :]).reshape(phi.shape[0], -1)
            coef = least_squares(columns, y, mask, whiten, offset)[1]
            p = basis[: last + 1] @ coef[: basis.shape[1]]  # the first input's parameter
            drifts.append(float(np.ptp(p) / max(abs(np.mean(p)), 1e-300)))
    row["least_drift"] = min(drifts) if drifts else None
    return row


def main(argv=None):
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    import bench_calibration as bc

    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--first", type=int, default=0)
    parser.add_argument("--per-family", type=int, default=12)
    parser.add_argument("--families", nargs="*", default=["white", "noisy", "irregular",
                                                           "lengths"])
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--out", default=None)
    args = parser.parse_args(argv)
    jobs = [(f, i, str(bc.DATA)) for i in range(args.first, args.first + args.per_family)
            for f in args.families]
    with mp.get_context("spawn").Pool(args.workers) as pool:
        rows = sorted(pool.map(_record, jobs), key=lambda r: (r["family"], r["index"]))
    lines = [f"# trade_drift: the default tracker on draws {args.first}–"
             f"{args.first + args.per_family - 1} of {', '.join(args.families)}; least drift: "
             "(max p − min p) / |mean p| over the fitted span, the least among the trade-off's "
             "fits inside its interval",
             "| family | draw | samples | identified | order RMS | trade-off interval | "
             "least drift |",
             "|---|---|---|---|---|---|---|"]
    for r in rows:
        trade = "–" if r["trade"] is None else f"{r['trade'][0]:.2f}–{r['trade'][1]:.2f}"
        drift = "–" if r["least_drift"] is None else f"{r['least_drift']:.2f}"
        lines.append(f"| {r['family']} | {r['index']} | {r['samples']} | "
                     f"{'yes' if r['identified'] else 'no'} | {r['rms']:.4f} | {trade} | "
                     f"{drift} |")
    refused = [r for r in rows if not r["identified"]]
    drifts = np.array([r["least_drift"] for r in refused if r["least_drift"] is not None])
    accurate = [r for r in refused if r["rms"] < 0.01]
    lines += [
        "",
        f"identified {len(rows) - len(refused)} of {len(rows)}; of the {len(refused)} refused, "
        f"{drifts.size} have a trade-off interval, whose fits need a least drift of "
        + (f"{np.min(drifts):.2f}–{np.max(drifts):.2f} (median {np.median(drifts):.2f}, "
           f"quartiles {np.percentile(drifts, 25):.2f}–{np.percentile(drifts, 75):.2f}); "
           if drifts.size else "– ; ")
        + f"{len(accurate)} refused records have an order RMS below 0.01 over the second half, "
        f"{sum(r['least_drift'] is not None for r in accurate)} of them with a trade-off "
        "interval",
    ]
    publish(lines, args.out)
    if args.out:
        Path(args.out).with_suffix(".json").write_text(json.dumps(rows, indent=1))


if __name__ == "__main__":
    main()
