"""Whether the moving-order search's second start can be skipped where it would repeat the
first: the two starts of ``TrackerSettings(moving_base="both")`` compared record by record.

The breakdown drift's moving-order search (`vojax._tracker._moving`) moves the answer's
projection on the order's hats, or with ``moving_base=True`` the answer itself, keeping the
part of its shape the hats cannot follow. Where that part is small the two searches start
almost at the same order, so one might expect the same least drift, and the second search
(which makes a warm call 6–7 % longer) could be skipped below a tolerance on that part. For
each record of the families named (the suite's draws, the parameters stated constant or
free), this runs `identify` with ``"both"`` and logs each search's least drift and the
largest kept part (in order units). The table gives, for each tolerance, how many answer
searches would still run and how many of those skipped would have found a least drift more
than 10 % below the projected one.

With ``--restarts K`` the projected search also runs again from K random starts (its hats'
weights θ₀ each moved by a normal draw of `--spread`, seed 0 per record), so that a search
that ends where it starts (a local one) shows as a spread of least drifts; a second table
gives each fit's least drifts side by side. ``--records drift:17 ...`` names the records.

    python scripts/moving_starts.py [--first 12] [--draws 12] [--parameters constant]
        [--families drift gain-drift ...] [--records FAMILY:INDEX ...] [--restarts 0]
        [--spread 0.05] [--out FILE] [--json FILE] [--from JSON]
"""

import argparse
import json
import sys
import time

import numpy as np
from _bench import publish

FAMILIES = ["drift", "gain-drift", "stated-drift", "informative", "drift-constant",
            "gain-drift-constant", "white", "long"]
TOLERANCES = (0.0, 0.005, 0.01, 0.02, 0.03, 0.05)
APART = 0.1  # two least drifts differ where one is more than this fraction below the other
FLOOR = 0.005  # … each counted at least this (`TrackerSettings.drift_floor`: below it, none)
NEAR = 0.05  # a random start comes near the projected search's least drift within this


def run(records, parameters, restarts=0, spread=0.05):
    """One row per record (`records`: ``(family, index)``): family, index, true drift,
    verdict, breakdown drift, for each fit that searched moving orders `_pairs` of its
    searches, and with `restarts` each fit's least drift from each random start."""
    import jax

    jax.config.update("jax_enable_x64", True)
    from calibration_suite import draw_case, suite_signals

    import vojax
    from vojax._tracker import _fit, _moving

    signals, log, again = suite_signals(), [], []
    orders, moves = _fit.moving_orders, _moving._moves

    def logged_orders(profile, band, half):  # one fit's searches: a list of its own
        log.append([])
        found = orders(profile, band, half)
        if restarts and profile.forms:
            rng = np.random.default_rng(0)
            band, theta0, answer = _moving.start_of(profile, band)
            again.append([min((e.drift for row in profile.forms for e in moves(
                profile, band, half, theta0 + spread * rng.standard_normal(theta0.size),
                np.zeros_like(answer), row)), default=np.inf) for _ in range(restarts)])
        return found

    def logged(profile, band, half, theta0, base, row):
        found = moves(profile, band, half, theta0, base, row)
        log[-1].append((float(np.max(np.abs(base[: profile.span]))),
                        min((e.drift for e in found), default=np.inf)))
        return found

    _fit.moving_orders, _moving._moves = logged_orders, logged
    rows = []
    for family, index in records:
        case = draw_case(family, index, signals)
        grid = (dict(t=case["t"]) if case["irregular"]
                else dict(dt=float(case["t"][1] - case["t"][0])))
        log.clear()
        again.clear()
        res = vojax.identify(case["u"], case["y"], warn=False, parameters=parameters,
                             settings=vojax.TrackerSettings(moving_base="both"), **grid)
        rows.append(dict(family=family, index=index, true_drift=case["true_drift"],
                         verdict=res.diagnostics.verdict,
                         breakdown_drift=res.diagnostics.breakdown_drift,
                         searches=_pairs(log), restarts=list(again)))
        print(json.dumps(rows[-1]), file=sys.stderr, flush=True)
    return rows


def _pairs(log):
    """Each fit's searches as ``[kept, projected's least drift, answer's least drift]``:
    every form moved from the projection, then every form from the answer."""
    out = []
    for fit in filter(None, log):  # a fit without forms to search has no searches
        k = len(fit) // 2
        out.append([fit[k][0], min(d for _, d in fit[:k]), min(d for _, d in fit[k:])])
    return out


def table(rows):
    """The report's lines: per tolerance, the answer searches run and those skipped that
    would have found a least drift more than `APART` below the projected one."""
    pairs = [(r["family"], r["index"], p[0], max(p[1], FLOOR), max(p[2], FLOOR))
             for r in rows for p in r["searches"]]
    lower = [p for p in pairs if p[4] < (1 - APART) * p[3]]
    higher = [p for p in pairs if p[4] > (1 + APART) * p[3]]
    small = [p for p in pairs if p[2] <= 0.01]
    apart = [p for p in lower + higher if p[2] <= 0.01]
    lines = ["| kept part at most | answer searches run | skipped, the answer's least drift "
             f"more than {APART:.0%} lower |", "|---|---|---|"]
    for tol in TOLERANCES:
        run_ = sum(p[2] > tol for p in pairs)
        lost = [f"{p[0]} {p[1]}" for p in lower if p[2] <= tol]
        lines.append(f"| {tol:g} | {run_}/{len(pairs)} | {len(lost)}"
                     + (f" ({', '.join(lost[:6])}{', …' if len(lost) > 6 else ''})" if lost
                        else "") + " |")
    kept = np.median([p[2] for p in pairs])
    lines += ["", f"{len(rows)} records, {len(pairs)} pairs of searches; the answer's least "
              f"drift more than {APART:.0%} below the projected one's on {len(lower)}, more "
              f"than {APART:.0%} above on {len(higher)}; the kept part's median {kept:.3f}. "
              f"Where it is at most 0.01 ({len(small)} pairs), the two least drifts still "
              f"differ by more than {APART:.0%} on {len(apart)}"
              + (": the kept shape, held under every move and never fitted, moves the "
                 "least drift however small it is." if apart else ".")]
    return lines


def restart_table(rows):
    """The report's lines for fits searched again from random starts: the projected and the
    answer's search's least drifts and the random starts' (least, largest), and how many
    fits' random starts find none more than `NEAR` below the projected search's."""
    fits = [(r, p, a) for r in rows for p, a in zip(r["searches"], r.get("restarts", []))]
    if not fits:
        return []
    lines = ["| record | true drift | kept part | projected | answer | random starts "
             "(least – largest) |", "|---|---|---|---|---|---|"]
    near = 0
    for r, (kept, projected, answer), starts in fits:
        near += min(max(d, FLOOR) for d in starts) >= (1 - NEAR) * max(projected, FLOOR)
        lines.append(f"| {r['family']} {r['index']} | {r['true_drift']:.3f} | {kept:.3f} | "
                     f"{projected:.3f} | {answer:.3f} | {min(starts):.3f} – "
                     f"{max(starts):.3f} |")
    return ["", *lines, "", f"Random starts of the projected search: none more than "
            f"{NEAR:.0%} below its least drift on {near} of {len(fits)} fits."]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--families", nargs="+", default=FAMILIES)
    ap.add_argument("--first", type=int, default=12)
    ap.add_argument("--draws", type=int, default=12)
    ap.add_argument("--records", nargs="+", help="FAMILY:INDEX, instead of the draws")
    ap.add_argument("--parameters", default="constant", choices=["constant", "free"])
    ap.add_argument("--restarts", type=int, default=0)
    ap.add_argument("--spread", type=float, default=0.05)
    ap.add_argument("--out", help="write the report to this file")
    ap.add_argument("--json", help="write the rows to this file")
    ap.add_argument("--from", dest="source", help="tabulate these saved rows, run nothing")
    args = ap.parse_args(argv)
    if args.source:
        with open(args.source) as f:
            saved = json.load(f)
        rows, head = saved["rows"], saved["head"]
    else:
        start = time.perf_counter()
        records = ([(f, int(i)) for f, i in (r.split(":") for r in args.records)]
                   if args.records else [(f, i) for f in args.families
                                         for i in range(args.first, args.first + args.draws)])
        rows = run(records, args.parameters, args.restarts, args.spread)
        what = (" ".join(args.records) if args.records else
                f"families {' '.join(args.families)}, draws {args.first}–"
                f"{args.first + args.draws - 1}")
        head = (f"# moving_starts: {what}, parameters {args.parameters}, moving_base=\"both\""
                + (f", {args.restarts} random starts ±{args.spread:g}" if args.restarts
                   else "")
                + f"; {time.perf_counter() - start:.0f} s wall, {time.strftime('%Y-%m-%d')}")
        if args.json:
            with open(args.json, "w") as f:
                json.dump(dict(head=head, rows=rows), f)
    publish([head, *table(rows), *restart_table(rows)], args.out)


if __name__ == "__main__":
    main()
