"""Identify one recorded test and write its outputs (CSV, JSON, PNG), atomically."""


import numpy as np

from .._stats import delta_stderr
from .._validate import window_mask
from ._buckets import COMPILE_COST_SAMPLES as COMPILE_COST_SAMPLES
from ._buckets import bucket_length as bucket_length
from ._buckets import plan_buckets as plan_buckets
from ._outputs import ESTIMATES as ESTIMATES
from ._outputs import _non_finite as _non_finite
from ._outputs import _without_errors as _without_errors
from ._outputs import check_finite as check_finite
from ._outputs import diagnostics_dict as diagnostics_dict
from ._outputs import file_sha256 as file_sha256
from ._outputs import finish_outputs as finish_outputs
from ._outputs import make_provenance as make_provenance
from ._outputs import nrmse as nrmse
from ._outputs import record_header as record_header
from ._outputs import versions as versions
from ._outputs import write_outputs as write_outputs
from ._outputs import write_table as write_table
from ._parts import _padded as _padded
from ._parts import adaptive_part as adaptive_part
from ._parts import compare_part as compare_part
from ._parts import disagreement as disagreement
from ._parts import settling_part as settling_part
from ._parts import time_unit as time_unit
from ._regressors import MODELS as MODELS
from ._regressors import _Columns as _Columns
from ._regressors import _stress_strain as _stress_strain
from ._regressors import output_scale as output_scale
from ._regressors import refit_options as refit_options
from ._regressors import regressors as regressors
from ._regressors import stress_strain as stress_strain

# models with an order-0 regressor: the refit takes them, the adaptive law and the tracker not
REFIT_ONLY = ("maxwell", "zener")


# the estimators by one name each, as `vojax.identify`'s `method` and `summary.json`'s keys:
# "kalman" the tracker, "gradient" the paper's law, "refit" the constant-order refit; a
# record runs one of them or one of the first two with the refit
METHODS = ("kalman", "gradient", "refit", "kalman+refit", "gradient+refit")


# earlier names, still accepted: "adaptive" was the law, "both" the law with the refit
ALIASES = {"adaptive": "gradient", "both": "gradient+refit"}


def canonical_method(method) -> str:
    """The method's name in `METHODS` (an alias replaced); `ValueError` naming the choices."""
    method = ALIASES.get(method, method)
    if method not in METHODS:
        raise ValueError(f"`method` must be one of {', '.join(METHODS)}, got {method!r}.")
    return method


def estimator(method) -> str | None:
    """The order tracker a method runs, "kalman" or "gradient", or None (the refit alone)."""
    first = method.split("+")[0]
    return first if first in ("kalman", "gradient") else None


def check_parameters(method, parameters, max_points=None, x0=None, time_scale=None,
                     noise=None) -> None:
    """`parameters`, `max_points`, `x0`, `time_scale` and `noise` (the tracker's) are refused
    with a method that does not run the tracker; `x0` must be a finite number, `time_scale`
    a positive one, `noise` the tracker's three intensities and not beside
    ``parameters="constant"``."""
    if x0 is not None:
        from .._validate import known_offset

        known_offset(x0)
    if time_scale is not None:
        from .._validate import positive

        positive(time_scale, "time_scale")
    if noise is not None:
        from .._tracker._estimator import check_noise, parameters_statement

        try:
            check_noise(noise, parameters_statement(parameters))
        except ValueError as e:  # in the command's words
            raise ValueError(str(e).replace("`noise`", "--noise").replace(
                "parameters='constant'", "--parameters constant")) from None
    if estimator(canonical_method(method)) == "kalman":
        return
    for name, value in (("--parameters", parameters), ("--max-points", max_points),
                        ("--x0", x0), ("--time-scale", time_scale), ("--noise", noise)):
        if value is not None:
            raise ValueError(
                f"{name} sets the tracker, which --method {method} does not run; add "
                "--method kalman (or kalman+refit)."
            )


def runs_refit(method) -> bool:
    return method.endswith("refit")


def identify_record(
    record, *, model="springpot", method="kalman", gamma="auto", lam=None, area=None,
    length=None, pad_to=None, origin=None, fit_from=None, fit_to=None, parameters=None,
    max_points=None, x0=None, threads=None, time_scale=None, alpha_bounds=None, noise=None,
):
    """Runs the tracker or the law and/or the refit on one record (`method`: one of
    `METHODS`); returns ``(columns, summary)``.
    With `pad_to`, the tracker and the refit of a record on a uniform clock run on it padded
    to that length and masked (results equal to the unpadded run within the solvers'
    tolerances). `origin` (the test's start, before the first sample) and the fit window
    `fit_from`, `fit_to` are in the file's time unit; the window applies to the tracker and
    the refit (not to the paper's law, which fits every sample), the origin to the refit; the
    refit keeps
    the model's coefficients physical (`p_signs`). `parameters`, `max_points`: the
    tracker's, as in `vojax.identify` (its defaults when None); `x0`: the tracker's known
    offset of the output, in the unit of the file's output column (None: estimated);
    `time_scale`: the unit of time, in the file's, in which `parameters` holds (None: the
    record's span, as in `vojax.identify`); `noise`: the tracker's noise intensities, its
    ``noise_std`` in the unit of the file's output column (None: tuned); `alpha_bounds` ``(lo, hi)``: the order's range
    for every estimator run (None: each one's default);
    `threads`: the most threads the tracker's smoothings run in (None: its settings')."""
    method = canonical_method(method)
    _check_record_options(record, model, method, origin, fit_from, fit_to)
    check_parameters(method, parameters, max_points, x0, time_scale, noise)
    window = _window(record, fit_from, fit_to)  # on the record's clock
    u, y, names, physical = regressors(record, model, area, length)
    pad_to = pad_to if record.uniform else None  # a bucket pads a uniform clock only
    # the record's clock (from 0 at its first sample) and the file's own time
    columns = {"time": record.time, "file_time": record.time + record.time_offset}
    summary = record_header(record, model, method, area, length)
    tracker = estimator(method)
    if tracker is not None:
        settings = dict(
            gamma=gamma, lam=lam, max_points=max_points, x0=x0, threads=threads,
            time_scale=time_scale, parameters=parameters, alpha_bounds=alpha_bounds,
            noise=noise, window=window,
        )
        cols, summary[tracker] = _tracker_part(
            record, tracker, u, y, physical, pad_to, model, length, settings
        )
        columns.update(cols)
    columns["y"] = y  # between the tracker's columns and its fit, as the files have it
    if tracker is not None:
        columns["y_hat"] = columns.pop("y_hat")
    if runs_refit(method):
        options = refit_options(record, model, area, length, origin, fit_from, fit_to)
        if alpha_bounds is not None:
            options["order_bounds"] = tuple(alpha_bounds)
        cols, summary["refit"] = _refit_part(record, u, y, physical, pad_to, options, model)
        columns.update(cols)
    summary["parameter_names"] = names
    if tracker is not None and "refit" in summary:
        summary["disagreement"] = disagreement(columns, summary)
    return columns, summary


def _check_record_options(record, model, method, origin, fit_from, fit_to):
    if model in REFIT_ONLY and estimator(method) is not None:
        raise ValueError(
            f"--model {model} has a spring (an order-0 term) that the adaptive law and the "
            "tracker do not take; use --method refit."
        )
    if not runs_refit(method) and origin is not None:
        raise ValueError(
            f"--origin sets the refit; use --method refit or {method}+refit."
        )
    if method == "gradient" and not (fit_from is None and fit_to is None):
        raise ValueError(
            "--fit-from and --fit-to set the tracker and the refit; the paper's law fits every "
            "sample: use --method kalman, refit or gradient+refit."
        )
    silent = [n for n, col in zip(record.input_names, np.asarray(record.inputs).T) if not col.any()]
    if silent:
        raise ValueError(
            f"the input column {silent[0]!r} is 0 at every sample: nothing it drives can be "
            "identified (its coefficient is undetermined); leave it out of --input."
        )


MIN_WINDOW = 4  # the fewest samples a fit window may hold (a fit of one input and its offset)


def _window(record, fit_from, fit_to):
    """The fit window ``(from, to)`` on the record's clock from times in the file's (an end
    None: open), or None."""
    if fit_from is None and fit_to is None:
        return None
    shift = record.time_offset
    window = (None if fit_from is None else float(fit_from) - shift,
              None if fit_to is None else float(fit_to) - shift)
    inside = int(window_mask(window, record.time).sum())
    if inside < MIN_WINDOW:
        given = " and ".join(f"{name} {value:g}" for name, value in
                             (("--fit-from", fit_from), ("--fit-to", fit_to)) if value is not None)
        raise ValueError(
            f"{given} leave{'s' if ' and ' not in given else ''} {inside} "
            f"sample{'' if inside == 1 else 's'} of the "
            f"record, whose times run from {shift:g} to {record.time[-1] + shift:g} in the "
            f"file; a fit needs at least {MIN_WINDOW}."
        )
    return window


def _tracker_part(record, tracker, u, y, physical, pad_to, model, length, settings):
    """The tracker's or the law's columns and summary for one record."""
    from .._identify import identify

    bounds = settings["alpha_bounds"]
    extra = {} if bounds is None else {"alpha_bounds": tuple(bounds)}
    if tracker == "kalman":
        if settings["max_points"] is not None:
            extra["max_points"] = settings["max_points"]
        if settings["x0"] is not None:  # in the model's output, as the output column is
            extra["x0"] = float(settings["x0"]) / output_scale(model, length)
        if settings["time_scale"] is not None:
            extra["time_scale"] = float(settings["time_scale"])
        if settings["noise"] is not None:  # its noise_std in the output column's unit
            extra["noise"] = dict(settings["noise"], noise_std=float(
                settings["noise"]["noise_std"]) / abs(output_scale(model, length)))
        if settings["window"] is not None:
            extra["window"] = settings["window"]
        if settings["threads"] is not None:
            from .._settings import TrackerSettings

            extra["settings"] = TrackerSettings(run_threads=settings["threads"])
        res = _padded(
            identify, u, y, pad_to, **record.grid, method="kalman",
            parameters=settings["parameters"], warn=False, **extra,
        )
    else:
        res = identify(u, y, **record.grid, method="gradient", gamma=settings["gamma"],
                       lam=settings["lam"], warn=False, **extra)
    columns, summary = adaptive_part(res, y, physical)
    columns["y_hat"] = np.asarray(res.y_hat)
    if tracker == "kalman":
        if {"trade_off", "held_shift", "clock"} & set(res.diagnostics.reasons):
            summary["settling_test"] = settling_part(u, y, res, record.time, time_unit(record))
        summary["parameter_model"] = res.parameters
        summary["offset_model"] = "estimated" if settings["x0"] is None else "known"
    return columns, summary


def _refit_part(record, u, y, physical, pad_to, options, model="linear"):
    """The refit's columns and summary for one record: ``nrmse`` is that of the fitted law
    solved for the output from the stress (`fitted_strain`) where it can be, else the
    regression's (``nrmse_of`` says which)."""
    import optimistix as optx  # imported where it is used: 0.07 s of `import vojax`

    from .._refit import refit

    fit = _padded(refit, u, y, pad_to, **record.grid, **options, warn=False)
    p = np.asarray(fit.p)
    with np.errstate(divide="ignore", invalid="ignore"):
        phys = {k: float(v) for k, v in physical(p).items()}
    # η = 1/p with p = 0 (held at its sign's bound, or 0 to rounding): the data bound the
    # coefficient, not the parameter; written as null and named, not a failure
    undetermined = [k for k, v in phys.items() if not np.isfinite(v)]
    columns = {
        "refit_alpha": np.asarray(fit.order),
        "refit_alpha_lower": np.asarray(fit.order_lower),
        "refit_alpha_upper": np.asarray(fit.order_upper),
        "refit_y_hat": np.asarray(fit.y_hat),
    }
    summary = {
        "order": float(fit.order[0]),
        "order_stderr": float(fit.order_stderr[0]),
        "order_lower": float(fit.order_lower[0]),
        "order_upper": float(fit.order_upper[0]),
        "at_bound": bool(fit.at_bound),
        "p": p.tolist(),
        "p_stderr": np.asarray(fit.p_stderr).tolist(),
        "p_at_bound": list(fit.p_at_bound),
        "parameters": phys,
        "parameters_stderr": {
            k: (float("inf") if k in undetermined else v)
            for k, v in delta_stderr(physical, p, np.asarray(fit.p_cov)).items()
        },
        "parameters_undetermined": undetermined,
        "x0": float(fit.x0),
        "x0_stderr": float(fit.x0_stderr),
        **_solved_nrmse(record, u, y, fit, model, options.get("origin")),
        "converged": bool(fit.result == optx.RESULTS.successful),
        "residual_correlation": float(fit.residual_correlation),
        "error_inflation": float(fit.error_inflation),
    }
    return columns, summary


def _solved_nrmse(record, u, y, fit, model, origin):
    """``nrmse`` of the fitted law solved exactly for the output (`fitted_strain`), its
    regression's own (``nrmse_regression``: the measured output inside the integral where the
    law feeds it back) and which of the two ``nrmse`` is (``nrmse_of``): the regression's for
    the linear model, a fit whose law is not physical, or a clock on which the solve is
    `too_costly`."""
    from .._models._fitted import too_costly

    regression = nrmse(y, fit.y_hat)
    out = {"nrmse": regression, "nrmse_regression": regression, "nrmse_of": "regression"}
    if model not in MODELS or too_costly(record.grid.get("t")):
        return out
    try:
        solved = MODELS[model].fitted_strain(fit, np.asarray(u)[:, 0], **record.grid,
                                             origin=origin)
    except ValueError:  # not physical: the regression's residual is all there is
        return out
    return dict(out, nrmse=nrmse(y, solved), nrmse_of="the fitted law solved")
