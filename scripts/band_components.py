"""What sets the width of the tracker's band on the records it identifies.

For each record of the calibration suite (`bench_calibration.py`) that the default tracker
identifies, over the second half of the record: the order's RMS error, and the RMS of the
standardised error (z) against three standard deviations:

- the tuned smoothing's own (the Laplace band of the posterior mode at the tuned intensities);
- the evidence-weighted mixture of smoothings (`mix_modes`);
- the reported one (`alpha_std`), which also covers the alternatives that explain the data
  (the envelope: other order drifts and drifting parameters) and the trade-off's constant
  orders (`trade_interval`).

Also whether an alternative with the parameters drifting explains the data (and so widens the
band). For a record fitted as block means (more than `max_points` samples) the tuned and
the mixture's standard deviations are interpolated from the blocks' times to the samples'.

Then a summary, records whose parameters are constant (white, noisy, coloured, irregular,
lengths) apart from those whose parameters drift: medians, and how many records have a z RMS
above 2 (confidently wrong by that σ).

    python scripts/band_components.py [--first 0] [--draws 12] [--out FILE]
    python scripts/band_components.py --summarise FILE   # the summary of a results file again
"""

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))


CONSTANT = ("white", "noisy", "coloured", "irregular", "lengths")  # families with p constant
SUMMARY_HEADER = (
    "| parameters | records | z tuned (median) | z tuned > 2 | z mixture (median) | "
    "z reported (median) | z reported > 2 | σ reported ÷ σ tuned (median) | "
    "a drifting alternative fits |"
)


def summarise(lines):
    """The summary table (lines) of the per-record table `lines`."""
    rows = [[c.strip() for c in line.strip().strip("|").split("|")] for line in lines
            if line.startswith("| ") and not line.startswith("| family")
            and not line.startswith("| parameters") and "–" != line.split("|")[5].strip()]
    rows = [r for r in rows if len(r) == 12]
    out = [SUMMARY_HEADER, "|" + "---|" * 9]
    for name, keep in (("constant", True), ("drifting", False)):
        picked = [r for r in rows if (r[0] in CONSTANT) == keep]
        if not picked:
            continue
        tuned, mixed, reported = (np.array([float(r[k]) for r in picked]) for k in (5, 7, 9))
        ratio = np.array([float(r[8]) / float(r[4]) for r in picked])
        fits = sum(r[10] == "yes" for r in picked)
        out.append(
            f"| {name} | {len(picked)} | {np.median(tuned):.2f} | {int(np.sum(tuned > 2))} | "
            f"{np.median(mixed):.2f} | {np.median(reported):.2f} | "
            f"{int(np.sum(reported > 2))} | {np.median(ratio):.1f} | {fits}/{len(picked)} |"
        )
    return out


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--first", type=int, default=0)
    parser.add_argument("--draws", type=int, default=12)
    parser.add_argument("--results", default=str(HERE / "results" / "bench_calibration.json"),
                        help="the suite's results: which records the default identified")
    parser.add_argument("--out", default=None)
    parser.add_argument("--summarise", default=None, metavar="FILE",
                        help="only rewrite FILE's summary from its per-record table")
    args = parser.parse_args(argv)
    if args.summarise:
        path = Path(args.summarise)
        lines = path.read_text().splitlines()
        table = lines[: next((i for i, x in enumerate(lines) if x.startswith("| parameters")),
                             len(lines))]
        while table and not table[-1].strip():
            table.pop()
        text = "\n".join(table + [""] + summarise(table)) + "\n"
        path.write_text(text)
        print(text)
        return

    import jax

    jax.config.update("jax_enable_x64", True)
    import bench_calibration as bench

    import vojax._tracker._track as track
    from vojax._identify import MAX_POINTS
    from vojax._tracker._blocks import block_average, block_size
    from vojax._tracker._model import order_of_np

    seen = {}
    mixture, trade_interval = track.mixture, track.trade_interval

    def spy_mixture(*a, **k):
        out = mixture(*a, **k)
        seen.update(mixture=out, smoothed=a[10], bounds=a[11])
        return out

    def spy_trade(*a, **k):
        out = trade_interval(*a, **k)
        seen["trade"] = out
        return out

    track.mixture, track.trade_interval = spy_mixture, spy_trade
    rows = json.loads(Path(args.results).read_text())
    picked = sorted(
        (r["family"], r["index"]) for r in rows
        if r["method"] == "tracker" and r["identified"]
        and args.first <= r["index"] < args.first + args.draws
    )
    signals = bench.real_signals()
    lines = [
        f"# band_components: the default tracker's identified records of draws "
        f"{args.first}–{args.first + args.draws - 1} ({len(picked)} records, from "
        f"{Path(args.results).name}); second half of each record; z = RMS of (α̂ − α)/σ",
        "| family | draw | samples | order RMS | σ tuned (median) | z tuned | σ mixture | "
        "z mixture | σ reported | z reported | drifting alternative fits | trade interval |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    began = time.perf_counter()
    for family, index in picked:
        seen.clear()
        case = bench.draw_case(family, index, signals)
        out = bench.run_method("tracker", case)
        alpha, std = out[0], out[1]
        truth, half = case["alpha"], case["t"] > case["t"][-1] / 2
        err = (alpha - truth)[half]

        def z(sd):
            return float(np.sqrt(np.mean((err / sd[half]) ** 2)))

        cells = [family, str(index), str(case["samples"]),
                 f"{np.sqrt(np.mean(err**2)):.4f}"]
        sm = seen.get("smoothed")
        if sm is not None:
            theta = np.asarray(sm.theta)[:, 0]
            _, slope = order_of_np(theta, seen["bounds"])
            tuned = slope * np.sqrt(np.maximum(np.asarray(sm.cov)[:, 0, 0], 0.0))
            variance, _, _, drifting = seen["mixture"]
            mixed = slope * np.sqrt(np.maximum(np.asarray(variance), 0.0))
            if theta.shape[0] != alpha.shape[0]:  # block means: onto the samples' clock
                size = block_size(alpha.shape[0], MAX_POINTS)
                assert 1 + -(-(alpha.shape[0] - 1) // size) == theta.shape[0]
                t_b = block_average(np.asarray(case["t"], float), size)
                tuned, mixed = (np.interp(case["t"], t_b, a) for a in (tuned, mixed))
            trade = seen.get("trade")
            cells += [f"{np.median(tuned[half]):.4f}", f"{z(tuned):.2f}",
                      f"{np.median(mixed[half]):.4f}", f"{z(mixed):.2f}",
                      f"{np.median(std[half]):.4f}", f"{z(std):.2f}",
                      "yes" if drifting else "no",
                      "none" if trade is None else f"{trade[0]:.3f}–{trade[1]:.3f}"]
        else:  # not smoothed with the mixture (no tuned intensities)
            cells += ["–"] * 4 + [f"{np.median(std[half]):.4f}", f"{z(std):.2f}", "–", "–"]
        lines.append("| " + " | ".join(cells) + " |")
        print(lines[-1], flush=True)
    lines.append(f"# {time.perf_counter() - began:.0f} s")
    text = "\n".join(lines + [""] + summarise(lines)) + "\n"
    if args.out:
        Path(args.out).write_text(text)
    print(text)


if __name__ == "__main__":
    main()
