"""Polypropylene creep (../shared/data/pp-pvc-creep-vo): vojax's order against the published
variable-order springpot fit of Telles Ribeiro & Cunha (Proc. R. Soc. A, 2025).

Their model: ε(t) = σ₀ (t/T)^{β(t)} / (Γ(β(t)+1) E), β(t) = (β∞ (t/γ)^δ + β₀)/((t/γ)^δ + 1).
With the order taken at the evaluation time (NOTES §1), the springpot's creep under a constant
stress is exactly ε = (σ₀/η) t^{q(t)}/Γ(q(t)+1) — the same form — so the comparison is like
for like. The curves are log-spaced in time (10 s … 1e8 s); vojax needs a uniform grid, so each
record is resampled onto N uniform samples and compared where the grid resolves it.

    python scripts/compare_pp_creep.py [--samples 20000] [--data ../shared/data]
"""

import argparse
import csv
from pathlib import Path

import numpy as np


def main():
    import jax

    jax.config.update("jax_enable_x64", True)
    import vojax

    parser = argparse.ArgumentParser()
    parser.add_argument("--data", default=str(Path(__file__).resolve().parents[2] / "shared" / "data"))
    parser.add_argument("--samples", type=int, default=20000)
    args = parser.parse_args()
    folder = Path(args.data) / "pp-pvc-creep-vo"
    rows = list(csv.DictReader(open(folder / "CreepDataPP.csv")))
    loads = sorted({float(r["Load_MPa"]) for r in rows})
    print("| σ₀ (MPa) | t range (s) | refit q (3 knots) at 1e5 / 1e6 / end | published β at 1e5 / 1e6 / end | adaptive q̂ mean, last 50 % | refit NRMSE |")
    print("|---|---|---|---|---|---|")
    for load in loads:
        sel = [r for r in rows if float(r["Load_MPa"]) == load]
        t = np.array([float(r["Time_day"]) for r in sel]) * 86400.0
        eps = np.array([float(r["Strain_dimensionless"]) for r in sel]) / 100.0  # percent
        name = f"{load:g}".rstrip(".")
        pfile = folder / "reference_fits" / f"VOSpringpotParameters_PP_sigma0_{name}MPa.csv"
        if not pfile.is_file():
            continue
        ref = {k: float(v) for k, v in next(csv.DictReader(open(pfile))).items()}
        grid = np.linspace(0.0, t[-1], args.samples)
        dt = grid[1]
        # creep from rest: ε(0) = 0, then the recorded curve (linear in time between samples)
        strain = np.interp(grid, np.r_[0.0, t], np.r_[0.0, eps])
        stress = np.full_like(grid, load)
        fit = vojax.refit(stress, strain, dt, order=3, x0=0.0, order_bounds=(0.01, 0.6))
        res = vojax.identify(stress, strain, dt, gamma="auto", x0=0.0, alpha_bounds=(0.01, 0.6))

        def beta(tt):
            s = (tt / ref["gamma_sec"]) ** ref["delta_dimless"]
            return (ref["beta_inf_dimless"] * s + ref["beta_0_dimless"]) / (s + 1)

        probes = [1e5, 1e6, t[-1]]
        idx = [min(int(round(p / dt)), grid.size - 1) for p in probes]
        q_fit = [float(fit.order[i]) for i in idx]
        q_pub = [beta(grid[i]) for i in idx]
        half = grid > 0.5 * grid[-1]
        nr = float(np.sqrt(np.mean((np.asarray(fit.y_hat) - strain) ** 2)) / np.ptp(strain))
        print(
            f"| {load:g} | 10 … {t[-1]:.2g} | {' / '.join(f'{q:.3f}' for q in q_fit)} | "
            f"{' / '.join(f'{q:.3f}' for q in q_pub)} | {float(np.mean(np.asarray(res.alpha)[half])):.3f} | {nr:.2g} |"
        )



if __name__ == "__main__":
    main()
