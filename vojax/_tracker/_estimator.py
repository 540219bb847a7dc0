"""`Tracker`: the Bayesian tracker of (α, p, x0) as one object: its options and settings, and
`fit`, which validates a record once, fits it (as block means where it is long) and returns an
`Identification` with its diagnostics."""

import dataclasses
import warnings

import numpy as np

from .. import _validate as check
from .._diagnostics import IdentifiabilityWarning, Reason, diagnose
from .._identification import Conditional, Identification
from .._integral import make_memory
from .._settings import MIN_POINTS, TRACKER_MAX_POINTS, TrackerSettings
from .._stats import prediction_error_correlation
from .._steps import Step
from .._xla import to_device
from ._band import first_fitted
from ._blocks import block_size, fit_blocks
from ._clock import clock_order, second_clock, weigh_clock
from ._fit import fit_points
from ._smoother import resolve_schedule
from ._threads import two_at_once

KALMAN_BOUNDS = (0.01, 0.99)  # the tracker's logistic map
# the most inputs the tracker takes: 400 samples on 2 cores took 17 s with 1 input, 36 s
# with 4 and about 2 minutes with 8 or 16 (other work beside it); 50 did not finish in 20 min
MAX_INPUTS = 16
NOISE_KEYS = frozenset({"order_drift", "parameter_drift", "noise_std"})
NOISE_LIMIT = 1e150  # above it an intensity's square overflows float64


def check_noise(noise, parameters) -> None:
    """`noise` None, or a dict of the three intensities, each positive and below
    `NOISE_LIMIT`; not beside ``parameters="constant"`` (the statement, as
    `parameters_statement` gives it), which sets the parameters' drift itself."""
    if noise is None:
        return
    if parameters == "constant":
        raise ValueError(
            "`noise` sets the parameters' drift itself (its 'parameter_drift'); give it, "
            "or parameters='constant', not both."
        )
    if not isinstance(noise, dict) or set(noise) != NOISE_KEYS:
        raise ValueError(f"`noise` must be a dict with keys {sorted(NOISE_KEYS)}, got {noise!r}.")
    for k, v in noise.items():
        check.positive(v, f"noise[{k!r}]", upper=NOISE_LIMIT)


def parameters_statement(value):
    """What `parameters=` states: "free" (also "drifting", and None), "constant" (also 0),
    or the largest relative drift (max − min)/|mean| vouched for, a number > 0."""
    if value is None or isinstance(value, str) and value in ("free", "drifting"):
        return "free"
    if isinstance(value, str) and value == "constant":
        return "constant"
    if isinstance(value, (str, bool)):
        raise ValueError(
            "`parameters` must be 'free', 'constant' or the largest relative drift of the "
            f"parameters over the record (a number ≥ 0), got {value!r}."
        )
    try:
        bound = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"`parameters` must be 'free', 'constant' or a number ≥ 0, got "
                         f"{value!r}.") from None
    if not (np.isfinite(bound) and bound >= 0):
        raise ValueError(f"`parameters` as a drift bound must be a finite number ≥ 0, got "
                         f"{value!r}.")
    return "constant" if bound == 0 else bound


@dataclasses.dataclass(frozen=True)
class Tracker:
    """The joint Bayesian tracker of the order α(t), the parameters p(t) and the output
    offset x0 (`identify`'s default, ``method="kalman"``); see `identify` for what each
    option means. `settings` holds every tuned number (`TrackerSettings`).

    ```python
    tracker = vojax.Tracker(parameters="constant")
    res = tracker.fit(u, y, dt=0.01)
    ```
    """

    parameters: str | float = "free"
    x0: float | None = None
    smooth: bool = True
    alpha_bounds: tuple[float, float] = KALMAN_BOUNDS
    memory: str = "exponential"
    rule: str = "trapezoid"
    noise: dict | None = None
    max_points: int | None = None
    tol: float = 1e-10
    time_scale: float | None = None
    settings: TrackerSettings = TrackerSettings()

    def __post_init__(self):
        object.__setattr__(self, "parameters", parameters_statement(self.parameters))
        object.__setattr__(self, "smooth", check.flag(self.smooth, "smooth"))
        check_noise(self.noise, self.parameters)
        if self.x0 is not None:
            object.__setattr__(self, "x0", check.known_offset(self.x0))
        object.__setattr__(self, "alpha_bounds",
                           check.interval(self.alpha_bounds, "alpha_bounds"))
        check.choice(self.memory, check.MEMORIES, "memory")
        if self.max_points is not None:
            object.__setattr__(self, "max_points", check.count(
                self.max_points, "max_points", low=MIN_POINTS, high=TRACKER_MAX_POINTS))
        if self.time_scale is not None:
            check.positive(self.time_scale, "time_scale")
        if not isinstance(self.settings, TrackerSettings):
            raise TypeError(f"`settings` must be a vojax.TrackerSettings, got {self.settings!r}.")

    def fit(self, u, y=None, dt=None, *, t=None, mask=None, window=None,
            warn=True) -> Identification:
        """Identifies the order and the parameters of ``D^{α(t)} x = pᵀu`` from the inputs
        `u` (N,) or (N, n) and the output `y` (N,) on the step `dt` or at the sample times
        `t` (or from a `Record` alone, on its own clock); `mask` (N,) of 0/1 leaves samples
        with 0 unfitted; `window` ``(from, to)`` fits the samples with ``from ≤ t_k ≤ to``
        only (an end None: open), the whole input history still driving the memory. Returns an `Identification`; with `warn`, an
        `IdentifiabilityWarning` where the order is not identified."""
        u, y, dt, t = check.record_arguments(u, y, dt, t, call="Tracker.fit")
        return self._fit(u, y, dt, t, mask, warn, stacklevel=3, window=window)

    def _fit(self, u, y, dt, t, mask, warn, stacklevel, window=None):
        warn = check.flag(warn, "warn")
        u2, y, bounds, _, _ = check.check_options(
            u, y, dt, None, sum(self.alpha_bounds) / 2, self.alpha_bounds, self.memory,
            self.rule, None, None, t=t,
        )
        if u2.shape[1] > MAX_INPUTS:
            raise ValueError(
                f"the tracker takes at most {MAX_INPUTS} inputs (its state holds one parameter "
                f"per input, and its cost grows as the cube of the state), got {u2.shape[1]}: "
                "use vojax.refit, or fewer inputs."
            )
        if mask is not None:
            mask = check.check_mask(mask, u2.shape[0], u2.shape[1])
        if window is not None:
            mask = _windowed(mask, window, dt, t, u2.shape)
        s = self.settings
        max_points = s.max_points if self.max_points is None else self.max_points
        # the record's length up to its last fitted sample (padding after it is not the
        # record's)
        length = u2.shape[0] if mask is None else int(np.flatnonzero(np.asarray(mask))[-1]) + 1
        size = block_size(length, max_points)
        # a record in long blocks whose prediction errors correlate: the coarse clock misses
        # part of the signal (on the suite's `long` family, order errors of 1e-4 to 4e-3
        # refused by lag-1 autocorrelations of 0.10–0.88), fitted again once on shorter
        # blocks; the first fit stops once its tuned smoothing shows it (None)
        finer = block_size(length, min(max_points * s.block_refine, TRACKER_MAX_POINTS))
        refine = size >= s.block_refine_from and finer < size
        first = self._fit_sized(u2, y, dt, t, mask, length, size, bounds, refine)
        if first is None or (refine and Reason.CORRELATED in first[2].reasons):
            size = finer
            first = self._fit_sized(u2, y, dt, t, mask, length, size, bounds)
        res, fit, diagnostics = first
        if warn and diagnostics.message:
            warnings.warn(f"vojax.identify: {diagnostics.message}.", IdentifiabilityWarning,
                          stacklevel=stacklevel)
        nan = to_device(np.nan)
        from .._adaptive._build import nominal_step

        return Identification(
            alpha=res.alpha, alpha_std=res.alpha_std, alpha_lower=res.alpha_lower,
            alpha_upper=res.alpha_upper, p=res.p, p_std=res.p_std, y_hat=res.y_hat,
            y_pred=res.y_pred, x0=res.x0, x0_std=res.x0_std, dp=None, Lambda=None, gamma=nan,
            lam=nan, alpha0=nan, dt=to_device(nominal_step(dt, t)), alpha_bounds=bounds,
            memory=self.memory, method="kalman", diagnostics=diagnostics, tuning=res.tuning,
            parameters=self.parameters,
            conditional=None if res.conditional is None else Conditional(*res.conditional),
            fitted=None if mask is None else _fitted_range(mask, length), y=y,
        )

    def _fit_sized(self, u2, y, dt, t, mask, length, size, bounds, refine=False):
        """``(result, fitted points, diagnostics)`` of the record fitted in blocks of `size`
        samples (1: every sample), on both clocks where the second one runs; with `refine`,
        None where the span's tuned smoothing leaves correlated prediction errors (see
        `fit_blocks`)."""
        # the tracker's clock: time over the record's span (or `time_scale`), so that
        # parameters held constant (or drift-bounded) mean the same in any unit of time
        scale = self._time_scale(dt, t, length)

        def on(unit, weigh=True, refine=False):
            return lambda: self._fit_on(unit, u2, y, dt, t, mask, length, size, bounds,
                                        weigh=weigh, refine=refine)

        # the parameters constant in the data's own unit of time too: an account the band
        # must cover where its order lies outside (see `vojax._tracker._clock`); its tuned
        # smoothing and that smoothing's own band, in a second thread beside the span's fit
        both = self.time_scale is None and second_clock(scale)
        span_fit, other = two_at_once(
            self.settings, resolve_schedule(self.settings.schedule),
            # what selects the programs a call compiles: a new one runs one after the other
            (u2.shape, size, self.memory, self.rule, t is None, mask is None, self.parameters,
             self.x0 is None, self.smooth, self.noise is None), on(scale, refine=refine),
            on(1.0, weigh=False) if both else None)
        if span_fit is None:
            return None
        res, fit = span_fit
        clock, clock_at = None, float("nan")
        if other is not None:
            clock_at = clock_order(fit, *other)
            # the data unit's account is excluded where a constant statement excludes it (its
            # parameters drift on the span's clock) or where the data do (the evidence), but
            # not under a drift bound: on `stated-drift` draw 16, a true bound of 30 %, the
            # union holds the truth the span's band alone misses (docs/tracker.md)
            stated = self.settings.drift_floor if self.parameters == "constant" else None
            bounded = not isinstance(self.parameters, str)
            evidence = np.inf if bounded else self.settings.clock_evidence
            profile = (self.settings.level_profile_chi2
                       if self.settings.level_weights == "profile" else None)
            res, fit, clock = weigh_clock(res, fit, *other, bound=stated, scale=scale,
                                          answer=self.settings.identified_halfwidth,
                                          evidence=evidence, profile=profile)
        bad = check.first_bad(res.alpha, res.p, res.y_hat, res.alpha_std, res.p_std)
        if bad is not None:
            raise ValueError(f"the tracker diverged at sample {bad} (non-finite estimate).")
        diagnostics = self._diagnose(res, fit, size, bounds, clock, clock_at)
        return res, fit, diagnostics

    def _fit_on(self, scale, u2, y, dt, t, mask, length, size, bounds, weigh=True,
                refine=False):
        """The tracker's result and its fitted points (the block means of a long record) on
        the clock of unit `scale` in the user's time; ``weigh=False``: the tuned smoothing
        and its own band only (see `fit_points`); `refine`: see `fit_blocks`."""
        s = self.settings
        dt_c = None if dt is None else float(np.asarray(dt)) / scale
        t_c = None if t is None else np.asarray(t, float) / scale
        if size > 1:
            # the sample times on the tracker's clock, as the user's over the scale (so that
            # a uniform `t` and its `dt` give the same block means to the last bit)
            user_times = np.asarray(t, float) if t is not None else float(
                np.asarray(dt)) * np.arange(u2.shape[0])
            return fit_blocks(self, u2, y, dt_c, t_c, mask, size, length, scale,
                              times=user_times / scale, weigh=weigh, refine=refine)
        mem = make_memory(self.memory, dt_c, u2.shape[0], rule=self.rule, tol=self.tol,
                          order_range=bounds, times=t_c)
        res = fit_points(mem, u2, y, dt_c, bounds, s, smooth=self.smooth, noise=self.noise,
                         mask=mask, times=t_c, parameters=self.parameters, x0=self.x0,
                         time_scale=scale, weigh=weigh)
        return res, dict(alpha=res.alpha, lower=res.alpha_lower, upper=res.alpha_upper,
                         held=res.alpha_held, y=y, y_pred=res.y_pred, span=length, mask=mask,
                         conditional=res.conditional)

    def _time_scale(self, dt, t, length):
        """The unit of the tracker's clock in the user's: `time_scale`, or the span of the
        record's fitted samples."""
        if self.time_scale is not None:
            return float(np.asarray(self.time_scale))
        if t is not None:
            return float(np.asarray(t)[length - 1] - np.asarray(t)[0])
        return float(np.asarray(dt)) * (length - 1)

    def _diagnose(self, res, fit, size, bounds, clock=None, clock_at=float("nan")):
        """The diagnostics of what the tracker fitted (the block means of a long record); cut
        in NumPy: an eager slice of a JAX array compiles anew for every record length.
        `clock`: the order's median over the second half with the parameters constant in the
        data's unit of time, where it lies outside the span's band (see `weigh_clock`), else None;
        `clock_at`: that median wherever that fit ran (see `clock_order`), else NaN.
        The diagnostics cover the fitted range: from the first fitted point to the last."""
        fit_mask, span = fit["mask"], fit["span"]
        first = first_fitted(fit_mask)
        cut = slice(first, span)
        alpha, lower, upper = (np.asarray(fit[k])[cut] for k in ("alpha", "lower", "upper"))
        shift, conditional = None, fit.get("conditional")
        if conditional is not None:  # the held smoothing is an explanation the band weighed
            conditional = tuple(np.asarray(a)[cut] for a in conditional[1:3])
        elif fit["held"] is not None:
            held = np.asarray(fit["held"])[cut]
            shift = float(np.median(np.abs(held - alpha)[alpha.shape[0] // 2 :]))
        y_np, pred = np.asarray(fit["y"])[cut], np.asarray(fit["y_pred"])[cut]
        fitted = (np.ones(span - first, bool) if fit_mask is None
                  else np.asarray(fit_mask)[cut] > 0)
        correlation, samples = prediction_error_correlation(y_np, pred, fitted)
        return diagnose(
            alpha, lower, upper, bounds, res.converged, res.tuning.at_edge, shift,
            correlation=correlation, trade=res.trade, samples=samples,
            drift_covered=res.drift_covered, block=size, block_error=fit.get("block_error"),
            noise_correlation=res.tuning.noise_correlation, settings=self.settings,
            conditional=conditional, breakdown_drift=res.breakdown_drift,
            reference_drift=res.reference_drift, given=self._given(),
            clock=clock, clock_order=clock_at,
        )

    def _given(self):
        """The next steps this tracker's options already took: not suggested again."""
        taken = [(self.parameters != "free", Step.PARAMETERS_CONSTANT),
                 (self.x0 is not None, Step.X0), (self.noise is not None, Step.NOISE),
                 (self.time_scale is not None, Step.TIME_SCALE)]
        return tuple(step for done, step in taken if done)


def _windowed(mask, window, dt, t, shape):
    """The fitted samples' mask (or None) restricted to the fit `window` ``(from, to)``;
    refuses a window that leaves too few samples to fit."""
    num, n = shape
    times = np.asarray(t, float) if t is not None else float(np.asarray(dt)) * np.arange(num)
    inside = check.window_mask(window, times)
    kept = inside if mask is None else inside * mask
    if kept.sum() < n + 3:
        raise ValueError(
            f"`window` {tuple(window)} leaves {int(kept.sum())} fitted samples "
            f"(the record's times run from {times[0]:g} to {times[-1]:g}); the tracker needs at "
            f"least {n + 3}."
        )
    return kept


def _fitted_range(mask, length) -> tuple[int, int]:
    """``(first, stop)``: the first fitted sample and one past the last."""
    return first_fitted(mask), int(length)
