"""Fractional Kelvin–Voigt fits of the passive myocardium ramp–hold records
(../shared/data/myocardium-ramp-hold), on their own clock (linear in the ramp, log-spaced in
the hold), with and without the sign constraints that keep k ≥ 0 and η > 0, over the whole
record and over the hold phase only (the whole stress history still drives the model).

σ = F (kPa), ε = (L − 0.95)/0.95; the ramp starts at t = 2 s and lasts 0.1, 1, 10 or 100 s.
Intervals are ±2 standard errors (delta method for η and k). NRMSE is the refit's own (the
measured strain in the regressors); "solved" is that of the fitted law solved exactly for
the strain from the stress (`KelvinVoigt.fitted_strain`, a springpot where k is held at
0; "–" where the fit is not physical, η ≤ 0 or k < 0), both over the fitted samples.

    python scripts/myocardium_kelvin_voigt.py [--data DIR] [--out FILE]
"""

import argparse
import time
from pathlib import Path

import numpy as np

DATA = Path(__file__).resolve().parents[2] / "shared" / "data"
RAMPS = {"0.1s": 0.1, "1s": 1.0, "10s": 10.0, "100s": 100.0}


def main():
    import jax

    jax.config.update("jax_enable_x64", True)
    import vojax

    parser = argparse.ArgumentParser()
    parser.add_argument("--data", default=str(DATA))
    parser.add_argument("--out")
    args = parser.parse_args()
    model = vojax.KelvinVoigt()
    lines = [
        "| file | samples | fitted | signs | q ± 2se | η (kPa·s^q) ± 2se | k (kPa) ± 2se | held at 0 "
        "| NRMSE | solved | s |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for prefix in ("AvgRelaxed", "AvgRelaxedMavaSet"):
        for name, ramp in RAMPS.items():
            path = Path(args.data) / "myocardium-ramp-hold" / f"{prefix}_{name}.csv"
            if not path.is_file():
                continue
            (rec,) = vojax.load_records(path, time="Time", inputs=["F"], output="L")
            stress = rec.inputs[:, 0]
            strain = (rec.output - 0.95) / 0.95
            u = model.inputs(stress, strain)
            hold_from = 2.0 + ramp - rec.time_offset  # the record's clock starts at its first sample
            for fitted, window in (("whole", None), ("hold", (hold_from, np.inf))):
                for signs in (None, model.p_signs):
                    started = time.perf_counter()
                    fit = vojax.refit(u, strain, **rec.grid, window=window, p_signs=signs)
                    took = time.perf_counter() - started
                    phys = model.parameters(np.asarray(fit.p))
                    se = model.parameters_stderr(np.asarray(fit.p), np.asarray(fit.p_cov))
                    keep = np.ones(strain.size, bool) if window is None else rec.time >= hold_from
                    res = np.asarray(fit.residuals)[keep]
                    nrmse = np.sqrt(np.mean(res**2)) / np.ptp(strain[keep])
                    held = [n for n, b in zip(model.names, fit.p_at_bound) if b]
                    solved = _solved(model, fit, stress, rec.grid)
                    solved = "–" if solved is None else f"{np.sqrt(np.mean((solved - strain)[keep] ** 2)) / np.ptp(strain[keep]):.3g}"
                    lines.append(
                        f"| {path.stem} | {strain.size} | {fitted} | {'k ≥ 0' if signs else 'free'} "
                        f"| {float(fit.order[0]):.4f} ± {2 * float(fit.order_stderr[0]):.4f} "
                        f"| {float(phys['eta']):.4g} ± {2 * float(se['eta']):.2g} "
                        f"| {float(phys['k']):.4g} ± {2 * float(se['k']):.2g} "
                        f"| {', '.join(held) or '–'} | {nrmse:.3g} | {solved} | {took:.2f} |"
                    )
                    print(lines[-1], flush=True)
    if args.out:
        Path(args.out).write_text("\n".join(lines) + "\n")


def _solved(model, fit, stress, grid):
    """The strain of the fitted law solved exactly (`fitted_strain`), or None where the fit
    is not physical."""
    try:
        return model.fitted_strain(fit, stress, **grid)
    except ValueError:
        return None


if __name__ == "__main__":
    main()
