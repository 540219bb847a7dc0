"""The level profile: with the parameters constant, the order's level and the parameters'
scale trade off along a ridge that one input can leave flat; smoothings with the parameters
held at other scales show how far it runs."""

import numpy as np

from .._xla import to_device
from ._explanations import smoothing_explanations
from ._mixture import fitting
from ._smoother import smoother_modes
from ._threads import in_threads, stack_hypers


def level_profile(problem, tuning, sm, fit_noise, whiten=None, kind="level"):
    """The smoothings at the tuned intensities `tuning` with the parameters held at one of
    `level_ratios` × their mean over the tuned mode `sm` (a prior of variance `level_pin` on
    θ_0's parameters, which the parameters' floor drift then keeps; at most `level_max_iter`
    iterations, a run still climbing there does not fit), each an `Explanation` of kind
    `kind` (its χ² at `fit_noise`, or under `whiten`). Where the largest (smallest) ratio
    still fits (the χ² test of `Explanation.fits`), the profile goes on by factors of
    `level_step` up to `level_max` (down to its inverse) until one does not. Between the tuned
    scale (or a ratio that fits) and the nearest ratio that does not, it bisects on the log
    scale while the failing run's order is outside its fitting neighbour's ±2σ band, up to
    `level_splits` times a side (`level_next`). The order's level is not settled by the data
    along that ridge: the band weighs these smoothings by their likelihood."""
    s = problem.settings
    if not s.level_ratios:
        return []
    n, span = problem.n, problem.span
    mean = np.mean(np.asarray(sm.theta)[:span], axis=0)
    hyper = stack_hypers([tuning.values])

    def held_runs(ratios):
        runs = []
        for ratio in ratios:
            held = ratio * mean[1 : 1 + n]
            m, p = np.array(problem.m0), np.array(problem.p0)
            m[1 : 1 + n] = held
            p[1 : 1 + n, 1 : 1 + n] = np.diag(s.level_pin * np.maximum(held * held, 1.0))
            start = mean.copy()
            start[1 : 1 + n] = held
            runs.append((to_device(m), to_device(p), start[None]))

        def call(lo, hi):
            return [
                smoother_modes(*problem.record, hyper, m, p, start, problem.bounds,
                               s.level_max_iter, False, problem.schedule)
                for m, p, start in runs[lo:hi]
            ]

        outs = [o for _, share in in_threads(problem, smoother_modes, len(runs), call,
                                              (problem.u.shape, s.level_max_iter)) for o in share]
        return (np.concatenate(output) for output in zip(*outs))

    # each ratio run: (fits, β (N,), σ of β (N,)); the tuned run is ratio 1, the anchor
    def sd(variance):
        return np.sqrt(np.maximum(variance, 0.0))

    tried = {1.0: (True, np.asarray(sm.theta)[:, 0], sd(np.asarray(sm.cov)[:, 0, 0]))}
    ratios = list(s.level_ratios)
    explanations = []
    while ratios:
        betas, variances, scores, residuals, params, traces = held_runs(ratios)
        explanations += smoothing_explanations([kind] * len(ratios), betas, variances, scores,
                                               residuals, params, problem, fit_noise, whiten,
                                               freedoms=traces)
        fits = fitting(residuals, problem.mask, n, fit_noise, whiten) & np.isfinite(scores)
        for r, f, b, v in zip(ratios, fits, betas, variances):
            tried[r] = (bool(f), b, sd(v))
        ratios = [r for side in (1, -1) for r in level_next(tried, side, span, s)]
    return explanations


def level_next(tried, side, span, settings):
    """The held ratios to run next on one side of the tuned scale (``side`` +1: above 1, −1:
    below), from `tried` (ratio ↦ ``(fits, β, σ)``): past the outermost ratio, by
    `level_step` up to `level_max`, where it fits; and the log-midpoint between the nearest
    ratio that does not fit and its inner neighbour (one that fits, or 1), where the failing
    run's β is more than 2σ of the neighbour's from it (median over the first `span`
    samples) and the two are more than `level_step`'s `level_splits`-th halving apart."""
    s = settings
    x = {float(np.log(r)) * side: v for r, v in tried.items()}  # outward: x > 0
    own = sorted(k for k in x if k > 0)
    out = []
    if own and x[own[-1]][0] and own[-1] + np.log(s.level_step) <= np.log(s.level_max) + 1e-9:
        out.append(own[-1] + np.log(s.level_step))
    failing = [k for k in own if not x[k][0]]
    if failing:
        outer = failing[0]
        inner = max(k for k in x if k < outer)  # fits: the anchor 0, or a ratio that fits
        _, b_in, sd_in = x[inner]
        apart = np.median(np.abs(x[outer][1][:span] - b_in[:span])
                          / np.maximum(sd_in[:span], 1e-300))
        finest = np.log(s.level_step) / 2**s.level_splits
        if apart > 2.0 and outer - inner > finest * (1 + 1e-9):
            out.append((outer + inner) / 2)
    return [float(np.exp(side * k)) for k in out]
