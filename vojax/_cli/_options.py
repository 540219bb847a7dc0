"""The options the commands share (columns, data, the fit, the law) and how they become the
settings of a record's pipeline."""

import argparse
import sys

from .._data._contact import BASELINES, CONTACT_METHODS
from .._settings import MIN_POINTS, TRACKER_MAX_POINTS, TrackerSettings
from ._args import check_fit_window
from ._types import (
    CLIError,
    _bounds,
    _delimiter,
    _finite,
    _gain,
    _noise,
    _parameters,
    _positive,
    _rate,
    _segments,
    _units,
)


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
        "--strain-from-length",
        type=_positive,
        metavar="L0",
        help="the output column is the specimen's length L and L0 its rest length, in that "
        "column's unit: the output becomes the strain (L − L0)/L0 (not with --length)",
    )
    p.add_argument(
        "--length-column",
        metavar="NAME",
        help="a column whose value at a record's first sample is its specimen's initial "
        "length l (e.g. the tool gap of each specimen): ε = d/l per record (not with --length)",
    )
    p.add_argument(
        "--area-column",
        metavar="NAME",
        help="a column whose value at a record's first sample is its contact area a: σ = F/a "
        "per record, one input only (not with --area)",
    )
    p.add_argument(
        "--group-by",
        help="column naming the record in a long-format file (default: the file is one record)",
    )
    _reading_options(p)
    _afm_options(p)


def _reading_options(p):
    """How a file's samples are read: clock, resampling, trimming, separators."""
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


def _afm_options(p):
    """AFM files and CSV exports of force curves: segments, the contact point, the tip and
    the sample."""
    p.add_argument(
        "--segments",
        type=_segments,
        help="AFM curves: the segments to keep, e.g. 1,2 (numbered as in the file; default: all)",
    )
    p.add_argument(
        "--no-contact",
        action="store_true",
        help="AFM curves: keep the samples before the contact point and after the tip leaves "
        "the sample (default: drop them)",
    )
    p.add_argument(
        "--tip",
        help="AFM curves: the tip, for nanite's Hertz fit of the loading (the Young's modulus "
        "in the summary) and the contact_strain column: sphere:RADIUS_m, cone:HALF_ANGLE_deg "
        "or pyramid:FACE_ANGLE_deg (three-sided) (default: none)",
    )
    p.add_argument(
        "--contact",
        choices=CONTACT_METHODS,
        help="AFM curves: how the contact point is found, 'fit' (the Hertz fit's free contact "
        "point; needs --tip) or one of nanite's estimators (default: 'fit' with --tip, else "
        "'deviation_from_baseline')",
    )
    p.add_argument(
        "--baseline",
        choices=BASELINES,
        help="AFM curves: how the force's baseline is corrected before the contact point is "
        "found: 'offset' (default) or 'tilt' (also a slope against the tip position, fitted "
        "before contact and subtracted over the approach: a virtual deflection)",
    )
    p.add_argument(
        "--spring-constant",
        type=_finite,
        metavar="K_N_per_m",
        help="a CSV export of force curves (columns time_s, segment, force_N and "
        "height_measured_m or height_piezo_m): the cantilever's spring constant in N/m, "
        "which makes the AFM options and columns work on it",
    )
    p.add_argument(
        "--poisson",
        type=_finite,
        default=0.5,
        help="AFM curves: the sample's Poisson ratio for contact_strain and the Hertz fit "
        "(default 0.5)",
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
        help="the tracker and the refit fit samples from this time on, in the time column's "
        "unit (the whole record still drives the model; default: the first sample)",
    )
    p.add_argument(
        "--fit-to",
        type=_finite,
        metavar="T",
        help="the tracker and the refit fit samples up to this time (default: the last sample)",
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
    _tracker_options(p)
    p.add_argument("--out", required=True, help="output folder (created if missing)")
    p.add_argument(
        "--format",
        choices=("png", "svg", "pdf"),
        default="png",
        help="format of the per-record figure (default png)",
    )
    _method_options(p)


def _tracker_options(p):
    """What the user states to the tracker: the parameters' drift, its time unit, the offset,
    the points it fits."""
    p.add_argument(
        "--parameters",
        type=_parameters,
        default=None,
        metavar="free|constant|DRIFT",
        help="what you know of the tracker's parameters: free (default, as vojax.identify: "
        "they may drift, and the order band covers every order a drifting parameter explains "
        "as well), constant (known not to drift: the band holds under that assumption only), "
        "or the largest relative drift you vouch for over the test, (max − min)/|mean|, e.g. "
        "0.1",
    )
    p.add_argument(
        "--time-scale",
        type=_positive,
        default=None,
        metavar="SECONDS",
        help="the unit of time, in the time column's unit, in which --parameters holds (default: "
        "the record's span, so that the order does not depend on the unit of the time column; "
        "with a moving order a parameter constant in seconds drifts in milliseconds); as "
        "vojax.identify(time_scale=...)",
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
        "--noise",
        type=_noise,
        default=None,
        metavar="order_drift=A,parameter_drift=B,noise_std=S",
        help="the tracker's noise intensities, instead of tuning them: the variance of the "
        "order's (logistic) change over the record, of each normalised parameter's change, "
        "and the measurement noise's standard deviation in the output column's unit; as "
        "vojax.identify(noise=...)",
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


def _method_options(p):
    """The estimator (--method), the order's range and the paper's law's gains."""
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
        "--alpha-bounds",
        type=_bounds,
        default=None,
        metavar="LO,HI",
        help="the range the order is searched in, for every estimator run, 0 < LO < HI < 1 "
        "(default: 0.01,0.99 for the tracker and the refit, 0.05,0.95 for the paper's law); "
        "as vojax.identify(alpha_bounds=...) and vojax.refit(order_bounds=...)",
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
    from .._data._pipeline import ALIASES, canonical_method

    try:
        method = canonical_method(text)
    except ValueError as e:
        raise argparse.ArgumentTypeError(str(e).replace("`method`", "--method")) from None
    if text in ALIASES:
        print(f"vojax: note: --method {text} is now called {method}.", file=sys.stderr)
    return method


def _law_options(args):
    """``--gamma``/``--lam`` apply to the paper's law only: refused with another method;
    ``--strain-from-length`` not beside ``--length`` (before a batch creates its folder)."""
    from ._args import check_strain_options

    check_strain_options(args)
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
    from .._data._pipeline import check_parameters

    try:  # the tracker's options, checked as the batch's Python route checks them
        check_parameters(args.method, getattr(args, "parameters", None), points,
                         getattr(args, "x0", None), getattr(args, "time_scale", None),
                         getattr(args, "noise", None))
    except ValueError as e:
        raise CLIError(str(e)) from None
    if points is not None and not MIN_POINTS <= points <= TRACKER_MAX_POINTS:
        raise CLIError(
            f"--max-points must be from {MIN_POINTS:,} to {TRACKER_MAX_POINTS:,}, got {points:,}."
        )
    if getattr(args, "origin", None) is not None and not args.method.endswith("refit"):
        raise CLIError(
            f"--origin sets the refit, which --method {args.method} does not run; "
            f"add --method refit (or {args.method}+refit)."
        )
    window = [f"--{k}" for k in ("fit-from", "fit-to") if getattr(args, k.replace("-", "_")) is not None]
    if window and args.method == "gradient":
        raise CLIError(
            f"{' and '.join(window)} {'set' if len(window) > 1 else 'sets'} the tracker and "
            "the refit; the paper's law (--method "
            "gradient) fits every sample: use --method kalman, refit or gradient+refit."
        )
    check_fit_window(args)
