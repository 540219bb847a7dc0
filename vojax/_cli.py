"""The ``vojax`` command. Errors are one sentence on stderr and a non-zero exit code."""

import argparse
import sys
import time
from pathlib import Path


class CLIError(Exception):
    """A problem the user can fix; printed as one sentence."""


def _new_dir(out: str | None) -> Path:
    if out is None:
        stamp = time.strftime("%Y%m%d-%H%M%S")
        path = Path(f"vojax-demo-{stamp}")
        i = 1
        while path.exists():
            path = Path(f"vojax-demo-{stamp}-{i}")
            i += 1
    else:
        path = Path(out)
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise CLIError(f"cannot create output folder {str(path)!r}: {e.strerror}.") from None
    return path


def _gain(text: str):
    if text == "auto":
        return "auto"
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected a positive number or 'auto', got {text!r}"
        ) from None
    if not value > 0:
        raise argparse.ArgumentTypeError(f"expected a positive number, got {text!r}")
    return value


def demo(args) -> int:
    import numpy as np

    from ._identify import identify
    from ._io import write_json
    from ._plotting import study_figures
    from ._study import simulate_study, study_errors

    if not args.dt > 0 or 300.0 / args.dt > 2e6:
        raise CLIError(
            f"--dt must be positive and give at most 2e6 samples over 300 s, got {args.dt}."
        )
    out = _new_dir(args.out)
    started = time.perf_counter()
    data = simulate_study(args.dt, args.seed)
    simulated = time.perf_counter()
    result = identify(
        data["u"],
        data["y"],
        args.dt,
        lam=args.lam,
        gamma=args.gamma,
        alpha0=args.alpha0,
        memory=args.memory,
        rule=args.rule,
        x0=0.0,
    )
    result.alpha.block_until_ready()
    identified = time.perf_counter()
    errors = study_errors(data["t"], data["alpha"], data["p"], result)
    figures = study_figures(data["t"], data["alpha"], data["p"], data["x"], data["y"], result, out)
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
        "time_simulate_s": simulated - started,
        "time_identify_s": identified - simulated,
        "figures": figures,
    }
    write_json(out / "summary.json", summary)
    rows = [
        ("order RMS error, t > 50 s", f"{errors['order_rms_t_gt_50']:.4f}"),
        ("order RMS error, last 100 s", f"{errors['order_rms_last_100s']:.4f}"),
        ("p1 RMS error, t > 50 s", f"{errors['p1_rms_t_gt_50']:.3f}"),
        ("p2 RMS error, t > 50 s", f"{errors['p2_rms_t_gt_50']:.3f}"),
        ("gains γ, λ", f"{float(result.gamma):.4g}, {float(result.lam):.4g}"),
        ("samples, h", f"{data['t'].size}, {args.dt:g} s"),
        (
            "time: simulate, identify",
            f"{simulated - started:.2f} s, {identified - simulated:.2f} s (incl. compile)",
        ),
    ]
    width = max(len(r[0]) for r in rows)
    print(f"vojax demo: the simulation study (34) of the paper → {out}/")
    for name, value in rows:
        print(f"  {name:<{width}}  {value}")
    print(f"  wrote {', '.join(figures)}, summary.json")
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="vojax", description=__doc__)
    sub = parser.add_subparsers(dest="command", required=True)
    d = sub.add_parser(
        "demo", help="simulate and identify the paper's study (34); write Figs. 2–4 and a summary"
    )
    d.add_argument("--out", help="output folder (default: a new vojax-demo-<time> folder here)")
    d.add_argument("--dt", type=float, default=0.05, help="sampling step h in s (default 0.05)")
    d.add_argument("--seed", type=int, default=0, help="noise seed (default 0)")
    d.add_argument(
        "--gamma", type=_gain, default=0.01, help="order gain γ or 'auto' (default 0.01)"
    )
    d.add_argument(
        "--lam", type=_gain, default=0.9, help="forgetting factor λ (default 0.9, the paper's)"
    )
    d.add_argument("--alpha0", type=float, default=0.5, help="initial order estimate (default 0.5)")
    d.add_argument("--memory", choices=("exponential", "direct"), default="exponential")
    d.add_argument("--rule", choices=("trapezoid", "rectangle"), default="trapezoid")
    d.set_defaults(run=demo)
    return parser


def main(argv=None) -> int:
    import jax

    jax.config.update("jax_enable_x64", True)
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return args.run(args)
    except CLIError as e:
        print(f"vojax: error: {e}", file=sys.stderr)
        return 1
    except (ValueError, TypeError) as e:
        print(f"vojax: error: {str(e).splitlines()[0]}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print("vojax: interrupted.", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
