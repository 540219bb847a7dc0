"""What a user should know before trusting an identification: typed reasons (`Reason`), each
with its message, and the `Diagnostics` that carries them."""

import dataclasses
import enum

import numpy as np

from ._settings import TrackerSettings
from ._stats import correlation_limit
from ._steps import Step, say

# the tracker's measurement-noise intensities (white; or white and coloured parts): at an edge
# of their search box (the lower edges of the two parts are named "… (lower edge)") the band
# is not a statement about the data
NOISE_EDGES = frozenset({"noise", "white_noise", "coloured_noise"})


class IdentifiabilityWarning(UserWarning):
    """The data do not pin the order down: its band is wide, or the estimate sits at a bound."""


LAW_BAND = (
    "the paper's law gives no confidence band (its ±2σ is the spread over the measurement "
    "noise, without its tracking error, and misses the truth on simulated records)"
)


class Reason(enum.StrEnum):
    """Why an order is not reported identified: a name a program can branch on (the CLI's
    `summary.json`, the troubleshooting page), each rendered into one clause of
    `Diagnostics.message` by `render`."""

    TRADE_OFF = "trade_off"  # wide because a drifting parameter explains the data as well
    CLOCK = "clock"  # wide: the order depends on the unit of time the parameters hold in
    WIDE_BAND = "wide_band"  # wide: the data do not determine the order
    AT_BOUND = "at_bound"  # the order sits at a bound of its range
    NOT_CONVERGED = "not_converged"  # the estimation did not converge
    NOISE_AT_EDGE = "noise_at_edge"  # the noise was tuned to the edge of its range
    HELD_SHIFT = "held_shift"  # holding the parameters moves the order beyond its band
    DRIFT_AT_EDGE = "drift_at_edge"  # a drift at the top of its range: a missing element?
    SETTING_AT_EDGE = "setting_at_edge"  # a tuned gain at the edge of its search
    CORRELATED = "correlated"  # correlated prediction errors: the model misses a part
    COARSE_BLOCKS = "coarse_blocks"  # the block means misrepresent the record
    UNSTABLE = "unstable"  # the law's linearisation is unstable at these gains
    NO_CONFIDENCE = "no_confidence"  # the paper's law gives no confidence band

    def render(self, interface: str = "python", **c) -> str:
        """This reason's clause of the message from its context `c` (see `diagnose`): what
        is wrong, then its numbered next steps in the words of `interface` ("python" or
        "cli")."""
        return say(self.finding(**c), self.steps(**c), interface)

    def finding(self, **c) -> str:
        """What is wrong, from the context `c`, without the next steps."""
        return _FINDINGS[self](c)

    def steps(self, **c) -> tuple[Step, ...]:
        """What would help, most useful first."""
        if self is Reason.TRADE_OFF and c.get("conditional"):  # the offset is no help there
            return tuple(step for step in _STEPS[self] if step is not Step.X0)
        return _STEPS[self]


def _trade_off(c):
    trade = c["trade"]
    where = (f" with any constant order from {trade[0]:.2f} to {trade[1]:.2f}"
             if trade is not None else "")
    if c.get("conditional"):
        answer = f"±{c['cond_width']:.2g} (the conditional answer: `conditional` of the result)"
        reach = (
            f"with the parameters drifting less than {100 * c['breakdown']:.0f} % over the "
            f"record the band is {answer}, and beyond that drift an order outside it fits as "
            "well" if np.isfinite(c["breakdown"]) else
            # no drifting explanation left the conditional band: what widens the stated one
            # is the tuned fit's own alternatives (`vojax._tracker._band.INTEGRATED`)
            f"no drift of the parameters tried moves the order outside {answer}; the wider "
            "band also covers the tuned fit's other starting orders, order drifts and "
            "parameter scales"
        )
        return (f"the order band is ±{c['width']:.2g} wide because a drifting parameter "
                f"explains the data as well{where}; {reach}")
    return (
        f"the order band is ±{c['width']:.2g} wide because a drifting parameter explains the "
        f"data as well{where}: an order and a drifting parameter can trade off (with one "
        "input they always do), and the band covers both"
    )


_FINDINGS = {
    Reason.TRADE_OFF: _trade_off,
    Reason.CLOCK: lambda c: (
        # after the trade-off's clause, which states the width, only the second cause
        ("and because" if c.get("traded") else
         f"the order band is ±{c['width']:.2g} wide because")
        + " the order depends on the unit of "
        "time in which the parameters are constant: constant over the record's span (the "
        f"estimate) it is {c['span_order']:.2f}, constant in the data's unit of time "
        f"{c['clock']:.2f} (medians over the second half); one record cannot tell which "
        "holds, and the band covers both"
    ),
    Reason.WIDE_BAND: lambda c: (
        f"the order band is ±{c['width']:.2g} wide: these data do not determine the order"
    ),
    Reason.AT_BOUND: lambda c: (
        f"the order sits at a bound of {c['bounds']} for {100 * c['at_bound']:.0f} % of samples"
    ),
    Reason.NOT_CONVERGED: lambda c: "the estimation did not converge",
    Reason.NOISE_AT_EDGE: lambda c: (
        "the measurement noise was tuned to the edge of its range (an output almost free "
        "of noise, or drifting states that absorb the misfit): the band is not a "
        "statement about the data"
    ),
    Reason.HELD_SHIFT: lambda c: (
        f"the order trades off with the parameters' drift: with the parameters held it "
        f"moves by {c['held_shift']:.2g}, more than its band (±{c['width']:.2g})"
    ),
    Reason.DRIFT_AT_EDGE: lambda c: (
        f"{', '.join(c['drifts'])} at the upper edge of the search box: the states move as "
        "fast as the model allows, which suggests the model misses part of the physics "
        "(another element, a nonlinearity)"
    ),
    Reason.SETTING_AT_EDGE: lambda c: f"{', '.join(c['others'])} at the edge of the search box",
    Reason.CORRELATED: lambda c: (
        f"the prediction errors are correlated (lag-1 autocorrelation {c['correlation']:.2f} "
        f"> {c['limit']:.2g}): the model misses part of the signal, or the measurement noise "
        "is coloured in a way that neither white noise nor white plus AR(1) noise explains, "
        "and the band is too narrow"
    ),
    Reason.COARSE_BLOCKS: lambda c: (
        f"the record was averaged in blocks of {c['block']} samples, and the coarser clock "
        f"misrepresents it (its model error is {c['block_error']:.2g} times the noise of a "
        "block mean)"
    ),
    Reason.UNSTABLE: lambda c: (
        f"the law is unstable at these gains: from sample {c['unstable_from']} its spread over "
        "the measurement noise is wider than the order's range (a change of the data in their "
        "last digits moves the order)"
    ),
    Reason.NO_CONFIDENCE: lambda c: LAW_BAND,
}

_STEPS = {
    Reason.TRADE_OFF: (Step.PARAMETERS_CONSTANT, Step.TIME_SCALE, Step.X0, Step.SETTLING_TEST),
    Reason.CLOCK: (Step.TIME_SCALE, Step.SETTLING_TEST),
    Reason.WIDE_BAND: (Step.LONGER_TEST, Step.TIME_SCALE, Step.X0, Step.REFIT),
    Reason.AT_BOUND: (Step.ALPHA_BOUNDS, Step.INPUTS),
    Reason.NOT_CONVERGED: (Step.OUTLIERS, Step.NOISE),
    Reason.NOISE_AT_EDGE: (Step.NOISE, Step.PARAMETERS_CONSTANT),
    Reason.HELD_SHIFT: (Step.PARAMETERS_CONSTANT, Step.TIME_SCALE, Step.SETTLING_TEST),
    Reason.DRIFT_AT_EDGE: (Step.COMPARE,),
    Reason.SETTING_AT_EDGE: (Step.GAINS,),
    Reason.CORRELATED: (Step.COMPARE, Step.COARSER_CLOCK, Step.NOISE),
    Reason.COARSE_BLOCKS: (Step.MAX_POINTS,),
    Reason.UNSTABLE: (Step.SMALLER_GAMMA,),
    Reason.NO_CONFIDENCE: (Step.KALMAN,),
}


@dataclasses.dataclass(frozen=True)
class Diagnostics:
    """What a user should know before trusting an identification.

    - `band_halfwidth`: median over the second half of the record of the ±2σ half-width of the
      order band (order units).
    - `at_bound_fraction`: fraction of samples whose order lies at a bound of `alpha_bounds`.
    - `converged`: the tracker's smoother (or the gain tuning) converged.
    - `at_edge`: names of automatically chosen settings that sit at the edge of their search box;
      a tracker's drift at the lower edge is named ``"order_drift (lower edge)"`` (or
      ``"parameter_drift (lower edge)"``): the data show no such drift, which is a finding,
      not a problem, and it is not in `message`.
    - `identified`: the band is a confidence band (the tracker's; never the paper's
      law's, whose band leaves out its tracking error), narrower than ±0.1, the order
      is at a bound for < 5 % of samples, the estimation converged, and the measurement noise
      was not tuned to the edge of its range (where the band would not be a statement about
      the data).
    - `message`: one sentence when something is wrong, else ``""``: `finding`, then the
      numbered `next_steps` in Python's words (`say` gives them in the command line's).
    - `reasons`: the names (`Reason` values) of what is wrong, in the message's order.
    - `finding`: the clauses of `reasons`, what is wrong, without the next steps.
    - `next_steps`: the names (`Step` values) of what would help, most useful first, none
      that the call already gave (its `parameters`, `x0` or `noise`).
    - `innovation_correlation`: lag-1 autocorrelation of the one-step prediction errors
      (innovations) over the fitted samples; white noise and a right model give about 0.
      Above `correlation_limit` (3/√n for n innovations, within 0.1–0.25) the tracker's
      band is not trusted.
    - `block`: the tracker fitted a long record as the means of blocks of this many samples
      (1: every sample; see `identify`'s `max_points`), and `block_error` is the model
      error of that coarser clock, at the constant-order fit, over the noise of a block mean
      (NaN when there are no blocks). Above the settings' `block_error_limit` (0.5) the order
      is not reported identified.
    - `noise_correlation`: where the tracker modelled the measurement noise as coloured (an
      AR(1) part besides white noise, chosen by evidence), that part's correlation between
      consecutive samples (block means for a long record); NaN where the noise is white.
    - `clock_order`: the tracker's order (median over the second half) with the parameters
      constant in the data's unit of time instead of over the record's span, where the
      tracker fitted that too (without `time_scale`, and a span more than 5 % from one
      unit), else NaN. Where it lies outside the band the band covers it (the reason
      ``clock``), unless that account is excluded (under ``parameters="constant"``, a
      statement on the span's clock, or where the data exclude it,
      `TrackerSettings.clock_evidence`); it is then reported here and in
      `Identification.verdict_line`.
    """

    band_halfwidth: float
    at_bound_fraction: float
    converged: bool
    at_edge: tuple[str, ...]
    identified: bool
    message: str
    innovation_correlation: float = float("nan")
    block: int = 1
    block_error: float = float("nan")
    noise_correlation: float = float("nan")
    reasons: tuple[str, ...] = ()
    verdict: str = "not identified"
    conditional_halfwidth: float = float("nan")
    breakdown_drift: float = float("nan")
    reference_drift: float = float("nan")
    finding: str = ""
    next_steps: tuple[str, ...] = ()
    clock_order: float = float("nan")

    def say(self, interface: str = "python") -> str:
        """The message in the words of `interface`: ``"python"`` (`message`) or ``"cli"``
        (the ``vojax`` command's options)."""
        return say(self.finding, self.next_steps, interface)


def _nan_or(value):
    return float("nan") if value is None else float(value)


def diagnose(
    alpha, lower, upper, bounds, converged, at_edge, held_shift=None, *, calibrated=True,
    correlation=float("nan"), unstable_from=None, trade=None, samples=None,
    drift_covered=False, block=1, block_error=None, noise_correlation=None, settings=None,
    conditional=None, breakdown_drift=float("nan"), reference_drift=float("nan"), given=(),
    clock=None, clock_order=float("nan"),
) -> Diagnostics:
    """The `Diagnostics` of an order trajectory and its band. `held_shift`: how far the order
    moves (median over the second half) when the tracker's drifting parameters are held.
    ``calibrated=False``: the band is not a confidence band (the paper's law: the spread of its
    estimate over the measurement noise, without its tracking error), so nothing is
    identified by it. `correlation`: the innovations' lag-1 autocorrelation (see
    `Diagnostics`). `unstable_from`: the first sample at which the law's spread passes the
    order's range (its linearisation is unstable), or None. `trade`: the constant orders
    ``(lo, hi)`` with which a drifting parameter explains the data as well, which the band
    was widened to cover, or None; `drift_covered`: the band was widened to cover the
    tracker's drifting-parameter alternatives that explain the data. `samples`: how many
    innovations `correlation` is over (see `correlation_limit`); `noise_correlation`: the
    coloured noise part's correlation between samples, or None for white noise. `settings`:
    the thresholds (a `TrackerSettings`; its defaults where None). `conditional`: the
    conditional band ``(lower, upper)`` (while the parameters drift less than
    `breakdown_drift`; the answer's own parameters drift by `reference_drift`), or None.
    `given`: the `Step`s the call already took (its `parameters`, `x0`, `noise`), which the
    message does not suggest again. `clock`: the order's median over the second half with the
    parameters constant in the data's unit of time, where it lies outside the band the
    span's clock gives (the band was widened to cover it) or outside its conditional band,
    else None (see `vojax._tracker._clock`); `clock_order`: that median wherever it was
    fitted (`Diagnostics.clock_order`)."""
    s = TrackerSettings() if settings is None else settings
    alpha, lower, upper = (np.asarray(a) for a in (alpha, lower, upper))
    lo, hi = bounds
    half = alpha.shape[0] // 2
    width = float(np.median((upper - lower)[half:]) / 2)
    tol = s.bound_tol * (hi - lo)
    at_bound = float(np.mean((alpha <= lo + tol) | (alpha >= hi - tol)))
    wide = width > s.identified_halfwidth
    noise_edge = bool(NOISE_EDGES & set(at_edge))
    traded = held_shift is not None and held_shift > width
    clocked = clock is not None and wide
    covered = trade is not None or drift_covered or clocked
    # a tracker's drift at its lower edge (the data show none) is no problem: not in the
    # message; at its upper edge the states move as fast as the search allows
    drifts = [name for name in at_edge if name in ("order_drift", "parameter_drift")]
    others = [
        name for name in at_edge
        if name not in NOISE_EDGES | {"order_drift", "parameter_drift"}
        and not name.endswith("(lower edge)")
    ]
    limit = correlation_limit(samples)
    coloured = calibrated and correlation > limit
    coarse = block_error is not None and block_error > s.block_error_limit
    found = [
        (Reason.TRADE_OFF, (trade is not None or drift_covered) and wide),
        (Reason.CLOCK, clocked),
        (Reason.WIDE_BAND, not covered and wide),
        (Reason.AT_BOUND, at_bound >= s.bound_fraction),
        (Reason.NOT_CONVERGED, not converged),
        (Reason.NOISE_AT_EDGE, noise_edge),
        (Reason.HELD_SHIFT, traded),
        (Reason.DRIFT_AT_EDGE, bool(drifts)),
        (Reason.SETTING_AT_EDGE, bool(others)),
        (Reason.CORRELATED, coloured),
        (Reason.COARSE_BLOCKS, coarse),
        (Reason.UNSTABLE, unstable_from is not None),
        (Reason.NO_CONFIDENCE, not calibrated),
    ]
    reasons = [reason for reason, present in found if present]
    context = dict(width=width, trade=trade, bounds=bounds, at_bound=at_bound,
                   held_shift=held_shift, drifts=drifts, others=others,
                   correlation=correlation, limit=limit, block=block, block_error=block_error,
                   unstable_from=unstable_from, clock=clock,
                   span_order=float(np.median(alpha[half:])))
    sound = (
        at_bound < s.bound_fraction and bool(converged) and not noise_edge and not traded
        and calibrated and not coloured and unstable_from is None and not coarse
    )
    # the conditional answer bounds the parameters' drift on the span's clock; where the
    # unit of time decides the order, that bound is no answer
    settled = sound and not clocked
    identified = width <= s.identified_halfwidth and sound
    cond_width = float("nan")
    if conditional is not None:
        c_lower, c_upper = (np.asarray(a) for a in conditional)
        cond_width = float(np.median((c_upper - c_lower)[half:]) / 2)
    reach = breakdown_drift - (reference_drift if np.isfinite(reference_drift) else 0.0)
    conditional_answer = (not identified and settled and cond_width <= s.identified_halfwidth
                          and reach > s.drift_floor)
    verdict = ("identified" if identified else "conditional" if conditional_answer
               else "not identified")
    context.update(conditional=conditional_answer, cond_width=cond_width,
                   breakdown=breakdown_drift, traded=Reason.TRADE_OFF in reasons)
    finding = "; ".join(r.finding(**context) for r in reasons)
    taken = set(given)
    steps = tuple(dict.fromkeys(
        step.value for r in reasons for step in r.steps(**context) if step not in taken
    ))
    return Diagnostics(
        width, at_bound, bool(converged), tuple(at_edge), identified,
        say(finding, steps), correlation, int(block), _nan_or(block_error),
        _nan_or(noise_correlation), tuple(r.value for r in reasons), verdict, cond_width,
        float(breakdown_drift), float(reference_drift), finding, steps, float(clock_order),
    )
