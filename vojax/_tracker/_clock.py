"""The unit of time in which the parameters are constant.

When the order moves, "the parameters are constant" depends on the unit of time: ``I^α`` on a
clock of unit ``s`` is ``s^(−α)`` times ``I^α`` on the user's, so a parameter constant in one
unit drifts in another by the factor ``s^(α(t) − α(0))``. The tracker states its parameters
on the record's span (a unit-free choice: the answer does not depend on whether the times are
in seconds or milliseconds). Unless `time_scale` is given, it also fits on the data's own unit
of time (``time_scale=1``). Where that order lies outside the span's band on most of the
second half, one record cannot tell the two accounts apart (their evidence does not pick the
true one), and the band covers both; where it lies inside, the band is the span's, unchanged,
but a conditional answer (a bound on the drift on the span's clock) is withdrawn where that
order lies outside the conditional band.
"""

import dataclasses

import numpy as np

from .._xla import to_device

# the second clock is skipped where the span is within this relative distance of one unit
# of the data's time: the two clocks then differ by less than a factor 1.05^Δα
SAME_CLOCK = 0.05


def second_clock(span) -> bool:
    """The data's unit of time differs from the record's `span` enough to fit on it too."""
    return bool(abs(np.log(span)) > SAME_CLOCK)


def outside(alpha, lower, upper) -> bool:
    """The order trajectory `alpha` lies outside the band ``[lower, upper]`` at most samples
    of the second half."""
    alpha, lower, upper = (np.asarray(a) for a in (alpha, lower, upper))
    half = alpha.shape[0] // 2
    out = (alpha < lower) | (alpha > upper)
    return bool(np.mean(out[half:]) > 0.5)


def union(band, other):
    """The band ``(lower, upper)`` covering both `band` and `other`, each ``(lower,
    upper)``."""
    return np.minimum(band[0], other[0]), np.maximum(band[1], other[1])


def weigh_clock(res, fit, other, other_fit):
    """The span's result `res` and its fitted points `fit` (see `Tracker._fit`) weighed
    against the data's-unit fit (`other`, `other_fit`): where that fit's order lies outside
    the stated band (`outside`, on the fitted points) the band is widened to cover both;
    where it lies outside the stated or the conditional band, that order's median over the
    second half is returned (the conditional answer bounds a drift on the span's clock only),
    else None, and `res` and `fit` unchanged."""
    span = fit["span"]
    points = [np.asarray(f[k])[:span] for f in (fit, other_fit)
              for k in ("alpha", "lower", "upper")]
    alpha, lower, upper, o_alpha, o_lower, o_upper = points
    finite = all(np.all(np.isfinite(a)) for a in (o_alpha, o_lower, o_upper))
    if not (other.converged and finite):
        return res, fit, None
    clock = float(np.median(o_alpha[span // 2 :]))
    if not outside(o_alpha, lower, upper):
        cond = fit.get("conditional")
        beyond = cond is not None and outside(o_alpha, *(np.asarray(a)[:span] for a in cond[1:3]))
        return res, fit, clock if beyond else None
    lo, hi = union((lower, upper), (o_lower, o_upper))
    fit = dict(fit, lower=np.concatenate([lo, np.asarray(fit["lower"])[span:]]),
               upper=np.concatenate([hi, np.asarray(fit["upper"])[span:]]))
    r_lo, r_hi = union((np.asarray(res.alpha_lower), np.asarray(res.alpha_upper)),
                       (np.asarray(other.alpha_lower), np.asarray(other.alpha_upper)))
    std = np.maximum(np.asarray(res.alpha_std), (r_hi - r_lo) / 4)
    res = dataclasses.replace(res, alpha_lower=to_device(r_lo), alpha_upper=to_device(r_hi),
                              alpha_std=to_device(std))
    return res, fit, clock
