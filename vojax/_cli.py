"""The ``vojax`` command. Errors are one sentence on stderr and a non-zero exit code."""

import argparse
import contextlib
import os
import sys
import time
from pathlib import Path

from ._tracker._estimator import MIN_POINTS, TRACKER_MAX_POINTS
from ._settings import TrackerSettings


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


def _expand(paths, pattern=None, out=None):
    """The batch's inputs as ``(file, prefix)``: a folder stands for its CSV, NPZ and AFM files
    (not those of its subfolders), or with `pattern` for the files that glob matches in it
    (``**/*.csv`` recurses); a path that does not exist and holds ``*``, ``?`` or ``[`` is a
    glob itself. A file found in a subfolder of a given folder has that subfolder as
    `prefix`, which heads its records' names (``specimen_2/test``): names stay apart. Files
    found inside `out` (vojax's own outputs, when --out lies in a folder searched) are left
    out; a file named explicitly is taken as it is."""
    import glob

    from ._data._afm import AFM_SUFFIXES

    kinds = (".csv", ".npz", *AFM_SUFFIXES)
    inside_out = (lambda p: False) if out is None else (
        lambda p, o=Path(out).resolve(): Path(p).resolve().is_relative_to(o)
    )
    files = []
    for path in paths:
        folder = Path(path)
        if folder.is_dir():
            if pattern is None:
                found = [p for p in folder.iterdir() if p.is_file() and p.suffix.lower() in kinds]
            else:
                found = [p for p in folder.glob(pattern) if p.is_file()]
            found = [p for p in found if not inside_out(p)]
            if not found:
                what = f"files matching {pattern!r}" if pattern else "CSV, NPZ or AFM files"
                raise CLIError(f"{path} is a folder without {what}.")
            for p in sorted(found):
                prefix = p.parent.relative_to(folder).as_posix()
                files.append((str(p), "" if prefix == "." else prefix))
        elif not folder.exists() and any(c in str(path) for c in "*?["):
            found = sorted(
                p for p in glob.glob(str(path), recursive=True)
                if Path(p).is_file() and not inside_out(p)
            )
            if not found:
                raise CLIError(f"no file matches {path!r}.")
            files.extend((p, "") for p in found)
        else:
            files.append((str(path), ""))
    return files


def _out_apart(out, files):
    """--out must not be, or hold, an input file (see `check_out_holds_no_input`)."""
    from ._data._paths import check_out_holds_no_input

    try:
        check_out_holds_no_input(out, files)
    except ValueError as e:
        raise CLIError(str(e)) from None


class _Parser(argparse.ArgumentParser):
    """An unknown option or a bad value: one line, exit 1, as every other bad input (argparse
    would print its usage and exit 2, the code of a batch with failed records)."""

    def error(self, message):
        self.exit(1, f"vojax: error: {message} (see {self.prog} --help).\n")


BIG = 1e300  # numbers beyond this (or below its inverse, for sizes) overflow in arithmetic


def _number(text):
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None


def _positive(text: str):
    """A size (area, length, step, tolerance): finite, > 0, within 1e-300…1e300."""
    value = _number(text)
    if not (1.0 / BIG <= value <= BIG):
        raise argparse.ArgumentTypeError(
            f"expected a positive number between 1e-300 and 1e300, got {text!r}"
        )
    return value


def _finite(text: str):
    """A time or a threshold: finite, within ±1e300."""
    value = _number(text)
    if not abs(value) <= BIG:
        raise argparse.ArgumentTypeError(f"expected a finite number, got {text!r}")
    return value


def _fraction(text: str):
    """A relative tolerance: in (0, 1)."""
    value = _number(text)
    if not 0.0 < value < 1.0:
        raise argparse.ArgumentTypeError(f"expected a number between 0 and 1, got {text!r}")
    return value


def _order(text: str):
    value = _number(text)
    if not 0.0 < value < 1.0:
        raise argparse.ArgumentTypeError(f"expected an order between 0 and 1, got {text!r}")
    return value


def _count(text: str):
    """A non-negative integer below 2^63 (a seed, a number of samples)."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a whole number, got {text!r}") from None
    if not 0 <= value < 2**63:
        raise argparse.ArgumentTypeError(f"expected a whole number from 0 to 2^63 - 1, got {text!r}")
    return value


def _delimiter(text: str):
    value = {"tab": "\t", "\\t": "\t", "comma": ",", "semicolon": ";"}.get(text, text)
    if value not in (",", ";", "\t"):
        raise argparse.ArgumentTypeError(f"expected ',', ';' or tab, got {text!r}")
    return value


def _rate(text: str):
    return None if text == "auto" else _gain(text)


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

    from ._data._pipeline import versions
    from ._identify import identify
    from ._io import write_json
    from ._data._paths import claim_outputs
    from ._plotting import STUDY_FIGURES, study_figures
    from ._study import band_coverage, simulate_study, study_errors

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
    tracker, tracked = None, {}
    if args.tracker:  # vojax's default estimator on the same record, with its band
        tracker = identify(data["u"], data["y"], args.dt, warn=False)
        tracker.alpha.block_until_ready()
        tracked = {
            **study_errors(data["t"], data["alpha"], data["p"], tracker),
            **band_coverage(data["t"], data["alpha"], tracker),
            "identified": bool(tracker.diagnostics.identified),
            "message": tracker.diagnostics.message,
            "time_identify_s": time.perf_counter() - identified,
        }
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
            f"{simulated - started:.2f} s, {identified - simulated:.2f} s (incl. compile)",
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
    width = max(len(r[0]) for r in rows)
    print(f"vojax demo: the simulation study (34) of the paper → {out}/")
    for name, value in rows:
        print(f"  {name:<{width}}  {value}")
    print(f"  wrote {', '.join(figures)}, summary.json")
    return 0


def _segments(text: str):
    try:
        values = tuple(int(v) for v in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected comma-separated segment numbers (0, 1, …), got {text!r}"
        ) from None
    if any(v < 0 for v in values):
        raise argparse.ArgumentTypeError(f"segment numbers are 0 or more, got {text!r}")
    return values


def _units(text: str):
    """``--units stress=kPa,time=ms`` as a dict."""
    out = {}
    for part in text.split(","):
        column, eq, unit = part.partition("=")
        if not eq or not column.strip() or not unit.strip():
            raise argparse.ArgumentTypeError(
                f"expected COLUMN=UNIT pairs separated by commas (stress=kPa,time=ms), got {text!r}"
            )
        out[column.strip()] = unit.strip()
    return out


def _column_options(p):
    """How a file is read and turned into the model's signals (identify, batch, check)."""
    p.add_argument("--time", required=True, help="name of the time column (its unit is the time unit)")
    p.add_argument(
        "--input",
        action="append",
        required=True,
        dest="inputs",
        help="input column (stress or force); repeat for several inputs (--model linear)",
    )
    p.add_argument("--output", required=True, help="output column (strain or displacement)")
    p.add_argument(
        "--model",
        choices=("springpot", "kelvin-voigt", "maxwell", "zener", "linear"),
        default="springpot",
        help="springpot (default): σ = η D^q ε, u = σ, p = 1/η; kelvin-voigt: σ = kε + η D^q ε, "
        "u = [σ, ε], p = [1/η, −k/η]; maxwell: ε = σ/E + I^q σ/η (--method refit); zener: a "
        "spring E0 in parallel with a spring E1 and a springpot in series (--method refit); "
        "linear: the input columns as given, x = output. The refit keeps moduli and "
        "viscosities non-negative (a coefficient that breaks its sign is held at 0)",
    )
    p.add_argument(
        "--area",
        type=_positive,
        help="contact area a of eq. (35): σ = F/a, in the units that make σ your stress unit "
        "(default: none, the input column is the stress)",
    )
    p.add_argument(
        "--length",
        type=_positive,
        help="specimen length l of eq. (35): ε = d/l, in the displacement column's unit "
        "(default: none, the output column is the strain)",
    )
    p.add_argument(
        "--group-by",
        help="column naming the record in a long-format file (default: the file is one record)",
    )
    p.add_argument(
        "--strict",
        action="store_true",
        help="reject non-uniform time steps (default: use them as recorded; the kernels "
        "integrate exactly between any increasing sample times)",
    )
    p.add_argument(
        "--resample",
        type=_positive,
        metavar="STEP",
        help="resample every record linearly onto a uniform grid of this step (default: no); "
        "refused above 1,000,000 samples or where the file has steps 4 times shorter",
    )
    p.add_argument(
        "--trim-column",
        help="drop leading samples while |this column| < --trim-below (e.g. force before "
        "contact); the time restarts at 0 at the first kept sample (default: keep all)",
    )
    p.add_argument(
        "--delimiter",
        type=_delimiter,
        default=",",
        help="the CSV's field separator: ',' (default), ';' or tab",
    )
    p.add_argument(
        "--decimal-comma",
        action="store_true",
        help="numbers are written with a decimal comma (1,5): needs --delimiter ';' or tab "
        "(default: a decimal point)",
    )
    p.add_argument(
        "--trim-below",
        type=_finite,
        help="the threshold of --trim-column, in that column's unit",
    )
    p.add_argument(
        "--segments",
        type=_segments,
        help="AFM files: the segments to keep, e.g. 1,2 (numbered as in the file; default: all)",
    )
    p.add_argument(
        "--no-contact",
        action="store_true",
        help="AFM files: keep the samples before the contact point (default: drop them)",
    )
    p.add_argument(
        "--tip",
        help="AFM files: the tip for the contact_strain column, sphere:RADIUS_m or "
        "cone:HALF_ANGLE_deg (default: none)",
    )
    p.add_argument(
        "--poisson",
        type=_finite,
        default=0.5,
        help="AFM files: the sample's Poisson ratio for contact_strain (default 0.5)",
    )


def _refit_options(p):
    """The refit's own options (identify, batch)."""
    p.add_argument(
        "--origin",
        type=_finite,
        metavar="T0",
        help="the time (in the time column's unit) at which the test started, before the first "
        "sample: the inputs are taken as held at their first values from T0 (a step load) and "
        "the refit's x0 is the output at T0 (default: the first sample)",
    )
    p.add_argument(
        "--fit-from",
        type=_finite,
        metavar="T",
        help="the refit fits samples from this time on (the whole record still drives the "
        "model; default: the first sample)",
    )
    p.add_argument(
        "--fit-to",
        type=_finite,
        metavar="T",
        help="the refit fits samples up to this time (default: the last sample)",
    )


def _data_options(p, *, many: bool):
    _column_options(p)
    _refit_options(p)
    p.add_argument(
        "--units",
        type=_units,
        metavar="COLUMN=UNIT,…",
        help="units of columns whose names do not end in one, for the figures' axis labels, "
        "e.g. stress=kPa,strain=1,time=ms (a name such as stress_kPa already says it); "
        "changes no number",
    )
    p.add_argument(
        "--parameters",
        choices=("drifting", "constant"),
        default=None,
        help="the tracker's parameters: drifting (default, as vojax.identify: their drift is "
        "tuned, and the order band also covers every constant order that a drifting parameter "
        "explains as well) or constant (known not to drift: the band holds under that "
        "assumption only)",
    )
    p.add_argument(
        "--x0",
        type=_finite,
        default=None,
        metavar="VALUE",
        help="the output's offset, where it is known (the output column's reading at rest, in "
        "its unit; a tared sensor reads 0): the tracker holds it there instead of estimating "
        "it, which narrows the order's band where the order's level, the parameters' scale and "
        "the offset trade off; as vojax.identify(x0=...)",
    )
    p.add_argument(
        "--max-points",
        type=int,
        default=None,
        metavar="N",
        help=f"the most points the tracker fits (default {TrackerSettings().max_points:,}, as vojax.identify): "
        "a longer record is fitted as the means of blocks of consecutive samples, and the "
        "estimates are given at every sample",
    )
    p.add_argument("--out", required=True, help="output folder (created if missing)")
    p.add_argument(
        "--format",
        choices=("png", "svg", "pdf"),
        default="png",
        help="format of the per-record figure (default png)",
    )
    p.add_argument(
        "--method",
        type=_method,
        default="kalman",
        metavar="{kalman,gradient,refit,kalman+refit,gradient+refit}",
        help="kalman (default, as vojax.identify): the Bayesian tracker, with an order band "
        "and a verdict; gradient: the paper's adaptive law (its band is not a confidence "
        "band); refit: constant-order least squares; kalman+refit, gradient+refit: one of "
        "the first two and the refit, with a warning where their bands are disjoint",
    )
    p.add_argument(
        "--gamma",
        type=_gain,
        default=None,
        help="the law's order gain γ (1/time unit) or 'auto' (default); for --method "
        "gradient|gradient+refit only",
    )
    p.add_argument(
        "--lam",
        type=_rate,
        default=None,
        help="forgetting factor λ in 1/(time unit) (default: tuned with γ when --gamma auto, "
        "else 0.9); a number with --gamma auto tunes γ alone at that λ; for --method "
        "gradient|gradient+refit only",
    )


def _method(text):
    """``--method``: a name of `METHODS`, or an earlier name (a note says which it means)."""
    from ._data._pipeline import ALIASES, canonical_method

    try:
        method = canonical_method(text)
    except ValueError as e:
        raise argparse.ArgumentTypeError(str(e).replace("`method`", "--method")) from None
    if text in ALIASES:
        print(f"vojax: note: --method {text} is now called {method}.", file=sys.stderr)
    return method


def _law_options(args):
    """``--gamma``/``--lam`` apply to the paper's law only: refused with another method."""
    if not args.method.startswith("gradient"):
        given = [f"--{k}" for k in ("gamma", "lam") if getattr(args, k) is not None]
        if given:
            raise CLIError(
                f"{' and '.join(given)} set the paper's law, which --method {args.method} does "
                "not use; add --method gradient (or gradient+refit), or leave them out."
            )
    if args.gamma is None:
        args.gamma = "auto"
    if args.method != "refit" and args.model in ("maxwell", "zener"):
        raise CLIError(
            f"--model {args.model} has a spring (an order-0 term) that the adaptive law and the "
            "tracker do not take; add --method refit."
        )
    points = getattr(args, "max_points", None)
    for name, value in (("--parameters", getattr(args, "parameters", None)),
                        ("--max-points", points), ("--x0", getattr(args, "x0", None))):
        if value is not None and not args.method.startswith("kalman"):
            raise CLIError(
                f"{name} sets the tracker, which --method {args.method} does not run; add "
                "--method kalman (or kalman+refit)."
            )
    if points is not None and not MIN_POINTS <= points <= TRACKER_MAX_POINTS:
        raise CLIError(
            f"--max-points must be from {MIN_POINTS:,} to {TRACKER_MAX_POINTS:,}, got {points:,}."
        )
    fit = [f"--{k.replace('_', '-')}" for k in FIT_OPTIONS if getattr(args, k) is not None]
    if fit and not args.method.endswith("refit"):
        raise CLIError(
            f"{' and '.join(fit)} set the refit, which --method {args.method} does not run; "
            f"add --method refit (or {args.method}+refit)."
        )
    if args.fit_from is not None and args.fit_to is not None and not args.fit_from < args.fit_to:
        raise CLIError(f"--fit-from must be before --fit-to, got {args.fit_from} and {args.fit_to}.")


FIT_OPTIONS = ("origin", "fit_from", "fit_to")


def _load(path, args):
    from ._data import load_records
    from ._data._records import check_units

    if (args.trim_column is None) != (args.trim_below is None):
        raise CLIError("--trim-column and --trim-below go together.")
    if args.decimal_comma and args.delimiter == ",":
        raise CLIError("--decimal-comma needs another separator: add --delimiter ';' (or tab).")
    try:
        check_units(getattr(args, "units", None), [args.time, *args.inputs, args.output])
    except ValueError as e:
        raise CLIError(str(e).replace("`units`", "--units")) from None
    import warnings

    # the loader's warnings (resampled time steps) are shown as one line each, not as Python's
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        records = load_records(path, **_loader(args))
    for w in caught:
        print(f"vojax: warning: {w.message}", file=sys.stderr)
    return records


def _settings(args) -> dict:
    """The options that set the identification."""
    return dict(
        model=args.model,
        method=args.method,
        gamma=args.gamma,
        lam=args.lam,
        area=args.area,
        length=args.length,
        **{k: getattr(args, k) for k in FIT_OPTIONS if getattr(args, k) is not None},
        **({"parameters": args.parameters} if getattr(args, "parameters", None) else {}),
        **({"max_points": args.max_points} if getattr(args, "max_points", None) else {}),
        **({"x0": args.x0} if getattr(args, "x0", None) is not None else {}),
        **({"compare": True} if getattr(args, "compare", False) else {}),
    )


def _loader(args) -> dict:
    """The options that set how records are read."""
    return dict(
        time=args.time,
        inputs=list(args.inputs),
        output=args.output,
        group_by=args.group_by,
        strict=args.strict,
        resample=args.resample,
        trim_column=args.trim_column,
        trim_below=args.trim_below,
        delimiter=args.delimiter,
        decimal="," if args.decimal_comma else ".",
        **_afm_loader(args),
        **({"units": args.units} if getattr(args, "units", None) else {}),
    )


def _afm_loader(args) -> dict:
    """The AFM options, only where given (a CSV's provenance is unchanged by them)."""
    from ._data._afm import check_tip

    try:
        check_tip(args.tip, args.poisson)
    except ValueError as e:
        raise CLIError(str(e)) from None
    out = {}
    if args.segments is not None:
        out["segments"] = list(args.segments)
    if args.no_contact:
        out["from_contact"] = False
    if args.tip is not None:
        out["tip"] = args.tip
    if args.poisson != 0.5:
        out["poisson"] = args.poisson
    return out


def _select(records, args):
    """`identify` works on one record: with --group-by, --record names it."""
    names = [r.name for r in records]
    if args.record is not None:
        if args.group_by is None:
            raise CLIError("--record selects a record of a long-format file: give --group-by too.")
        chosen = [r for r in records if r.name == args.record]
        if not chosen:
            shown = ", ".join(repr(n) for n in names[:5]) + (", …" if len(names) > 5 else "")
            raise CLIError(f"no record {args.record!r} in {args.file} (records: {shown}).")
        return chosen
    if len(records) > 1:
        raise CLIError(
            f"{args.file} holds {len(records)} records (--group-by {args.group_by}); identify "
            f"takes one: add --record NAME (e.g. --record {names[0]!r}), or use vojax batch."
        )
    return records


def identify_command(args) -> int:
    from ._data._paths import claim_outputs
    from ._data._pipeline import check_finite, identify_record, make_provenance, write_outputs

    _law_options(args)
    _out_apart(args.out, [args.file])
    records = _select(_load(args.file, args), args)
    out = _new_dir(args.out)
    for record in records:
        target = out
        columns, summary = identify_record(record, **_settings(args))
        try:
            check_finite(summary, columns)
        except ValueError as e:
            raise CLIError(f"{record.name}: {e}") from None
        summary["provenance"] = make_provenance(
            record, {**_settings(args), "figure_format": args.format, **_loader(args)}
        )
        claim_outputs(
            target, ["identification.csv", "summary.json", f"identification.{args.format}"]
        )
        write_outputs(target, columns, summary, record.inputs, args.format)
        parts = [f"{record.name}: {record.time.size} samples"]
        for key in ("kalman", "gradient"):
            if key not in summary:
                continue
            a = summary[key]
            parts.append(
                f"{a['method']} q ∈ [{a['alpha_min']:.3f}, {a['alpha_max']:.3f}] "
                f"(band ±{a['band_halfwidth']:.2g}), NRMSE {a['nrmse']:.3g}"
            )
            if a["message"]:
                print(f"vojax: warning: {record.name}: {a['message']}.", file=sys.stderr)
        if "refit" in summary:
            r = summary["refit"]
            flag = " (at a bound: the interval is not meaningful)" if r["at_bound"] else ""
            parts.append(
                f"refit q = {r['order']:.4f} [{r['order_lower']:.4f}, {r['order_upper']:.4f}]"
                f"{flag}, NRMSE {r['nrmse']:.3g}"
            )
        if summary.get("disagreement"):
            print(f"vojax: warning: {record.name}: {summary['disagreement']}.", file=sys.stderr)
        print("; ".join(parts) + f" → {target}/")
    return 0


def compare_command(args) -> int:
    from ._compare import MODELS, compare
    from ._data._batch import _write_table
    from ._data._pipeline import stress_strain
    from ._data._paths import claim_outputs

    if args.model is not None:
        raise CLIError("--model does not apply to compare: it fits every model (--models).")
    models = tuple(m.strip() for m in args.models.split(","))
    unknown = [m for m in models if m not in MODELS]
    if unknown or not models:
        raise CLIError(f"--models takes some of {','.join(MODELS)}, got {args.models!r}.")
    if not 1 <= args.knots <= 10:
        raise CLIError(f"--knots must be from 1 to 10, got {args.knots}.")
    _out_apart(args.out, [args.file])
    records = _select(_load(args.file, args), args)
    for record in records:
        if len(record.input_names) != 1:
            raise CLIError("compare takes one input column, the stress: give one --input.")
    out = _new_dir(args.out)
    claim_outputs(out, ["comparison.csv"])
    rows = []
    for record in records:
        stress, strain = stress_strain(record, args.area, args.length)
        try:
            result = compare(stress, strain, **record.grid, models=models, knots=args.knots)
        except ValueError as e:
            raise CLIError(f"{record.name}: {e}") from None
        print(f"{record.name}:")
        print(result.table())
        for r in result.rows:
            rows.append({"record": record.name, **{k: v for k, v in r.items() if k != "refit"},
                         "verdict": result.verdict})
    _write_table(out / "comparison.csv", rows)
    print(f"→ {out / 'comparison.csv'}")
    return 0


def batch_command(args) -> int:
    from ._data import DataError
    from ._data._batch import run_batch

    _law_options(args)
    if args.workers is not None and args.scheduler != "local":
        raise CLIError("--workers sets the worker processes of --scheduler local; use it with that.")
    if args.workers is not None and args.workers < 1:
        raise CLIError(f"--workers must be at least 1, got {args.workers}.")
    if args.scheduler is not None and not args.scheduler.strip():
        raise CLIError("--scheduler needs 'local' or a scheduler's address (tcp://host:8786).")
    import dataclasses

    if args.pattern is not None and not any(Path(f).is_dir() for f in args.files):
        raise CLIError("--pattern chooses the files of a folder: give a folder as input.")
    found = _expand(args.files, args.pattern, args.out)
    files = [path for path, _ in found]
    _out_apart(args.out, files)
    out = _new_dir(args.out)
    records, failures = [], []
    for path, prefix in found:
        try:
            loaded = _load(path, args)
        except DataError as e:
            failures.append((str(path), "", str(e)))
            continue
        if prefix:
            loaded = [dataclasses.replace(r, name=f"{prefix}/{r.name}") for r in loaded]
        records.extend(loaded)
    names = [r.name for r in records]
    duplicated = sorted({n for n in names if names.count(n) > 1})
    if duplicated:
        raise CLIError(
            f"two records share the name {duplicated[0]!r}; rename a file or use --group-by."
        )
    from ._data._batch import BatchBusy, dask_client


    with contextlib.ExitStack() as stack:
        client = None
        if args.scheduler is not None:
            try:
                client = stack.enter_context(dask_client(args.scheduler, args.workers))
            except ImportError as e:
                raise CLIError(str(e)) from None
            except (OSError, TimeoutError) as e:
                raise CLIError(
                    f"could not reach the Dask scheduler {args.scheduler!r}: {e}"
                ) from None
        try:
            report = run_batch(
                records,
                out,
                **_settings(args),
                failures=failures,
                progress=False if args.quiet else (True if args.progress else None),
                loader=_loader(args),
                overwrite=not args.no_overwrite,
                figure_format=args.format,
                record_figures=args.figures == "records",
                client=client,
            )
        except BatchBusy as e:
            raise CLIError(str(e)) from None
    unidentified = (
        f", {report.unidentified} of them with the order not identified (see summary.csv)"
        if report.unidentified else ""
    )
    print(
        f"vojax batch: {report.computed} computed, {report.skipped} up to date (skipped), "
        f"{report.redone} redone, {report.failed} failed{unidentified} → {out}/"
    )
    if report.failed:
        print(
            f"vojax batch: the failures and their reasons are in {out / 'failures.csv'}",
            file=sys.stderr,
        )
        return 2
    return 0


def _order_list(text: str):
    try:
        values = tuple(float(v) for v in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected comma-separated numbers, got {text!r}") from None
    if not all(0 < v < 1 for v in values):
        raise argparse.ArgumentTypeError(f"every order must lie in (0, 1), got {text!r}")
    return values


def check_command(args) -> int:
    from . import testing
    from ._data import DataError
    from ._data._pipeline import regressors

    if args.max_samples < 3:
        raise CLIError(f"--max-samples must be at least 3, got {args.max_samples}.")
    failed = 0
    for path in args.files:
        try:
            records = _load(path, args)
        except DataError as e:
            raise CLIError(str(e)) from None
        for record in records:
            if not record.uniform:
                raise CLIError(
                    f"{record.name}: its time steps are not uniform, and the closed forms (14) "
                    "and (26) that check compares with are written for a uniform step; add "
                    f"--resample STEP (its median step is {record.dt:g})."
                )
            u, y, _, _ = regressors(record, args.model, args.area, args.length)
            num = min(len(y), args.max_samples)
            note = f" (first {num} of {len(y)} samples)" if num < len(y) else ""
            print(f"{record.name}: {num} samples, step {record.dt:g}{note}")
            u, y = u[:num], y[:num]
            for order in args.order:
                for report in (
                    testing.check_gradients(
                        u, order, record.dt, memory=args.memory, rtol=args.rtol,
                        fd_rtol=args.fd_rtol, raise_on_failure=False,
                    ),
                    testing.check_parameter_sensitivity(
                        u, y - y[0], order, record.dt, lam=args.lam, memory=args.memory,
                        rtol=args.rtol, fd_rtol=args.fd_rtol, raise_on_failure=False,
                    ),
                ):
                    print(f"  order {order:g}: " + report.table().replace("\n", "\n    "))
                    failed += not report.passed
    if failed:
        print(f"vojax check: {failed} check(s) beyond tolerance.", file=sys.stderr)
        return 1
    print("vojax check: every comparison within tolerance.")
    return 0


def example_command(args) -> int:
    import shutil

    from .io import example_file

    source = example_file(args.name)
    target = Path(args.out) if args.out else Path(source.name)
    if target.exists():
        raise CLIError(f"{target} exists; remove it or give another --out.")
    shutil.copyfile(source, target)
    licence = source.parent / f"LICENSE-{args.name}.txt"
    print(f"vojax example: wrote {target} (MIT licence: {licence})")
    return 0


def build_parser() -> argparse.ArgumentParser:
    from . import __version__

    parser = _Parser(
        prog="vojax",
        description="Identify the variable order q(t) and the parameters of recorded tests "
        "(D^q(t) x = p·u), with bands and a verdict; simulate the paper's study; cross-check "
        "the order sensitivities on your data. Each command's --help says its options, with "
        "their defaults and units.",
    )
    parser.add_argument("--version", action="version", version=f"vojax {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)
    d = sub.add_parser(
        "demo", help="simulate the paper's study (34), identify it with the paper's law and with "
        "vojax's tracker; write Figs. 2–4 with their bands and a summary"
    )
    d.add_argument("--out", help="output folder (default: a new vojax-demo-<time> folder here)")
    d.add_argument("--dt", type=_positive, default=0.05, help="sampling step h in s (default 0.05)")
    d.add_argument("--seed", type=_count, default=0, help="noise seed (default 0)")
    d.add_argument(
        "--gamma", type=_gain, default=0.01, help="order gain γ or 'auto' (default 0.01)"
    )
    d.add_argument(
        "--lam", type=_gain, default=0.9, help="forgetting factor λ (default 0.9, the paper's)"
    )
    d.add_argument("--alpha0", type=_order, default=0.5, help="initial order estimate (default 0.5)")
    d.add_argument(
        "--tracker",
        action=argparse.BooleanOptionalAction,
        default=True,
        help="also run vojax's tracker (identify's default) on the same record and draw its "
        "band (default; about 10 s on 2 cores); --no-tracker: the paper's law alone",
    )
    d.add_argument(
        "--memory",
        choices=("exponential", "direct"),
        default="exponential",
        help="memory kernel: exponential (O(1) per sample, default) or direct (whole history)",
    )
    d.add_argument(
        "--rule",
        choices=("trapezoid", "rectangle"),
        default="trapezoid",
        help="quadrature of the input between samples: trapezoid (O(h²), default) or rectangle",
    )
    d.set_defaults(run=demo)
    i = sub.add_parser("identify", help="identify q(t) and the parameters of one recorded test")
    i.add_argument("file", help="CSV (header row, '#' comments) or NPZ file")
    _data_options(i, many=False)
    i.add_argument(
        "--record",
        help="with --group-by: the record to identify (identify takes one; batch takes all)",
    )
    i.set_defaults(run=identify_command)
    c = sub.add_parser(
        "check",
        help="cross-check the order sensitivities on your data: autodiff vs the closed forms "
        "(14) and (26) vs finite differences; exit 1 beyond tolerance",
    )
    c.add_argument("files", nargs="+", help="CSV or NPZ files; each is a record unless --group-by")
    _column_options(c)
    c.add_argument(
        "--order",
        type=_order_list,
        default=(0.25, 0.5, 0.75),
        help="constant orders to check at, comma-separated, each in (0, 1) (default 0.25,0.5,0.75)",
    )
    c.add_argument(
        "--lam",
        type=_gain,
        default=0.9,
        help="forgetting factor λ in 1/(time unit) for ∂p/∂β (default 0.9)",
    )
    c.add_argument(
        "--memory",
        choices=("direct", "exponential"),
        default="direct",
        help="the memory kernel checked (default direct)",
    )
    c.add_argument(
        "--max-samples",
        type=_count,
        default=2000,
        help="check the first this many samples of each record: the closed forms are O(N²) "
        "(default 2000)",
    )
    c.add_argument(
        "--rtol",
        type=_fraction,
        default=1e-8,
        help="tolerance of autodiff vs closed form, relative to the largest value (default 1e-8)",
    )
    c.add_argument(
        "--fd-rtol",
        type=_fraction,
        default=1e-6,
        help="tolerance of central finite differences (order step 1e-5), relative (default 1e-6)",
    )
    c.set_defaults(run=check_command)
    m = sub.add_parser(
        "compare",
        help="which law do the data of one recorded test support: springpot, Kelvin-Voigt, "
        "Maxwell, Zener and a variable order, ranked by evidence",
    )
    m.add_argument("file", help="CSV, NPZ or AFM file")
    _column_options(m)
    m.set_defaults(model=None)
    m.add_argument("--out", required=True, help="output folder for comparison.csv")
    m.add_argument(
        "--record", help="with --group-by: the record to compare (default: the only one)"
    )
    m.add_argument(
        "--models", default="springpot,kelvin-voigt,maxwell,zener,variable",
        help="comma-separated laws to fit (default: all five)",
    )
    m.add_argument("--knots", type=int, default=3,
                   help="knots of the variable order (default 3)")
    m.set_defaults(run=compare_command)
    e = sub.add_parser(
        "example", help="copy a real recording shipped with vojax into the current folder"
    )
    e.add_argument("name", choices=("adhesive", "myocardium"), help="which recording")
    e.add_argument("--out", help="file to write (default: the example's own name, here)")
    e.set_defaults(run=example_command)
    b = sub.add_parser(
        "batch", help="identify many recorded tests (files, or groups of a long file)"
    )
    b.add_argument(
        "files", nargs="+",
        help="CSV, NPZ or AFM files, folders of them (their files, not their subfolders'; "
        "see --pattern) or quoted globs ('runs/*/test_*.csv'); each file is a record "
        "unless --group-by or an AFM map",
    )
    b.add_argument(
        "--compare",
        action="store_true",
        help="also rank the laws each record supports (as vojax compare: springpot, "
        "Kelvin-Voigt, Maxwell, Zener, a variable order), in summary.json and the compare_* "
        "columns of summary.csv (one input column; about 2 s a record)",
    )
    b.add_argument(
        "--pattern",
        metavar="GLOB",
        help="the files to take from each folder given, as a glob inside it: '*.txt.csv', or "
        "'**/*.csv' to recurse (a record in a subfolder is named subfolder/name) (default: "
        "the folder's .csv, .npz and AFM files)",
    )
    _data_options(b, many=True)
    shown = b.add_mutually_exclusive_group()
    shown.add_argument(
        "--progress", action="store_true",
        help="a progress bar on stderr even when it is not a terminal (default: only on a "
        "terminal)",
    )
    shown.add_argument("--quiet", action="store_true", help="no progress bar")
    b.add_argument(
        "--no-overwrite",
        action="store_true",
        help="fail a record whose outputs exist from other settings or inputs instead of redoing "
        "it (default: redo it)",
    )
    b.add_argument(
        "--figures",
        choices=("records", "overview"),
        default="records",
        help="records (default): each record's figure, drawn in worker processes, and the "
        "overview; overview: only overview.<format> of all records (faster: a record's figure "
        "costs about 0.14 s of one core)",
    )
    b.add_argument(
        "--scheduler",
        help="compute the records on Dask (pip install \"vojax[dask]\"): 'local' for worker "
        "processes on this machine, or a running scheduler's address (tcp://host:8786); this "
        "process writes every output (default: compute here)",
    )
    b.add_argument(
        "--workers", type=int,
        help="worker processes of --scheduler local (default: the cores, at most 8)",
    )
    b.set_defaults(run=batch_command)
    return parser


def main(argv=None) -> int:
    import jax

    from ._xla import CACHE_ENV, use_compilation_cache, use_fast_cpu_loops

    if os.environ.get("VOJAX_FAST_CPU_LOOPS", "1") != "0":
        try:
            use_fast_cpu_loops()
        except RuntimeError:  # main() run inside a process that has already computed
            pass
    jax.config.update("jax_enable_x64", True)
    # after a SIGKILL of this process, multiprocessing's helper would print a warning about
    # the figure pool's semaphores into the user's terminal: it inherits this setting
    os.environ.setdefault(
        "PYTHONWARNINGS", "ignore::UserWarning:multiprocessing.resource_tracker"
    )
    cache = os.environ.get(CACHE_ENV, "")
    if cache.lower() != "off":
        use_compilation_cache(cache or None)
    parser = build_parser()
    args = parser.parse_args(argv)
    import signal

    def stop(signum, frame):
        # Ctrl-C or SIGTERM: one line, then out at once. Raising an exception here could land
        # in a garbage-collector callback, where Python prints it and goes on; exiting is
        # safe: every output is written atomically, a re-run removes the temporaries and
        # redoes what is incomplete, the lock dies with the process and so do the workers
        interrupted = signum == signal.SIGINT
        sys.stdout.flush()
        print(f"vojax: {'interrupted' if interrupted else 'terminated'}.", file=sys.stderr,
              flush=True)
        os._exit(130 if interrupted else 143)

    previous = {}
    try:
        for sig in (signal.SIGINT, signal.SIGTERM):
            previous[sig] = signal.signal(sig, stop)
    except ValueError:  # not the main thread (main() called from a thread): leave them
        pass
    try:
        return args.run(args)
    except CLIError as e:
        print(f"vojax: error: {e}", file=sys.stderr)
        return 1
    except OSError as e:
        print(f"vojax: error: {e.strerror or e}: {e.filename}.", file=sys.stderr)
        return 1
    except (ValueError, TypeError) as e:
        print(f"vojax: error: {str(e).splitlines()[0]}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print("vojax: interrupted.", file=sys.stderr)
        return 130
    except Exception as e:  # a bug, not the user's fault: still one line, the trace on request
        if os.environ.get("VOJAX_DEBUG"):
            raise
        first = str(e).splitlines()[0] if str(e) else ""
        print(
            f"vojax: internal error ({type(e).__name__}: {first}); set VOJAX_DEBUG=1 for the traceback.",
            file=sys.stderr,
        )
        return 3
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)


if __name__ == "__main__":
    sys.exit(main())
