"""The band from the explanations: the answer under what the user states about the
parameters, the conditional answer (the band the data give while the parameters drift less
than its breakdown drift), and that breakdown drift.

Each explanation that fits the data (`Explanation.fits`), a smoothing only where its
evidence is not far below the tuned one's (`bands`' `evidence_floor`; the freest order
drift tried, `fastest_evidence`), is an account the band must cover when the statement
allows its drift. The reference is the fitting smoothing
whose parameters drift least (the tuned smoothing where none fits); its band is the
evidence-weighted mixture of the tuned intensities' modes and order drifts, with the
parameters' scale integrated over the level profile where they are held; with the
parameters stated constant, its modes and order drifts whose evidence lies within
`near_evidence` nats of the tuned one's are covered as well. Going up in drift,
each fitting explanation inside the band so far joins it; the first one outside it sets the
breakdown drift: with that much drift an order outside the band explains the data as well,
and no test of this record tells them apart. Moving orders (`vojax._tracker._moving`) join
the ladder where a constant order breaks the conditional answer: they can only lower the
breakdown drift. Where the statement allows more drift than that, the stated band covers
only the explanations that also fit as well as the tuned smoothing, their freedom counted
(`fits_as_well`).
"""

import dataclasses

import numpy as np

from ._model import order_of_np
from ._smoother import mix_modes

# the tuned run's own alternatives: its intensities from other starting orders, its order
# drift scaled (the same parameters' drift)
OWN = ("start", "order_drift")
# the alternatives that share the reference's assumption about the parameters: weighed into
# its variance (by evidence, or the level profile's χ²), never unioned with it
INTEGRATED = (*OWN, "level")
# the held smoothing's own held scales: weighed into its variance where it is the reference,
# never unioned with a band nor a rung of the ladder (where the tuned smoothing is the
# reference, they were run about another smoothing)
HELD_SCALES = ("held_level",)
# the alternatives that only set the breakdown drift, never widen a band: moving orders placed
# outside the band by a fixed offset (`vojax._tracker._moving`), so a band that covered them
# would be as wide as the offset, not as the data allow
REACH_ONLY = ("moving",)
# the alternatives that are smoothings, with a Laplace evidence the tuned one's is weighed
# against (the trade-off's and the moving orders' profiles have their own rule)
SMOOTHINGS = ("start", "order_drift", "param_drift", "held_order", "held", "level",
              "held_level")


@dataclasses.dataclass(frozen=True)
class Bands:
    """Bands on the order scale over the fitted points: `stated` (under the statement about
    the parameters) and `conditional` (while they drift less than `breakdown_drift`), each
    ``(alpha, lower, upper, std)``; `reference_drift` is the drift of the conditional
    answer's own parameters; `breakdown_drift` is ∞ where no order outside the conditional
    band fits the data with any drift tried."""

    stated: tuple
    conditional: tuple
    breakdown_drift: float
    reference_drift: float
    drifting: bool = False  # the stated band covers an explanation with drifting parameters
    reference_freedom: float = np.nan  # the freedom the conditional answer's drifts fit


def _orders(beta, var, bounds, scale, floor=0.0):
    """``(alpha, lower, upper, std)`` of the β trajectory `beta` with variance `var`, its
    standard deviation × `scale`, and on the order's scale at least `floor`."""
    alpha, slope = order_of_np(beta, bounds)
    sd = np.maximum(scale * np.sqrt(np.maximum(var, 0.0)), floor / np.maximum(slope, 1e-300))
    return (alpha, order_of_np(beta - 2 * sd, bounds)[0], order_of_np(beta + 2 * sd, bounds)[0],
            slope * sd)


def own_halfwidth(explanation, bounds, scale, floor, half, span) -> float:
    """The median ±2σ half-width over the second half of the fitted points, ``[half, span)``,
    of `explanation`'s own band (its Laplace variance alone; `scale`, `floor` as `bands`):
    the width the verdict reads, of the narrowest band `bands` builds about it."""
    _, lower, upper, _ = _orders(explanation.beta, explanation.var, bounds, scale, floor)
    return float(np.median((upper - lower)[half:span]) / 2)


def reference_variance(explanations, tuned, span, level_weights="chi2", level_gap=None,
                       profile_chi2=4.0, excess_alike=0.5):
    """The tuned smoothing's variance of β (N,): the evidence-weighted mixture of its modes and
    order drifts (`mix_modes`), plus, where the level profile ran, the parameters' scale
    integrated over it. `level_weights`: how each held scale is weighed against the tuned run:
    ``"chi2"``, by exp(−Δχ²/2) from the best, a χ² below its degrees of freedom counted as dof
    (a run that fits below the noise has fitted noise, and that earns it no weight over a held
    scale that fits as well as the noise allows); ``"freedom"``, the same with each run's
    floor at its degrees of freedom less the freedom its drifts fit (`chi2_floor`: a tuned
    run whose drifts fit 150 effective parameters leaves a χ² about 150 below dof where it
    is the truth, so a held scale 100 units above it, as free, fits worse than the noise
    allows, not as well); ``"evidence"``, by its Laplace evidence
    (where every member's is finite; else by χ²); ``"profile"``, not weighed but covered as
    a profile likelihood's interval, each moved back by `profile_chi2` (`profile_spread`);
    ``"excess"``, by exp(−Δ/2) of each run's χ² above what it leaves on average where it is
    the truth, every run within `excess_alike` × √(2 dof) of that alike (`level_score`).
    `level_gap`: a held scale whose χ² exceeds
    the tuned run's by more than this many standard deviations of a χ² with its degrees of
    freedom (√(2 dof)) is left out (the two share every intensity, so that gap is the data's,
    not the tuned run's freedom to fit the noise); None: none is."""
    mixed = [tuned] + [e for e in explanations if e.kind in OWN]
    var, _ = mix_modes(np.stack([e.beta for e in mixed]), np.stack([e.var for e in mixed]),
                       np.array([e.evidence for e in mixed]), 0, span)
    return var + level_spread(explanations, tuned, level_weights, gap=level_gap,
                              profile_chi2=profile_chi2, excess_alike=excess_alike)


def level_spread(explanations, reference, level_weights="chi2", kind="level", gap=None,
                 profile_chi2=4.0, excess_alike=0.5):
    """What the level profile adds to the variance of β (N,) of the `reference` (the
    smoothing it ran about, or one with the parameters as constant): its held scales (the
    explanations of `kind`; with a `gap`, only those whose χ² exceeds the reference's by at
    most that many √(2 dof), see `reference_variance`) and the reference weighed as
    `reference_variance` says, their mixture's variance about the reference's β less the
    reference's own; 0 where the profile did not run. About the held smoothing
    (``kind="held_level"``) by exp(−Δχ²/2) from the best, with no floor at the degrees of
    freedom: the held smoothing and its scales share every intensity, so their χ² differ by
    the likelihood ratio alone."""
    at_dof = kind == "level"
    levels = [e for e in explanations if e.kind == kind and e.converged and (
        gap is None or e.chi2 <= reference.chi2 + gap * np.sqrt(2.0 * e.dof))]
    if at_dof and level_weights == "profile":
        return profile_spread([e for e in levels if e.fits], reference, profile_chi2)
    if not levels:
        return 0.0
    members = [reference] + levels
    if level_weights == "evidence" and all(np.isfinite(e.evidence) for e in members):
        score = np.array([e.evidence for e in members])
        w = np.exp(score - score.max())
    else:
        chi2 = np.array([level_score(e, level_weights, excess_alike) if at_dof else e.chi2
                         for e in members])
        w = np.exp(-(chi2 - chi2.min()) / 2)
    return mixture_spread(members, w, reference)


def level_score(explanation, level_weights="chi2", excess_alike=0.5) -> float:
    """The χ² by which a run of the level profile (or the run it is weighed against) is
    weighed: its χ² floored at `chi2_floor`; with ``"excess"``, its χ² plus the freedom its
    drifts fit (0 where unknown), floored at its degrees of freedom plus `excess_alike` ×
    √(2 dof): how far its χ² lies above what it leaves on average where it is the truth
    (``dof − freedom``), every run within that many standard deviations of a χ² alike (a
    run fitting below its expectation has fitted noise, and earns no weight by it)."""
    e = explanation
    if level_weights == "excess":
        free = max(e.freedom, 0.0) if np.isfinite(e.freedom) else 0.0
        return max(e.chi2 + free, e.dof + excess_alike * np.sqrt(2.0 * e.dof))
    return max(e.chi2, chi2_floor(e, level_weights))


def chi2_floor(explanation, level_weights="chi2") -> float:
    """The χ² below which a held scale (or the run it is weighed against) earns no more
    weight: its degrees of freedom (``"chi2"``), or, with ``"freedom"``, those less the
    freedom its drifts fit (`Explanation.freedom`): the χ² it leaves on average where it is
    the truth (its degrees of freedom where that freedom is unknown)."""
    e = explanation
    if level_weights == "freedom" and np.isfinite(e.freedom):
        return e.dof - max(e.freedom, 0.0)
    return e.dof


def moved_share(gap, profile) -> float:
    """The share of an account's distance from the answer that a profile likelihood keeps
    where that account fits `gap` units of χ² worse: all of it up to `profile` units, then
    √(`profile`/`gap`) (a quadratic profile's Δχ² = `profile` point)."""
    return 1.0 if gap <= profile else float(np.sqrt(profile / gap))


def profile_spread(levels, reference, chi2=4.0):
    """What the level profile adds to the variance of β (N,) of the `reference` read as a
    profile likelihood: each held scale in `levels` (those that fit) moves the order by its
    β − the reference's, kept at `moved_share` of the Δχ² by which it lies above the
    reference (all of it within `chi2`; at 4, the ±2σ edge of one parameter's interval).
    The variance makes the ±2σ band cover each moved scale's own ±2σ; 0 where none fits."""
    if not levels:
        return 0.0
    need = 0.0
    for e in levels:
        moved = (e.beta - reference.beta) * moved_share(e.chi2 - reference.chi2, chi2)
        need = np.maximum(need, (np.abs(moved) / 2 + np.sqrt(e.var)) ** 2)
    return np.maximum(need - reference.var, 0.0)


def mixture_spread(members, weights, reference):
    """What a mixture of `members` (explanations, the `reference` among them) in proportion
    to `weights` adds to the variance of β (N,) of the `reference`: the mixture's variance
    about the reference's β less the reference's own."""
    w = np.asarray(weights, float) / np.sum(weights)
    spread = sum(wi * (e.var + (e.beta - reference.beta) ** 2) for wi, e in zip(w, members))
    return spread - reference.var


def first_fitted(mask) -> int:
    """The first fitted sample: a fit window's start (0 without a mask)."""
    return 0 if mask is None else int(np.flatnonzero(np.asarray(mask) > 0)[0])


def second_half(mask, span) -> int:
    """Where the second half of the fitted samples' range begins: the range from the first
    fitted sample to `span`, halved."""
    first = first_fitted(mask)
    return first + (span - first) // 2


def outside(alpha, band, half):
    """An order trajectory lies outside a band: at most samples of the second half."""
    _, lower, upper, _ = band
    out = (alpha < lower) | (alpha > upper)
    return bool(np.mean(out[half:]) > 0.5)


def union(band, member):
    """The `band` ``(alpha, lower, upper, std)`` widened to cover `member`'s: its estimate
    kept, its standard deviation at least a quarter of the union's width."""
    alpha, lower, upper, std = band
    _, lo, hi, _ = member
    return alpha, np.minimum(lower, lo), np.maximum(upper, hi), np.maximum(std, (np.maximum(
        upper, hi) - np.minimum(lower, lo)) / 4)


def fastest_far(explanations, tuned, limit):
    """The `explanations` less the freest order drift tried (the largest `factor` among the
    order drifts) where its evidence lies more than `limit` nats below the `tuned` one's: its
    weight in the tuned run's mixture is below e^−limit, and leaving it out of the band is
    leaving it to that weight."""
    factors = [e.factor for e in explanations if e.kind == "order_drift" and e.factor is not None]
    if not factors or not np.isfinite(tuned.evidence):
        return list(explanations)
    top = max(factors)
    return [e for e in explanations if not (
        e.kind == "order_drift" and e.factor == top and e.evidence < tuned.evidence - limit)]


def near_alternatives(explanations, tuned, limit):
    """The `tuned` run's own alternatives (its other starts and order drifts: the same
    parameters, other intensities or starting orders) that stand for the data (`holds`) with
    a Laplace evidence at most `limit` nats below its own. Their weight in the tuned run's
    mixture is at least e^−limit; an evidence that near does not exclude them, for a
    random-walk order whose one intensity cannot follow both a fast and a slow part of the
    record."""
    if not np.isfinite(tuned.evidence):
        return []
    return [e for e in explanations if e.kind in OWN and e.holds
            and e.evidence >= tuned.evidence - limit]


def fits_as_well(e, tuned, gap_z):
    """`e` fits the data as well as the `tuned` smoothing, its freedom counted: its χ² plus
    the freedom its drifts fit exceeds the tuned run's by at most `gap_z` standard
    deviations of that difference where `e` is the truth (`gap_spread`). True for the
    explanations that are no smoothing, where either freedom is unknown (a coloured noise)
    and where `gap_z` is None."""
    if gap_z is None or e.kind not in SMOOTHINGS or not (
            np.isfinite(e.freedom) and np.isfinite(tuned.freedom)):
        return True
    gap = (e.chi2 + e.freedom) - (tuned.chi2 + tuned.freedom)
    return bool(gap <= gap_z * gap_spread(e, tuned))


def gap_spread(e, tuned) -> float:
    """The standard deviation of `fits_as_well`'s gap where `e` is the truth: the run ΔF
    effective parameters freer fits a χ² of ΔF degrees of freedom better on average (variance
    2ΔF, and 2 more for the rest of the freedoms' estimate), and two runs that fit other
    outputs d apart differ in χ² by 2 d·noise/σ² as well, variance 4 Σd²/σ², which their
    χ² difference stands in for (Vuong's test of models that are not nested)."""
    return float(np.sqrt(2 * (abs(tuned.freedom - e.freedom) + 1) + 4 * abs(e.chi2 - tuned.chi2)))


def bands(explanations, bounds, span, stated_drift, scale=1.0, drift_floor=0.005,
          floor=0.0, evidence_floor=np.inf, half=None, level_weights="chi2",
          fastest_evidence=np.inf, near_evidence=None, level_gap=None, profile_chi2=4.0,
          excess_alike=0.5, gap_z=None):
    """The `Bands` of the `explanations` (the tuned smoothing's among them) on the order
    range `bounds`, over the first `span` points; `stated_drift`: the largest relative drift
    of the parameters the user vouches for (0: constant, ∞: free); `scale`: the calibrated
    factor on each explanation's standard deviation; `drift_floor`: drifts below it count as
    none (a held smoothing's parameters still move a little); `floor`: the least standard
    deviation of the order (its model error: quadrature, interpolation of the input between
    samples); `evidence_floor`: an alternative smoothing whose Laplace evidence lies more
    than this many nats below the tuned one's neither widens a band nor sets the breakdown
    drift, however well it fits: the data exclude it (a smoothing freer than the data need
    fits below the noise, its χ² no test of it); `half`: where the second half of the
    fitted samples begins (None: ``span // 2``, every sample fitted); `level_weights`: see
    `reference_variance`; `fastest_evidence`: the freest order drift tried lying more than
    this many nats below the tuned one is left to its mixture weight (`fastest_far`);
    `near_evidence`: with the parameters stated constant, the tuned run's own alternatives
    (`near_alternatives`) within this many nats of its evidence are covered, not only
    weighed (None: weighed only); `level_gap`, `profile_chi2`, `excess_alike`: see
    `reference_variance`; `gap_z`: with more drift allowed than the breakdown drift, the
    stated band covers only the explanations that fit as well as the tuned smoothing
    (`fits_as_well`), about the held smoothing only where it does (None: every one that
    fits); the conditional band and the breakdown drift are the χ² test's, whatever it is."""
    tuned = next(e for e in explanations if e.kind == "tuned")
    explanations = fastest_far(explanations, tuned, fastest_evidence)
    held = next((e for e in explanations if e.kind == "held" and e.holds), None)
    plausible = lambda e: not (  # noqa: E731
        e.kind in SMOOTHINGS and np.isfinite(tuned.evidence)
        and e.evidence < tuned.evidence - evidence_floor)
    # the reference: the tuned smoothing, with its alternatives weighed in; the smoothing with
    # the parameters held where the tuned one lets them drift and the held one fits too, with
    # its held scales that the data do not exclude
    def reference_of(held):
        if held is not None and tuned.drift > drift_floor:
            # its scales widen it, never narrow it: a scale whose curvature is sharper than
            # the held smoothing's is no evidence that the held smoothing's own σ is too wide
            spread = np.maximum(level_spread([e for e in explanations if plausible(e)], held,
                                             level_weights, "held_level"), 0.0)
            return held, _orders(held.beta, held.var + spread, bounds, scale, floor)
        return tuned, _orders(tuned.beta, reference_variance(
            explanations, tuned, span, level_weights, level_gap, profile_chi2, excess_alike),
            bounds, scale, floor)

    reference, ref_band = reference_of(held)
    ladder = [e for e in explanations
              if e.kind not in ("tuned", *INTEGRATED, *HELD_SCALES) and e is not held
              and e.holds and plausible(e)]
    if reference is held:
        ladder.append(tuned)
    ladder.sort(key=lambda e: e.drift)
    half = span // 2 if half is None else half
    band = tuple(a[:span] for a in ref_band)
    breakdown = np.inf
    def member(e):
        return _orders(e.beta, e.var, bounds, scale, floor)

    conditional_drifts = False
    for e in ladder:
        m = tuple(a[:span] for a in member(e))
        if max(e.drift - reference.drift, 0.0) > drift_floor and outside(m[0], band, half):
            breakdown = e.drift
            break
        if e.kind in REACH_ONLY:
            continue
        band = union(band, m)
        conditional_drifts |= e.drift > reference.drift + drift_floor
    conditional = tuple(np.concatenate([a, b[span:]]) for a, b in zip(band, ref_band))
    # the stated band: with the parameters held, the reference's (its alternatives weighed
    # in, those near its evidence covered too); with a drift bound below the breakdown
    # drift, the conditional band (the promise the conditional answer makes for every drift
    # below it); with more drift allowed, every explanation that fits within it, the
    # reference's alternatives included: one input cannot say which holds
    stated, drifting = ref_band, False
    if stated_drift == 0 and near_evidence is not None and reference is tuned:
        for e in near_alternatives(explanations, tuned, near_evidence):
            stated = union(stated, member(e))
    if 0 < stated_drift < breakdown:
        stated, drifting = conditional, conditional_drifts
    elif stated_drift > 0:
        members = [e for e in explanations
                   if e.kind in INTEGRATED and e.holds and plausible(e)] + ladder
        about = reference
        if gap_z is not None:  # only those that fit as well as the tuned smoothing
            members = [e for e in members if fits_as_well(e, tuned, gap_z)]
            if reference is held and not fits_as_well(held, tuned, gap_z):
                about, stated = reference_of(None)
                drifting = tuned.drift > held.drift + drift_floor  # the band's own account
        for e in members:
            if e.kind not in REACH_ONLY and (
                    e.drift <= max(stated_drift, about.drift) + drift_floor):
                stated = union(stated, member(e))
                drifting |= e.drift > about.drift + drift_floor
    return Bands(stated, conditional, float(breakdown), float(reference.drift), drifting,
                 float(reference.freedom))
