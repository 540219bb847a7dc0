"""The tracker's explanations on the calibration suite, saved once and scored under band rules.

Every band the tracker reports is built from its explanations of the record
(`vojax._tracker._explanations`): the tuned smoothing, its alternatives (other starts, order
drifts, parameter drifts), the level profile's held scales and the trade-off's constant
orders, each with its order trajectory and Laplace band, its χ², its evidence and the drift of
its parameters. `--dump` runs the tracker on the suite's draws (`bench_calibration.draw_case`)
under the settings named and saves, per record and setting, every explanation on the clock
the tracker fitted (block means of a long record), with the truth there; `--evaluate` then
scores band rules on them as the suite does (per family: identified, pooled coverage of the
±2σ band over the second half, median z RMS, median order RMS, confidently wrong), and, for
the conditional answer, how often its promise is false (the band misses the truth while the
breakdown drift exceeds the true drift).

    python scripts/band_explanations.py --dump DIR [--first 0] [--per-family 12]
        [--settings free constant constant-x0] [--families ...] [--workers 2] [--data DIR]
    python scripts/band_explanations.py --dump DIR --demo-seeds 0 1 2 ...  (the demo's record)
    python scripts/band_explanations.py --evaluate DIR [DIR ...] [--out FILE] [--rules WORD ...]
"""

import argparse
import gzip
import os
import pickle
import sys
import time
import warnings
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

SETTINGS = {
    "free": {},
    "constant": dict(parameters="constant"),
    "constant-x0": dict(parameters="constant", x0=0.0),
    "free-x0": dict(x0=0.0),
}

_CAP: dict = {}


def spy(into):
    """Keeps the `fit_points` results (on the fitted points) in the dict `into`: the span
    clock's (``"result"``: the band weighed from its explanations, before the second clock's
    widening) and the data's unit's (``"other"``, where `vojax._tracker._clock` fits it).
    Returns the function that puts the original back."""
    from vojax._tracker import _estimator, _fit

    original = _fit.fit_points

    def watched(*args, **kwargs):
        out = original(*args, **kwargs)
        # the span's clock; the data's unit's (`weigh=False`) comes second
        into["result" if kwargs.get("weigh", True) else "other"] = out
        if kwargs.get("weigh", True):
            into["scale"] = kwargs.get("time_scale", 1.0)  # the span in the data's unit
        return out

    # `Tracker` calls it by its own name; the blocks import it when they run
    _estimator.fit_points = _fit.fit_points = watched

    def undo():
        _estimator.fit_points = _fit.fit_points = original

    return undo


def _compact(a):
    a = np.asarray(a)
    return a.astype(np.float32) if a.dtype == np.float64 and a.ndim >= 1 else a


def _watch():
    """The spy on `fit_points` (`spy`), installed once per process."""
    if "watching" not in _CAP:
        spy(_CAP)
        _CAP["watching"] = True


def _saved(res, t, alpha, seconds):
    """What a record keeps of the tracker's call `res` on the times `t` (the truth `alpha`
    on them), `seconds` long, with `_CAP` holding what the spy saw: the fit on the fitted
    points (block means of a long record), its explanations and the truth there, the band
    the call reported, the second clock's tuned smoothing where it ran. Returns the fields
    and the fitted points' times."""
    import vojax
    from vojax._tracker._blocks import block_average, block_size

    fit, other = _CAP["result"], _CAP.get("other")
    t = np.asarray(t, float)
    # the blocks the answer was fitted on (a long record's refit on shorter ones included)
    size = int(getattr(res.diagnostics, "block", 0)) or block_size(
        t.size, vojax.TrackerSettings().max_points)
    t_fit = t if size == 1 else block_average(t, size)
    d = res.diagnostics
    return dict(
        block=size, seconds=seconds, identified=bool(d.identified), reasons=tuple(d.reasons),
        verdict=getattr(d, "verdict", None),
        breakdown_drift=getattr(d, "breakdown_drift", None),
        truth=_compact(np.interp(t_fit, t, alpha)), alpha=_compact(fit.alpha),
        lower=_compact(fit.alpha_lower), upper=_compact(fit.alpha_upper),
        std=_compact(fit.alpha_std), bounds=tuple(res.alpha_bounds),
        explanations=[dict(kind=e.kind, beta=_compact(e.beta), var=_compact(e.var),
                           chi2=e.chi2, dof=e.dof, evidence=e.evidence, drift=e.drift,
                           accepted=e.accepted, factor=e.factor, freedom=e.freedom) for e in fit.explanations],
        other_reasons=tuple(r for r in d.reasons if r not in ("wide_band", "trade_off")),
        noise_levels=getattr(fit, "noise_levels", None),
        log_likelihood=fit.tuning.log_likelihood, clock_scale=_CAP.get("scale"),
        # the band the call reported (the second clock weighed in), where every sample is a
        # fitted point
        final=None if size > 1 else dict(lower=_compact(res.alpha_lower),
                                         upper=_compact(res.alpha_upper)),
        # the second clock's tuned smoothing (the data's unit of time), where it ran
        other=None if other is None else dict(
            alpha=_compact(other.alpha), lower=_compact(other.alpha_lower),
            upper=_compact(other.alpha_upper), log_likelihood=other.tuning.log_likelihood,
            converged=bool(other.converged)),
    ), t_fit


def _record(family, index, setting, data):
    import jax

    jax.config.update("jax_enable_x64", True)
    import bench_calibration as bench

    import vojax

    if "signals" not in _CAP:
        _CAP["signals"] = bench.real_signals(Path(data))
    _watch()
    case = bench.draw_case(family, index, _CAP["signals"])
    grid = dict(t=case["t"]) if case["irregular"] else dict(dt=float(case["t"][1] - case["t"][0]))
    kwargs = dict(SETTINGS.get(setting, {}))
    if setting == "stated":
        kwargs = dict(parameters=case["stated"])
    started = time.perf_counter()
    _CAP.pop("other", None)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            res = vojax.identify(case["u"], case["y"], warn=False, **grid, **kwargs)
        except ValueError as e:
            return dict(family=family, index=index, setting=setting, error=str(e))
    fields, _ = _saved(res, case["t"], case["alpha"], time.perf_counter() - started)
    return dict(
        family=family, index=index, setting=setting, samples=case["samples"],
        shape=case["shape"], true_drift=case["true_drift"], stated=case.get("stated"),
        drift=case["drift"], noise=case["noise"], rho=case["rho"],
        case_noise=float(np.var(case["y"] - case["x"])), **fields)


def _demo_record(seed):
    """The demo's record (the paper's simulation study, noise `seed`) under the default
    tracker, saved like a suite record (family ``demo``, setting ``free``); its scores are
    taken after t = 50 (``scored_from``, the first fitted point there), as the demo's test
    takes them."""
    import jax

    jax.config.update("jax_enable_x64", True)
    import vojax
    from vojax._study import STUDY_DT, simulate_study

    _watch()
    data = simulate_study(STUDY_DT, seed)
    started = time.perf_counter()
    _CAP.pop("other", None)
    res = vojax.identify(data["u"], data["y"], STUDY_DT, warn=False)
    fields, t_fit = _saved(res, data["t"], data["alpha"], time.perf_counter() - started)
    return dict(family="demo", index=seed, setting="free", samples=np.asarray(data["t"]).size,
                shape="paper", true_drift=0.0, stated=None, drift=0.0, noise=None, rho=0.0,
                scored_from=int(np.searchsorted(t_fit, 50.0, "right")), **fields)


def _job(args):
    family, index, settings, data = args
    return [_record(family, index, s, data) for s in settings]


def dump(directory, first, per_family, workers, data, families, settings):
    import multiprocessing as mp

    import bench_calibration as bench

    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    jobs = [(f, i, settings, data) for i in range(first, first + per_family)
            for f in (families or bench.FAMILIES)]
    rows = []
    began = time.perf_counter()
    with mp.get_context("spawn").Pool(workers) as pool:
        for out in pool.imap_unordered(_job, jobs):
            rows.extend(out)
            for r in out:
                print(f"{r['family']:20s} {r['index']:3d} {r['setting']:12s} "
                      f"{'ID' if r.get('identified') else '--'} {r.get('seconds', 0):.1f}s",
                      flush=True)
    path = directory / f"explanations_{first}_{first + per_family - 1}.pkl.gz"
    with gzip.open(path, "wb") as f:
        pickle.dump(rows, f)
    print(f"-> {path}: {len(rows)} records, {time.perf_counter() - began:.0f} s, "
          f"{os.cpu_count()} CPUs, {workers} workers")


def load(directories):
    rows = []
    for d in directories:
        for path in sorted(Path(d).glob("explanations_*.pkl.gz")):
            with gzip.open(path, "rb") as f:
                rows.extend(pickle.load(f))
    return [r for r in rows if "error" not in r]


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--dump", default=None)
    parser.add_argument("--evaluate", nargs="*", default=None)
    parser.add_argument("--first", type=int, default=0)
    parser.add_argument("--per-family", type=int, default=12)
    parser.add_argument("--families", nargs="*", default=None)
    parser.add_argument("--settings", nargs="*", default=["free", "constant", "constant-x0"])
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--out", default=None)
    parser.add_argument("--rules", nargs="*", default=None,
                        help="score only the rules whose names contain one of these words")
    parser.add_argument("--data", default=None, help="the recordings (default ../shared/data)")
    parser.add_argument("--demo-seeds", nargs="*", type=int, default=None,
                        help="with --dump: the demo's record at these noise seeds instead of "
                        "the suite's draws (explanations_demo.pkl.gz)")
    args = parser.parse_args(argv)
    import bench_calibration as bench

    if args.dump and args.demo_seeds is not None:
        rows = [_demo_record(seed) for seed in args.demo_seeds]
        Path(args.dump).mkdir(parents=True, exist_ok=True)
        with gzip.open(Path(args.dump) / "explanations_demo.pkl.gz", "wb") as f:
            pickle.dump(rows, f)
    elif args.dump:
        dump(args.dump, args.first, args.per_family, args.workers, args.data or str(bench.DATA),
             args.families, args.settings)
    if args.evaluate:
        from band_scores import report

        report(load(args.evaluate), args.out, args.rules)


if __name__ == "__main__":
    main()
