"""Simulation-based calibration of the order bands: are they honest on data like a user's?

The records are `calibration_suite`'s draws (its docstring lists the families and the
order shapes).

Per family and pooled, over the second half of each record: coverage of the ±2σ band
(pooled over samples of the records each method calls identified), RMS of the standardised
error (α̂ − α)/σ, the median order RMS, the fraction identified, and the **confidently wrong**
rate: identified, yet the truth outside the band at more than half of the samples; and the
identified records whose own coverage falls short of 0.85 (`calibration_tables` scores and
tabulates). Every draw is seeded from its family and index.

Methods: ``tracker`` (`identify`'s default: the parameters may drift), ``tracker-constant``
(``parameters="constant"``: the user states that they do not; false on the drift families,
which measure what that costs), ``tracker-x0`` and ``tracker-constant-x0`` (the same with the
output's offset stated, ``x0=0``: true of every draw, whose output starts from rest) and
``tracker-constant-span`` and ``tracker-constant-x0-span`` (the same statements with the
unit of time in which the parameters are constant stated too, ``time_scale=`` the record's
span: the whole truth of the draws), ``law`` (the paper's law, automatic gains); ``refit`` (the constant-order refit's 95 %
interval, scored only on the records it models, a constant order with constant parameters,
in a table of its own with its error inflation for correlated residuals).

    python scripts/bench_calibration.py [--per-family 12] [--methods tracker tracker-constant
        tracker-x0 tracker-constant-x0 law] [--families ...] [--workers 2] [--threads N]
        [--set NAME=VALUE ...] [--out scripts/results/bench_calibration.txt]
"""

import argparse
import ast
import json
import os
import sys
import time
import warnings
from pathlib import Path

import numpy as np
from calibration_suite import DATA, FAMILIES, draw_case, real_signals  # the suite's draws
from calibration_tables import score, summarise  # its scores and tables

# ---------------------------------------------------------------- the methods


# the tracker's settings: the user states that the parameters are constant, that the output's
# offset is known (0: every draw starts from rest), both, or neither
TRACKERS = {
    "tracker": {},
    "tracker-constant": dict(parameters="constant"),
    "tracker-x0": dict(x0=0.0),
    "tracker-constant-x0": dict(parameters="constant", x0=0.0),
}
# the same statements made whole: the draws' parameters are constant in units of the record's
# span (with a moving order, "constant" in seconds would be another statement), so these
# state that unit too (``time_scale=`` the span), as a user who knows the parameters constant
# would state the unit in which they are
SPAN = ("tracker-constant-span", "tracker-constant-x0-span")
# the stated-drift family's own statement: the drift bound drawn with the record
STATED = ("tracker-stated",)


def run_method(method, case, max_points=None, threads=None, sets=None):
    """``(alpha, std, lower, upper, identified, message)`` of one method on one case;
    `max_points`: the tracker's (None: `identify`'s default); `threads`: the most threads of
    one record's smoothings (None: the tracker's default); `sets`: other `TrackerSettings`
    fields, by name (None: the defaults)."""
    import vojax
    from vojax._stats import noise_variance

    grid = dict(t=case["t"]) if case["irregular"] else dict(dt=float(case["t"][1] - case["t"][0]))
    if max_points is not None and method.startswith("tracker"):
        grid["max_points"] = max_points
    if (threads or sets) and method.startswith("tracker"):
        grid["settings"] = vojax.TrackerSettings(
            **(sets or {}), **({"run_threads": threads} if threads else {}))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        if method in TRACKERS or method in STATED or method in SPAN:
            base = method.removesuffix("-span")
            options = (TRACKERS[base] if base in TRACKERS  # ("tracker" states nothing: {})
                       else dict(parameters=case["stated"] or "free"))
            if method in SPAN:
                options = dict(options, time_scale=float(case["t"][-1] - case["t"][0]))
            res = vojax.identify(case["u"], case["y"], method="kalman", warn=False, **grid,
                                 **options)
        elif method == "law":
            res = vojax.identify(case["u"], case["y"], warn=False, **grid, method="gradient")
        elif method == "refit":
            return _refit_method(case, grid)
        else:
            raise ValueError(method)
    d = res.diagnostics
    extra = dict(
        innovation_r1=_lag1(case["y"] - np.asarray(res.y_pred)),
        residual_r1=_lag1(case["y"] - np.asarray(res.y_hat)),
        # the residual variance over the noise the data's second differences show, and over
        # the true noise (< 1: the fit follows the noise)
        chi2_data=float(np.mean((case["y"] - np.asarray(res.y_hat)) ** 2)
                        / max(noise_variance(case["y"]), 1e-300)),
        chi2_true=float(np.mean((case["y"] - np.asarray(res.y_hat)) ** 2)
                        / max(float(np.var(case["y"] - case["x"])), 1e-300)),
        verdict=getattr(d, "verdict", "identified" if d.identified else "not identified"),
        breakdown_drift=float(getattr(d, "breakdown_drift", float("nan"))),
        # the tuned intensities' marginal log-likelihood and parameter drift (NaN untuned)
        log_likelihood=float(getattr(res.tuning, "log_likelihood", float("nan"))),
        parameter_drift=float(getattr(res.tuning, "parameter_drift", float("nan"))),
    )
    conditional = getattr(res, "conditional", None)
    if conditional is not None:
        extra["conditional"] = tuple(np.asarray(a) for a in (
            conditional.alpha, conditional.alpha_std, conditional.alpha_lower,
            conditional.alpha_upper))
    return (np.asarray(res.alpha), np.asarray(res.alpha_std), np.asarray(res.alpha_lower),
            np.asarray(res.alpha_upper), bool(d.identified), d.message, extra)


def _refit_method(case, grid):
    """The constant-order refit's 95 % interval as a band (its standard error as σ), on the
    records whose truth it models: a constant order with constant parameters (None on the
    others, which it misspecifies); its `error_inflation` for correlated residuals kept."""
    import vojax

    if case["shape"] != "constant" or case["drift"] != 0:
        return None
    fit = vojax.refit(case["u"], case["y"], **grid, warn=False)
    n = case["t"].size
    full = lambda v: np.full(n, float(v))  # noqa: E731
    residuals = case["y"] - np.asarray(fit.y_hat)
    extra = dict(residual_r1=_lag1(residuals), innovation_r1=float("nan"),
                 error_inflation=float(fit.error_inflation), verdict="refit",
                 breakdown_drift=float("nan"))
    return (full(fit.order_value), full(fit.order_value_stderr), full(fit.order_lower[0]),
            full(fit.order_upper[0]), False, "", extra)


def _lag1(e):
    e = np.asarray(e)[1:] - np.mean(np.asarray(e)[1:])
    return float(np.sum(e[1:] * e[:-1]) / max(np.sum(e * e), 1e-300))


def _worker(job):
    family, index, methods, data, max_points, reuse, threads, sets = job
    import jax

    jax.config.update("jax_enable_x64", True)
    import vojax

    MAX_POINTS = vojax.TrackerSettings().max_points

    signals = _SIGNALS.get(data)
    if signals is None:
        signals = _SIGNALS[data] = real_signals(Path(data))
    case = draw_case(family, index, signals)
    rows = []
    for method in methods:
        if method in STATED and case["stated"] is None:  # a statement only that family draws
            continue
        # a record no longer than `max_points` and than identify's default is fitted sample by
        # sample in both runs: the same computation, so its row of the default's run is reused
        key = (family, index, method)
        if key in reuse and case["samples"] <= min(max_points or MAX_POINTS, MAX_POINTS):
            rows.append(dict(reuse[key], reused=True))
            continue
        started = time.perf_counter()
        try:
            out = run_method(method, case, max_points, threads, sets)
            if out is None:  # a method that does not model this record (the refit)
                continue
            row = score(case, out)
        except ValueError as e:  # a refusal by error counts as not identified
            row = dict(coverage=float("nan"), inside=0, count=0, z_rms=float("nan"),
                       rms=float("nan"), identified=False, wrong=False, message=str(e))
        row.update(
            family=family, index=index, method=method, input=case["input"], shape=case["shape"],
            samples=case["samples"], noise=case["noise"], rho=case["rho"], drift=case["drift"],
            true_drift=case["true_drift"], stated=case["stated"],
            seconds=time.perf_counter() - started,
        )
        rows.append(row)
    return rows


_SIGNALS: dict = {}


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--per-family", type=int, default=12)
    parser.add_argument(
        "--first", type=int, default=0,
        help="index of the first draw (the thresholds were set on draws 0–11; 12 on are held out)",
    )
    parser.add_argument("--families", nargs="*", default=list(FAMILIES))
    parser.add_argument("--methods", nargs="*", default=[
        "tracker", "tracker-constant", "tracker-x0", "tracker-constant-x0", "tracker-stated",
        "law"])
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--threads", type=int, default=None,
                        help="threads of one record's smoothings (default: one per core, at "
                        "most 8); 1 where every core runs a worker")
    parser.add_argument("--data", default=str(DATA))
    parser.add_argument("--max-points", type=int, default=None,
                        help="the tracker's max_points (default: identify's): longer records "
                        "are fitted as block means")
    parser.add_argument("--out", default=None, help="write the table and the rows (JSON) here")
    parser.add_argument(
        "--reuse", default=None,
        help="the rows (JSON) of a run of the same code at identify's default max_points: with "
        "--max-points, a record that both runs fit sample by sample takes its row from there",
    )
    parser.add_argument(
        "--keep", nargs="*", default=[],
        help="the rows (JSON) of earlier runs: each (family, index, method) not run now is "
        "taken from there (e.g. the law's rows, after a change to the tracker only)",
    )
    parser.add_argument("--note", default="", help="a line for the table's header")
    parser.add_argument(
        "--set", nargs="*", default=[], metavar="NAME=VALUE",
        help="a TrackerSettings field for the tracker's runs (a Python literal), e.g. "
        "envelope_evidence=20: a candidate setting measured against the defaults",
    )
    args = parser.parse_args(argv)
    if not Path(args.data).is_dir():
        sys.exit(f"no data folder at {args.data}: the suite draws its inputs from ../shared/data")
    reuse = {}
    if args.reuse:
        reuse = {(r["family"], r["index"], r["method"]): r
                 for r in json.loads(Path(args.reuse).read_text())}
    # each record's rows are appended to OUT.partial.jsonl as they come: a run stopped by a
    # time limit is resumed from there (the records it finished are not run again)
    partial = Path(args.out).with_suffix(".partial.jsonl") if args.out else None
    done = []
    if partial is not None and partial.exists():
        done = [json.loads(line) for line in partial.read_text().splitlines() if line.strip()]
    finished = {(r["family"], r["index"]) for r in done}
    sets = {k: ast.literal_eval(v) for k, _, v in (a.partition("=") for a in args.set)}
    jobs = [(f, i, tuple(args.methods), args.data, args.max_points, reuse, args.threads, sets)
            for i in range(args.first, args.first + args.per_family) for f in args.families
            if (f, i) not in finished]
    started = time.perf_counter()
    rows = [r for r in done if r["family"] in args.families
            and args.first <= r["index"] < args.first + args.per_family]

    def record(out):
        rows.extend(out)
        _progress(out)
        if partial is not None:
            with partial.open("a") as f:
                f.write("".join(json.dumps(r, default=float) + "\n" for r in out))

    if args.workers > 1:
        import multiprocessing as mp

        with mp.get_context("spawn").Pool(args.workers) as pool:
            for out in pool.imap_unordered(_worker, jobs):
                record(out)
    else:
        for job in jobs:
            record(_worker(job))
    wall = time.perf_counter() - started
    ran = {(r["family"], r["index"], r["method"]) for r in rows}
    kept = [dict(r, kept=True) for path in args.keep
            for r in json.loads(Path(path).read_text())
            if r["family"] in args.families and args.first <= r["index"] < args.first
            + args.per_family and (r["family"], r["index"], r["method"]) not in ran]
    rows.extend(kept)
    methods = [*args.methods, *dict.fromkeys(r["method"] for r in kept
                                             if r["method"] not in args.methods)]
    lines = [
        f"# bench_calibration: {args.per_family} draws per family (indices {args.first}–"
        f"{args.first + args.per_family - 1}), seeds from family/index; "
        f"{os.cpu_count()} CPUs, {args.workers} workers, {wall:.0f} s wall"
        + (f" (resumed: {len(finished)} records from an earlier run)" if finished else "")
        + ("" if args.max_points is None else
           f"; the tracker at max_points={args.max_points} (longer records as block means)")
        + ("" if not args.reuse else
           f"; {sum(r.get('reused', False) for r in rows)} rows of records no longer than "
           "max_points and identify's default taken from the run at the default")
        + ("" if not kept else f"; {len(kept)} rows ({', '.join(methods[len(args.methods):])})"
           " kept from an earlier run")
        + (f"; {args.note}" if args.note else "")
        + (f"; settings {', '.join(args.set)}" if args.set else ""),
        *summarise(rows, methods, args.families),
    ]
    print("\n".join(lines))
    if args.out:
        Path(args.out).write_text("\n".join(lines) + "\n")
        Path(args.out).with_suffix(".json").write_text(json.dumps(rows, indent=1, default=float))
        partial.unlink(missing_ok=True)
    return rows


def _progress(rows):
    for r in rows:
        print(
            f"{r['family']:14s} {r['index']:3d} {r['method']:8s} {r['shape']:8s} "
            f"{r['samples']:5d} {r['input'][:34]:34s} cov {r['coverage']:.2f} "
            f"rms {r['rms']:.3f} {'ID' if r['identified'] else '--'}"
            f"{' WRONG' if r['wrong'] else ''} {r['seconds']:.1f}s",
            flush=True,
        )


if __name__ == "__main__":
    main()
