"""Rules for the tracker's band, compared on the calibration suite without re-running it.

The tracker's reported band is assembled from parts (`vojax._tracker._track`): the tuned
smoothing's Laplace band, the evidence-weighted mixture of smoothings, the ±2σ bands of the
alternatives whose residuals pass a χ² test (other starts, other order drifts, drifting
parameters; where the parameters are constant, stated or tuned, the level profile's held
scales), and the trade-off's constant orders. `--dump` runs both settings of the tracker on the suite's draws
(`bench_calibration.draw_case`) and saves every part, on the clock the tracker fitted (block
means of a long record), over the second half of the record, with the truth there and the
arguments of the verdict (`vojax._identify.diagnose`). `--evaluate` then builds the band by
each rule below from the saved parts and scores it as the suite does: per family and pooled,
the records identified, the coverage of the ±2σ band, the median z RMS, the confidently wrong.

    python scripts/band_rules.py --dump DIR [--first 0] [--per-family 12] [--workers 2]
    python scripts/band_rules.py --evaluate DIR [DIR ...] [--out FILE]

The dump is a measurement tool: its scores are on the fitted clock (a block mean's time for a
long record), not on every sample as `bench_calibration.py` scores them.
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

from _bench import publish  # noqa: E402

SETTINGS = ("drifting", "constant")
CONSTANT_FAMILIES = ("white", "noisy", "coloured", "irregular", "lengths", "long")


# ---------------------------------------------------------------- the dump


def _install_spies(cap):
    """Wrap the tracker's band-building steps so that each call's parts land in `cap`."""
    import vojax._identify as ident
    import vojax._tracker._track as track

    orig = {k: getattr(track, k) for k in (
        "run_mode_shares", "_fitting", "level_profile", "_in_threads", "trade_interval",
        "mixture")}
    orig_diagnose = ident.diagnose

    def mixture(*a, **k):
        cap["tuned"] = a[10]
        cap["bounds"] = a[11]
        cap["hold"] = a[13] if len(a) > 13 else k.get("hold", False)
        cap["starts"] = len(a[9])
        cap["phase"] = "mixture"
        try:
            out = orig["mixture"](*a, **k)
            cap["mix_out"] = out
            return out
        finally:
            cap["phase"] = None

    def run_mode_shares(*a, **k):
        out = orig["run_mode_shares"](*a, **k)
        if cap.get("phase") == "mixture":
            cap["mix_rows"] = [tuple(float(v) for v in r) for r in a[6]]
            cap["mix"] = [np.asarray(o) for o in out]
        return out

    def fitting(*a, **k):
        out = orig["_fitting"](*a, **k)
        cap.setdefault("fitting", []).append((cap.get("phase"), np.asarray(out)))
        return out

    def level_profile(*a, **k):
        cap["phase"] = "level"
        try:
            return orig["level_profile"](*a, **k)
        finally:
            cap["phase"] = None

    def in_threads(fn, count, call, key):
        out = orig["_in_threads"](fn, count, call, key)
        if cap.get("phase") == "level":  # every round of the profile's held scales
            cap.setdefault("level", []).extend(o for _, share in out for o in share)
        return out

    def trade_interval(*a, **k):
        out = orig["trade_interval"](*a, **k)
        cap["trade"] = out
        return out

    def diagnose(*a, **k):
        cap["diagnose"] = (a, k)
        return orig_diagnose(*a, **k)

    track.mixture, track.run_mode_shares, track._fitting = mixture, run_mode_shares, fitting
    track.level_profile, track._in_threads = level_profile, in_threads
    track.trade_interval = trade_interval
    ident.diagnose = diagnose


_CAP: dict = {}


def _record(family, index, setting, data):
    import jax

    jax.config.update("jax_enable_x64", True)
    import bench_calibration as bench

    import vojax
    from vojax._identify import MAX_POINTS
    from vojax._tracker._blocks import block_average, block_size
    from vojax._tracker._model import order_of_np
    from vojax._tracker._smoother import host_score
    from vojax._tracker._track import run_threads

    if not _CAP:
        _CAP["signals"] = bench.real_signals(Path(data))
        _CAP["cap"] = {}
        _install_spies(_CAP["cap"])
    cap = _CAP["cap"]
    cap.clear()
    case = bench.draw_case(family, index, _CAP["signals"])
    grid = dict(t=case["t"]) if case["irregular"] else dict(dt=float(case["t"][1] - case["t"][0]))
    started = time.perf_counter()
    with warnings.catch_warnings(), run_threads(1):
        warnings.simplefilter("ignore")
        try:
            res = vojax.identify(case["u"], case["y"], method="kalman", parameters=setting,
                                 warn=False, **grid)
        except ValueError as e:
            return dict(family=family, index=index, setting=setting, error=str(e))
    seconds = time.perf_counter() - started
    t = np.asarray(case["t"], float)
    size = block_size(t.size, MAX_POINTS)
    t_fit = t if size == 1 else block_average(t, size)
    truth = np.interp(t_fit, t, case["alpha"])
    a, k = cap["diagnose"]
    alpha_fit, lower, upper = (np.asarray(v) for v in a[:3])
    num = alpha_fit.shape[0]
    half = num // 2
    sl = slice(half, num)
    out = dict(
        family=family, index=index, setting=setting, samples=case["samples"], block=size,
        shape=case["shape"], seconds=seconds, identified=bool(res.diagnostics.identified),
        message=res.diagnostics.message, truth=truth[sl], alpha=alpha_fit[sl],
        lower=lower[sl], upper=upper[sl], diagnose=(tuple(a[3:]), k),
        full=(alpha_fit, lower, upper),
        bounds=tuple(a[3]),
    )
    if "tuned" in cap:
        sm = cap["tuned"]
        theta = np.asarray(sm.theta)[:, 0]
        out["tuned"] = dict(beta=theta[sl], var=np.asarray(sm.cov)[sl, 0, 0],
                            score=float(host_score(sm)))
        betas, variances, scores, residuals = cap["mix"]
        fits = [f for ph, f in cap.get("fitting", []) if ph == "mixture"]
        out["mixture"] = dict(
            rows=cap["mix_rows"], starts=cap["starts"], hold=bool(cap["hold"]),
            beta=betas[:, sl], var=variances[:, sl], score=np.asarray(scores),
            fits=fits[0] if fits else None,
            variance=np.asarray(cap["mix_out"][0])[sl],
        )
        if "level" in cap:
            lv = cap["level"]
            fits = [f for ph, f in cap.get("fitting", []) if ph == "level"]
            fits = [np.concatenate(fits)] if fits else []
            out["level"] = dict(
                beta=np.concatenate([np.asarray(o[0]) for o in lv])[:, sl],
                var=np.concatenate([np.asarray(o[1]) for o in lv])[:, sl],
                score=np.concatenate([np.asarray(o[2]) for o in lv]),
                fits=fits[0] if fits else None,
            )
        out["slope"] = order_of_np(theta, out["bounds"])[1][sl]
    out["trade"] = cap.get("trade")
    return out


def _job(args):
    family, index, data = args
    return [_record(family, index, s, data) for s in SETTINGS]


def dump(directory, first, per_family, workers, data, families=None):
    import bench_calibration as bench

    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    jobs = [(f, i, data) for i in range(first, first + per_family)
            for f in (families or bench.FAMILIES)]
    rows = []
    began = time.perf_counter()
    if workers > 1:
        import multiprocessing as mp

        with mp.get_context("spawn").Pool(workers) as pool:
            for out in pool.imap_unordered(_job, jobs):
                rows.extend(out)
                for r in out:
                    print(f"{r['family']:20s} {r['index']:3d} {r['setting']:9s} "
                          f"{'ID' if r.get('identified') else '--'} "
                          f"{r.get('seconds', 0):.1f}s", flush=True)
    else:
        for job in jobs:
            rows.extend(_job(job))
    for setting in SETTINGS:
        path = directory / f"parts_{setting}_{first}_{first + per_family - 1}.pkl.gz"
        with gzip.open(path, "wb") as f:
            pickle.dump([_compact(r) for r in rows if r["setting"] == setting], f)
        print(f"-> {path}")
    print(f"{len(rows)} records, {time.perf_counter() - began:.0f} s, {os.cpu_count()} CPUs, "
          f"{workers} workers")


def _compact(r):
    """The record with its per-sample arrays in float32 (the file's size)."""
    if isinstance(r, dict):
        return {k: _compact(v) for k, v in r.items()}
    if isinstance(r, np.ndarray) and r.dtype == np.float64 and r.ndim >= 1:
        return r.astype(np.float32)
    return r


# ---------------------------------------------------------------- the rules


def _order(beta, bounds):
    lo, hi = bounds
    return lo + (hi - lo) / (1 + np.exp(-beta))


def _union(env, lo, hi):
    if env is None:
        return lo, hi
    return np.minimum(env[0], lo), np.maximum(env[1], hi)


def kinds(r):
    """Each mixture alternative's kind: 'start', 'param', 'held', 'order'."""
    m = r["mixture"]
    out = ["start"] * m["starts"]
    if not m["hold"]:
        out += ["param"] * 3 + ["held"] * 3
    out += ["order"] * (len(m["rows"]) - len(out))
    return np.array(out)


def build(r, rule):
    """The band ``(alpha, lower, upper, sd)`` of record `r` by `rule`, over the second half."""
    bounds = r["bounds"]
    alpha = r["alpha"]
    if "tuned" not in r:
        lower, upper = r["lower"], r["upper"]
        return alpha, lower, upper, (upper - lower) / 4
    tb, tv = r["tuned"]["beta"], np.maximum(r["tuned"]["var"], 0)
    m = r["mixture"]
    scores = np.asarray(m["score"])
    top = r["tuned"]["score"]
    kind = kinds(r)
    fits = m["fits"] if m["fits"] is not None else np.zeros(len(scores), bool)
    finite = np.isfinite(scores)
    gap = top - scores if np.isfinite(top) else np.zeros_like(scores)
    param = np.isin(kind, ("param", "held"))
    plausible = finite & (~param | (gap <= 200.0))
    env = None
    var = tv
    mode = rule.get("mode", "union")
    scale = rule.get("scale", 1.0)
    # the evidence-weighted mixture (as `mix_modes`), recomputed from the parts
    if rule.get("mixture", True):
        var = np.maximum(m["variance"], 0)
    picks = fits & plausible
    if rule.get("floor") is not None:
        picks &= gap <= rule["floor"]
    if rule.get("drop"):
        picks &= ~np.isin(kind, rule["drop"])
    members = [(m["beta"][c], np.maximum(m["var"][c], 0)) for c in np.flatnonzero(picks)]
    if "level" in r and rule.get("level", True):
        lv = r["level"]
        lf = lv["fits"] if lv["fits"] is not None else np.zeros(len(lv["score"]), bool)
        lpick = lf & np.isfinite(lv["score"])
        if rule.get("level_floor") is not None and np.isfinite(top):
            lpick &= (top - lv["score"]) <= rule["level_floor"]
        members += [(lv["beta"][c], np.maximum(lv["var"][c], 0)) for c in np.flatnonzero(lpick)]
    for b, v in members:
        if mode == "union":
            half = 2 * np.sqrt(v)
        elif mode == "means":  # the alternative's mode inside the band, not its band
            half = 2 * np.sqrt(var)
        elif mode == "shift":  # the band about each mode's shift: √(var + shift²)
            d = np.abs(b - tb)
            extra = 2 * np.sqrt(var + d**2)
            env = _union(env, tb - extra, tb + extra)
            continue
        else:
            raise ValueError(mode)
        env = _union(env, b - half, b + half)
    sd_b = scale * np.sqrt(var)
    lower = _order(tb - 2 * sd_b, bounds)
    upper = _order(tb + 2 * sd_b, bounds)
    if env is not None:
        lower = np.minimum(lower, _order(env[0], bounds))
        upper = np.maximum(upper, _order(env[1], bounds))
    trade = r.get("trade")
    if trade is not None and rule.get("trade", True):
        lower, upper = np.minimum(lower, trade[0]), np.maximum(upper, trade[1])
    sd = np.maximum(r["slope"] * sd_b, (upper - lower) / 4)
    return alpha, lower, upper, sd


def verdict(r, lower, upper):
    """`identified` as `diagnose` says it with this band over the second half (the first
    half's as reported: the verdict reads the second half's width only)."""
    from vojax._identify import diagnose

    alpha, lo, hi = (np.array(v, float) for v in r["full"])
    half = alpha.shape[0] // 2
    lo[half:], hi[half:] = lower, upper
    a, k = r["diagnose"]
    return bool(diagnose(alpha, lo, hi, *a, **k).identified)


RULES = {
    "reported: the union": dict(),
    "tuned smoothing": dict(mixture=False, drop=("start", "param", "held", "order"),
                            level=False, trade=False),
    "mixture": dict(drop=("start", "param", "held", "order"), level=False, trade=False),
    "union without other order drifts": dict(drop=("order",)),
    "modes": dict(mode="means"),
    "shifts": dict(mode="shift"),
    "union within 50 nats": dict(floor=50.0),
    "union within 20 nats": dict(floor=20.0),
    "modes within 50 nats": dict(mode="means", floor=50.0),
}


def reproduction(rows):
    """How many records' rebuilt reported band (the first rule) differs from the recorded one
    (by more than 1e-4 in the order), and whose verdict differs."""
    band = verdict_diff = 0
    for r in rows:
        if "error" in r:
            continue
        _, lower, upper, _ = build(r, RULES["reported: the union"])
        band += int(max(np.max(np.abs(lower - r["lower"])), np.max(np.abs(upper - r["upper"])))
                    > 1e-4)
        verdict_diff += int(verdict(r, lower, upper) != r["identified"])
    return (f"reproduction: {band} of {len(rows)} records' rebuilt bands differ from the "
            f"recorded ones by > 1e-4, {verdict_diff} verdicts differ")


def pooled(rows, setting, rule):
    """``(identified, confidently wrong, records)`` of one setting's records by `rule`."""
    ident = wrong = total = 0
    for r in rows:
        if r["setting"] != setting:
            continue
        total += 1
        if "error" in r:
            continue
        alpha, lower, upper, _ = build(r, rule)
        if verdict(r, lower, upper):
            ident += 1
            wrong += int(np.mean((r["truth"] >= lower) & (r["truth"] <= upper)) < 0.5)
    return ident, wrong, total


def summary(groups, rules=RULES):
    """One line per setting and rule: identified and confidently wrong in each group of rows
    (e.g. the tuning draws and the held-out ones)."""
    names = list(groups)
    lines = ["| parameters | band | " + " | ".join(
        f"identified ({n}) | confidently wrong ({n})" for n in names) + " |",
        "|---|---|" + "---|---|" * len(names)]
    for setting in SETTINGS:
        for name, rule in rules.items():
            cells = []
            for n in names:
                ident, wrong, total = pooled(groups[n], setting, rule)
                cells += [f"{ident}/{total}", f"{wrong}"]
            lines.append(f"| {setting} | {name} | " + " | ".join(cells) + " |")
    return lines


def evaluate(rows, rules=RULES):
    lines = [reproduction(rows)]
    families = sorted({r["family"] for r in rows}, key=lambda f: (
        f not in CONSTANT_FAMILIES, f))
    for setting in SETTINGS:
        for name, rule in rules.items():
            lines.append(f"\n### {setting}: {name}")
            lines.append("| family | identified | coverage | z RMS (median) | order RMS (median) "
                         "| confidently wrong |")
            lines.append("|---|---|---|---|---|---|")
            for fam in families + ["pooled"]:
                sel = [r for r in rows if r["setting"] == setting and "error" not in r
                       and (fam == "pooled" or r["family"] == fam)]
                n = len([r for r in rows if r["setting"] == setting
                         and (fam == "pooled" or r["family"] == fam)])
                ident = inside = count = wrong = 0
                zs, rms = [], []
                for r in sel:
                    alpha, lower, upper, sd = build(r, rule)
                    ok = verdict(r, lower, upper)
                    truth = r["truth"]
                    err = alpha - truth
                    rms.append(float(np.sqrt(np.mean(err**2))))
                    if not ok:
                        continue
                    ident += 1
                    cov = (truth >= lower) & (truth <= upper)
                    inside += int(cov.sum())
                    count += cov.size
                    zs.append(float(np.sqrt(np.mean((err / np.maximum(sd, 1e-300)) ** 2))))
                    wrong += int(np.mean(cov) < 0.5)
                lines.append(
                    f"| {fam} | {ident}/{n} | {inside / count if count else float('nan'):.2f} | "
                    f"{np.median(zs) if zs else float('nan'):.2f} | "
                    f"{np.median(rms) if rms else float('nan'):.4f} | {wrong}/{ident} |")
    return lines


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--dump", default=None, metavar="DIR")
    parser.add_argument("--evaluate", nargs="*", default=None, metavar="DIR",
                        help="folders of parts, one per group of draws")
    parser.add_argument("--first", type=int, default=0)
    parser.add_argument("--per-family", type=int, default=12)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--data", default=str(HERE.parents[1] / "shared" / "data"))
    parser.add_argument("--families", nargs="*", default=None)
    parser.add_argument("--note", default=None, help="a line for the results' header")
    parser.add_argument("--out", default=None)
    args = parser.parse_args(argv)
    if args.dump:
        dump(args.dump, args.first, args.per_family, args.workers, args.data, args.families)
    if args.evaluate:
        groups = {}
        for d in args.evaluate:
            rows = []
            for path in sorted(Path(d).glob("parts_*.pkl.gz")):
                with gzip.open(path, "rb") as f:
                    rows.extend(pickle.load(f))
            draws = sorted({r["index"] for r in rows})
            groups[f"draws {draws[0]}–{draws[-1]}"] = rows
        lines = [f"# band_rules: {', '.join(f'{k}: {len(v)} runs' for k, v in groups.items())}"
                 " (both settings); pooled over the families", *(
                     [f"# {args.note}"] if args.note else []), *summary(groups)]
        for name, rows in groups.items():
            lines += ["", f"## {name}", *evaluate(rows)]
        publish(lines, args.out)


if __name__ == "__main__":
    main()
