"""Which recorded loading protocol identifies a variable order best, and what a designed
protocol of the same duration and peak load would give: the Cramér–Rao band of the order
(`vojax.fisher_information`, 3 knots), at each record's own constant-order refit (order,
parameter, noise), for the input as recorded and for an optimised ramp–hold and a
three-step staircase of the same duration and peak (`vojax.optimal_protocol`).

    python scripts/design_protocols.py [--samples 300] [--figure FILE] [--data DIR]

Records: the adhesive staircase and the myocardium ramp–hold shipped with vojax, and a beef
ramp–hold (specimen 1 of ../shared/data, where present). Each is resampled linearly onto
`--samples` uniform samples over its duration. Prints a table; draws the bands.
"""

import argparse
import warnings
from pathlib import Path

import jax

jax.config.update("jax_enable_x64", True)
import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402

import vojax  # noqa: E402
from vojax.io import example_file, load_records  # noqa: E402

DATA = Path(__file__).resolve().parents[2] / "shared" / "data"


def records(data):
    out = []
    (adh,) = load_records(example_file("adhesive"), time="time_s",
                          inputs=["nominal_shear_stress_kPa"], output="shear_strain")
    out.append(("adhesive staircase", adh))
    (myo,) = load_records(example_file("myocardium"), time="Time", inputs=["F"], output="L")
    out.append(("myocardium ramp–hold", myo))
    beef = Path(data) / "beef-indentation-relaxation" / "beef_indentation_relaxation.csv"
    if beef.is_file():
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            recs = load_records(beef, time="time_s", inputs=["force_N"], output="displacement_mm",
                                group_by="specimen", trim_column="force_N", trim_below=0.02)
        out.append(("beef ramp–hold", recs[0]))
    return out


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--samples", type=int, default=300)
    parser.add_argument("--figure", default=None)
    parser.add_argument("--data", default=str(DATA))
    args = parser.parse_args()
    n = args.samples
    rows, curves = [], []
    for name, rec in records(args.data):
        t = np.linspace(0.0, rec.time[-1], n)
        dt = t[1]
        u = np.interp(t, rec.time, rec.inputs[:, 0])
        y = np.interp(t, rec.time, rec.output)
        fit = vojax.refit(u, y, dt)
        q, p, sd = fit.order_value, np.asarray(fit.p), float(fit.sigma)
        peak, span = float(np.max(np.abs(u))), float(t[-1])
        sign = 1.0 if np.max(u) >= -np.min(u) else -1.0
        recorded = vojax.fisher_information(u, q, p, dt, noise_std=sd, knots=3)

        def ramp_hold(params, times, peak=peak, sign=sign):
            return sign * peak * jnp.minimum(times / params[0], 1.0)

        def staircase(params, times, peak=peak, sign=sign, span=span):
            # three steps of 1/3 of the test each, heights params (0 … peak), ramps of 2 % of it
            edges = span * jnp.array([0.0, 1 / 3, 2 / 3])
            rise = 0.02 * span
            level = jnp.zeros_like(times)
            previous = 0.0
            for k in range(3):
                frac = jnp.clip((times - edges[k]) / rise, 0.0, 1.0)
                level = level + (params[k] - previous) * frac
                previous = params[k]
            return sign * level

        best_r, ramp = vojax.optimal_protocol(ramp_hold, [0.2 * span], [0.01 * span], [span], q, p,
                                              dt, noise_std=sd, knots=3, num_samples=n)
        best_s, stairs = vojax.optimal_protocol(
            staircase, [0.3 * peak, 0.6 * peak, 0.9 * peak], [0.0] * 3, [peak] * 3, q, p, dt,
            noise_std=sd, knots=3, num_samples=n,
        )
        rows.append((name, q, recorded.order_band, ramp.order_band, best_r[0] / span,
                     stairs.order_band, best_s / peak))
        curves.append((name, t, recorded, ramp, stairs))
    print(f"{n} samples per record; order band: the predicted ±2σ of α(t) (3 knots), median "
          "over the second half, at each record's refit (order, parameter, noise)\n")
    print("| record | refit order | recorded protocol | ramp–hold (rise / duration) | "
          "staircase (heights / peak) | recorded / best designed |")
    print("|---|---|---|---|---|---|")
    for name, q, rec_b, ramp_b, rise, stair_b, heights in rows:
        print(f"| {name} | {q:.3f} | ±{rec_b:.3g} | ±{ramp_b:.3g} ({rise:.2f}) | ±{stair_b:.3g} "
              f"({', '.join(f'{h:.2f}' for h in heights)}) | {rec_b / min(ramp_b, stair_b):.2f} |")
    if args.figure:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, axes = plt.subplots(1, len(curves), figsize=(4.2 * len(curves), 3.4))
        for ax, (name, t, rec, ramp, stairs) in zip(np.atleast_1d(axes), curves):
            for d, label, style in ((rec, "recorded", "k-"), (ramp, "ramp–hold", "C0--"),
                                    (stairs, "staircase", "C3:")):
                ax.plot(t, 2 * d.order_stderr, style, label=label)
            ax.set(title=name, xlabel="time (s)", ylabel="predicted ±2σ of α(t)", yscale="log")
            ax.legend(fontsize=8)
        fig.tight_layout()
        fig.savefig(args.figure, dpi=110)
        print(f"\nfigure: {args.figure}")


if __name__ == "__main__":
    main()
