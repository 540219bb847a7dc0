"""The tracker on one record's points, as its passes: start (normalise, constant-order fit,
starting trajectories), tune (the noise intensities by the likelihood), coloured noise, the
order with the parameters held, the band (mixture, level profile, trade-off), the result."""

import dataclasses

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jax import lax

from .._identification import stated_drift
from .._stats import noise_variance
from .._xla import to_device
from ._band import bands, own_halfwidth, second_half
from ._coloured import ar_whitener, coloured
from ._filter import KalmanTracker
from ._level import level_profile
from ._mixture import held_order, mixture
from ._model import Hyper, model_output, order_of_np
from ._moving import moving_orders
from ._problem import Problem, Scales, data_scales, prior
from ._smoother import resolve_schedule
from ._start import constant_fit, starting_trajectories
from ._threads import host_hyper
from ._trade import trade_interval
from ._tuning import Tuning, tune


class TrackResult(eqx.Module):
    """Everything the tracker estimates on its points, in the user's units."""

    alpha: jax.Array
    alpha_std: jax.Array
    alpha_lower: jax.Array
    alpha_upper: jax.Array
    p: jax.Array
    p_std: jax.Array
    x0: jax.Array
    x0_std: jax.Array
    y_hat: jax.Array
    y_pred: jax.Array
    converged: bool = eqx.field(static=True)
    tuning: Tuning = eqx.field(static=True)
    constant_order: float = eqx.field(static=True)
    # the order smoothed again with the parameters held (see `held_order`), or None
    alpha_held: jax.Array | None = None
    # the evidence weights of the band's mixture (see `mixture`), the tuned run first
    mixture_weights: tuple[float, ...] | None = eqx.field(static=True, default=None)
    # the constant orders with which a drifting parameter explains the data as well (see
    # `trade_interval`), which the band covers, or None
    trade: tuple[float, float] | None = eqx.field(static=True, default=None)
    # the band covers a drifting-parameter alternative that explains the data (see `mixture`)
    drift_covered: bool = eqx.field(static=True, default=False)
    # every explanation the band weighed (see `vojax._tracker._explanations`)
    explanations: tuple = eqx.field(static=True, default=())
    # the conditional answer ``(alpha, lower, upper, std)``, its breakdown drift and its own
    # parameters' drift (see `vojax._tracker._band`); None and NaN where not computed
    conditional: tuple | None = None
    # the measurement noise's variance by each estimate (normalised units): the χ² tests'
    # (`fit`), the tuned one, the data's own from differences of order 2, 4 and 6
    noise_levels: dict | None = eqx.field(static=True, default=None)
    breakdown_drift: float = eqx.field(static=True, default=float("nan"))
    reference_drift: float = eqx.field(static=True, default=float("nan"))


@dataclasses.dataclass(frozen=True)
class Start:
    """What the start gives the later passes: the `problem`, the normalisation `scales` and
    the factor `p_scale` from normalised to physical parameters, the constant-order fit's
    order `alpha_c` and misfit, the `starts` (S, d), the data's own noise variance (second
    differences), its estimates from differences of order 4 and 6 and the noise's floor, the
    first pass's noise levels, whether the offset is `known`."""

    problem: Problem
    scales: Scales
    p_scale: np.ndarray
    alpha_c: float
    misfit: float
    starts: np.ndarray
    noise_data: float
    noise_higher: tuple[float, float]
    noise_floor: float
    noises: tuple[float, ...]
    known: bool


def start(memory, u, y, dt, bounds, settings, mask, times, x0, batched) -> Start:
    """Normalises the record, fits a constant order, and sets the first pass's noise levels."""
    s = settings
    num, n = u.shape
    dtype = np.dtype(u.dtype)
    mask = to_device(np.ones((num,), dtype) if mask is None else np.asarray(mask, dtype))
    scales = data_scales(u, y, mask)
    known = x0 is not None  # the offset known: the output normalised about it, held at 0
    if known:
        scales = dataclasses.replace(scales, y_ref=float(x0))
    # host arithmetic before the compiled programs (an eager JAX operation compiles its own)
    un = np.asarray(u) / np.asarray(scales.u_scale)
    yn = to_device((np.asarray(y) - scales.y_ref) / scales.y_scale)
    alpha_c, _, rss, rms_phi = constant_fit(memory, to_device(un), yn, mask, bounds, s,
                                            offset=not known)
    if not np.all(rms_phi > 0):
        raise ValueError("the fractional integral of an input is zero: its parameter is undefined.")
    # regressors scaled to unit RMS at the constant order: p̃ = O(1) whatever the units
    un = to_device(un / np.asarray(rms_phi))
    p_scale = scales.y_scale / (np.asarray(scales.u_scale) * rms_phi)
    m0, p0 = prior(n, u.dtype, s, offset_known=known)
    # the step after each sample, t_{k+1} − t_k (the last one repeated); arrays, not Python
    # numbers: a new record length or step must not recompile
    if times is None:
        steps = to_device(np.full((num,), float(dt), dtype))
        times = float(dt) * np.arange(num)
    else:
        gaps = np.diff(np.asarray(times))
        steps = to_device(np.concatenate([gaps, gaps[-1:]]).astype(dtype))
    # the record's span up to its last fitted sample (padding after it does not count)
    last = int(np.flatnonzero(np.asarray(mask) > 0)[-1])
    span = float(np.asarray(times)[last] - np.asarray(times)[0])
    horizon = to_device(np.asarray(max(span, float(np.min(np.asarray(steps)))), u.dtype))
    problem = Problem(memory, un, yn, mask, steps, horizon, m0, p0, bounds, np.asarray(times),
                      last, s, resolve_schedule(s.schedule), batched)
    starts = starting_trajectories(problem, alpha_c, offset=not known)
    dof = max(float(np.sum(np.asarray(mask))) - n - 2, 1.0)
    # the data's own noise level (second differences), capped by the constant fit's residual
    fitted = np.asarray(yn)[np.asarray(mask) > 0]
    noise_data = noise_variance(fitted)
    # the noise's floor from the least of the differences of order 2, 4 and 6: a signal that
    # curves at the sampling scale (an oscillation of few samples per cycle) inflates the
    # second differences, the higher orders less
    higher = (noise_variance(fitted, 4), noise_variance(fitted, 6))
    least = min(noise_data, *higher)
    misfit = max(rss / dof, s.noise_min)
    noise0 = float(np.clip(noise_data, s.noise_min, misfit))
    # first-pass noise levels, tried in turn until a run converges: the data's, then the
    # constant fit's misfit when much larger; the misfit first when the output shows no noise
    # at all (below the search box: a controlled signal), where the data's level stalls
    noises = (noise0,)
    if misfit >= s.misfit_ratio * noise0:
        noises = (misfit, noise0) if noise_data < s.noise_min else (noise0, misfit)
    return Start(problem, scales, p_scale, alpha_c, misfit, starts, noise_data, higher,
                 max(s.noise_floor * least, s.noise_min), noises, known)


def given_intensities(st, noise):
    """The smoothing at the user's intensities `noise` (a dict; see `identify`), untuned."""
    problem = st.problem
    hyper = Hyper(
        jnp.log(to_device(float(noise["order_drift"]))),
        jnp.log(to_device(float(noise["parameter_drift"]))),
        jnp.log(to_device((float(noise["noise_std"]) / st.scales.y_scale) ** 2)),
    )
    sm = problem.smooth_from(hyper, st.starts[0])
    return hyper, sm, Tuning.of(host_hyper(hyper), (), sm.log_likelihood, False)


def profiles_held(held, problem) -> bool:
    """The level profile runs about the held smoothing (explanation `held`, or None): where
    it stands for the data (it may be the reference) and its own band is no wider than an
    identified one. Its scales only widen the held band (`bands`), so about a wider one the
    answer is neither identified nor conditional whatever they say."""
    s = problem.settings
    return held is not None and held.holds and own_halfwidth(
        held, problem.bounds, s.band_scale, s.band_floor, second_half(problem.mask, problem.span),
        problem.span) <= s.identified_halfwidth


def alternatives(problem, tuning, starts, sm, hold, fit_noise, whiten, held=None):
    """The smoothed order's variance on the β scale (the mixture's), the mixture's weights,
    and every alternative run as an `Explanation`: the mixture's, and the level profile's
    about the smoothing with the parameters constant: the tuned one where they are stated
    so or tuned to no more drift than `held_order` tolerates, else the `held` run
    ``(Tuning, Smoothed)`` where it fits (then the conditional answer's reference)."""
    if not tuning.tuned:
        return np.asarray(sm.cov)[:, 0, 0], None, []
    beta_var, weights, explanations = mixture(problem, tuning, starts, sm, hold, fit_noise,
                                              whiten)
    s = problem.settings
    if hold or tuning.parameter_drift <= s.held_ratio * s.constant_drift:
        explanations += level_profile(problem, tuning, sm, fit_noise, whiten)
    elif held is not None:
        explanations += level_profile(problem, *held, fit_noise, whiten, kind="held_level")
    return beta_var, weights, explanations


def fit_points(memory, u, y, dt, bounds, settings, *, smooth=True, noise=None, mask=None,
               iterations=3, times=None, parameters="free", x0=None, batched=False,
               time_scale=1.0, weigh=True, give_up=None):
    """The tracker on samples ``u`` (N, n), ``y`` (N,) with step `dt`, or at the sample
    `times` (then `dt` is None); see `identify`. ``parameters="constant"`` (or `noise` with a
    parameter drift at most `constant_drift`): their drift held there, and the band
    conditional on it (no `trade_interval`). `x0`: the output's offset, known (held there) or
    None (estimated). `batched`: the first pass's and the mixture's runs through one vmapped
    program where that is faster (the same results to rounding). `dt`, `times` and the
    `memory` are on the tracker's clock, the user's time over `time_scale`. ``weigh=False``:
    the tuned smoothing and its own band only (no held smoothing, alternatives, trade-off or
    explanations' band: the second clock's quick look, see `vojax._tracker._clock`).
    `give_up`: a test of the tuned smoothing's one-step predictions (the output's units, every
    point); where it holds, None is returned before the band's passes (a long record's blocks
    whose prediction errors correlate, which the caller fits again on shorter ones)."""
    s = settings
    hold = parameters == "constant" or (
        noise is not None and float(noise["parameter_drift"]) <= s.constant_drift
    )
    st = start(memory, u, y, dt, bounds, s, mask, times, x0, batched)
    problem, starts = st.problem, st.starts
    if noise is None:
        hyper, sm, tuning = tune(problem, starts, st.noises, st.noise_floor, hold=hold)
    else:
        hyper, sm, tuning = given_intensities(st, noise)
    whiten = None
    if smooth and tuning.tuned:
        found = coloured(problem, sm, tuning, starts, st.noise_floor, hold, st.known,
                         st.noise_higher[0])
        if found is not None:
            problem, hyper, sm, tuning, starts = found
            whiten = ar_whitener(problem.steps, problem.mask, problem.horizon, tuning)
    if smooth and give_up is not None and give_up(st.scales.output(sm.y_pred)):
        return None
    # the χ² tests of what fits, at the larger of the tuned noise and the data's own
    # (drifting states absorb noise)
    fit_noise = max(tuning.noise, st.noise_data)
    alpha_held, held, held_run = None, None, None
    drifting = tuning.parameter_drift > s.held_ratio * s.constant_drift
    if smooth and weigh and tuning.tuned and drifting:
        alpha_held, held, held_run = held_order(problem, hyper, starts[0], tuning.noise,
                                                fit_noise, whiten)
        if not profiles_held(held, problem):
            held_run = None  # no level profile about it
    weights, explanations = None, []
    if smooth:
        theta, cov, y_hat_n, y_pred_n = sm.theta, sm.cov, None, sm.y_pred
        converged = bool(sm.converged)
        if weigh:
            beta_var, weights, explanations = alternatives(problem, tuning, starts, sm, hold,
                                                           fit_noise, whiten, held_run)
        else:  # the tuned smoothing's own band
            beta_var = np.asarray(sm.cov)[:, 0, 0]
    else:
        # the online filter starts from the constant-order fit (a whole-record summary, like
        # the tuned intensities): from the neutral prior its first samples cannot place p
        out = run_filter(problem.with_prior(to_device(starts[0]), problem.p0), hyper,
                         iterations)
        theta, cov, y_hat_n, y_pred_n = out.mean, out.cov, out.y_hat, out.y_pred
        converged = True
        beta_var = np.asarray(cov)[:, 0, 0]
    trade, traded, profile = None, [], None
    if weigh and (not hold or (smooth and tuning.tuned)):  # held: the breakdown drift only
        trade, traded, profile = trade_interval(problem, fit_noise, whiten,
                                                offset=not st.known)
    explanations = tuple(explanations + ([] if held is None else [held]) + traded)
    found = None
    if smooth and weigh and tuning.tuned:
        half = second_half(problem.mask, problem.span)

        def band_of(explanations):
            return bands(explanations, problem.bounds, problem.span,
                         0.0 if hold else stated_drift(parameters), s.band_scale,
                         s.drift_floor, floor=s.band_floor, evidence_floor=s.envelope_evidence,
                         half=half, level_weights=s.level_weights,
                         fastest_evidence=s.fastest_evidence, near_evidence=s.near_evidence,
                         level_gap=s.level_gap, profile_chi2=s.level_profile_chi2,
                         excess_alike=s.level_excess_alike, gap_z=s.relative_gap)

        found = band_of(explanations)
        # a constant order outside the band fits with some drift: a moving one may need less;
        # under a statement (constant, or a drift bound) the answer states its reach, so a
        # moving order is searched even where no constant one fits
        stated = hold or np.isfinite(stated_drift(parameters))
        if profile is not None and (np.isfinite(found.breakdown_drift) or stated):
            moving = moving_orders(profile, found.conditional, half, stated,
                                   found.reference_freedom)
            if moving:
                explanations = explanations + tuple(moving)
                found = band_of(explanations)
    res = assemble(st, problem, theta, cov, beta_var, None if hold else trade, y_hat_n,
                   y_pred_n, sm.phi if y_hat_n is None else None, converged, tuning,
                   alpha_held, weights, found, time_scale)
    levels = dict(fit=fit_noise, tuned=tuning.noise, data2=st.noise_data,
                  data4=st.noise_higher[0], data6=st.noise_higher[1],
                  coloured=whiten is not None)
    return dataclasses.replace(res, explanations=explanations, noise_levels=levels)


def user_parameters(theta, cov, p_scale, n, bounds, time_scale):
    """The parameters and their standard deviations (N, n) in the user's units from the
    states `theta` (N, d) and covariances `cov` (N, d, d) on the tracker's clock (time over
    `time_scale`): ``p = p̃ · p_scale · time_scale^(−α)``, since ``I^α`` on that clock is
    ``time_scale^(−α)`` times ``I^α`` on the user's; the standard deviation by the delta
    method through the order and the parameter together."""
    alpha, dalpha = order_of_np(theta[:, 0], bounds)
    log_ts = float(np.log(time_scale))
    factor = np.exp(-log_ts * alpha)[:, None] * np.asarray(p_scale)[None, :]
    p_n = theta[:, 1 : 1 + n]
    # ∂p/∂β = −p · ln(time_scale) · dα/dβ, ∂p/∂p̃ = factor
    d_beta = -p_n * factor * log_ts * dalpha[:, None]
    var = (d_beta**2 * cov[:, 0, 0][:, None]
           + 2 * d_beta * factor * cov[:, 0, 1 : 1 + n]
           + factor**2 * np.diagonal(cov, axis1=1, axis2=2)[:, 1 : 1 + n])
    return p_n * factor, np.sqrt(np.maximum(var, 0.0))


def assemble(st, problem, theta, cov, beta_var, trade, y_hat_n, y_pred_n, phi, converged,
             tuning, alpha_held, weights, found=None, time_scale=1.0) -> TrackResult:
    """The `TrackResult` in the user's units, on the host (NumPy: no program compiled); the
    band from the explanations' `Bands` where `found`, else from the mixture's variance
    `beta_var` (an untuned smoothing, the online filter); the parameters from the tracker's
    clock (time over `time_scale`) to the user's (`user_parameters`)."""
    bounds, n, scales = problem.bounds, problem.n, st.scales
    theta, cov = np.asarray(theta), np.asarray(cov)
    if y_hat_n is None:
        y_hat_n = model_output(theta, np.asarray(phi), n)
    beta_sd = np.sqrt(np.maximum(np.asarray(beta_var), 0.0))
    alpha, dalpha = order_of_np(theta[:, 0], bounds)
    alpha_std = dalpha * beta_sd
    lower = order_of_np(theta[:, 0] - 2 * beta_sd, bounds)[0]
    upper = order_of_np(theta[:, 0] + 2 * beta_sd, bounds)[0]
    conditional, breakdown, reference_drift = None, float("nan"), float("nan")
    if found is not None:
        _, lower, upper, std = found.stated
        alpha_std = np.maximum(std, (upper - lower) / 4)
        conditional = tuple(to_device(np.asarray(a)) for a in found.conditional)
        breakdown, reference_drift = found.breakdown_drift, found.reference_drift
    p, p_std = user_parameters(theta, cov, st.p_scale, n, bounds, time_scale)
    var = np.maximum(np.diagonal(cov, axis1=1, axis2=2), 0.0)
    known = st.known
    return TrackResult(
        alpha=to_device(alpha),
        alpha_std=to_device(alpha_std),
        alpha_lower=to_device(lower),
        alpha_upper=to_device(upper),
        p=to_device(p),
        p_std=to_device(p_std),
        x0=to_device(scales.y_ref if known else scales.output(theta[-1, 1 + n])),
        x0_std=to_device(0.0 if known else scales.y_scale * np.sqrt(var[-1, 1 + n])),
        y_hat=to_device(scales.output(y_hat_n)),
        y_pred=to_device(scales.output(y_pred_n)),
        converged=converged,
        tuning=tuning,
        constant_order=st.alpha_c,
        alpha_held=alpha_held,
        mixture_weights=None if weights is None else tuple(float(w) for w in weights),
        trade=trade,
        drift_covered=False if found is None else found.drifting,
        conditional=conditional,
        breakdown_drift=breakdown,
        reference_drift=reference_drift,
    )


def run_filter(problem, hyper, iterations=3):
    """The online iterated EKF over the whole record in one scan, from the problem's prior."""
    tracker = KalmanTracker(problem.memory, hyper, jnp.asarray(problem.horizon), problem.m0,
                            problem.p0, problem.bounds, iterations)
    return _scan_filter(tracker, problem.u, problem.y, problem.steps, problem.mask)


@eqx.filter_jit
def _scan_filter(tracker, u, y, steps, mask):
    @jax.checkpoint
    def body(state, x):
        return tracker.step(state, *x)

    _, out = lax.scan(body, tracker.init(u.shape[1]), (u, y, steps, mask))
    return out
