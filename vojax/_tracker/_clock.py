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
order lies outside the conditional band. `parameters="constant"` is a statement on the
span's clock: where the data unit's account drifts there (`clock_drift`), it is excluded,
and covered only where the data favour it at least as much as the span's account and the
union is still an answer. With the parameters free or stated constant, an account the data
exclude is not covered at all (a drift bound keeps the union): where the span's fit
explains them better by more than `TrackerSettings.clock_evidence` nats per fitted point
(`evidence_apart`; an input with an oscillation superposed can tell the clocks apart, a
staircase alone cannot, and there the evidence stays below it).
"""

import dataclasses

import numpy as np

from .._xla import to_device
from ._band import moved_share, outside, second_half, union
from ._explanations import relative_drift

# the second clock is skipped where the span is within this relative distance of one unit
# of the data's time: the two clocks then differ by less than a factor 1.05^Δα
SAME_CLOCK = 0.05


def second_clock(span) -> bool:
    """The data's unit of time differs from the record's `span` enough to fit on it too."""
    return bool(abs(np.log(span)) > SAME_CLOCK)


def clock_drift(alpha, scale) -> float:
    """The relative drift (max − min over the mean) on the span's clock of parameters
    constant in the data's unit of time, where the order is `alpha` (the fitted points) and
    the span is `scale` data units: ``p_span(t) ∝ scale^α(t)``."""
    g = np.exp(np.log(scale) * (np.asarray(alpha) - np.mean(alpha)))
    return float(relative_drift(g, g.shape[0]))


def _other_points(fit, other, other_fit):
    """The first sample of the second half and the data's-unit fit's ``(alpha, lower,
    upper)`` on the fitted points, or None for them where that fit failed."""
    span = fit["span"]
    o_points = tuple(np.asarray(other_fit[k])[:span] for k in ("alpha", "lower", "upper"))
    ok = other.converged and all(np.all(np.isfinite(a)) for a in o_points)
    return second_half(fit.get("mask"), span), o_points if ok else None


def clock_order(fit, other, other_fit) -> float:
    """The order with the parameters constant in the data's unit of time (`other`,
    `other_fit`): its median over the second half of the span's fitted points (`fit`), NaN
    where that fit failed. Reported whether or not the band covers it."""
    half, o_points = _other_points(fit, other, other_fit)
    return float("nan") if o_points is None else float(np.median(o_points[0][half:]))


def evidence_apart(res, fit, other) -> float:
    """How much better the span's fit (`res`, its fitted points `fit`) explains the data than
    the one with the parameters constant in the data's unit (`other`): the difference of
    their tuned log-likelihoods per fitted point (the block means of a long record)."""
    mask, span = fit.get("mask"), fit["span"]
    points = span if mask is None else int(np.sum(np.asarray(mask)[:span] > 0))
    gain = res.tuning.log_likelihood - other.tuning.log_likelihood
    return float(gain / max(points, 1))


def weigh_clock(res, fit, other, other_fit, bound=None, scale=1.0, answer=np.inf,
                evidence=np.inf, profile=None):
    """The span's result `res` and its fitted points `fit` (see `Tracker._fit`) weighed
    against the data's-unit fit (`other`, `other_fit`): where that fit's order lies outside
    the stated band (`outside`, on the fitted points) the band is widened to cover both;
    where it lies outside the stated or the conditional band, that order's median over the
    second half is returned (the conditional answer bounds a drift on the span's clock only),
    else None, and `res` and `fit` unchanged.

    `bound`: the relative drift of the parameters the call states (None: free). Where that
    fit's parameters, constant in the data's unit, drift beyond it on the span's clock
    (`clock_drift`, over the record's span of `scale` data units), the statement excludes
    that account: the band covers it only where the data favour it at least as much as the
    span's fit (`evidence_apart` ≤ 0) and the union's half-width (median over the second
    half) stays within `answer`, and the conditional answer is kept. Where the span's
    fit explains the data better by more than `evidence` nats per fitted point
    (`evidence_apart`), whatever the statement, the data exclude that account: the band is
    the span's and the conditional answer is kept. `profile` (Δχ²): where the statement
    excludes that account, the band still covers it read on a profile likelihood, as the
    level profile's held scales are (`vojax._tracker._band.profile_spread`): its order moved
    back towards the span's by `moved_share` of twice the log-likelihood it loses (None:
    not covered)."""
    span = fit["span"]
    half, o_points = _other_points(fit, other, other_fit)
    if o_points is None:
        return res, fit, None
    points = tuple(np.asarray(fit[k])[:span] for k in ("alpha", "lower", "upper"))
    o_alpha = o_points[0]
    clock = float(np.median(o_alpha[half:]))
    # an account the data exclude: the span's fit explains them better by a clear margin
    apart = evidence_apart(res, fit, other)
    if apart > evidence:
        return res, fit, None
    # a drift on the span's clock beyond the stated bound: an account the statement excludes
    excluded = bound is not None and clock_drift(o_alpha, scale) > bound
    if not outside(o_alpha, (*points, 0.0), half):
        cond = fit.get("conditional")
        beyond = cond is not None and outside(
            o_alpha, (None, *(np.asarray(a)[:span] for a in cond[1:3]), None), half)
        return res, fit, clock if beyond and not excluded else None
    _, lo, hi, _ = union((*points, 0.0), (*o_points, 0.0))
    fields = ("alpha", "alpha_lower", "alpha_upper", "alpha_std")
    o_res = tuple(np.asarray(getattr(other, k)) for k in fields)
    if excluded and (apart > 0.0 or np.median(hi[half:] - lo[half:]) / 2 > answer):
        # covered only where the data favour it as much and covering it leaves an answer …
        if profile is None:
            return res, fit, None
        # … or, read on a profile likelihood, its order moved back towards the span's
        move = moved_share(2.0 * (res.tuning.log_likelihood - other.tuning.log_likelihood),
                           profile)
        o_alpha = points[0] + move * (o_alpha - points[0])
        _, lo, hi, _ = union((*points, 0.0), (o_alpha, o_alpha, o_alpha, 0.0))
        r_alpha = np.asarray(res.alpha)
        o_res = (r_alpha + move * (o_res[0] - r_alpha),) * 3 + (0.0,)
        if not outside(o_alpha, (*points, 0.0), half):
            return res, fit, None
    fit = dict(fit, lower=np.concatenate([lo, np.asarray(fit["lower"])[span:]]),
               upper=np.concatenate([hi, np.asarray(fit["upper"])[span:]]))
    _, r_lo, r_hi, std = union(tuple(np.asarray(getattr(res, k)) for k in fields), o_res)
    res = dataclasses.replace(res, alpha_lower=to_device(r_lo), alpha_upper=to_device(r_hi),
                              alpha_std=to_device(std))
    return res, fit, clock
