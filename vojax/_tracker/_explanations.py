"""Explanations: each account of the data that the band weighs (the tuned smoothing, its
alternatives, the level profile's held scales, the trade-off's constant orders), with how
well it fits and how far its parameters drift over the record."""

import dataclasses

import numpy as np

# the kinds of explanation, and whether its parameters are free to drift
KINDS = {
    "tuned": "the tuned smoothing",
    "start": "the tuned intensities from another starting order",
    "order_drift": "another order drift",
    "param_drift": "the parameters drifting at another level",
    "held_order": "the order held, the parameters drifting",
    "held": "the tuned order drift with the parameters held (where the tuned ones drift)",
    "level": "the parameters held at another scale",
    "held_level": "the parameters held at another scale, about the held smoothing",
    "trade": "a constant order with the parameters drifting on hat functions",
    "moving": "a moving order outside the band with the parameters drifting on hat functions",
}


@dataclasses.dataclass(frozen=True)
class Explanation:
    """One explanation of the data: the order's logistic coordinate `beta` (N,) and its
    Laplace variance `var` (N,) (0 where it is profiled, not smoothed), its residuals' `chi2`
    over the fitted samples at the measurement noise (whitened for a coloured one) with `dof`
    degrees of freedom, its Laplace `evidence` (NaN where it is not a smoothing, −∞ where it
    did not converge), the relative `drift` of its parameters over the fitted span ((max −
    min)/|mean|, the largest over the inputs), and its `kind` (see `KINDS`); `accepted`:
    where its own rule decides whether it fits (the trade-off's profile), that rule's
    answer, else None; `factor`: an order drift's factor of `alt_order_drift` on the tuned
    drift, else None; `freedom`: for a smoothing under a white noise, the effective number
    of parameters its drifts fit beyond the constant fit's n + 2 (the function `freedom`,
    less n + 2), else NaN: where it is the truth, its χ² lies about `dof` − `freedom` on
    average."""

    kind: str
    beta: np.ndarray
    var: np.ndarray
    chi2: float
    dof: float
    evidence: float
    drift: float
    accepted: bool | None = None
    factor: float | None = None
    freedom: float = np.nan

    @property
    def fits(self) -> bool:
        """It explains the data: its own rule's answer, or its residuals pass the χ² test at
        2σ, ``χ² ≤ dof + 2√(2·dof)``."""
        if self.accepted is not None:
            return bool(self.accepted)
        return bool(self.chi2 <= self.dof + 2 * np.sqrt(2 * self.dof))

    @property
    def converged(self) -> bool:
        return bool(np.isfinite(self.chi2) and not self.evidence == -np.inf)

    @property
    def holds(self) -> bool:
        """It fits and converged: it may stand for the data (a band's member, a reference)."""
        return self.fits and self.converged


def relative_drift(params, span):
    """``(max − min)/|mean|`` of each parameter's trajectory (N, n) over its first `span`
    samples, the largest over the inputs (∞ where a parameter's mean is 0)."""
    p = np.asarray(params)[:span]
    if p.ndim == 1:
        p = p[:, None]
    mean = np.abs(np.mean(p, axis=0))
    spread = np.ptp(p, axis=0)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(mean > 0, spread / np.where(mean > 0, mean, 1.0), np.inf)
    return float(np.max(ratio))


def chi2_of(residuals, mask, fit_noise, whiten=None):
    """The χ² (C,) of runs' residuals (C, N) over the fitted samples at the white noise
    variance `fit_noise`, or for a coloured noise under its `whiten`."""
    w = np.asarray(mask)
    res = np.asarray(residuals).T  # (N, C)
    return np.sum(w[:, None] * (res**2 / fit_noise if whiten is None else whiten(res) ** 2), 0)


def smoothing_explanations(kinds, betas, variances, scores, residuals, params, problem,
                           fit_noise, whiten=None, factors=None, freedoms=None):
    """`Explanation`s of smoothing runs (`smoother_modes`' outputs), one per row of `kinds`
    (with its order drift's factor from `factors`, and from `freedoms` each run's trace of
    `freedom` less n + 2, where given and the noise is white: under a coloured noise's
    `whiten` the χ² is not on the scale of the white part that the trace is taken at, and
    the freedom is left NaN; a trace in the noise's own metric was measured and not kept:
    the whitener is tuned on the tuned run's residuals, docs/calibration.md)."""
    w = np.asarray(problem.mask)
    dof = max(float(np.sum(w)) - problem.n - 2, 1.0)
    chi2 = chi2_of(residuals, w, fit_noise, whiten)
    return [
        Explanation(kind, np.asarray(b), np.maximum(np.asarray(v), 0.0), float(c), dof,
                    float(s), relative_drift(p, problem.span), factor=f,
                    freedom=float(e) - problem.n - 2)
        for kind, b, v, s, c, p, f, e in zip(kinds, betas, variances, scores, chi2, params,
                                             factors or [None] * len(kinds),
                                             [np.nan] * len(kinds)
                                             if freedoms is None or whiten is not None
                                             else freedoms)
    ]


def freedom(sm, r, mask) -> float:
    """The run's effective number of fitted parameters: the trace of its linearised hat matrix
    for the noise-free output, ``Σ_t mask_t · J_t P_t Jᵀ_t / r`` over the order, the
    parameters and the offset (the smoothed variance of each fitted output over the white
    measurement variance `r`; a coloured noise's AR(1) state is left out). A smoothing whose
    states do not drift has n + 2 (the order, the n parameters and the offset); each drift
    adds what it fits."""
    k = min(np.asarray(sm.theta).shape[1], np.asarray(sm.phi).shape[1] + 2)
    jac, cov = np.asarray(sm.jacobian)[:, :k], np.asarray(sm.cov)[:, :k, :k]
    return float(np.sum(np.asarray(mask) * np.einsum("ti,tij,tj->t", jac, cov, jac)) / float(r))
