"""The alternatives to the tuned smoothing: other modes and other drift levels, mixed by
evidence, and those that explain the data as well (a χ² test) as members of the band."""

import jax.numpy as jnp
import numpy as np

from .._xla import to_device
from ._explanations import freedom, smoothing_explanations
from ._model import Hyper, model_output, order_of_np
from ._smoother import host_score, mix_modes
from ._threads import host_hyper, in_threads, run_mode_shares
from ._tuning import Tuning


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


def held_drift_search(run, log_tuned, settings):
    """The order drift (log) of the held smoothing with the largest evidence: `run(log_drifts)`
    → ``[(smoothing, score)]``, one for each (the runs of one call independent: they may run
    side by side), tried at the tuned drift `log_tuned` × each of `held_order_drift` (one
    call), then up to `held_order_climb` more runs: a step of `held_order_step` beyond the
    best while it is the highest (lowest) one tried and the range allows, then half a step
    either side of the best (one call), then a quarter. The evidence peaks where the held
    parameters' misfit stops paying for a freer order, and the tuned drift (at its range's
    floor where the parameters drift) does not say where that is: a ladder relative to it
    alone can stop short of the peak by a factor set by the tuning's rounding. Returns
    ``(smoothing, score)``, ``(None, -inf)`` where no run converged."""
    s = settings
    lowest, highest = (float(v) for v in np.log(np.asarray(s.order_drift_range, float)))
    budget = len(s.held_order_drift) + s.held_order_climb
    runs = {}

    def at(*log_drifts):
        keys = []
        for log_drift in log_drifts:
            key = round(float(np.clip(log_drift, lowest, highest)), 9)
            if key not in runs and key not in keys and len(runs) + len(keys) < budget:
                keys.append(key)
        if keys:
            runs.update(zip(keys, run(keys)))

    # the ladder, in one call; a factor 0 is the range's floor
    at(*(log_tuned + np.log(max(factor, 1e-300)) for factor in s.held_order_drift))

    def top():
        return max(runs, key=lambda k: runs[k][1])

    step = float(np.log(s.held_order_step))
    while len(runs) < budget:
        best, keys = top(), sorted(runs)
        if not np.isfinite(runs[best][1]):
            break
        if best == keys[-1] and best < highest:
            at(best + step)
        elif best == keys[0] and best > lowest:
            at(best - step)
        if len(runs) == len(keys):  # the peak bracketed, or the range's end reached
            break
    for fraction in (0.5, 0.25):
        best = top()
        if np.isfinite(runs[best][1]):
            at(best - fraction * step, best + fraction * step)
    best = top()
    return runs[best] if np.isfinite(runs[best][1]) else (None, -np.inf)


def held_order(problem, hyper, start, noise, fit_noise, whiten=None):
    """The order trajectory smoothed again with the parameters held (drift `constant_drift`)
    and the measurement noise at `noise` (the tuned one), from the constant-order fit
    `start`, its order drift chosen by Laplace evidence (`held_drift_search`). With one input
    an order and drifting parameters trade off; where the tuned parameters drift, this is the
    order the data give without that drift, and the order drift the tuned run needed is not
    that order's: a step in the order that drifting parameters absorbed, the held order must
    follow. Returns ``(order, explanation, run)``: the smoothing as an `Explanation` of kind
    "held" (χ² at `fit_noise`, or under `whiten`), and the held run ``(Tuning, Smoothed)``
    (its intensities and smoothing: the level profile's anchor where it is the reference);
    ``(None, None, None)`` if no run converges."""
    s = problem.settings
    dtype = problem.u.dtype

    def one(log_drift):
        held = Hyper(jnp.log(to_device(np.asarray(np.exp(log_drift), dtype))),
                     jnp.log(to_device(np.asarray(s.constant_drift, dtype))),
                     jnp.log(to_device(np.asarray(noise, dtype))), hyper.log_ar_var,
                     hyper.log_ar_time)
        sm = problem.smooth_from(held, start)
        return (sm, held), host_score(sm)  # −∞ where the run did not converge

    def run(log_drifts):  # side by side in threads (`in_threads`), the same runs
        shares = in_threads(problem, held_order, len(log_drifts),
                            lambda lo, hi: [one(d) for d in log_drifts[lo:hi]],
                            (problem.u.shape, s.max_iter))
        return [out for _, share in shares for out in share]

    found, best_score = held_drift_search(run, float(np.asarray(hyper.log_q_order)), s)
    if found is None:
        return None, None, None
    best, held = found
    theta, n = np.asarray(best.theta), problem.n
    residuals = np.asarray(problem.y) - model_output(theta, np.asarray(best.phi), n)
    (explanation,) = smoothing_explanations(
        ["held"], theta[None, :, 0], np.asarray(best.cov)[None, :, 0, 0], [best_score],
        residuals[None], theta[None, :, 1 : 1 + n], problem, fit_noise, whiten,
        freedoms=[freedom(best, np.exp(float(np.asarray(held.log_r))), problem.mask)])
    tuning = Tuning.of(host_hyper(held), (), best_score, True)
    return to_device(order_of_np(theta[:, 0], problem.bounds)[0]), explanation, (tuning, best)


def alternative_rows(settings, tuning, starts, hold):
    """The intensities of the mixture's runs after the tuned one: the tuned intensities from
    every start; unless `hold`, the parameters' drift set to each of `alt_param_drift`, then the
    order held with the parameters drifting at those levels; the order's drift scaled by each
    of `alt_order_drift` (from at least `order_drift_base`). Returns ``(rows, kinds,
    factors)``: each row's kind of `Explanation` and, for an order drift, its factor (else
    None)."""
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
    kinds = ["start"] * len(starts)
    if not hold:
        kinds += ["param_drift"] * len(s.alt_param_drift) + ["held_order"] * len(s.alt_param_drift)
    factors = [None] * len(kinds) + [float(f) for f in s.alt_order_drift]
    kinds += ["order_drift"] * len(drifts)
    return rows, kinds, factors


def mixture(problem, tuning, starts, sm, hold=False, fit_noise=None, whiten=None):
    """The order's variance (N,) on the β scale from an evidence-weighted mixture (see
    `mix_modes`) of the tuned smoothing `sm` and of the runs of `alternative_rows`, those
    after the starts from the time average of the tuned mode. Returns ``(variance, weights,
    explanations)``, the tuned run first; `explanations`: each run as an `Explanation` (its
    χ² at the noise variance `fit_noise`, or for a coloured noise under its `whiten`; []
    without it)."""
    span = problem.span
    mean = np.mean(np.asarray(sm.theta)[:span], axis=0)
    rows, kinds, factors = alternative_rows(problem.settings, tuning, starts, hold)
    firsts = np.concatenate(
        [np.asarray(starts), np.repeat(mean[None], len(rows) - len(starts), 0)]
    )
    betas, variances, scores, residuals, params, traces = run_mode_shares(
        problem, rows, to_device(np.asarray(firsts, problem.u.dtype)), problem.settings.max_iter,
    )
    theta, n = np.asarray(sm.theta), problem.n
    betas = np.concatenate([theta[None, :, 0], betas])
    variances = np.concatenate([np.asarray(sm.cov)[None, :, 0, 0], variances])
    scores = np.concatenate([[host_score(sm)], scores])
    variance, weights = mix_modes(betas, variances, scores, 0, span)
    explanations = []
    if fit_noise is not None:
        tuned = np.asarray(problem.y) - model_output(theta, np.asarray(sm.phi), n)
        explanations = smoothing_explanations(
            ["tuned", *kinds], betas, variances, scores, np.concatenate([tuned[None], residuals]),
            np.concatenate([theta[None, :, 1 : 1 + n], params]), problem, fit_noise, whiten,
            [None, *factors],
            [freedom(sm, tuning.values[2], problem.mask), *traces])
    return variance, weights, explanations
