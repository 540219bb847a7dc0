"""Coloured measurement noise: where the white-noise model's prediction errors are correlated,
the tracker with an AR(1) noise state besides white noise, kept where the evidence prefers it."""

import dataclasses

import jax
import numpy as np

from .._stats import correlation_limit, prediction_error_correlation
from .._xla import to_device
from ._model import Hyper
from ._problem import prior
from ._smoother import host_score
from ._threads import in_threads
from ._tuning import box, climb


def ar_whitener(steps, mask, horizon, tuning):
    """The linear map that whitens a series under the measurement noise of `tuning`: AR(1)
    (stationary variance ``s``, correlation time ``τ``) plus white (``r``), with
    ``a_k = exp(−(t_{k+1} − t_k)/τ)``. A scalar Kalman filter of the AR(1) part: each sample's
    innovation over its standard deviation, so ``Σ mask·whiten(x)²`` is ``xᵀ Σ⁻¹ x`` over the
    fitted samples (skipped samples carry the state forward unseen). Returns a function of
    an array (N, …), each column whitened alone, on the host."""
    steps, mask = np.asarray(steps, float), np.asarray(mask, float)
    s, r, tau = tuning.coloured_noise, tuning.noise, tuning.noise_time * float(horizon)
    a = np.exp(-steps / tau)
    num = steps.shape[0]
    gain, sd = np.empty(num), np.empty(num)
    var = s
    for k in range(num):  # the gains do not depend on the data: once for every column
        total = var + r
        gain[k], sd[k] = mask[k] * var / total, np.sqrt(total)
        var = a[k] ** 2 * (1.0 - gain[k]) * var + s * (1.0 - a[k] ** 2)

    # the prediction obeys pred_{k+1} = c_k pred_k + a_k g_k x_k (pred_0 = 0): an affine
    # recursion, composed by a doubling scan (log₂ N vectorised steps, not N Python steps)
    c = a * (1.0 - gain)
    shifts = [1 << i for i in range(max(num - 1, 1).bit_length())]

    def whiten(x):
        x = np.asarray(x, float)
        extra = (slice(None),) + (None,) * (x.ndim - 1)
        mult, acc = c.copy(), (a * gain)[extra] * x  # f_k(p) = mult_k p + acc_k
        for shift in shifts:  # each f_k becomes f_k ∘ … ∘ f_{k−2·shift+1}
            if shift >= num:
                break
            acc[shift:] = acc[shift:] + mult[shift:][extra] * acc[:-shift]
            mult[shift:] = mult[shift:] * mult[:-shift]
        pred = np.concatenate([np.zeros((1,) + x.shape[1:]), acc[:-1]])
        return (x - pred) / sd[extra]

    return whiten


def coloured(problem, sm, tuning, starts, noise_floor, hold, offset_known, noise_data):
    """The tracker with a coloured measurement noise (an AR(1) state, see `Hyper`), where the
    white-noise model's prediction errors' lag-1 is above `coloured_lag`/√n (at 0, above
    `correlation_limit`), or its
    noise variance is below `coloured_absorbed` × the data's own `noise_data` (its drifting
    states absorbed the noise, so its prediction errors look white); kept when
    its evidence is higher by more than `coloured_evidence` and its correlation time is not at
    the top of its range. Its start: the drifts of the white-noise smoothing `sm` (its
    intensities `tuning`), the noise split evenly between a white and an AR(1) part, each
    correlation between samples of `rho_starts` smoothed from the white mode (side by side in
    threads), the best by evidence (the first of equal ones); from there it climbs (`climb`,
    in a trust region, ended early where the correlation time stays at the top of its range).
    Returns ``(problem, hyper, smoothed, tuning, starts)`` of the coloured model (the problem
    with its prior, the starts with the noise state), or None (white noise kept)."""
    s = problem.settings
    fitted = np.asarray(problem.mask) > 0
    r1, count = prediction_error_correlation(problem.y, sm.y_pred, fitted)
    absorbed = tuning.noise < s.coloured_absorbed * noise_data
    limit = correlation_limit(count) if s.coloured_lag <= 0 else s.coloured_lag / np.sqrt(count)
    if not (r1 > limit or absorbed):
        return None
    step = float(np.median(np.asarray(problem.steps)[fitted]))
    span = float(problem.horizon)
    time_min = s.noise_time_min * step / span
    half = max(tuning.noise / 2, noise_floor)
    dtype = problem.u.dtype
    problem = problem.with_prior(*prior(problem.n, dtype, s, coloured=True,
                                        offset_known=offset_known))
    theta = np.asarray(sm.theta)
    starts = np.concatenate([np.asarray(starts), np.zeros((len(starts), 1))], axis=1)
    nominal = to_device(np.concatenate([theta, np.zeros((theta.shape[0], 1))], axis=1))
    hypers = []
    for rho in s.rho_starts:
        noise_time = float(np.clip(-step / np.log(rho) / span, 1.01 * time_min,
                                   0.99 * s.noise_time_max))
        values = (tuning.order_drift, tuning.parameter_drift, half, half, noise_time)
        hypers.append(Hyper(*(to_device(np.asarray(np.log(v), dtype)) for v in values)))

    def call(lo, hi):  # the starts are independent: side by side in threads
        return [jax.block_until_ready(problem.smooth(h, nominal)) for h in hypers[lo:hi]]

    runs = [smc for _, out in in_threads(problem, coloured, len(hypers), call,
                                         (problem.u.shape, s.max_iter)) for smc in out]
    best = None
    for hyper, smc in zip(hypers, runs):
        score = host_score(smc)
        if best is None or score > best[0]:
            best = (score, hyper, smc)
    _, hyper, smc = best
    hyper, smc, tuned = climb(problem, box(s, noise_floor, hold, time_min), hyper, smc,
                              rounds=s.coloured_rounds, radius=s.coloured_radius,
                              fatal="noise_time")
    # a correlation time at the top of its range: a slow drift of the output, not noise
    if "noise_time" in tuned.at_edge or not (
        tuned.log_likelihood > tuning.log_likelihood + s.coloured_evidence
    ):
        return None
    rho = float(np.exp(-step / (tuned.noise_time * span)))
    tuned = dataclasses.replace(tuned, noise_correlation=rho)
    return problem, hyper, smc, tuned, starts
