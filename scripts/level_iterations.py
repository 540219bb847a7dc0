"""How many iterations the level profile's held scales take, and what their budget
(`TrackerSettings.level_max_iter`) changes, on the calibration suite's records.

For each record (the families and draws named, the default and the parameters stated
constant) this runs `identify` with the held scales given `--long` iterations (400, the
tuned smoothing's budget) and logs each held scale's iterations, whether it converged and
whether it fits (its χ² test). Where a held scale went past `--cap`, the record runs again
with that budget and the two bands are compared sample by sample (elsewhere no run reaches
the cap and the two calls are the same). Prints the held scales' iterations by bracket, the
share of their iterations the cap saves, and one row per record that reached it.

    python scripts/level_iterations.py [--first 0 12] [--per-family 4] [--cap 150]
        [--families white coloured ...] [--workers 2] [--out FILE]
"""

import argparse
import json
import multiprocessing as mp
import threading
import warnings
from pathlib import Path

import numpy as np
from _bench import publish

FAMILIES = ("white", "coloured", "irregular", "lengths", "long", "drift", "gain-drift",
            "informative")
SETTINGS = {"default": {}, "constant": {"parameters": "constant"}}


_LOG = {"held": [], "pending": []}  # this process's log of the record it runs


def _watch():
    """Logs each held scale's iterations, convergence and χ² test into `_LOG` (installed once
    a process: a wrapper around a wrapper would log into the first record's lists)."""
    from vojax._tracker import _level
    from vojax._tracker import _smoother as smoother

    if getattr(_level, "_watched", False):
        return
    modes, fitting, runs = _level.smoother_modes, _level.fitting, smoother._runs
    here = threading.local()  # the thread running the held scales (the other clock's beside)

    def logged_runs(*args, **kwargs):
        for sm in runs(*args, **kwargs):
            if getattr(here, "on", False):
                _LOG["pending"].append((int(sm.iterations), bool(sm.converged)))
            yield sm

    def logged_modes(*args, **kwargs):  # the held scales' runs only
        here.on = True
        try:
            return modes(*args, **kwargs)
        finally:
            here.on = False

    def logged_fitting(residuals, *args, **kwargs):
        fits = fitting(residuals, *args, **kwargs)
        assert len(_LOG["pending"]) == len(fits), "a held scale's run went unlogged"
        _LOG["held"].extend((i, c, bool(f)) for (i, c), f in zip(_LOG["pending"], fits))
        _LOG["pending"].clear()
        return fits

    smoother._runs = logged_runs
    # one round's runs in order, so that each run's log meets its own χ² test
    _level.in_threads = lambda problem, fn, count, call, key: [((0, count), call(0, count))]
    _level.smoother_modes, _level.fitting, _level._watched = logged_modes, logged_fitting, True


def _record(job):
    family, index, setting, long, cap, data = job
    import jax

    jax.config.update("jax_enable_x64", True)
    import bench_calibration as bench

    import vojax

    _watch()
    _LOG["held"], _LOG["pending"] = [], []
    held = _LOG["held"]
    case = bench.draw_case(family, index, bench.real_signals(Path(data)))
    grid = (dict(t=case["t"]) if case["irregular"]
            else dict(dt=float(case["t"][1] - case["t"][0])))

    def band(budget):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            res = vojax.identify(case["u"], case["y"], warn=False, **grid,
                                 settings=vojax.TrackerSettings(level_max_iter=budget),
                                 **SETTINGS[setting])
        return res.diagnostics.verdict, np.asarray(res.alpha_lower), np.asarray(res.alpha_upper)

    verdict, lower, upper = band(long)
    row = dict(family=family, index=index, setting=setting, held=list(held), verdict=verdict)
    if any(i > cap for i, _, _ in held):
        capped, c_lower, c_upper = band(cap)
        row.update(capped=capped, change=float(max(np.max(np.abs(lower - c_lower)),
                                                   np.max(np.abs(upper - c_upper)))))
    return row


def main(argv=None):
    from calibration_suite import DATA

    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--first", type=int, nargs="+", default=[0, 12])
    p.add_argument("--per-family", type=int, default=4)
    p.add_argument("--families", nargs="+", default=list(FAMILIES))
    p.add_argument("--cap", type=int, default=150)
    p.add_argument("--long", type=int, default=400)
    p.add_argument("--workers", type=int, default=2)
    p.add_argument("--data", default=str(DATA))
    p.add_argument("--out")
    args = p.parse_args(argv)
    jobs = [(f, first + k, s, args.long, args.cap, args.data) for f in args.families
            for first in args.first for k in range(args.per_family) for s in SETTINGS]
    with mp.get_context("spawn").Pool(args.workers, maxtasksperchild=4) as pool:
        rows = list(pool.imap(_record, jobs, chunksize=1))
    runs = np.array([r for row in rows for r in row["held"]], dtype=float).reshape(-1, 3)
    its, conv, fits = runs[:, 0], runs[:, 1] > 0, runs[:, 2] > 0
    lines = [f"# level_iterations: {len(rows)} records ({', '.join(args.families)}; draws "
             f"{', '.join(f'{a}–{a + args.per_family - 1}' for a in args.first)}; default and "
             f"stated constant), {len(its)} held-scale runs at {args.long} iterations",
             "| iterations | converged | of them fitting |", "|---|---|---|"]
    edges = [0, 50, 100, args.cap, 200, 300, args.long]
    for lo, hi in zip(edges[:-1], edges[1:]):
        m = conv & (its > lo) & (its <= hi)
        lines.append(f"| {lo + 1}–{hi} | {int(m.sum())} | {int((m & fits).sum())} |")
    lines += [f"| not converged in {args.long} | {int((~conv).sum())} | "
              f"{int((~conv & fits).sum())} |", "",
              f"most iterations of a held scale that fits: "
              f"{int(its[fits].max()) if fits.any() else 0}; runs past {args.cap}: "
              f"{int((its > args.cap).sum())}; iterations saved by a budget of {args.cap}: "
              f"{np.maximum(its - args.cap, 0).sum() / max(its.sum(), 1):.1%}", "",
              f"records with a held scale past {args.cap}, their bands at {args.long} and at "
              f"{args.cap}:", "| record | verdict | capped | largest change of a band edge |",
              "|---|---|---|---|"]
    for row in rows:
        if "change" in row:
            lines.append(f"| {row['family']} {row['index']} {row['setting']} | "
                         f"{row['verdict']} | {row['capped']} | {row['change']:.3g} |")
    lines += ["", "rows: " + json.dumps([{k: v for k, v in r.items() if k != "held"}
                                          for r in rows if r["held"]])]
    publish(lines, args.out)


if __name__ == "__main__":
    main()
