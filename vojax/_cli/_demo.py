"""`vojax demo`: the paper's simulation study, its figures and a summary."""

import time

from ._commands import _new_dir
from ._types import CLIError


def demo(args) -> int:
    import numpy as np

    from .._data._paths import claim_outputs
    from .._data._pipeline import versions
    from .._identify import identify
    from .._io import write_json
    from .._plotting import STUDY_FIGURES, study_figures
    from .._study import band_coverage, simulate_study, study_errors

    if not args.dt > 0 or 300.0 / args.dt > 2e6:
        raise CLIError(
            f"--dt must be positive and give at most 2e6 samples over 300 s, got {args.dt}."
        )
    out = _new_dir(args.out)
    claim_outputs(out, ["summary.json", *STUDY_FIGURES])
    started = time.perf_counter()
    data = simulate_study(args.dt, args.seed)
    simulated = time.perf_counter()
    result = identify(
        data["u"],
        data["y"],
        args.dt,
        method="gradient",  # the paper's study is the paper's law
        lam=args.lam,
        gamma=args.gamma,
        alpha0=args.alpha0,
        r0=np.eye(2),  # the paper's P(0) = I
        memory=args.memory,
        rule=args.rule,
        x0=0.0,
        warn=False,  # its band is described in the table, as what it is
    )
    result.alpha.block_until_ready()
    identified = time.perf_counter()
    errors = study_errors(data["t"], data["alpha"], data["p"], result)
    law_band = band_coverage(data["t"], data["alpha"], result)
    tracker, tracked = _tracker(data, args) if args.tracker else (None, {})
    figures = study_figures(
        data["t"], data["alpha"], data["p"], data["x"], data["y"], result, out, tracker
    )
    summary = {
        "study": "paper eq. (34): u = [sin 0.5t, cos 0.2t], noise variance 0.25",
        "dt": args.dt,
        "samples": int(data["t"].size),
        "seed": args.seed,
        "gamma": float(result.gamma),
        "lam": float(result.lam),
        "alpha0": args.alpha0,
        "alpha_bounds": list(result.alpha_bounds),
        "memory": args.memory,
        "rule": args.rule,
        **errors,
        "output_rms_error_vs_noise_free": float(
            np.sqrt(np.mean((np.asarray(result.y_hat) - data["x"]) ** 2))
        ),
        **law_band,
        "time_simulate_s": simulated - started,
        "time_identify_s": identified - simulated,
        **({"tracker": tracked} if tracked else {}),
        "figures": figures,
        "versions": versions(),
    }
    write_json(out / "summary.json", summary)
    rows = _table(errors, law_band, tracked, result, data, args, identified - simulated,
                  simulated - started)
    width = max(len(r[0]) for r in rows)
    print(f"vojax demo: the simulation study (34) of the paper → {out}/")
    for name, value in rows:
        print(f"  {name:<{width}}  {value}")
    print(f"  wrote {', '.join(figures)}, summary.json")
    return 0


def _table(errors, law_band, tracked, result, data, args, identify_s, simulate_s):
    """The demo's printed summary: (name, value) rows."""
    rows = [
        ("order RMS error, t > 50 s", f"{errors['order_rms_t_gt_50']:.4f}"),
        ("order RMS error, last 100 s", f"{errors['order_rms_last_100s']:.4f}"),
        ("p1 RMS error, t > 50 s", f"{errors['p1_rms_t_gt_50']:.3f}"),
        ("p2 RMS error, t > 50 s", f"{errors['p2_rms_t_gt_50']:.3f}"),
        ("gains γ, λ", f"{float(result.gamma):.4g}, {float(result.lam):.4g}"),
        ("samples, h", f"{data['t'].size}, {args.dt:g} s"),
        (
            "law's ±2σ (noise only): coverage, half-width",
            f"{law_band['band_coverage_t_gt_50']:.2f}, {law_band['band_halfwidth_t_gt_50']:.4f}",
        ),
        (
            "time: simulate, identify",
            f"{simulate_s:.2f} s, {identify_s:.2f} s (incl. compile)",
        ),
    ]
    if tracked:
        rows += [
            ("tracker: order RMS error, t > 50 s", f"{tracked['order_rms_t_gt_50']:.4f}"),
            (
                "tracker's ±2σ band: coverage, half-width",
                f"{tracked['band_coverage_t_gt_50']:.2f}, "
                f"{tracked['band_halfwidth_t_gt_50']:.4f}",
            ),
            ("tracker: identified, time", f"{'yes' if tracked['identified'] else 'no'}, "
             f"{tracked['time_identify_s']:.1f} s (incl. compile)"),
        ]
    return rows


def _tracker(data, args):
    """vojax's default estimator on the same record, with its band: the result and its row
    of the summary."""
    from .._identify import identify
    from .._study import band_coverage, study_errors

    started = time.perf_counter()
    tracker = identify(data["u"], data["y"], args.dt, warn=False)
    tracker.alpha.block_until_ready()
    return tracker, {
        **study_errors(data["t"], data["alpha"], data["p"], tracker),
        **band_coverage(data["t"], data["alpha"], tracker),
        "identified": bool(tracker.diagnostics.identified),
        "message": tracker.diagnostics.say("cli"),
        "time_identify_s": time.perf_counter() - started,
    }
