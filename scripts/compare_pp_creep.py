"""Polypropylene creep (../shared/data/pp-pvc-creep-vo): vojax's order on the native log-spaced
samples against the published variable-order springpot fit of Telles Ribeiro & Cunha
("Advanced creep modelling for polymers: a variable-order fractional calculus approach",
Proc. R. Soc. A, 2025), shipped beside the data.

Their model: ε(t) = σ₀ (t/T)^{β(t)} / (Γ(β(t)+1) E), T = η/E, β(t) = (β∞ (t/γ)^δ + β₀)/((t/γ)^δ + 1).
vojax's springpot with the order taken at the evaluation time gives, under a constant stress,
ε = (σ₀/η) t^{q(t)}/Γ(q(t)+1): the same shape with a constant prefactor, so q(t) and β(t) are
comparable but not identical (their prefactor E^{β−1}/η^β moves with β).

Each record is used as recorded: log-spaced from 10 s, the load applied at t = 0 (`origin=0`),
the strain 0 before loading (x0 = 0). Per stress level:

- a constant order, by `refit(t=…, origin=0)` and by an independent closed-form least squares of
  ε = c t^q/Γ(1+q) on the same samples (golden-section search on q, c linear): they must agree
  to 1e-6 in q;
- a 4-knot order curve (knots evenly in log time) against the published β(t) at 1e2 … 1e7 s.

    python scripts/compare_pp_creep.py [--data ../shared/data] [--out scripts/results/compare_pp_creep.txt]
"""

import argparse
import csv
import math
import time
from pathlib import Path

import numpy as np

from _bench import publish

PROBES = (1e2, 1e3, 1e4, 1e5, 1e6, 1e7)


def closed_form_q(t, eps, load):
    """q minimising Σ (ε − c σ₀ t^q/Γ(1+q))² over the samples, c linear, by golden section."""

    def rss(q):
        a = load * t**q / math.gamma(1 + q)
        c = (a @ eps) / (a @ a)
        return np.sum((eps - c * a) ** 2)

    lo, hi = 0.001, 0.999
    g = (math.sqrt(5) - 1) / 2
    c, d = hi - g * (hi - lo), lo + g * (hi - lo)
    fc, fd = rss(c), rss(d)
    while hi - lo > 1e-13:
        if fc < fd:
            hi, d, fd = d, c, fc
            c = hi - g * (hi - lo)
            fc = rss(c)
        else:
            lo, c, fc = c, d, fd
            d = lo + g * (hi - lo)
            fd = rss(d)
    return 0.5 * (lo + hi)


def main():
    import jax

    jax.config.update("jax_enable_x64", True)
    import vojax

    parser = argparse.ArgumentParser()
    parser.add_argument("--data", default=str(Path(__file__).resolve().parents[2] / "shared" / "data"))
    parser.add_argument("--out", help="also write the table to this file")
    args = parser.parse_args()
    folder = Path(args.data) / "pp-pvc-creep-vo"
    rows = list(csv.DictReader(open(folder / "CreepDataPP.csv")))
    loads = sorted({float(r["Load_MPa"]) for r in rows})
    lines = [
        "Constant order: refit on the native samples (origin 0) against the closed-form fit",
        "",
        "| σ₀ (MPa) | samples | t (s) | refit q ± se | closed-form q | difference | refit time, s |",
        "|---|---|---|---|---|---|---|",
    ]
    curves = [
        "",
        "Order curve (4 knots, evenly in log time) against the published β(t), at "
        + ", ".join(f"{p:.0e}" for p in PROBES)
        + " s",
        "",
        "| σ₀ (MPa) | vojax q(t) | ±2σ half-width (max) | published β(t) | refit NRMSE | published NRMSE |",
        "|---|---|---|---|---|---|",
    ]
    for load in loads:
        sel = [r for r in rows if float(r["Load_MPa"]) == load]
        t = np.array([float(r["Time_day"]) for r in sel]) * 86400.0
        eps = np.array([float(r["Strain_dimensionless"]) for r in sel]) / 100.0  # percent
        name = f"{load:g}"
        pfile = folder / "reference_fits" / f"VOSpringpotParameters_PP_sigma0_{name}MPa.csv"
        ref = {k: float(v) for k, v in next(csv.DictReader(open(pfile))).items()}
        stress = np.full(t.size, load)
        t0 = time.perf_counter()
        fit = vojax.refit(stress, eps, t=t, origin=0.0, x0=0.0, order_bounds=(0.001, 0.999))
        fit.order.block_until_ready()
        seconds = time.perf_counter() - t0
        q_ref = closed_form_q(t, eps, load)
        q = float(fit.order[0])
        lines.append(
            f"| {load:g} | {t.size} | {t[0]:.3g} … {t[-1]:.3g} | {q:.6f} ± {float(fit.order_stderr[0]):.1e} "
            f"| {q_ref:.6f} | {abs(q - q_ref):.1e} | {seconds:.2f} |"
        )
        curve = vojax.refit(stress, eps, t=t, origin=0.0, x0=0.0, order=4, order_bounds=(0.001, 0.6))

        def beta(tt):
            s = (tt / ref["gamma_sec"]) ** ref["delta_dimless"]
            return (ref["beta_inf_dimless"] * s + ref["beta_0_dimless"]) / (s + 1)

        inside = [p for p in PROBES if t[0] <= p <= t[-1]]
        q_fit = np.interp(np.log(inside), np.log(t), np.asarray(curve.order))
        half = 0.5 * (np.asarray(curve.order_upper) - np.asarray(curve.order_lower))
        e, eta = ref["E_MPa"], ref["eta_MPa_sec"]
        published = load * (t * e / eta) ** beta(t) / np.array(
            [math.gamma(b + 1) for b in beta(t)]
        ) / e
        scale = np.ptp(eps)
        curves.append(
            f"| {load:g} | {' / '.join(f'{v:.3f}' for v in q_fit)} | {half.max():.3f} | "
            f"{' / '.join(f'{beta(p):.3f}' for p in inside)} | "
            f"{np.sqrt(np.mean((np.asarray(curve.y_hat) - eps) ** 2)) / scale:.2g} | "
            f"{np.sqrt(np.mean((published - eps) ** 2)) / scale:.2g} |"
        )
    publish(lines + curves, args.out)


if __name__ == "__main__":
    main()
