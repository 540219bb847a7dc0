"""Does the settling test keep its promise? The band a refusal predicts against the band the
tracker then gives.

A refused record names a test (`vojax.settling_test`, through the batch's
`settling_part`): "an oscillation of A at f from t0 would give about ±b whatever the
parameters do". Here the promise is tried on semi-synthetic records with a known truth:

1. a record of the calibration suite's single-input families (`white`: the parameter
   constant; `drift`: drifting by 10–40 % inside the integral; `bench_calibration.draw_case`);
2. the default tracker on it, and the settling test from its answer (the library's own
   route, `vojax._data._parts.settling_part`): the predicted band ``b``;
3. the same truth (order, parameter, noise realisation) driven by the input with that
   oscillation superposed, computed by `vojax.reference`'s direct sums on the record's own
   clock, and the default tracker on it: the realised band (the median ±2σ half-width over
   the second half), its coverage of the truth and its order RMS there; the conditional
   band (``cond.``: the band that holds while the parameters drift less than the breakdown
   drift, ``breaks``) beside it.

The table gives, per record, the tracker's band before (``before``), the band the Fisher
information predicts without the oscillation (``without``) and with it (``predicted``), the
realised band and its ratio to the prediction; the band the tracker was expected to give
(``expected``: its band before scaled by the bound's narrowing, `SettlingTest.expect`) and
the realised band's ratio to it (``÷exp.``); the median ratios per family and pooled, and
how many are within 30 % and within a factor 2. Records whose first run identified the order get no settling
test (the batch does not propose one) and are listed as such.

    python scripts/settling_prediction.py [--first 0] [--per-family 6] [--families white drift]
        [--data ../shared/data] [--out scripts/results/settling_prediction.txt]
"""

import argparse
import sys
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from calibration_suite import suite_signals, within  # noqa: E402


def _band(res, half):
    lower, upper = np.asarray(res.alpha_lower), np.asarray(res.alpha_upper)
    return float(np.median((upper - lower)[half]) / 2)


def one(case):
    import vojax
    from vojax import reference
    from vojax._data._parts import settling_part

    t, u, y, truth = case["t"], case["u"], case["y"], case["alpha"]
    dt = float(t[1] - t[0])
    half = t > t[-1] / 2
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        first = vojax.identify(u, y, dt, warn=False)
    row = dict(family=case["family"], index=case["index"], input=case["input"],
               shape=case["shape"], samples=int(t.size), band_before=_band(first, half),
               verdict_before=first.diagnostics.verdict)
    if first.diagnostics.identified:
        return row
    test = settling_part(u, y, first, t)
    if test is None:
        row["note"] = "no oscillation determines the order"
        return row
    wave = np.where(t >= test["start"],
                    np.sin(2 * np.pi * test["frequency"] * (t - test["start"])), 0.0)
    u2 = u + test["amplitude"] * wave
    # the truth on the record's own clock, time over the span as the suite's draws
    x2 = np.asarray(reference.fractional_integral(case["p"] * u2, truth, dt / t[-1],
                                                  memory="direct"))
    y2 = x2 + (y - case["x"])  # the same noise realisation
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        second = vojax.identify(u2, y2, dt, warn=False)
    alpha = np.asarray(second.alpha)
    inside = (truth >= np.asarray(second.alpha_lower)) & (truth <= np.asarray(second.alpha_upper))
    row.update(predicted=float(test["band"]), without=float(test["band_without"]),
               expected=np.nan if test["expected"] is None else float(test["expected"]),
               realised=_band(second, half),
               cycles=int(test["cycles"]), coverage=float(np.mean(inside[half])),
               rms=float(np.sqrt(np.mean((alpha - truth)[half] ** 2))),
               verdict_after=second.diagnostics.verdict,
               breakdown=float(second.diagnostics.breakdown_drift))
    if second.conditional is not None:  # the band while the parameters drift less than that
        row["conditional"] = _band(second.conditional, half)
    row["ratio"] = row["realised"] / row["predicted"]
    row["ratio_expected"] = row["realised"] / row["expected"]
    return row


def main(argv=None):
    import bench_calibration as bc

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--first", type=int, default=0)
    parser.add_argument("--per-family", type=int, default=6)
    parser.add_argument("--families", nargs="+", default=["white", "drift"])
    parser.add_argument("--data", type=Path, default=bc.DATA)
    parser.add_argument("--out", type=Path, default=None)
    args = parser.parse_args(argv)
    signals = suite_signals(args.data)
    lines = [f"{'family':<8}{'#':>3} {'input':<26}{'shape':<9}{'N':>6}{'before':>9}"
             f"{'without':>9}{'predicted':>10}{'realised':>10}{'ratio':>7}{'expected':>9}{'÷exp.':>7}"
             f"{'cover':>7}{'rms':>8}{'cond.':>8}"
             f"{'breaks':>8}  after"]
    rows = []
    start = time.perf_counter()
    for family in args.families:
        for index in range(args.first, args.first + args.per_family):
            row = one(bc.draw_case(family, index, signals))
            rows.append(row)
            if "predicted" in row:
                lines.append(
                    f"{family:<8}{index:>3} {row['input'][:25]:<26}{row['shape']:<9}"
                    f"{row['samples']:>6}{row['band_before']:>9.3f}{row['without']:>9.3f}"
                    f"{row['predicted']:>10.3f}"
                    f"{row['realised']:>10.3f}{row['ratio']:>7.2f}{row['expected']:>9.3f}"
                    f"{row['ratio_expected']:>7.2f}{row['coverage']:>7.2f}"
                    f"{row['rms']:>8.4f}{row.get('conditional', np.nan):>8.3f}"
                    f"{row['breakdown']:>8.2f}  {row['verdict_after']}")
            else:
                lines.append(f"{family:<8}{index:>3} {row['input'][:25]:<26}{row['shape']:<9}"
                             f"{row['samples']:>6}{row['band_before']:>9.3f}  "
                             f"{row.get('note', row['verdict_before'] + ': no test proposed')}")
            print(lines[-1], flush=True)
    lines.append("")
    for name in [*args.families, "pooled"]:
        got = [r for r in rows if "ratio" in r and (name == "pooled" or r["family"] == name)]
        if got:
            ratios = np.array([r["ratio"] for r in got])
            share = within(ratios, 1.3)
            expected = np.array([r["ratio_expected"] for r in got])
            known = expected[np.isfinite(expected)]
            near = (f"{np.median(known):.2f} (range {known.min():.2f}–{known.max():.2f}), "
                    f"within 30 %: {within(known, 1.3):.2f}, "
                    f"within 2x: {within(known, 2.0):.2f}"
                    if known.size else "none expected")
            lines.append(
                f"{name:<8} tests {len(got):>2}: realised/predicted median {np.median(ratios):.2f} "
                f"(range {ratios.min():.2f}–{ratios.max():.2f}), within 30 %: {share:.2f}; "
                f"realised/expected median {near}; "
                f"identified after: {sum(r['verdict_after'] == 'identified' for r in got)}, "
                f"median coverage {np.median([r['coverage'] for r in got]):.2f}")
    lines.append(f"wall time {time.perf_counter() - start:.0f} s")
    text = "\n".join(lines)
    print("\n".join(lines[-(len(args.families) + 3):]))
    if args.out:
        args.out.write_text(text + "\n")


if __name__ == "__main__":
    main()
