"""Band rules scored on saved explanations (`band_explanations.py --dump`): per setting and
family, the records identified, the pooled coverage of the ±2σ band over the second half of
the fitted clock, the median z RMS of the identified, the median order RMS, the confidently
wrong (identified, the truth outside the band at most samples)."""

import numpy as np
from band_library import as_reported, clock_union, library_bands, reported_kwargs  # noqa: F401
from calibration_tables import SHORT_OF  # the coverage an identified record owes

HALFWIDTH = 0.1
SMOOTHED = ("tuned", "start", "order_drift", "param_drift", "held_order")
CONSTANT = ("tuned", "start", "order_drift", "level", "held")


def order_of(beta, bounds):
    lo, hi = bounds
    s = 1.0 / (1.0 + np.exp(-np.asarray(beta, float)))
    return lo + (hi - lo) * s, (hi - lo) * s * (1.0 - s)


def explanations(r, kinds=None):
    return [e for e in r["explanations"] if kinds is None or e["kind"] in kinds]


def tuned(r):
    out = explanations(r, ("tuned",))
    return out[0] if out else None


def mixture_var(r, kinds=("tuned", "start", "order_drift")):
    """`mix_modes` over the tuned run and its alternatives of `kinds` (the tuned run first)."""
    from vojax._tracker._smoother import mix_modes

    ex = explanations(r, kinds)
    ex = [e for e in ex if e["kind"] == "tuned"] + [e for e in ex if e["kind"] != "tuned"]
    betas = np.stack([np.asarray(e["beta"], float) for e in ex])
    var = np.stack([np.maximum(np.asarray(e["var"], float), 0) for e in ex])
    scores = np.array([e["evidence"] for e in ex], float)
    span = betas.shape[1]
    v, _ = mix_modes(betas, var, scores, 0, span)
    return v


def band_from(center, var, bounds, members=(), k=1.0):
    """The band about the β trajectory `center` with variance `var` (× k²), widened to cover
    each member's ±2kσ; returns (alpha, lower, upper, sd) on the order scale."""
    sd_b = k * np.sqrt(np.maximum(var, 0))
    alpha, slope = order_of(center, bounds)
    lower = order_of(center - 2 * sd_b, bounds)[0]
    upper = order_of(center + 2 * sd_b, bounds)[0]
    widened = False
    for b, v in members:
        s = k * np.sqrt(np.maximum(v, 0))
        lower = np.minimum(lower, order_of(b - 2 * s, bounds)[0])
        upper = np.maximum(upper, order_of(b + 2 * s, bounds)[0])
        widened = True
    sd = slope * sd_b
    if widened:
        sd = np.maximum(sd, (upper - lower) / 4)
    return alpha, lower, upper, sd


def score(r, band):
    """`band`: ``(alpha, lower, upper, sd)``, or with a fifth element True where the rule
    weighed the second clock itself (`as_reported`): the record's own ``clock`` reason,
    given for the band it reported, then blocks nothing."""
    own_clock = len(band) == 5 and band[4]
    truth = np.asarray(r["truth"], float)
    # a long record's fitted points past its span (the bucket's padding) are not scored
    alpha, lower, upper, sd = (np.asarray(a, float)[:truth.size] for a in band[:4])
    half = slice(r.get("scored_from", truth.size // 2), truth.size)  # the demo's: t > 50
    inside = (truth >= lower) & (truth <= upper)
    width = float(np.median((upper - lower)[half]) / 2)
    others = [x for x in r["other_reasons"] if not (own_clock and x == "clock")]
    ident = width <= HALFWIDTH and not others
    cov = float(np.mean(inside[half]))
    z = (alpha - truth)[half] / np.maximum(sd[half], 1e-300)
    return dict(identified=ident, coverage=cov, inside=int(np.sum(inside[half])),
                count=int(truth[half].size), z=float(np.sqrt(np.mean(z**2))),
                rms=float(np.sqrt(np.mean((alpha - truth)[half] ** 2))),
                wrong=bool(ident and cov < 0.5), width=width)


def table(rows, rules, settings, families):
    """One row per setting, rule and family (and pooled). Each record is scored once per
    rule and its score reused by its family's row and the pooled one."""
    lines = ["| setting | rule | family | identified | coverage (identified) | z RMS "
             "(identified, median) | z RMS (all, median) | order RMS | confidently wrong | "
             f"coverage short of {SHORT_OF} (of identified) |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for setting in settings:
        mine = [r for r in rows if r["setting"] == setting]
        for name, rule in rules.items():
            scores = [(r["family"], score(r, b)) for r in mine if (b := rule(r)) is not None]
            for family in [*families, "pooled"]:
                scored = [s for f, s in scores if family == "pooled" or f == family]
                if not scored:
                    continue
                ident = [s for s in scored if s["identified"]]
                cov = (sum(s["inside"] for s in ident) / max(1, sum(s["count"] for s in ident))
                       if ident else float("nan"))
                zi = np.median([s["z"] for s in ident]) if ident else float("nan")
                za = np.median([s["z"] for s in scored])
                lines.append(
                    f"| {setting} | {name} | {family} | {len(ident)}/{len(scored)} | "
                    f"{cov:.2f} | {zi:.2f} | {za:.2f} | "
                    f"{np.median([s['rms'] for s in scored]):.4f} | "
                    f"{sum(s['wrong'] for s in ident)}/{len(ident)} | "
                    f"{sum(s['coverage'] < SHORT_OF for s in ident)}/{len(ident)} |")
    return lines


# ---------------------------------------------------------------- rules


def reported(r):
    return r["alpha"], r["lower"], r["upper"], r["std"]


def tuned_only(r, k=1.0):
    t = tuned(r)
    if t is None:
        return None
    return band_from(np.asarray(t["beta"], float), np.asarray(t["var"], float), r["bounds"], k=k)


def mixture_only(r, k=1.0):
    t = tuned(r)
    if t is None:
        return None
    return band_from(np.asarray(t["beta"], float), mixture_var(r), r["bounds"], k=k)


def level_weights(r, members):
    """Weights ∝ exp(−Δχ²/2) over the held scales' runs (the tuned run as the scale 1),
    by trapezoid quadrature in log-ratio order is not kept: equal weights per run."""
    chi2 = np.array([e["chi2"] for e in members], float)
    ok = np.isfinite(chi2) & np.array([np.isfinite(e["evidence"]) or e["kind"] == "tuned"
                                       for e in members])
    w = np.where(ok, np.exp(-(chi2 - np.min(chi2[ok])) / 2), 0.0)
    return w / w.sum()


def level_integrated(r, k=1.0, combine="add"):
    t = tuned(r)
    if t is None:
        return None
    members = [t] + explanations(r, ("level",))
    w = level_weights(r, members)
    bt = np.asarray(t["beta"], float)
    v_l = sum(wi * (np.asarray(e["var"], float) + (np.asarray(e["beta"], float) - bt) ** 2)
              for wi, e in zip(w, members))
    v_mix = mixture_var(r)
    var = v_mix + v_l - np.asarray(t["var"], float) if combine == "add" else np.maximum(v_mix, v_l)
    return band_from(bt, var, r["bounds"], k=k)


def union_fitting(r, kinds, k=1.0, delta=None):
    """The mixture's band widened by the ±2σ of every explanation of `kinds` that fits (the
    χ² test, or with `delta` Δχ² ≤ delta from the tuned run)."""
    t = tuned(r)
    if t is None:
        return None
    members = []
    for e in explanations(r, kinds):
        if e["kind"] == "tuned":
            continue
        fits = e["accepted"] if e["accepted"] is not None else (
            e["chi2"] <= e["dof"] + 2 * np.sqrt(2 * e["dof"]))
        if delta is not None and e["kind"] != "trade":
            fits = fits and e["chi2"] <= t["chi2"] + delta
        if fits and (np.isfinite(e["evidence"]) or e["kind"] == "trade"):
            members.append((np.asarray(e["beta"], float), np.asarray(e["var"], float)))
    return band_from(np.asarray(t["beta"], float), mixture_var(r), r["bounds"], members, k=k)


# the level profile's held scales weighed by each run's floor at its own expectation, and by
# its χ² above it, runs within k √(2 dof) of it alike (docs/calibration.md: measured, not
# adopted), by their `bands` arguments
LEVEL_RULES = {"as reported, level weights freedom": dict(level_weights="freedom"), **{
    f"as reported, level weights excess alike {k:g}": dict(level_weights="excess",
                                                           excess_alike=k)
    for k in (0.0, 0.25, 0.5, 1.0)}}


def false_statements(rows, named):
    """Per constant statement and rule of `named` (name: `bands` arguments): of the records
    whose parameters drift (the statement false), those the rule leaves confidently wrong,
    and those of them whose reach does not warn (a breakdown drift at or above the true
    drift), by name."""
    lines = ["| setting | rule | confidently wrong (statement false) | reach not below the "
             "true drift |", "|---|---|---|---|"]
    for setting in ("constant", "constant-x0"):
        false = [r for r in rows if r["setting"] == setting and r["true_drift"] > 0]
        for name, kw in {"as reported": {}, **named}.items():
            wrong = [r for r in false
                     if (b := as_reported(r, **kw)) is not None and score(r, b)["wrong"]]
            unwarned = [f"{r['family']} {r['index']}" for r in wrong if library_bands(
                r, **reported_kwargs(r, **kw)).breakdown_drift >= r["true_drift"]]
            lines.append(f"| {setting} | {name} | {len(wrong)}/{len(false)} | "
                         f"{len(unwarned)}: {', '.join(unwarned) or '-'} |")
    return lines


def report(rows, out=None, only=None):
    """The table of every rule (or those whose name contains a word of `only`) and the
    conditional answers' promises, printed and written to `out`."""
    families = sorted({r["family"] for r in rows})
    settings = sorted({r["setting"] for r in rows})
    rules = {
        "reported": reported,
        "tuned": tuned_only,
        "mixture": mixture_only,
        "level-integrated": level_integrated,
        "union-fitting (no trade)": lambda r: union_fitting(
            r, ("start", "order_drift", "param_drift", "held_order", "level", "held")),
        "union-fitting Δχ²≤4": lambda r: union_fitting(
            r, ("start", "order_drift", "param_drift", "held_order", "level", "held", "trade"),
            delta=4.0),
    }
    rules.update({
        # the evidence floor (`TrackerSettings.envelope_evidence`) on every alternative
        # smoothing, at the default and nearer (docs/calibration.md)
        **{f"as reported, floor {e:g} nats": (lambda e: lambda r: as_reported(
            r, evidence_floor=e))(e) for e in (200.0, 120.0, 5.0)},
        "library stated": library_rule("stated"),
        "library conditional": library_rule("conditional"),
        "library conditional k=1.5": library_rule("conditional", scale=1.5),
        # the level profile's held scales weighed by a tempered likelihood ratio, without
        # the floor at the degrees of freedom (docs/calibration.md: not adopted)
        **{f"as reported, held scales by exp(−Δχ²/{2 * c:g})": tempered_levels(c)
           for c in (1.0, 4.0, 10.0)},
        # the level profile's held scales within an evidence floor of the tuned run
        **{f"as reported, held scales within {f:g} nats": held_scales(within=f)
           for f in (50.0, 100.0, 200.0, 400.0)},
        # the level profile's held scales within k σ of a χ² of the tuned run's (`level_gap`),
        # at the order's least σ (`band_floor`) of the defaults and at twice it
        **{f"as reported, held scales within {k:g} sigma, σ floor {f:g}": levels_near_chi2(
            k, floor=f) for k in (1.0, 2.0, 2.5, 3.0, 4.0, np.inf) for f in (0.0025, 0.005)},
        # the tuned run's alternatives far below its evidence weighed, not covered
        # (CHANGELOG: measured and not adopted)
        **{f"as reported, far ({20:g} nats) {w} weighed": far_alternatives_weighed(w)
           for w in ("starts", "slower", "faster", "fastest", "all")},
        # the level profile's held scales weighed by each run's own expectation
        **{name: (lambda kw: lambda r: as_reported(r, **kw))(kw)
           for name, kw in LEVEL_RULES.items()},
        # the stated band where the parameters may drift over the explanations that fit as
        # well as the tuned smoothing, off and at 2 (the default) and 3 standard deviations
        **{f"as reported, relative gap {z}": (lambda z: lambda r: as_reported(
            r, gap_z=z))(z) for z in (None, 2.0, 3.0)},
        # the held smoothing and its held scales left out where the data exclude constant
        # parameters (CHANGELOG: measured and not adopted)
        **{f"as reported, held within {x:g} nats": held_within(x)
           for x in (50.0, 20.0, 10.0, 5.0)},
    })
    if only:
        rules = {name: rule for name, rule in rules.items() if any(w in name for w in only)}
    lines = table(rows, rules, settings, families) + [""] + promises(rows)
    named = {name: kw for name, kw in LEVEL_RULES.items() if name in rules}
    if named:
        lines += [""] + false_statements(rows, named)
    text = "\n".join(lines)
    print(text)
    if out:
        from pathlib import Path

        Path(out).write_text(text + "\n")


def held_scales(temper=None, within=None):
    """`as_reported` with the level profile's held scales about the tuned smoothing
    (``kind="level"``) weighed otherwise than by the library: ``temper`` c, by
    exp(−Δχ²/(2c)) from the best (the tuned run among them), no χ² raised to the degrees of
    freedom, a likelihood ratio tempered by c instead of the library's rule that every scale
    fitting within the noise weighs alike; ``within`` N, as the library weighs them, but only
    those whose Laplace evidence lies within N nats of the tuned run's."""
    def rule(r):
        from vojax._tracker import _band

        library = _band.level_spread

        def spread(explanations, reference, level_weights="chi2", kind="level", gap=None,
                   **rest):
            levels = [e for e in explanations if e.kind == kind and e.converged]
            if kind != "level" or not levels:
                return library(explanations, reference, level_weights, kind, gap, **rest)
            if within is not None:
                near = [e for e in explanations if e.kind != "level"
                        or e.evidence >= reference.evidence - within]
                return library(near, reference, level_weights, kind, gap, **rest)
            members = [reference] + levels
            chi2 = np.array([e.chi2 for e in members])
            return _band.mixture_spread(members, np.exp(-(chi2 - chi2.min()) / (2.0 * temper)),
                                        reference)

        _band.level_spread = spread
        try:
            return as_reported(r)
        finally:
            _band.level_spread = library
    return rule


def tempered_levels(c):
    """`held_scales` weighed by a likelihood ratio tempered by `c`."""
    return held_scales(temper=c)


def levels_near_chi2(k, **kwargs):
    """`as_reported` (with `kwargs`) with the held scales left out where their χ² exceeds the
    tuned run's by more than `k` standard deviations of a χ² with their degrees of freedom
    (k·√(2 dof): the library's `level_gap`; ∞, every held scale that fits weighs)."""
    return lambda r: as_reported(r, level_gap=k, **kwargs)


def far_alternatives_weighed(which, limit=20.0):
    """`as_reported` with some of the tuned run's own alternatives more than `limit` nats
    below its evidence left out of the union (their weight in its mixture is below e^−limit,
    so leaving them out of the list is leaving them to that weight): ``"starts"``, its other
    starts; ``"slower"``, those and its order drifts at the factors of `alt_order_drift` below
    1 (× the tuned drift, or `order_drift_base` where that is larger); ``"faster"``, its
    order drifts at the factors above 1 alone; ``"fastest"``, its order drift at the largest
    factor alone; ``"all"``, every start and order drift (the
    rule measured and withdrawn before, less its change where the held smoothing answers)."""
    from vojax import TrackerSettings

    factors = TrackerSettings().alt_order_drift

    def rule(r):
        ex = r["explanations"]
        ref = tuned(r)
        if ref is None or not np.isfinite(ref["evidence"]):
            return as_reported(r)
        drifts = [i for i, e in enumerate(ex) if e["kind"] == "order_drift"]
        if len(drifts) != len(factors):
            return as_reported(r)  # some did not run: which is which is not known
        pick = {"starts": [], "all": drifts,
                "slower": [i for i, m in zip(drifts, factors) if m < 1],
                "faster": [i for i, m in zip(drifts, factors) if m > 1],
                "fastest": [i for i, m in zip(drifts, factors) if m == max(factors)]}[which]
        dropped = {i for i, e in enumerate(ex)
                   if e["evidence"] < ref["evidence"] - limit
                   and ((e["kind"] == "start" and which in ("starts", "slower", "all"))
                        or i in pick)}
        return _without(r, lambda i, e: i in dropped)
    return rule


def held_within(limit):
    """`as_reported` with the held smoothing (the parameters held where the tuned ones
    drift) and its held scales left out where its evidence lies more than `limit` nats below
    the tuned smoothing's: the data exclude constant parameters, so it is neither the
    band's reference nor a member."""
    def rule(r):
        ex = r["explanations"]
        ref = tuned(r)
        held = next((e for e in ex if e["kind"] == "held"), None)
        if (ref is None or held is None or not np.isfinite(ref["evidence"])
                or held["evidence"] >= ref["evidence"] - limit):
            return as_reported(r)
        return _without(r, lambda i, e: e["kind"] in ("held", "held_level"))
    return rule


def _without(r, drop):
    """`as_reported` on the record `r` less the explanations for which `drop(index,
    explanation)` is true."""
    return as_reported(dict(r, explanations=[e for i, e in enumerate(r["explanations"])
                                             if not drop(i, e)]))


def library_rule(which, **kwargs):
    def rule(r):
        b = library_bands(r, **kwargs)
        if b is None:
            return None
        return b.stated if which == "stated" else b.conditional
    return rule


def promises(rows, **kwargs):
    """The conditional answers' promise per setting and family: how many records are
    conditionally identified, how many of those miss the truth, and how many of the latter
    promise more than their true drift (breakdown > true drift)."""
    lines = ["| setting | family | conditional (narrow) | miss the truth | breakdown > true "
             "drift (false promise) | breakdown drift (median, conditional) |",
             "|---|---|---|---|---|---|"]
    for setting in sorted({r["setting"] for r in rows}):
        for family in sorted({r["family"] for r in rows}):
            sel = [r for r in rows if r["setting"] == setting and r["family"] == family]
            narrow, miss, false, drifts = 0, 0, 0, []
            for r in sel:
                b = library_bands(r, **kwargs)
                if b is None:
                    continue
                s = score(r, b.conditional)
                if s["width"] <= HALFWIDTH:
                    narrow += 1
                    drifts.append(b.breakdown_drift)
                    if s["coverage"] < 0.5:
                        miss += 1
                        false += b.breakdown_drift > r["true_drift"]
            med = np.median(drifts) if drifts else float("nan")
            lines.append(f"| {setting} | {family} | {narrow}/{len(sel)} | {miss} | {false} | "
                         f"{med:.3g} |")
    return lines
