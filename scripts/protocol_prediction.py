"""Does a planned test's expected tracker band hold? `Design.expected` against the band the
tracker gives on records of the `informative` family.

A planned test has no band of the tracker to scale (the settling test of a refused record
scales its band now, `SettlingTest.expect`), so `fisher_information` states the band the
tracker is expected to give as the Cramér–Rao bound with the parameters free on 8 hat
functions × `TrackerSettings.protocol_factor` (`Design.expected`). Here, per record of the
calibration suite's `informative` family (a recorded input with a superposed sine or chirp;
the parameter constant, drifting inside the integral or as a gain; white or AR(1) noise;
`bench_calibration.draw_case`):

1. the default tracker on it: its band (the median ±2σ half-width over the second half) and
   its order RMS there;
2. the Fisher bound of the same test at the truth (the true order trajectory, one order
   shift, the offset estimated, the parameter's mean, the noise's standard deviation; time
   over the span), with the parameters free on 8 hat functions (``bound``) and on 4
   (``bound 4``, not used: the factor is calibrated on 8);
3. the ratio of the tracker's band to the bound (``band÷bound``, what the factor fits) and to
   `Design.expected` (``÷exp.``).

The summary gives, for the draws the factor was fitted on (``--fit``, default 0–11: the
geometric mean of band÷bound there, the least-squares fit in logs) and the draws after them (held out), the median ratio to the
expectation, how many are within 30 % and within a factor 2, per form (the parameter
constant, drifting inside the integral, drifting as a gain) and per noise (white, AR(1)).

    python scripts/protocol_prediction.py [--first 0] [--count 60] [--fit 12]
        [--data ../shared/data] [--out scripts/results/protocol_prediction.txt]
"""

import argparse
import sys
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from calibration_suite import suite_signals, within  # noqa: E402

FORMS = ("constant", "inside", "gain")  # the `informative` family's index % 3


def one(case):
    import vojax

    t, truth = case["t"], case["alpha"]
    half = t > t[-1] / 2
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = vojax.identify(case["u"], case["y"], t=t, warn=False)
    lower, upper = np.asarray(res.alpha_lower), np.asarray(res.alpha_upper)
    band = float(np.median((upper - lower)[half]) / 2)
    rms = float(np.sqrt(np.mean((np.asarray(res.alpha) - truth)[half] ** 2)))
    common = dict(t=t / t[-1], noise_std=float(np.std(case["y"] - case["x"])))
    p = [float(np.mean(case["p"]))]
    design = vojax.fisher_information(case["u"], truth, p, parameter_knots=8, **common)
    coarse = vojax.fisher_information(case["u"], truth, p, parameter_knots=4, **common)
    return dict(index=case["index"], input=case["input"], shape=case["shape"],
                samples=int(t.size), form=FORMS[case["index"] % 3],
                noise="AR(1)" if case["rho"] > 0 else "white", band=band, rms=rms,
                verdict=res.diagnostics.verdict, bound=design.order_band,
                bound_4=coarse.order_band, expected=design.expected)


def summary(rows, fit):
    """The summary's lines: the factor the fitted draws give, then the ratios to the
    expectation per part of the family."""
    fitted = np.log([r["band"] / r["bound"] for r in rows if r["index"] < fit])
    lines = [f"band÷bound on draws < {fit}: geometric mean {np.exp(np.mean(fitted)):.2f} "
             f"(the least-squares fit in logs: what protocol_factor is), median "
             f"{np.exp(np.median(fitted)):.2f}" if fitted.size else "",
             "", f"{'draws':<10}{'part':<10}{'records':>8}{'median ÷exp.':>14}{'range':>14}"
             f"{'within 30 %':>13}{'within 2×':>11}"]
    for name, chosen in (("fitted", lambda r: r["index"] < fit),
                         ("held out", lambda r: r["index"] >= fit)):
        parts = [("all", lambda r: True)]
        parts += [(f, lambda r, f=f: r["form"] == f) for f in FORMS]
        parts += [(n, lambda r, n=n: r["noise"] == n) for n in ("white", "AR(1)")]
        for part, keep in parts:
            got = np.array([r["band"] / r["expected"] for r in rows if chosen(r) and keep(r)])
            if got.size:
                lines.append(f"{name:<10}{part:<10}{got.size:>8}{np.median(got):>14.2f}"
                             f"{f'{got.min():.2f}–{got.max():.2f}':>14}"
                             f"{within(got, 1.3):>13.2f}{within(got, 2.0):>11.2f}")
    return lines


def main(argv=None):
    import bench_calibration as bc

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--first", type=int, default=0)
    parser.add_argument("--count", type=int, default=60)
    parser.add_argument("--fit", type=int, default=12,
                        help="draws below this index are those the factor was fitted on")
    parser.add_argument("--data", type=Path, default=bc.DATA)
    parser.add_argument("--out", type=Path, default=None)
    args = parser.parse_args(argv)
    signals = suite_signals(args.data)
    import vojax

    lines = [f"{'#':>3} {'input':<26}{'shape':<9}{'form':<9}{'noise':<6}{'N':>6}{'band':>8}"
             f"{'rms':>8}{'bound':>9}{'bound 4':>9}{'band÷bound':>11}{'expected':>9}"
             f"{'÷exp.':>7}  verdict"]
    print(lines[0], flush=True)
    rows, start = [], time.perf_counter()
    for index in range(args.first, args.first + args.count):
        r = one(bc.draw_case("informative", index, signals))
        rows.append(r)
        lines.append(f"{index:>3} {r['input'][:25]:<26}{r['shape']:<9}{r['form']:<9}"
                     f"{r['noise']:<6}{r['samples']:>6}{r['band']:>8.3f}{r['rms']:>8.4f}"
                     f"{r['bound']:>9.4f}{r['bound_4']:>9.4f}{r['band'] / r['bound']:>11.1f}"
                     f"{r['expected']:>9.3f}{r['band'] / r['expected']:>7.2f}  {r['verdict']}")
        print(lines[-1], flush=True)
    lines += ["", *summary(rows, args.fit), "",
              f"protocol_factor {vojax.TrackerSettings().protocol_factor}; "
              f"{time.perf_counter() - start:.0f} s"]
    if args.out:
        args.out.write_text(
            f"# python scripts/protocol_prediction.py --first {args.first} --count "
            f"{args.count} --fit {args.fit} ({time.strftime('%Y-%m-%d')}, 2-core CPU)\n"
            + "\n".join(lines) + "\n")
    print("\n".join(lines[-12:]))


if __name__ == "__main__":
    main()
