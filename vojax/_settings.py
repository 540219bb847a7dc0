"""Every tuned number of the tracker, in one frozen object with a line of meaning each.

Intensities are in the tracker's normalised units (output about its reference level over its
RMS, each input over its RMS at the constant-order fit, time over the record's span), so the
same numbers serve every record. The solvers' own tolerances (the smoother's
Levenberg–Marquardt damping, the small BFGS's line search) live with the solvers.
"""

import dataclasses
import math
import typing

# the fewest and the most points a record is fitted at (`max_points`): the tracker's cost
# grows with its points (a few minutes at the most on a 2-core CPU)
MIN_POINTS = 100
TRACKER_MAX_POINTS = 50_000
# the settings that may be empty tuples (no alternatives of that kind, no level profile)
MAY_BE_EMPTY = frozenset({"alt_order_drift", "alt_param_drift", "level_ratios", "moving_offsets"})
# the settings whose None turns them off
MAY_BE_NONE = frozenset({"level_gap", "relative_gap"})


@dataclasses.dataclass(frozen=True)
class TrackerSettings:
    """The tracker's settings; pass another to `vojax.Tracker` (or `identify(settings=…)`)
    to change one, e.g. ``TrackerSettings(max_iter=200)``. Frozen: a setting never changes
    under a running fit.

    **Raises:** `ValueError` naming the setting for a value the tracker cannot use: each
    numeric setting has limits (`RANGES`; positive where unnamed), counts are whole numbers
    (``200.0`` is taken as 200), several values come as a tuple (a list is taken as one), and
    ``noise_min < noise_max``."""

    # ---- the prior of the first state (normalised units)
    prior_beta_var: float = 4.0  # β = logit of the order's place in its range: ±2 covers 12–88 %
    prior_var: float = 100.0  # parameters and offset: ±10 × the data's scale
    offset_pin: float = 1e-10  # a known offset's prior variance (±2e-5 of the output's RMS)

    # ---- the likelihood search over the noise intensities (variances over the record)
    noise_min: float = 1e-10  # the smallest measurement variance searched
    noise_max: float = 2.0  # the largest measurement variance searched
    order_drift_range: tuple[float, float] = (1e-6, 1e4)  # variance of β's change
    parameter_drift_range: tuple[float, float] = (1e-10, 1e2)  # a parameter's change
    constant_drift: float = 1e-6  # a parameter drift this small holds the parameters constant
    grid_order: tuple[float, ...] = (1e-1, 1.0, 1e1)  # order drifts of the first pass
    start_orders: tuple[float, ...] = (0.15, 0.35, 0.5, 0.65, 0.85)  # starts, fractions of range
    noise_floor: float = 0.25  # the noise variance stays ≥ this × the least difference estimate
    max_iter: int = 400  # Levenberg–Marquardt iterations of one smoothing
    # iterations of each run of the first pass: enough for the run that reaches the best mode
    grid_max_iter: int = 60
    # the first pass is also made at the constant fit's misfit when that is at least this many
    # times the data's noise (an output smoother than the model can follow stalls otherwise)
    misfit_ratio: float = 10.0
    edge: float = 0.05  # an intensity this close to an end of its range (logs) is at the edge
    refine_rtol: float = 1e-7  # the BFGS refinement's relative tolerance (step and loss)
    refine_atol: float = 1e-9  # … and its absolute one
    refine_steps: int = 60  # the most loss evaluations of one refinement
    climb_rounds: int = 2  # refinement and re-smoothing rounds of the white-noise climb
    # where the climb ends with the order's drift at its floor and the parameters drifting,
    # climb again from the first pass's best run at another order drift (stated-drift draw
    # 16: from 1.0 the evidence stops at 1599, parameters drifting 52 %; from 0.1 it is 1631)
    second_climb: bool = True
    constant_grid: int = 13  # orders of the constant fit's grid in β (−4.5 … 4.5)
    golden_steps: int = 24  # golden-section steps of the constant fit

    # ---- coloured measurement noise (white plus AR(1), chosen by evidence)
    coloured_evidence: float = 2.0  # nats the coloured model must gain (two more intensities)
    # the coloured model is also tried where the white model's noise variance is below this ×
    # the data's own (differences of order 4): its drifting states absorbed a correlated noise,
    # and its prediction errors look white (0: only where they are correlated; the suite's
    # rows in docs/calibration.md: `coloured` draw 4's order error 0.10 → 0.011)
    coloured_absorbed: float = 0.5
    # the coloured model is tried where the white model's prediction errors' lag-1 is above
    # this / √n (n errors; 2: two standard errors of a white sequence's, below the refusal
    # limit 3/√n within 0.1–0.25, which 0 restores; `informative` draw 3, lag-1 0.16 against
    # the limit 0.17: order error 0.12 → 0.0012, the rows in docs/calibration.md)
    coloured_lag: float = 2.0
    noise_time_min: float = 0.3  # shortest correlation time searched, × the median step
    noise_time_max: float = 0.1  # longest, × the span: beyond it a drift, not noise
    rho_starts: tuple[float, ...] = (0.5, 0.7, 0.85, 0.95)  # starting correlations per sample
    coloured_radius: float = math.log(3.0)  # trust region of each coloured refinement (log)
    coloured_rounds: int = 6  # refinement rounds of the coloured climb
    fatal_edge_rounds: int = 2  # rounds at the top of the correlation time that end the climb

    # ---- the alternatives the band integrates over
    held_ratio: float = 2.0  # a tuned parameter drift above this × `constant_drift` is drift
    # the held smoothing's first order drifts, × the tuned one (the best by evidence is
    # kept): a step in the order that drifting parameters absorbed needs a faster order once
    # they are held (lengths draw 7: χ²/dof 16 at the tuned drift, the truth's 0.12 unseen)
    held_order_drift: tuple[float, ...] = (1.0, 1e2, 1e4)
    # then up to this many runs climb to the evidence's peak (white draw 9: the peak at
    # ×1e5–1e6; stopped at ×1e4, χ² 742 for 597 dof, the band's reference lost) …
    held_order_climb: int = 7
    held_order_step: float = 10.0  # … by this factor, then half and a quarter of it (logs)
    alt_order_drift: tuple[float, ...] = (1e-2, 1e-1, 1e1, 1e2)  # × the tuned order drift …
    order_drift_base: float = 1e-3  # … or × this, where the tuned drift is smaller
    alt_param_drift: tuple[float, ...] = (1e-3, 1e-2, 1e-1)  # parameter drifts tried
    # nats below the tuned smoothing beyond which an alternative smoothing that fits covers
    # nothing: the data exclude it (a run freer than they need fits below the noise)
    envelope_evidence: float = 200.0
    # nats below the tuned smoothing beyond which the freest order drift tried (the largest
    # of `alt_order_drift`) is left to its weight in the mixture, not covered: on held-out
    # records its freedom fitted the noise (3 more identified, none wrong); the slower ones
    # stay covered (a moving order's lag needs its ×10 drift, 114–126 nats below)
    fastest_evidence: float = 20.0
    # nats below the tuned smoothing within which, with the parameters stated constant, its
    # own alternatives (other starts, order drifts) that fit are covered, not only weighed:
    # one order drift cannot follow a fast and a slow part of a record alike, and the
    # evidence does not exclude one so near (held-out white 23: the ×10 drift 4.5 nats below
    # covers the truth the tuned band missed; true statements' confidently wrong 2 → 0 of
    # 72 held out, identified 42 → 42, draws 0–11 54 → 53)
    near_evidence: float = 5.0
    # where the parameters are free (or drift more than the breakdown drift), an alternative
    # smoothing whose χ² plus the freedom its drifts fit exceeds the tuned run's by more than
    # this many standard deviations of that difference (`_band.gap_spread`) fits worse than
    # the tuned run: the stated band does not cover it (the conditional answer and its reach
    # still do; None: off; not made under a coloured noise). 2, as the χ² test's 2σ; replayed
    # on saved explanations, the default identifies 42 → 44 of 144 held out and 45 → 47 on
    # draws 0–11, none confidently wrong; at 3, 42 and 46 (docs/calibration.md)
    relative_gap: float | None = 2.0
    # the trade-off profile: constant orders with the parameters drifting on hat functions
    trade_knots: int = 8  # knots of the drifting parameter (and their midpoints where it pays)
    trade_orders: int = 25  # constant orders profiled, evenly across the bounds
    trade_chi2: float = 4.0  # Δχ² from the best drifting fit within which an order fits as well
    # moving orders (piecewise linear on `trade_knots` knots) tried where the constant ones
    # set a breakdown drift: their second half placed this far outside the band
    moving_offsets: tuple[float, ...] = (0.01, 0.05, 0.15)
    # each moving order a move of the answer's projection on the order's hats (False), of the
    # answer itself (True: the part of its shape the hats cannot follow, a step, kept under
    # the move), both searches ("both"), or both where the call states the parameters
    # (constant or a drift bound) and the projection alone where they are free ("stated"):
    # held out under false constant statements, both searches leave 1 of 17 confidently
    # wrong answers unwarned by their reach (2 with the projection), 5 of 19 with the offset
    # stated (7), at 6–7 % of a warm call; with free parameters they change no false
    # promise (docs/calibration.md)
    moving_base: bool | str = "stated"
    # the χ² the moves of the answer itself must reach: within `trade_chi2` of their own best
    # fit raised by the freedom the answer's drifts fit less the hats' ("freedom": its kept
    # shape was fitted to these data and lowered that fit by about so much), or of the
    # form's best constant-order fit where lower; "own": their own best as it is (as the
    # projection's moves, which carry no fitted shape); "trade": the constant orders' fit
    # alone. Held out under false constant statements "freedom" warns every confidently
    # wrong answer (1 and 5 of 17 and 19 unwarned by "own"), the reach's median 0.089 →
    # 0.023 ("trade": the same warnings, 0.015; `white`, where the statement is true, 0.13 →
    # 0.065 against 0.011; docs/calibration.md)
    moving_limit: str = "freedom"
    # the level profile: the parameters held at other scales (parameters constant)
    level_ratios: tuple[float, ...] = (0.5, 0.71, 1.41, 2.0)  # first held scales
    level_step: float = math.sqrt(2.0)  # the profile's step past an outer scale that fits …
    level_max: float = 4.0  # … up to this ratio (and down to its inverse)
    level_splits: int = 3  # bisections a side between a fitting and a failing scale
    level_pin: float = 1e-8  # prior variance of a held parameter, × its square (at least 1)
    # iterations of a held scale's smoothing: on the suite 216 of the 218 held scales that fit
    # converged within 100, and this budget moved no band edge of 128 records by over 1e-4
    # (a run still climbing here is far off the ridge; docs/calibration.md)
    level_max_iter: int = 150
    # how the band weighs the held scales: "chi2" (exp(−Δχ²/2), a χ² below its degrees of
    # freedom counted as dof: every scale that fits as well as the noise allows weighs alike)
    # or "evidence" (each smoothing's Laplace evidence: narrower, but confidently wrong on 6 of
    # 25 held-out records identified with the parameters truly stated constant, docs/calibration.md)
    # or "profile" (a profile likelihood's interval, `level_profile_chi2`: held out 52 of 72
    # identified under true constant statements, 1 confidently wrong; 45 and 0 by χ²)
    # or "freedom" (as "chi2", each run's floor at dof less the freedom its drifts fit: held
    # out with band_floor 0.005, 50 of 72 identified under true constant statements, none
    # confidently wrong, but 29 confidently wrong under false ones, 2 of them with a reach
    # above their true drift or none; 17 and 0 by χ²; with x0 stated, `long` 17 identified
    # 0.134 from the truth under a true statement)
    # or "excess" (each run by its χ² plus its fitted freedom above dof, `level_excess_alike`:
    # replayed held out, 36 of 48 on white/lengths/long/irregular under true constant
    # statements, none wrong (33 by χ²), draws 0–11 41 (41); under false ones 22 and 35
    # confidently wrong, 1 and 5 unwarned by their reach (17 and 29; 0 and 4))
    level_weights: str = "chi2"
    # standard deviations of a χ² with its degrees of freedom (√(2 dof) each) by which a held
    # scale's χ² may exceed the tuned smoothing's and still weigh in its band (None: every held
    # scale that fits weighs). Measured at 2.5, not adopted: held out, 2 more identified under
    # a true constant statement, 2 fewer by default, 5 more confidently wrong under false
    # ones (docs/calibration.md); kept for measuring
    level_gap: float | None = None
    # with `level_weights="excess"`: the standard deviations of a χ² (√(2 dof) each) above
    # its expectation within which runs weigh alike (held out, replayed on saved
    # explanations: 0.25 is confidently wrong on `lengths` 12, 0.5 on none, 1 identifies 4
    # fewer under true constant statements; docs/calibration.md)
    level_excess_alike: float = 0.5
    # with `level_weights="profile"`: the Δχ² at which a held scale's order counts in full
    # (4: the ±2σ edge of a quadratic profile); one further above is moved back by √(4/Δχ²)
    level_profile_chi2: float = 4.0
    # the band from the explanations (`vojax._tracker._band`)
    band_scale: float = 1.0  # the factor on each explanation's σ (1: calibrated on the suite)
    band_floor: float = 0.0025  # the order's least σ: its model error (quadrature, the input)
    drift_floor: float = 0.005  # a relative parameter drift below this counts as none
    # nats per fitted point by which the span's fit must out-fit the fit with the parameters
    # constant in the data's unit of time for the band to exclude that account (free or
    # stated constant; docs/calibration.md: where that account is true, the span's fit led by
    # at most 0.086 on the `clock` family and 0.136 on a staircase; where it is false and
    # outside the span's band, by 0.22–0.58 on `informative` draws 2, 5, 6 and 18)
    clock_evidence: float = 0.2

    # ---- the verdict
    identified_halfwidth: float = 0.1  # the widest ±2σ half-width (median) called identified
    bound_tol: float = 1e-3  # an order within this fraction of the range of a bound is at it
    bound_fraction: float = 0.05  # the most samples at a bound an identified order may have
    block_error_limit: float = 0.5  # the coarse clock's model error (× block noise) allowed
    # the band a refused record's settling test is expected to give the tracker: its band now
    # × (the test's bound with the oscillation / without it) to this power (fitted 0.26 on
    # draws 0–11 of four families, docs/calibration.md: the oscillation narrows the bound far
    # more than the band, which also covers parameters drifting fast enough to follow it)
    settling_exponent: float = 0.25
    # the band the tracker is expected to give on a planned test (no band now to scale): the
    # Fisher bound with one order shift and the parameters free on 8 hat functions
    # (`Design.expected`), × this (the geometric mean ratio, 6.81, on `informative` draws
    # 0–11, docs/calibration.md: the band covers drift faster than the bound's hats follow)
    protocol_factor: float = 6.8

    # ---- long records (their blocks set the numbers) and execution (no effect on them)
    max_points: int = 1_000  # a longer record is fitted as the means of blocks of samples
    # a record in blocks of at least `block_refine_from` samples whose prediction errors
    # correlate is fitted again once on up to `block_refine` times `max_points` (1: never)
    block_refine: int = 3
    block_refine_from: int = 10
    batched_block: int = 10  # blocks of at least this many samples batch each pass's runs
    run_threads: int = 8  # a pass's independent smoothings run in up to this many threads
    # the linear filter and smoother's schedule: None (sequential on a CPU, chunked on a GPU
    # or TPU), "sequential", "associative" or "chunked"
    schedule: str | None = None

    @property
    def trade_knots_fine(self) -> int:
        """The trade-off's fine knots: the coarse ones and their midpoints."""
        return 2 * self.trade_knots - 1

    @property
    def phi_block(self) -> int:
        """The columns of one run of the memory at a constant order: an input and its fine
        drifting copies."""
        return self.trade_knots_fine + 1

    def __post_init__(self):
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            if value is None and f.name in MAY_BE_NONE:
                continue
            if f.name in CHOICES:
                choices = CHOICES[f.name]
                if not any(type(value) is type(c) and value == c for c in choices):
                    words = ", ".join(repr(c) for c in choices[:-1]) + f" or {choices[-1]!r}"
                    raise ValueError(f"`{f.name}` must be {words}, got {value!r}.")
                continue
            several = typing.get_origin(f.type) is tuple
            if several and isinstance(value, list):
                value = tuple(value)  # a list where a tuple belongs: kept as a tuple
            values = value if several and isinstance(value, tuple) else (value,)
            lo, hi, whole = RANGES.get(f.name, POSITIVE)
            what = f"{'whole' if whole else 'finite'} number"
            words = (f"hold {what}s {_interval(lo, hi)}" if several
                     else f"be a {what} {_interval(lo, hi)}")
            if f.name in MAY_BE_NONE:
                words += " or None"
            if (several and not isinstance(value, tuple)) or (
                    not values and f.name not in MAY_BE_EMPTY) or not all(
                isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
                and (float(v).is_integer() if whole else True)
                and _inside(v, lo, hi) for v in values
            ) or (f.name in PAIRS and not (len(values) == 2 and values[0] < values[1])):
                shape = (", two of them, the first the smaller" if f.name in PAIRS
                         else " (a tuple)" if several else "")
                raise ValueError(f"TrackerSettings.{f.name} must {words}{shape}, got "
                                 f"{getattr(self, f.name)!r}.")
            if whole:
                value = int(value)
            object.__setattr__(self, f.name, value)
        if not self.noise_min < self.noise_max:
            raise ValueError("TrackerSettings.noise_min must be below noise_max, got "
                             f"{self.noise_min!r} and {self.noise_max!r}.")


# the settings that name a choice, and their choices
CHOICES = {"schedule": (None, "sequential", "associative", "chunked"),
           "second_climb": (True, False), "moving_base": (True, False, "both", "stated"),
           "moving_limit": ("own", "trade", "freedom"),
           "level_weights": ("evidence", "chi2", "profile", "freedom", "excess")}
# the settings that hold a range (low, high)
PAIRS = frozenset({"order_drift_range", "parameter_drift_range"})
# each numeric setting's limits ``(low, high, whole)``: a bound ``(x,)`` is open (x itself
# refused), a bare number closed; unnamed ones are `POSITIVE`. A limit keeps a value out
# that the tracker cannot use: a fraction of the order's range outside it, a step that
# climbs nowhere (the level profile would loop for ever at ``level_step`` 1), a count of
# iterations or knots that leaves nothing to fit.
POSITIVE = ((0.0,), math.inf, False)
AT_LEAST_0 = (0.0, math.inf, False)
FRACTION = ((0.0,), (1.0,), False)
RANGES = {
    "noise_floor": AT_LEAST_0, "edge": AT_LEAST_0, "coloured_evidence": AT_LEAST_0,
    "coloured_absorbed": AT_LEAST_0, "coloured_lag": AT_LEAST_0,
    "band_floor": AT_LEAST_0, "drift_floor": AT_LEAST_0, "misfit_ratio": AT_LEAST_0,
    "clock_evidence": AT_LEAST_0,
    "held_ratio": AT_LEAST_0, "envelope_evidence": AT_LEAST_0, "fastest_evidence": AT_LEAST_0,
    "near_evidence": AT_LEAST_0, "level_gap": AT_LEAST_0, "relative_gap": AT_LEAST_0,
    "level_excess_alike": AT_LEAST_0,
    "trade_chi2": AT_LEAST_0,
    "start_orders": FRACTION,
    "rho_starts": FRACTION, "noise_time_max": ((0.0,), 1.0, False),
    "bound_tol": (0.0, (0.5,), False), "bound_fraction": (0.0, 1.0, False),
    "settling_exponent": (0.0, 1.0, False), "protocol_factor": ((0.0,), (math.inf,), False),
    "held_order_step": ((1.0,), math.inf, False), "level_step": ((1.0,), math.inf, False),
    "level_max": (1.0, math.inf, False),
    "max_iter": (1, math.inf, True), "grid_max_iter": (1, math.inf, True),
    "level_max_iter": (1, math.inf, True),
    "refine_steps": (1, math.inf, True), "climb_rounds": (1, math.inf, True),
    "constant_grid": (3, math.inf, True), "golden_steps": (1, math.inf, True),
    "coloured_rounds": (1, math.inf, True), "fatal_edge_rounds": (1, math.inf, True),
    "held_order_climb": (0, math.inf, True), "trade_knots": (2, math.inf, True),
    "trade_orders": (2, math.inf, True), "level_splits": (0, math.inf, True),
    "max_points": (MIN_POINTS, TRACKER_MAX_POINTS, True), "batched_block": (1, math.inf, True),
    "run_threads": (1, math.inf, True),
    "block_refine": (1, math.inf, True), "block_refine_from": (2, math.inf, True),
}


def _inside(v, lo, hi) -> bool:
    """`v` within the limits (a one-tuple: open)."""
    above = v > lo[0] if isinstance(lo, tuple) else v >= lo
    below = v < hi[0] if isinstance(hi, tuple) else v <= hi
    return above and below


def _interval(lo, hi) -> str:
    """The limits in words: "> 0", "≥ 1", "in (0, 1)", "in [100, 50000]"."""
    lo_open, hi_open = isinstance(lo, tuple), isinstance(hi, tuple)
    lo, hi = (lo[0] if lo_open else lo), (hi[0] if hi_open else hi)
    if hi == math.inf:
        return f"{'>' if lo_open else '≥'} {lo:g}"
    return f"in {'(' if lo_open else '['}{lo:g}, {hi:g}{')' if hi_open else ']'}"
