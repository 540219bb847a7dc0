"""`Tracker`: the Bayesian tracker of (α, p, x0) as one object: its options and settings, and
`fit`, which validates a record once, fits it (as block means where it is long) and returns an
`Identification` with its diagnostics."""

import dataclasses
import warnings

import numpy as np

from .. import _validate as check
from .._diagnostics import IdentifiabilityWarning, diagnose
from .._identification import Identification
from .._integral import make_memory
from .._settings import TrackerSettings
from .._stats import prediction_error_correlation
from .._xla import to_device
from ._blocks import block_size, fit_blocks
from ._fit import fit_points

KALMAN_BOUNDS = (0.01, 0.99)  # the tracker's logistic map
# the most points `max_points` may ask for: the tracker's cost grows with its points (a few
# minutes at this many on a 2-core CPU)
TRACKER_MAX_POINTS = 50_000
MIN_POINTS = 100  # the fewest points `max_points` may ask for
NOISE_KEYS = frozenset({"order_drift", "parameter_drift", "noise_std"})


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

    parameters: str = "drifting"
    x0: float | None = None
    smooth: bool = True
    alpha_bounds: tuple[float, float] = KALMAN_BOUNDS
    memory: str = "exponential"
    rule: str = "trapezoid"
    noise: dict | None = None
    max_points: int | None = None
    tol: float = 1e-10
    settings: TrackerSettings = TrackerSettings()

    def __post_init__(self):
        check.choice(self.parameters, ("drifting", "constant"), "parameters")
        if self.parameters == "constant" and self.noise is not None:
            raise ValueError(
                "`noise` sets the parameters' drift itself (its 'parameter_drift'); give it, "
                "or parameters='constant', not both."
            )
        if self.noise is not None:
            if not isinstance(self.noise, dict) or set(self.noise) != NOISE_KEYS:
                raise ValueError(
                    f"`noise` must be a dict with keys {sorted(NOISE_KEYS)}, got {self.noise!r}."
                )
            for k, v in self.noise.items():
                check.positive(v, f"noise[{k!r}]")
        if self.x0 is not None:
            object.__setattr__(self, "x0", check.known_offset(self.x0))
        object.__setattr__(self, "alpha_bounds",
                           check.interval(self.alpha_bounds, "alpha_bounds"))
        check.choice(self.memory, check.MEMORIES, "memory")
        if self.max_points is not None:
            object.__setattr__(self, "max_points", check.count(
                self.max_points, "max_points", low=MIN_POINTS, high=TRACKER_MAX_POINTS))
        if not isinstance(self.settings, TrackerSettings):
            raise TypeError(f"`settings` must be a vojax.TrackerSettings, got {self.settings!r}.")

    def fit(self, u, y, dt=None, *, t=None, mask=None, warn=True) -> Identification:
        """Identifies the order and the parameters of ``D^{α(t)} x = pᵀu`` from the inputs
        `u` (N,) or (N, n) and the output `y` (N,) on the step `dt` or at the sample times
        `t`; `mask` (N,) of 0/1 leaves samples with 0 unfitted. Returns an `Identification`;
        with `warn`, an `IdentifiabilityWarning` where the order is not identified."""
        return self._fit(u, y, dt, t, mask, warn, stacklevel=3)

    def _fit(self, u, y, dt, t, mask, warn, stacklevel):
        u2, y, bounds, _, _ = check.check_options(
            u, y, dt, None, sum(self.alpha_bounds) / 2, self.alpha_bounds, self.memory,
            self.rule, None, None, t=t,
        )
        if mask is not None:
            mask = check.check_mask(mask, u2.shape[0], u2.shape[1])
        s = self.settings
        max_points = s.max_points if self.max_points is None else self.max_points
        # the record's length up to its last fitted sample (padding after it is not the
        # record's)
        length = u2.shape[0] if mask is None else int(np.flatnonzero(np.asarray(mask))[-1]) + 1
        size = block_size(length, max_points)
        if size > 1:
            res, fit = fit_blocks(self, u2, y, dt, t, mask, size, length)
        else:
            mem = make_memory(self.memory, dt, u2.shape[0], rule=self.rule, tol=self.tol,
                              order_range=bounds, times=t)
            res = fit_points(mem, u2, y, dt, bounds, s, smooth=self.smooth, noise=self.noise,
                             mask=mask, times=t, parameters=self.parameters, x0=self.x0)
            fit = dict(alpha=res.alpha, lower=res.alpha_lower, upper=res.alpha_upper,
                       held=res.alpha_held, y=y, y_pred=res.y_pred, span=length, mask=mask)
        bad = check.first_bad(res.alpha, res.p, res.y_hat, res.alpha_std, res.p_std)
        if bad is not None:
            raise ValueError(f"the tracker diverged at sample {bad} (non-finite estimate).")
        diagnostics = self._diagnose(res, fit, size, bounds)
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
        )

    def _diagnose(self, res, fit, size, bounds):
        """The diagnostics of what the tracker fitted (the block means of a long record); cut
        in NumPy: an eager slice of a JAX array compiles anew for every record length."""
        fit_mask, span = fit["mask"], fit["span"]
        alpha, lower, upper = (np.asarray(fit[k])[:span] for k in ("alpha", "lower", "upper"))
        shift = None
        if fit["held"] is not None:
            held = np.asarray(fit["held"])[:span]
            shift = float(np.median(np.abs(held - alpha)[span // 2 :]))
        y_np, pred = np.asarray(fit["y"])[:span], np.asarray(fit["y_pred"])[:span]
        fitted = np.ones(span, bool) if fit_mask is None else np.asarray(fit_mask)[:span] > 0
        correlation, samples = prediction_error_correlation(y_np, pred, fitted)
        return diagnose(
            alpha, lower, upper, bounds, res.converged, res.tuning.at_edge, shift,
            correlation=correlation, trade=res.trade, samples=samples,
            drift_covered=res.drift_covered, block=size, block_error=fit.get("block_error"),
            noise_correlation=res.tuning.noise_correlation, settings=self.settings,
        )
