"""`LawEstimator`: the paper's adaptive law (Theorem 1) as one object: its gains (tuned or
given), its order bounds and memory, and `fit`, which validates a record once, tunes the gains
where asked, runs the law in one scan and returns an `Identification` with the law's band."""

import dataclasses
import warnings

import jax.numpy as jnp

from .. import _validate as check
from .._diagnostics import IdentifiabilityWarning
from .._identification import Identification
from .._stats import noise_variance
from ._bands import law_covariance
from ._build import (
    DEFAULT_BOUNDS,
    PAPER_LAM,
    auto_r0,
    build_law,
    law_identification,
    nominal_step,
    run_law,
)


@dataclasses.dataclass(frozen=True)
class LawEstimator:
    """The paper's adaptive law (``identify(method="gradient")``) as one object; see
    `identify` for what each option means.

    - `gamma`: the order gain γ > 0, or ``"auto"`` (tuned with `tune_gains`);
    - `lam`: the forgetting factor λ > 0, or None (tuned with γ where ``gamma="auto"``, the
      paper's 0.9 otherwise);
    - `alpha0`: α̂(0), inside `alpha_bounds` (the law's projection);
    - `x0`: the output's offset (None: ``y[0]``); `r0`: ``"auto"`` or an ``(n, n)`` matrix.

    Its band is the law's spread over the measurement noise, not a confidence band: it never
    reports the order identified.

    ```python
    law = vojax.LawEstimator(gamma=0.01, lam=0.9, x0=0.0)
    res = law.fit(u, y, dt=0.05)
    ```
    """

    gamma: float | str = "auto"
    lam: float | None = None
    alpha0: float = 0.5
    alpha_bounds: tuple[float, float] = DEFAULT_BOUNDS
    memory: str = "exponential"
    rule: str = "trapezoid"
    x0: float | None = None
    r0: object = "auto"
    tol: float = 1e-10

    def __post_init__(self):
        if isinstance(self.gamma, str):
            if self.gamma != "auto":
                raise ValueError(f"`gamma` must be a positive number or 'auto', got {self.gamma!r}.")
        else:
            check.positive(self.gamma, "gamma")
        if isinstance(self.lam, str):
            raise ValueError(f"`lam` must be a positive number or None, got {self.lam!r}.")
        object.__setattr__(self, "alpha_bounds", check.law_settings(
            self.lam, self.alpha0, self.alpha_bounds, self.memory, self.rule))
        if self.x0 is not None:
            check.magnitude(check.scalar(self.x0, "x0"), "x0", tiny=True)
        if self.r0 is None:
            object.__setattr__(self, "r0", "auto")
        if isinstance(self.r0, str) and self.r0 != "auto":
            raise ValueError(f"`r0` must be 'auto' or an (n, n) matrix, got {self.r0!r}.")
        check.positive(self.tol, "tol")

    def fit(self, u, y=None, dt=None, *, t=None, warn=True) -> Identification:
        """Runs the law over the inputs `u` (N,) or (N, n) and the output `y` (N,) on the step
        `dt` or at the sample times `t` (or over a `Record` alone, on its own clock), its gains
        tuned first where ``gamma="auto"``. Returns an `Identification`; with `warn`, an
        `IdentifiabilityWarning` with the diagnostics' message."""
        u, y, dt, t = check.record_arguments(u, y, dt, t, call="LawEstimator.fit")
        return self._fit(u, y, dt, t, warn, stacklevel=3)

    def _fit(self, u, y, dt, t, warn, stacklevel):
        warn = check.flag(warn, "warn")
        # validate once, before any (possibly long) tuning; the law and the tuner share it
        u2, y, bounds, x0, r0 = check.check_options(
            u, y, dt, self.lam, self.alpha0, self.alpha_bounds, self.memory, self.rule,
            self.x0, self.r0, t=t,
        )
        step = nominal_step(dt, t)
        if isinstance(r0, str):
            r0 = auto_r0(u2, step, self.alpha0, self.memory, self.rule, self.tol, bounds, times=t)
        shared = dict(alpha0=self.alpha0, alpha_bounds=bounds, memory=self.memory,
                      rule=self.rule, r0=r0, tol=self.tol)
        gamma, lam, at_edge = self.gamma, self.lam, ()
        if isinstance(gamma, str):  # "auto", checked when built
            from .._tune import tune_gains

            gains = tune_gains(u2, y, dt, t=t, x0=x0, lam=lam, **shared)
            gamma, lam, at_edge = gains.gamma, gains.lam, gains.at_edge
        elif lam is None:
            lam = PAPER_LAM
        law = build_law(step, u2.shape[0], lam=lam, gamma=gamma, times=t, **shared)
        out = run_law(law, u2, y - x0)
        bad = check.first_bad(out.alpha, out.p, out.dp, out.y_hat)
        if bad is not None:
            raise ValueError(
                f"the adaptive law diverged at sample {bad} (non-finite estimate): the inputs do "
                f"not excite every parameter within the forgetting horizon 1/λ = "
                f"{1 / float(lam):.3g}; use a smaller `lam`, fewer inputs, or r0='auto'."
            )
        var_alpha, var_p = law_covariance(law, u2, y - x0, jnp.asarray(noise_variance(y - x0)))
        res = law_identification(
            out, var_alpha, var_p, x0, law.order.gamma, law.lsff.lam, law.order.alpha0,
            law.lsff.dt, bounds, self.memory, at_edge, y=y,
        )
        if warn and res.diagnostics.message:
            warnings.warn(f"vojax.identify: {res.diagnostics.message}.", IdentifiabilityWarning,
                          stacklevel=stacklevel)
        return res
