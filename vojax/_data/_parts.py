"""The blocks of a record's summary: the tracker's or the law's, the comparison's, the
test that would settle a refused order, and the disagreement of two estimators."""


import dataclasses

import numpy as np

from .._stats import delta_stderr
from ._outputs import diagnostics_dict, nrmse
from ._regressors import stress_strain


def adaptive_part(res, y, physical):
    """Per-sample columns and the summary block of an `Identification` (either method); its
    numbers over the fitted samples (a fit window: `Identification.fitted`)."""
    fitted = getattr(res, "fitted", None)
    cut = slice(None) if fitted is None else slice(*fitted)
    alpha = np.asarray(res.alpha)
    p = np.asarray(res.p)
    params = {k: np.asarray(v) for k, v in physical(p).items()}
    columns = {
        "alpha": alpha,
        "alpha_lower": np.asarray(res.alpha_lower),
        "alpha_upper": np.asarray(res.alpha_upper),
        **params,
    }
    if getattr(res, "conditional", None) is not None:
        c = res.conditional
        columns.update(alpha_conditional=np.asarray(c.alpha),
                       alpha_conditional_lower=np.asarray(c.alpha_lower),
                       alpha_conditional_upper=np.asarray(c.alpha_upper))
    a, p_fit = alpha[cut], p[cut]
    part = {
        "method": res.method,
        "nrmse": nrmse(np.asarray(y)[cut], np.asarray(res.y_hat)[cut]),
        "alpha_min": float(a.min()),
        "alpha_max": float(a.max()),
        "alpha_mean": float(a.mean()),
        "alpha_final": float(a[-1]),
        "alpha_final_std": float(np.asarray(res.alpha_std)[cut][-1]),
        "parameters_final": {k: float(v[cut][-1]) for k, v in params.items()},
        "parameters_final_stderr": delta_stderr(
            physical, p_fit[-1], np.diag(np.asarray(res.p_std)[cut][-1] ** 2)
        ),
        "x0": float(res.x0),
        "x0_std": float(res.x0_std),
        **diagnostics_dict(res.diagnostics),
    }
    if fitted is not None and tuple(fitted) != (0, alpha.shape[0]):  # a window, not padding
        part["fitted_samples"] = [int(fitted[0]), int(fitted[1])]
    if res.method == "kalman":
        part["answer"] = res.verdict_line()
    if res.method == "gradient":
        part.update(gamma=float(res.gamma), lam=float(res.lam))
    else:
        part.update(tuning=dataclasses.asdict(res.tuning))
    return columns, part


def compare_part(record, area=None, length=None, origin=None, fit_from=None, fit_to=None):
    """`vojax.compare` of one record (its one input as the stress, its output as the strain,
    through `area` and `length` as eq. (35)), over the refit's window and from its origin (in
    the file's time unit), as the ``compare`` block of its summary: the best law, the next
    one and the Bayes factor between them, the verdict, and each law's log evidence, weight
    and held-out NRMSE."""
    from .._compare import compare
    from ._regressors import refit_options

    if record.inputs.shape[1] != 1:
        raise ValueError(
            f"--compare takes one input column (the stress); this record has "
            f"{record.inputs.shape[1]}."
        )
    fitting = refit_options(record, None, area, length, origin, fit_from, fit_to)
    c = compare(*stress_strain(record, area, length), **record.grid, **fitting)
    rows = c.rows
    out = {
        "best": rows[0]["model"],
        "second": rows[1]["model"] if len(rows) > 1 else None,
        "bayes_factor": c.bayes_factor(rows[0]["model"], rows[1]["model"]) if len(rows) > 1 else None,
        "verdict": c.verdict,
    }
    for key in ("log_evidence", "weight", "holdout_nrmse"):
        out[key] = {r["model"]: float(r[key]) for r in rows}
    return out


# the lengths a record's settling test is padded to: a batch compiles its design at most 4×
# (once a length: about 0.7 s each), not once a record length
SETTLING_LENGTHS = (128, 256, 512, 1000)


def settling_part(u, y, res, times, unit=""):
    """The oscillation that would settle a refused order (`vojax.settling_test` on the
    record's own load, at its median order and parameters over the second half and its
    noise), as JSON-ready values with its sentence; the record averaged to at most 1,000
    points (the design needs no finer clock) and padded to one of `SETTLING_LENGTHS` (one
    compiled program for all records of a batch up to that length; the same result). With
    the bound (`band`) it gives the band the tracker is expected to give (`expected`, from
    its band now, `band_now`; `SettlingTest.expect`). None where no oscillation determines
    it."""
    from .._settling import settling_test
    from .._stats import noise_variance
    from .._tracker._blocks import block_average, block_size

    times = np.asarray(times, float)
    size = block_size(times.size, 1000)
    t_b, u_b = block_average(times, size), block_average(np.asarray(u, float), size)
    alpha, p = np.asarray(res.alpha), np.asarray(res.p)
    half = alpha.size // 2
    noise = float(np.sqrt(max(noise_variance(np.asarray(y)), 1e-300) / size))
    pad = next(n for n in SETTLING_LENGTHS if n >= t_b.size)
    band_now = float(res.diagnostics.band_halfwidth)
    try:
        test = settling_test(u_b, float(np.median(alpha[half:])), np.median(p[half:], axis=0),
                             t=t_b - t_b[0], noise_std=noise, pad_to=pad,
                             band_now=band_now if 0 < band_now < np.inf else None)
    except ValueError:
        return None
    return {"amplitude": test.amplitude, "frequency": test.frequency,
            "start": test.start + float(t_b[0]), "cycles": test.cycles, "band": test.band,
            "band_without": test.band_without, "band_now": band_now,
            "expected": test.expected, "sentence": test.sentence(unit)}


def time_unit(record) -> str:
    """The unit of a record's time column: given in its `units`, or the last part of its
    name where that is a unit of time (``time_s``), else ""."""
    units = dict(record.units)
    if record.time_name in units:
        return units[record.time_name]
    unit = str(record.time_name).rpartition("_")[2]
    return unit if unit in ("s", "ms", "us", "min", "h", "day") else ""


def disagreement(columns, summary) -> str:
    """One sentence when the two estimators run on a record give disjoint order bands over
    the second half of the fitted samples (median of each bound), else ``""``: at most one of
    them can be right, and the sentence says which the data support. The tracker's order is
    the one to report where it is identified and the refit's residuals are correlated (a
    constant order leaves part of the signal); neither where the tracker does not identify
    the order (or the paper's law ran, whose band is no confidence band); and where the
    refit's residuals are white, the residuals do not decide and `compare` ranks the laws."""
    from .._refit import CORRELATED_RESIDUALS

    half = len(columns["alpha"]) // 2
    lo_a = float(np.median(columns["alpha_lower"][half:]))
    hi_a = float(np.median(columns["alpha_upper"][half:]))
    refit = summary["refit"]
    lo_r, hi_r = refit["order_lower"], refit["order_upper"]
    if not (hi_a < lo_r or hi_r < lo_a):
        return ""
    name = "the tracker" if "kalman" in summary else "the paper's law"
    rho = refit.get("residual_correlation", float("nan"))
    correlated = bool(np.isfinite(rho) and rho > CORRELATED_RESIDUALS)
    lag = f"lag-1 {rho:.2f}" if np.isfinite(rho) else "lag-1 unknown"
    verdict = summary.get("kalman", {}).get("verdict")
    if verdict == "identified" and correlated:
        support = (f"the data support the tracker's order: the refit's residuals are "
                   f"correlated ({lag}), the part of the signal a constant order misses")
    elif verdict == "identified":
        support = (f"the refit's residuals are white ({lag}), so they do not decide between "
                   "a moving and a constant order: rank the laws with vojax compare")
    else:
        said = {
            None: "gives a band that is no confidence band",
            "conditional": "identifies the order only under a bound on the parameters' drift",
        }.get(verdict, "does not identify the order")
        support = (f"report neither: {name} {said}, and the refit's interval holds only if "
                   f"the order is constant ({lag})")
    return (
        f"{name} ([{lo_a:.3g}, {hi_a:.3g}] over the second half) and the constant-order "
        f"refit ([{lo_r:.3g}, {hi_r:.3g}]) disagree, their bands disjoint; {support}"
    )


def _padded(fn, u, y, pad_to, **kwargs):
    """``fn(u, y, …)`` on the record padded to `pad_to` samples and masked, its per-sample
    outputs cut back: one compiled program serves every record of a bucket. Padding comes
    after the end, so the causal memory of the real samples does not see it."""
    from .._xla import cut_padding

    num = y.shape[0]
    if pad_to is None or pad_to <= num:
        return fn(u, y, **kwargs)
    extra = pad_to - num
    up = np.concatenate([u, np.zeros((extra, u.shape[1]))])
    yp = np.concatenate([y, np.full(extra, y[-1])])
    mask = np.r_[np.ones(num), np.zeros(extra)]
    if kwargs.get("direct") is not None:  # order-0 regressors are padded like the inputs
        d = kwargs["direct"]
        kwargs = {**kwargs, "direct": np.concatenate([d, np.zeros((extra, d.shape[1]))])}
    return cut_padding(fn(up, yp, mask=mask, **kwargs), num, pad_to)
