"""The library's own bands on saved explanations (`band_explanations.py --dump`): the band
as the tracker reports it (`as_reported`), from `vojax._tracker._band.bands` on the saved
explanations and the second clock's replay (`clock_union`); `band_scores.py` scores rules
built on them."""

import numpy as np


def as_explanations(r):
    """The record's saved explanations as the library's `Explanation`s (each one's fitted
    freedom under ``"freedom"``, or ``"edf"`` in dumps saved before that name)."""
    from vojax._tracker._explanations import Explanation

    return [Explanation(e["kind"], np.asarray(e["beta"], float),
                        np.maximum(np.asarray(e["var"], float), 0), float(e["chi2"]),
                        float(e["dof"]), float(e["evidence"]), float(e["drift"]), e["accepted"],
                        e.get("factor"), float(e.get("freedom", e.get("edf", np.nan))))
            for e in r["explanations"]]


def library_bands(r, **kwargs):
    from vojax._tracker._band import bands

    ex = as_explanations(r)
    if not any(e.kind == "tuned" for e in ex):
        return None
    stated = {"free": np.inf, "constant": 0.0, "constant-x0": 0.0, "free-x0": np.inf}.get(
        r["setting"], r.get("stated") or np.inf)
    return bands(ex, r["bounds"], len(r["truth"]), stated, **kwargs)


def reported_kwargs(r, **kwargs):
    """`bands`' arguments as the tracker passes them (its default settings) for the record
    `r`, with `kwargs` in their place."""
    from vojax import TrackerSettings

    s = TrackerSettings()
    return dict(dict(scale=s.band_scale, drift_floor=s.drift_floor, floor=s.band_floor,
                     half=len(r["truth"]) // 2, level_weights=s.level_weights,
                     evidence_floor=s.envelope_evidence,
                     fastest_evidence=s.fastest_evidence,
                     near_evidence=s.near_evidence, level_gap=s.level_gap,
                     profile_chi2=s.level_profile_chi2,
                     excess_alike=s.level_excess_alike, gap_z=s.relative_gap), **kwargs)


def as_reported(r, **kwargs):
    """The band as the tracker reports it, from the library's `bands` (with `kwargs`, e.g.
    `evidence_floor`) on the saved explanations: the stated band about the reported
    estimate, its σ at least a quarter of its width, widened to the second clock's tuned
    smoothing as `clock_union` says; the fifth element True (see `score`)."""
    n = len(r["truth"])
    kwargs = reported_kwargs(r, **kwargs)
    b = library_bands(r, **kwargs)
    if b is None:
        return None
    alpha = np.asarray(r["alpha"], float)
    _, lower, upper, sd = (np.asarray(a, float)[:n] for a in b.stated)
    band = (alpha, lower, upper, np.maximum(sd, (upper - lower) / 4))
    profile = kwargs["profile_chi2"] if kwargs["level_weights"] == "profile" else None
    return (*clock_union(r, band, profile), True)


def clock_union(r, band, profile=None):
    """`band` widened to the second clock's tuned smoothing (the data's unit of time) as
    `Tracker` weighs it (`vojax._tracker._clock.weigh_clock`): where that order lies outside
    the band, the union, unless the data exclude that account (the span's fit ahead by more
    than `clock_evidence` nats per point, unless a drift bound is stated), or the statement
    does (parameters stated constant, which drift on the span's clock beyond `drift_floor`)
    and either the span's fit is ahead or covering it would leave no answer (a half-width
    beyond `identified_halfwidth`). Dumps without the span's length in the data's unit
    (`clock_scale`) count a constant statement's account as drifting. `profile`: where the
    statement excludes that account, its order moved back towards the span's band's estimate
    as `vojax._tracker._clock.weigh_clock` moves it, and covered where it is then outside."""
    from vojax import TrackerSettings
    from vojax._tracker._band import outside, union
    from vojax._tracker._clock import clock_drift

    other, n = r.get("other"), len(r["truth"])
    half = n // 2
    if other is None or not other["converged"]:
        return band
    o_alpha = np.asarray(other["alpha"], float)[:n]
    if not outside(o_alpha, (*band[:3], 0.0), half):
        return band
    s = TrackerSettings()
    scale = r.get("clock_scale")
    constant = r["setting"] in ("constant", "constant-x0")
    drifts = scale is None or clock_drift(o_alpha, scale) > s.drift_floor
    apart = (r["log_likelihood"] - other["log_likelihood"]) / max(n, 1)
    if r["setting"] != "stated" and apart > s.clock_evidence:
        return band
    excluded = constant and drifts
    widened = union(band, (o_alpha, np.asarray(other["lower"], float)[:n],
                           np.asarray(other["upper"], float)[:n], 0.0))
    wide = np.median(widened[2][half:] - widened[1][half:]) / 2 > s.identified_halfwidth
    if not (excluded and (apart > 0.0 or wide)):
        return widened
    if profile is None:
        return band
    from vojax._tracker._band import moved_share

    a = np.asarray(band[0], float)
    moved = a + moved_share(2.0 * apart * n, profile) * (o_alpha - a)
    return union(band, (moved, moved, moved, 0.0)) if outside(moved, (*band[:3], 0.0),
                                                                half) else band
