"""The alternatives to the tuned smoothing: other modes and other drift levels, mixed by
evidence, and those that explain the data as well (a χ² test) as members of the band."""

import jax.numpy as jnp
import numpy as np

from .._xla import to_device
from ._model import Hyper, order_of_np
from ._smoother import host_score, mix_modes
from ._threads import run_mode_shares


def chi2_fits(chi2, dof):
    """A fit passes the χ² test at 2σ: ``χ² ≤ dof + 2√(2·dof)``."""
    return chi2 <= dof + 2 * np.sqrt(2 * dof)


def fitting(residuals, mask, n, fit_noise, whiten=None):
    """Which runs' residuals (C, N) from the noise-free output pass the χ² test at 2σ
    (`chi2_fits`, with n parameters, the offset and the order taken from the samples' count)
    at the white noise variance `fit_noise`, or for a coloured noise under its `whiten`; (C,)
    booleans."""
    w = np.asarray(mask)
    dof = max(float(np.sum(w)) - n - 2, 1.0)
    res = np.asarray(residuals).T  # (N, C)
    chi2 = np.sum(w[:, None] * (res**2 / fit_noise if whiten is None else whiten(res) ** 2), 0)
    return np.asarray(chi2_fits(chi2, dof), bool)


def widened(envelope, beta, variance):
    """The envelope ``(lo, hi)`` (None: empty) widened to cover ``β ± 2σ``."""
    sd = np.sqrt(np.maximum(variance, 0.0))
    lo, hi = beta - 2 * sd, beta + 2 * sd
    if envelope is None:
        return lo, hi
    return np.minimum(envelope[0], lo), np.maximum(envelope[1], hi)


def held_order(problem, hyper, start, noise):
    """The order trajectory smoothed again with the tuned order drift but the parameters held
    (drift `constant_drift`) and the measurement noise at `noise` (the constant fit's misfit:
    held parameters leave more of it), from the constant-order fit `start`. With one input an
    order and drifting parameters trade off; where the tuned parameters drift, this is the
    order the data give without that drift. None if the smoothing does not converge."""
    dtype = problem.u.dtype
    held = Hyper(hyper.log_q_order,
                 jnp.log(to_device(np.asarray(problem.settings.constant_drift, dtype))),
                 jnp.log(to_device(np.asarray(noise, dtype))), hyper.log_ar_var,
                 hyper.log_ar_time)
    sm = problem.smooth_from(held, start)
    if not bool(sm.converged):
        return None
    return to_device(order_of_np(np.asarray(sm.theta)[:, 0], problem.bounds)[0])


def alternative_rows(settings, tuning, starts, hold):
    """The intensities of the mixture's runs after the tuned one, and how many of them have
    the parameters drifting (they follow the starts): the tuned intensities from every
    start; unless `hold`, the parameters' drift set to each of `alt_param_drift`, then the
    order held with the parameters drifting at those levels; the order's drift scaled by each
    of `alt_order_drift` (from at least `order_drift_base`)."""
    s = settings
    qo, qp, *rest = tuning.values
    # the order drift's range as the search box holds it (logs, and back)
    lowest, highest = np.exp(np.log(np.asarray(s.order_drift_range, float)))
    rows = [(qo, qp, *rest)] * len(starts)
    if not hold:
        rows += [(qo, alt, *rest) for alt in s.alt_param_drift]
        # the other explanation a single input allows: the order (nearly) constant, the
        # parameters drifting
        rows += [(float(lowest), alt, *rest) for alt in s.alt_param_drift]
    base = max(qo, s.order_drift_base)
    drifts = np.clip(base * np.asarray(s.alt_order_drift), lowest, highest)
    rows += [(float(q), qp, *rest) for q in drifts]
    return rows, 0 if hold else 2 * len(s.alt_param_drift)


def mixture(problem, tuning, starts, sm, hold=False, fit_noise=None, whiten=None):
    """The order's variance (N,) on the β scale from an evidence-weighted mixture (see
    `mix_modes`) of the tuned smoothing `sm` and of the runs of `alternative_rows`, those
    after the starts from the time average of the tuned mode. Returns
    ``(variance, weights, envelope, drifting)``, the tuned run first; `envelope`:
    ``(lo, hi)`` (N,) on the β scale, the union of the ±2σ bands of the alternatives whose
    residuals pass a χ² test at 2σ at the noise variance `fit_noise` (or, for a coloured
    noise, under its `whiten`), or None; `drifting`: one of those has the parameters
    drifting."""
    span = problem.span
    mean = np.mean(np.asarray(sm.theta)[:span], axis=0)
    rows, drifting_count = alternative_rows(problem.settings, tuning, starts, hold)
    firsts = np.concatenate(
        [np.asarray(starts), np.repeat(mean[None], len(rows) - len(starts), 0)]
    )
    betas, variances, scores, residuals = run_mode_shares(
        problem, rows, to_device(np.asarray(firsts, problem.u.dtype)), problem.settings.max_iter,
    )
    betas = np.concatenate([np.asarray(sm.theta)[None, :, 0], np.asarray(betas)])
    variances = np.concatenate([np.asarray(sm.cov)[None, :, 0, 0], np.asarray(variances)])
    scores = np.concatenate([[host_score(sm)], np.asarray(scores)])
    variance, weights = mix_modes(betas, variances, scores, 0, span)
    # the alternatives that explain the data (a χ² test at 2σ, at the noise `fit_noise`):
    # the band covers each one's ±2σ, whatever its evidence (evidence under the random-walk
    # prior is not a safe guide between a moving order and drifting parameters, nor between
    # order-drift levels)
    envelope, drifting = None, False
    first = 1 + len(starts)  # after the tuned run and the starts: the drifting parameters
    drift_rows = range(first, first + drifting_count)
    if fit_noise is not None:
        # the alternatives only: `residuals` has no row for the tuned run (index 0). One with
        # the parameters drifting must also be within the evidence floor: those runs fit
        # almost any record, with the order's level free
        drifts = np.isin(np.arange(1, len(scores)), drift_rows)
        floor = evidence_floor(scores[0], problem.settings.envelope_evidence)
        plausible = np.isfinite(scores[1:]) & (~drifts | (scores[1:] >= floor))
        passing = fitting(residuals, problem.mask, problem.n, fit_noise, whiten) & plausible
        for c in 1 + np.flatnonzero(passing):
            drifting |= c in drift_rows
            envelope = widened(envelope, betas[c], variances[c])
    return variance, weights, envelope, drifting


def evidence_floor(tuned, below):
    """The lowest Laplace evidence at which a run with the parameters drifting may widen the
    band: `below` nats under the tuned run's evidence `tuned`, or −∞ (no floor) where the
    tuned run did not converge."""
    return tuned - below if np.isfinite(tuned) else -np.inf
