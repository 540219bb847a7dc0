"""The tracker end to end: normalise, start from a constant-order fit, tune the noise
intensities by the innovation likelihood, then smooth (or filter) with bands."""

import concurrent.futures
import contextlib
import contextvars
import dataclasses
import os
import threading

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jax import lax

from .._stats import correlation_limit, noise_variance, prediction_error_correlation
from .._xla import to_device
from . import _bfgs as bfgs
from ._filter import KalmanTracker
from ._model import Hyper, beta_of_np, model_output, order_of_np
from ._smoother import (
    batch_pays,
    host_score,
    iterated_smoother,
    linearised_log_likelihood,
    mix_modes,
    schedule,
    smoother_batch,
    smoother_modes,
)

PRIOR_BETA_VAR = 4.0  # β = logit of the order's place in its range: ±2 covers 12 %…88 %
PRIOR_VAR = 100.0  # normalised parameters and offset: ±10 × the data's scale
# a known offset (`identify(x0=…)`) is held by a prior of this variance (normalised units:
# ±2e-5 of the output's RMS), so that it runs the same compiled programs as an estimated one
OFFSET_PIN = 1e-10
NOISE_MIN = 1e-10  # the smallest measurement noise searched (normalised variance)
# the box of the likelihood search, natural logs of normalised intensities
BOX = {
    "order_drift": (np.log(1e-6), np.log(1e4)),
    "parameter_drift": (np.log(1e-10), np.log(1e2)),
    "noise": (np.log(NOISE_MIN), np.log(2.0)),
}
LOWER_EDGE = " (lower edge)"  # suffix of a drift tuned to the bottom of its search box
GRID_ORDER = (1e-1, 1.0, 1e1)  # variance of the change of β over the record, first pass
PARAM_DRIFT0 = 1e-6  # parameters nearly constant in the first pass (the model's p is constant)
START_ORDERS = (0.15, 0.35, 0.5, 0.65, 0.85)  # starting orders, as fractions of the range
NOISE_FLOOR = 0.25  # the noise variance stays ≥ this × the second-difference estimate
MAX_ITER = 400  # Levenberg–Marquardt iterations of one smoothing
# iterations of each run of the first pass: enough for the run that reaches the best mode (a
# 1e4-sample record as 1,000 block means: 6 of 18 runs converge within 60, 17 within 400, the
# same mode picked either way, 1,044 iterations against 1,955; docs/identifiability.md)
GRID_MAX_ITER = 60
# an output smoother than the model can follow (a controlled displacement, say: its second
# differences show almost no noise, while a constant order leaves a misfit 1e8 times larger)
# makes every run of a first pass at the data's noise stall; the first pass is also made at
# the constant fit's misfit when that is at least this many times the data's noise
MISFIT_RATIO = 10.0
# tuned parameter drift above this many times `PARAM_DRIFT0`: the order is smoothed again
# with the parameters held, and the diagnostics compare the two (`held_order`)
HELD_RATIO = 2.0
# the band integrates over what the data do not settle: besides the tuned smoothing, the
# modes reached from every start at the tuned intensities, and the tuned intensities with the
# order's or the parameters' drift set to each of these levels, all weighted by evidence
ALT_ORDER_DRIFT = (1e-2, 1e-1, 1e1, 1e2)  # × the tuned order drift, or × 1e-3 if smaller
ORDER_DRIFT_BASE = 1e-3  # (an order tuned to be constant still has its variable alternatives)
ALT_PARAM_DRIFT = (1e-3, 1e-2, 1e-1)  # variance of a normalised parameter's change
# an alternative with the parameters drifting whose Laplace evidence is this far (nats) below
# the tuned run's does not widen the band, however well it fits
ENVELOPE_EVIDENCE = 200.0
# with one input a drifting parameter can stand in for a moving order: the band also covers
# every constant order with which a parameter free to drift (a piecewise-linear p(t) on
# `TRADE_KNOTS` knots, as a gain on the memory term or inside the integral) explains the data
# as well (Δχ² ≤ `TRADE_CHI2` from the best), when such a fit explains them at all
TRADE_KNOTS = 8
# … or on `TRADE_KNOTS_FINE` knots (those and their midpoints) where that lowers the form's
# best χ² by more than 2 for each added coefficient (Akaike's criterion): a drift faster than
# 8 knots follow leaves a misfit that biases the coarse profile's orders
TRADE_KNOTS_FINE = 2 * TRADE_KNOTS - 1
TRADE_ORDERS = 25  # constant orders profiled, evenly across the bounds
TRADE_CHI2 = 4.0
PHI_BLOCK = TRADE_KNOTS_FINE + 1  # the columns of one run of Φ at a constant order
# with the parameters stated constant, the order's level and the parameters' scale trade off
# along a ridge that one input can leave flat (a lower order with larger parameters and
# another offset fits as well); the random-walk prior then settles the level, and the Laplace
# band, conditional on it, can miss the truth. The band also covers the smoothings with the
# parameters held at these multiples of the tuned ones, where they explain the data
LEVEL_RATIOS = (0.5, 0.71, 1.41, 2.0)
# past an outermost ratio that fits, the profile goes on by this factor, as far as this
LEVEL_STEP = float(np.sqrt(2.0))
LEVEL_MAX = 4.0
# between the tuned scale (or a held ratio that fits) and the nearest held ratio that does
# not, the profile bisects (on the log scale) while the failing run's order lies outside the
# ±2σ band of its fitting neighbour (median over the record), at most this many times a side:
# sharp records (long ones: block means) have a narrow ridge whose fitting scales fall
# between the ratios above
LEVEL_SPLITS = 3
LEVEL_PIN = 1e-8  # prior variance of a held parameter, × its square (at least 1)
# coloured measurement noise: where the white-noise model's prediction errors are correlated
# (`correlation_limit`), the tracker is run again with an AR(1) noise state, kept when its
# evidence is higher by more than this (two more intensities: the AIC's price)
COLOURED_EVIDENCE = 2.0
# the AR(1) part's correlation time is searched from this fraction of the median step (its
# correlation between samples e^(−1/0.3) ≈ 0.04: white) …
NOISE_TIME_MIN = 0.3
# … up to this fraction of the span: a noise correlated for longer is a drift of the output,
# which the offset and the parameters' drift cannot be told from (a coloured model tuned to
# this end is not kept)
NOISE_TIME_MAX = 0.1
RHO_STARTS = (0.5, 0.7, 0.85, 0.95)  # the AR(1) part's starting correlations between samples
# its intensities climb in a trust region: each BFGS refinement within a factor e^radius of
# the current ones, the radius halved after a refinement the re-smoothed evidence rejects
CLIMB_RADIUS = float(np.log(3.0))
CLIMB_ROUNDS = 6
# each refinement's BFGS stops where its step and the change of its loss (the negative
# linearised likelihood per fitted sample) are both within atol + rtol·|·|, or after 60
# evaluations
REFINE_RTOL, REFINE_ATOL = 1e-7, 1e-9
# a coloured climb whose correlation time sat at the top of its range after this many accepted
# rounds in a row ends there: the coloured model is rejected at that edge anyway
FATAL_EDGE_ROUNDS = 2
# a pass's smoothings are independent: they run side by side in up to this many threads
# (one per core), each over an equal share of them (one compiled program for all shares)
RUN_THREADS = 8


@dataclasses.dataclass(frozen=True)
class Scales:
    """Normalisation: ``ỹ = (y − y_ref)/y_scale``, ``ũ_j = u_j/u_scale_j``; the tracker's
    parameters are then ``p̃ = p · u_scale / y_scale`` and its offset ``c̃ = (x0 − y_ref)/y_scale``."""

    y_ref: float
    y_scale: float
    u_scale: tuple[float, ...]


def _weighted_mean(x, w):
    return float(np.sum(w * x) / np.sum(w))


def _rms(x, w=None):
    """Root mean square without overflow (scaled by the largest magnitude first)."""
    x = np.asarray(x, dtype=float)
    big = float(np.max(np.abs(x))) if x.size else 0.0
    if not big > 0 or not np.isfinite(big):
        return big if np.isfinite(big) else float("inf")
    z = (x / big) ** 2
    mean = float(np.sum(w * z) / np.sum(w)) if w is not None else float(np.mean(z))
    return big * float(np.sqrt(mean))


def data_scales(u, y, mask) -> Scales:
    """Reference level and scale of the output, RMS of each input; errors name what is flat."""
    y, u, w = np.asarray(y), np.asarray(u), np.asarray(mask)
    if not np.all(np.isfinite(y)) or not np.all(np.isfinite(u)):
        raise ValueError("`u` and `y` must be finite (an overflow in a unit conversion?).")
    y_ref = _weighted_mean(y, w)
    y_scale = _rms(y - y_ref, w)
    if not y_scale > 0 or not np.isfinite(y_scale):
        raise ValueError("`y` is constant over the fitted samples: there is nothing to identify.")
    u_scale = np.array([_rms(u[:, j], w) for j in range(u.shape[1])])
    if np.any(~(u_scale > 0)) or not np.all(np.isfinite(u_scale)):
        j = int(np.argmax(~(u_scale > 0) | ~np.isfinite(u_scale)))
        raise ValueError(f"input column {j} of `u` is zero everywhere: its parameter is undefined.")
    return Scales(y_ref, y_scale, tuple(float(s) for s in u_scale))


@eqx.filter_jit
def _phi_constant(memory, x, alpha):
    """``Φ`` of the input columns `x` (N, `PHI_BLOCK`) at the constant order `alpha`."""
    return memory.run(x, jnp.full((x.shape[0],), alpha, x.dtype), False)


def phi_columns(memory, x, alpha):
    """``Φ`` (N, m) of each column of `x` (N, m) at the constant order `alpha`, in blocks of
    `PHI_BLOCK` columns (the last padded with zeros): the constant fit and the trade-off's
    profile share one compiled program whatever the number of inputs, and one scan of the
    memory costs about the same for one column as for nine."""
    x = np.asarray(x)
    num, m = x.shape
    padded = np.zeros((num, -(-m // PHI_BLOCK) * PHI_BLOCK), x.dtype)
    padded[:, :m] = x
    a = to_device(np.asarray(alpha, x.dtype))
    return np.concatenate(
        [np.asarray(_phi_constant(memory, to_device(padded[:, j : j + PHI_BLOCK]), a))
         for j in range(0, padded.shape[1], PHI_BLOCK)],
        axis=1,
    )[:, :m]


def _least_squares(x, y, mask, whiten=None, offset=True):
    """Weighted least squares with an offset column, on the host: ``(rss, coef)``, the offset
    last. With `whiten` (see `ar_whitener`), generalised least squares: the columns and `y`
    whitened first, and `rss` is then the χ². ``offset=False``: the offset is known to be 0
    (no column; its coefficient 0)."""
    if offset:
        x = np.concatenate([x, np.ones((x.shape[0], 1), x.dtype)], axis=1)
    if whiten is not None:
        x, y = whiten(x), whiten(y)
    w = np.sqrt(mask)
    coef = np.linalg.lstsq(x * w[:, None], y * w, rcond=None)[0]
    res = (y - x @ coef) * w
    if not offset:
        coef = np.concatenate([coef, np.zeros(1, coef.dtype)])
    return float(res @ res), coef


def _constant_profile(memory, u, y, mask, alpha, offset=True):
    """Residual sum of squares and ``[p, c]`` of the least-squares fit at a constant order,
    and the RMS of each column of ``Φ`` (`u`, `y`, `mask`: host arrays); ``offset=False``:
    ``c`` known to be 0."""
    phi = phi_columns(memory, u, alpha)
    rss, coef = _least_squares(phi, y, mask, offset=offset)
    return rss, coef, np.sqrt(np.sum(mask[:, None] * phi**2, 0) / np.sum(mask))


def constant_fit(memory, u, y, mask, bounds, num_grid=13, golden_steps=24, offset=True):
    """Constant-order least squares with offset (``offset=False``: the offset known to be 0):
    a grid in β, then golden-section search in β between the best grid point's neighbours.
    Returns ``(α, coef, rss, rms of Φ columns)``."""
    betas = np.linspace(-4.5, 4.5, num_grid)
    u, y, mask = (np.asarray(a) for a in (u, y, mask))  # once, not at each of ~40 orders

    def at(beta):
        alpha, _ = order_of_np(beta, bounds)
        return _constant_profile(memory, u, y, mask, alpha, offset)

    values = [float(at(b)[0]) for b in betas]
    i = int(np.nanargmin(values))
    lo, hi = betas[max(i - 1, 0)], betas[min(i + 1, num_grid - 1)]
    ratio = (np.sqrt(5.0) - 1) / 2
    a, b = hi - ratio * (hi - lo), lo + ratio * (hi - lo)
    fa, fb = float(at(a)[0]), float(at(b)[0])
    for _ in range(golden_steps):
        if fa < fb:
            hi, b, fb = b, a, fa
            a = hi - ratio * (hi - lo)
            fa = float(at(a)[0])
        else:
            lo, a, fa = a, b, fb
            b = lo + ratio * (hi - lo)
            fb = float(at(b)[0])
    best = a if fa < fb else b
    if values[i] < min(fa, fb):
        best = betas[i]
    rss, coef, rms_phi = at(best)
    alpha, _ = order_of_np(best, bounds)
    return float(alpha), np.asarray(coef), float(rss), np.asarray(rms_phi)


@dataclasses.dataclass(frozen=True)
class Tuning:
    """How the noise intensities were chosen: their values (normalised units), whether each
    sits at the edge of the search box, and the likelihood."""

    order_drift: float
    parameter_drift: float
    noise: float  # the white measurement variance
    at_edge: tuple[str, ...]
    log_likelihood: float
    tuned: bool
    # a coloured measurement noise's AR(1) part: its stationary variance and its correlation
    # time (a fraction of the record's span); None for white noise
    coloured_noise: float | None = None
    noise_time: float | None = None
    # that part's correlation between consecutive samples (at the median step), or None
    noise_correlation: float | None = None

    @property
    def values(self) -> tuple[float, ...]:
        """The intensities in `Hyper`'s order (five with a coloured noise, else three)."""
        extra = () if self.coloured_noise is None else (self.coloured_noise, self.noise_time)
        return (self.order_drift, self.parameter_drift, self.noise, *extra)

    @classmethod
    def of(cls, x, at_edge, log_likelihood, tuned):
        """From the log-intensities `x` (three or five, in `Hyper`'s order)."""
        v = [float(a) for a in np.exp(np.asarray(x, float))]
        extra = v[3:] if len(v) == 5 else [None, None]
        return cls(*v[:3], tuple(at_edge), float(log_likelihood), bool(tuned), *extra)


def box(noise_floor, hold=False, time_min=None):
    """The search box (natural logs): `BOX`, with the noise's lower end raised to the floor;
    `hold`: the parameters' drift held at `PARAM_DRIFT0` (a box of zero width). With
    `time_min` (the shortest correlation time, a fraction of the span) the box of a coloured
    noise, in `Hyper`'s order: the white part (from the floor), the AR(1) part (from
    `NOISE_MIN`) and its correlation time (up to `NOISE_TIME_MAX` of the span)."""
    out = {k: v for k, v in BOX.items() if k != "noise"}
    if hold:
        out["parameter_drift"] = (float(np.log(PARAM_DRIFT0)),) * 2
    floor = (max(BOX["noise"][0], float(np.log(noise_floor))), BOX["noise"][1])
    if time_min is None:
        out["noise"] = floor
    else:
        out["white_noise"] = floor
        out["coloured_noise"] = BOX["noise"]
        out["noise_time"] = (float(np.log(time_min)), float(np.log(NOISE_TIME_MAX)))
    return out


def _refine(hyper, smoothed, mask, steps, horizon, m0, p0, limits, max_steps=60):
    """Maximises the linearised innovation likelihood over the three log-intensities."""
    dtype = smoothed.pseudo.dtype
    lo = to_device(np.asarray([v[0] for v in limits.values()], dtype))
    hi = to_device(np.asarray([v[1] for v in limits.values()], dtype))
    # a strongly typed start: a weakly typed one (from Python numbers) would compile anew
    return _refine_compiled(
        to_device(np.asarray(_host_hyper(hyper), dtype)), smoothed.jacobian, smoothed.pseudo,
        mask, steps, horizon, m0, p0, lo, hi, max_steps,
    )


@eqx.filter_jit
def _refine_compiled(x0, jac, z, mask, steps, horizon, m0, p0, lo, hi, max_steps):
    count = jnp.sum(mask)

    def loss(zeta):
        # box by a smooth squashing, so that BFGS works unconstrained
        x = lo + (hi - lo) * jax.nn.sigmoid(zeta)
        return -linearised_log_likelihood(Hyper.from_array(x), jac, z, mask, steps, horizon, m0, p0) / count

    # inside the box (a box of zero width holds its coordinate: ζ = 0, x = lo)
    margin = jnp.minimum(1e-3, (hi - lo) / 2)
    x0 = jnp.clip(x0, lo + margin, hi - margin)
    zeta0 = jnp.where(hi > lo, jnp.log((x0 - lo) / jnp.where(hi > lo, hi - x0, 1.0)), 0.0)
    # optimistix's BFGS at REFINE_RTOL, REFINE_ATOL, written as one small loop (`_bfgs`)
    zeta, _ = bfgs.minimise(loss, zeta0, max_steps, rtol=REFINE_RTOL, atol=REFINE_ATOL)
    zeta = jnp.where(jnp.all(jnp.isfinite(zeta)), zeta, zeta0)
    return Hyper.from_array(lo + (hi - lo) * jax.nn.sigmoid(zeta))


def starting_trajectories(memory, u, y, mask, bounds, alpha_c, offset=True):
    """Constant-order trajectories to start the smoother from: the constant fit's order (kept
    off the flat ends of the logistic map) and `START_ORDERS` across the range, each with its
    least-squares parameters and offset (``offset=False``: 0). Returns (S, d)."""
    lo, hi = bounds
    frac = (alpha_c - lo) / (hi - lo)
    # always the same number of starts: one compiled program for every record of a shape
    fracs = [float(np.clip(frac, START_ORDERS[0], START_ORDERS[-1])), *START_ORDERS]
    u, y, mask = (np.asarray(a) for a in (u, y, mask))
    out = []
    for f in fracs:
        alpha = lo + (hi - lo) * f
        _, coef, _ = _constant_profile(memory, u, y, mask, alpha, offset)
        out.append(np.concatenate([[float(beta_of_np(alpha, bounds))], np.asarray(coef)]))
    return np.stack(out)


def ar_whitener(steps, mask, horizon, tuning):
    """The linear map that whitens a series under the measurement noise of `tuning`: AR(1)
    (stationary variance ``s``, correlation time ``τ``) plus white (``r``), with
    ``a_k = exp(−(t_{k+1} − t_k)/τ)``. A scalar Kalman filter of the AR(1) part: each sample's
    innovation over its standard deviation, so ``Σ mask·whiten(x)²`` is ``xᵀ Σ⁻¹ x`` over the
    fitted samples (skipped samples carry the state forward unseen). Returns a function of
    an array (N,) or (N, m), on the host."""
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

    def whiten(x):
        x = np.asarray(x, float)
        out = np.empty_like(x)
        pred = np.zeros(x.shape[1:])
        for k in range(num):
            e = x[k] - pred
            out[k] = e / sd[k]
            pred = a[k] * (pred + gain[k] * e)
        return out

    return whiten


def chi2_fits(chi2, dof):
    """A fit passes the χ² test at 2σ: ``χ² ≤ dof + 2√(2·dof)``."""
    return chi2 <= dof + 2 * np.sqrt(2 * dof)


def hat_basis(times, last, knots=TRADE_KNOTS):
    """Piecewise-linear hat functions (N, knots) on evenly spaced knots over ``times[0]`` …
    ``times[last]``: a parameter that drifts smoothly over the fitted span."""
    times = np.asarray(times, float)
    s = np.clip((times - times[0]) / max(times[last] - times[0], 1e-300), 0.0, 1.0)
    return np.clip(1.0 - np.abs(s[:, None] * (knots - 1) - np.arange(knots)[None, :]), 0.0, None)


def refinement(knots):
    """The matrix R (2k − 1, k) with ``coarse = fine @ R`` for hat functions on `knots`
    evenly spaced knots (coarse) and on those knots with their midpoints added (fine): a
    coarse hat is its knot's fine hat plus half of each neighbouring one (exact: it is linear
    between the fine knots)."""
    r = np.zeros((2 * knots - 1, knots))
    for k in range(knots):
        r[2 * k, k] = 1.0
        if k > 0:
            r[2 * k - 1, k] = 0.5
        if k < knots - 1:
            r[2 * k + 1, k] = 0.5
    return r


def _drift_profile(memory, u, y, mask, alphas, fine, whiten=None, offset=True):
    """Weighted residual sums of squares (A, 2, 2) of least squares at each constant order of
    `alphas` with an offset (``offset=False``: known to be 0) and the parameters free to
    drift, ``p_j(t) = Σ_k a_jk B_k(t)``: on `TRADE_KNOTS` knots, then on the hat functions
    `fine` (N, `TRADE_KNOTS_FINE`: those knots and their midpoints); each as a gain on the
    memory term (``y ≈ c + Σ a_jk B_k Φ_j``), then inside the integral
    (``y ≈ c + Σ a_jk I^α(B_k u_j)``); χ² where `whiten` is given (see `_least_squares`).
    The integral is linear: the coarse hats' columns are sums of the fine ones'
    (`refinement`), so one run of the memory a constant order serves both."""
    u, y, mask, fine = (np.asarray(a) for a in (u, y, mask, fine))
    num, n = u.shape
    k = fine.shape[1]
    r = refinement(TRADE_KNOTS)
    coarse = fine @ r
    inside_u = (u[:, :, None] * fine[:, None, :]).reshape(num, n * k)
    # one block of `PHI_BLOCK` = k + 1 columns an input: its own and its k drifting ones
    columns = np.concatenate([u, inside_u], axis=1)
    out = []
    for alpha in alphas:
        both = phi_columns(memory, columns, alpha)
        phi, inside = both[:, :n], both[:, n:].reshape(num, n, k)
        row = []
        for basis, drifting in ((coarse, inside @ r), (fine, inside)):
            gain = phi[:, :, None] * basis[:, None, :]
            row.append([_least_squares(x.reshape(num, -1), y, mask, whiten, offset)[0]
                        for x in (gain, drifting)])
        out.append(row)
    return np.asarray(out)


def trade_interval(memory, u, y, mask, times, last, bounds, noise, whiten=None, offset=True):
    """The constant orders ``(lo, hi)`` with which a drifting parameter explains the data as
    well as the best such fit (``Δχ² ≤ TRADE_CHI2`` at the measurement variance `noise`, on the
    same scale as `y`, or under a coloured noise's `whiten`), over the forms (gain, inside)
    whose best fit passes a χ² test at 2σ (``χ² ≤ dof + 2√(2 dof)``); None when neither
    explains the data. Each form's drift is on `TRADE_KNOTS` knots, or on `TRADE_KNOTS_FINE`
    where Akaike's criterion prefers them. ``offset=False``: the offset is known to be 0."""
    lo, hi = bounds
    n = u.shape[1]
    alphas = np.linspace(lo, hi, TRADE_ORDERS + 2)[1:-1]
    fine = hat_basis(times, last, TRADE_KNOTS_FINE)
    chi2 = _drift_profile(memory, u, y, mask, alphas, fine, whiten, offset)
    chi2 = chi2 / noise if whiten is None else chi2
    fitted = float(np.sum(np.asarray(mask)))
    found = []
    for form in range(chi2.shape[2]):
        c, knots = chi2[:, 0, form], TRADE_KNOTS
        c_fine = chi2[:, 1, form]
        # the finer drift where its added coefficients pay for themselves (Akaike)
        if np.all(np.isfinite(c_fine)) and (
            c.min() - c_fine.min() > 2 * n * (TRADE_KNOTS_FINE - TRADE_KNOTS)
        ):
            c, knots = c_fine, TRADE_KNOTS_FINE
        dof = max(fitted - n * knots - 1, 1.0)
        if not np.all(np.isfinite(c)) or not chi2_fits(c.min(), dof):
            continue
        excess = c - c.min() - TRADE_CHI2
        inside = np.flatnonzero(excess <= 0)

        def crossing(a, b):  # where Δχ² crosses the limit between grid orders a (in), b (out)
            return alphas[a] + (alphas[b] - alphas[a]) * -excess[a] / (excess[b] - excess[a])

        i, j = inside[0], inside[-1]
        found.append(lo if i == 0 else crossing(i, i - 1))
        found.append(hi if j == alphas.size - 1 else crossing(j, j + 1))
    return (float(min(found)), float(max(found))) if found else None


_warm: set = set()  # (function, shapes) already run: their shares may run in threads
_warm_lock = threading.Lock()
_thread_limit = contextvars.ContextVar("vojax_run_threads", default=None)
# the passes' runs batched (`smooth_batched`), for the duration of a `track(batched=True)`
_batched = contextvars.ContextVar("vojax_batched_runs", default=False)


@contextlib.contextmanager
def run_threads(limit: int):
    """Within the block the tracker's smoothings use at most `limit` threads (1: one after
    another), e.g. in a process that already runs one record per core (a Dask worker)."""
    token = _thread_limit.set(int(limit))
    try:
        yield
    finally:
        _thread_limit.reset(token)


def _in_threads(fn, count, call, key):
    """``call(lo, hi)`` for equal shares ``[lo, hi)`` of the `count` runs, in threads
    (`RUN_THREADS`, at most one per core) once `fn` has run for these shapes (`key`); the
    first time one share after another, so that two threads never compile the same
    program. Returns the shares' outputs in order, with their ``(lo, hi)``."""
    limit = _thread_limit.get()
    if schedule() != "sequential" and jax.default_backend() == "cpu":
        # XLA:CPU's runtime was seen to deadlock running the prefix sums' programs from two
        # threads at once (1e6 samples, 1,000 block means): one thread on a CPU
        limit = 1
    workers = max(1, min(count, os.cpu_count() or 1, RUN_THREADS, limit or RUN_THREADS))
    size = -(-count // workers)
    shares = [(lo, min(lo + size, count)) for lo in range(0, count, size)]
    key = (id(fn), size, *key)
    with _warm_lock:
        warm = key in _warm
    if not warm or len(shares) == 1:
        out = [call(lo, hi) for lo, hi in shares]
        with _warm_lock:
            _warm.add(key)
    else:
        with concurrent.futures.ThreadPoolExecutor(len(shares)) as pool:
            out = list(pool.map(lambda share: call(*share), shares))
    return list(zip(shares, out))


def _share(rows, firsts, lo, hi):
    """Rows ``[lo, hi)`` of the intensities and starts."""
    return _stack_hypers(rows[lo:hi]), np.asarray(firsts)[lo:hi]


def _run_shares(fn, memory, u, y, mask, steps, horizon, rows, m0, p0, firsts, bounds, budget):
    """`fn` (`smoother_batch` or `smoother_modes`) over the runs ``rows`` × ``firsts``, split
    into shares run in threads (`_in_threads`), each share's runs batched where `track` was
    asked to and it pays (`batch_pays`); ``[((lo, hi), output)]``."""
    batched = _batched.get() and batch_pays()  # read here: a thread starts with no context

    def call(lo, hi):
        hyper, first = _share(rows, firsts, lo, hi)
        out = fn(memory, u, y, mask, steps, horizon, hyper, m0, p0, first, bounds, budget,
                 batched)
        return jax.block_until_ready(out)

    return _in_threads(fn, len(rows), call, (u.shape, budget, batched))


def _joined(parts, k):
    """Output `k` of every share, its padding dropped, end to end."""
    return np.concatenate([np.asarray(o[k])[: hi - lo] for (lo, hi), o in parts])


def run_batch_shares(memory, u, y, mask, steps, horizon, rows, m0, p0, firsts, bounds, budget):
    """`smoother_batch` in shares (`_run_shares`); the same result as one call: the best run
    by score (the first of equal ones), its index, the index of the best by objective, the
    scores."""
    parts = _run_shares(smoother_batch, memory, u, y, mask, steps, horizon, rows, m0, p0,
                        firsts, bounds, budget)
    scores, alts = _joined(parts, 3), _joined(parts, 5)
    i = int(np.argmax(scores)) if np.any(np.isfinite(scores)) else -1
    i_alt = int(np.argmax(alts)) if np.any(np.isfinite(alts)) else -1
    holder = next(o for (lo, hi), o in parts if lo <= max(i, 0) < hi)
    return holder[0], i, i_alt, scores


def run_mode_shares(memory, u, y, mask, steps, horizon, rows, m0, p0, firsts, bounds, budget):
    """`smoother_modes` in shares (`_run_shares`): its four outputs, one row per run."""
    parts = _run_shares(smoother_modes, memory, u, y, mask, steps, horizon, rows, m0, p0,
                        firsts, bounds, budget)
    return tuple(_joined(parts, k) for k in range(4))


def _host_hyper(hyper):
    """``hyper.as_array()`` on the host."""
    return np.array([float(v) for v in jax.tree_util.tree_leaves(hyper)])


def _stack_hypers(values):
    """A batched `Hyper` from rows of intensities in its order (``(q_order, q_params, r)``,
    and a coloured noise's ``(s, τ)``)."""
    arr = np.log(np.asarray(values, dtype=float))
    return Hyper(*(to_device(arr[:, i]) for i in range(arr.shape[1])))


def tune(
    memory, u, y, mask, steps, horizon, m0, p0, starts, noises, bounds, noise_floor=NOISE_MIN,
    rounds=2, hold=False,
):
    """Maximises the marginal likelihood (Laplace evidence at the posterior mode) over the
    noise intensities and over starting trajectories, since the posterior of a variable order
    can have several modes. One compiled smoothing of every start × order-drift on `GRID_ORDER`
    (parameter drift `PARAM_DRIFT0`, noise ``noises[0]``), each given `GRID_MAX_ITER`
    iterations; if none converges, the same at each further level of `noises` in turn, then
    at ``noises[0]`` with `MAX_ITER` iterations. From the best run, alternate a BFGS
    refinement of the likelihood of the linearised model and re-smoothing. Returns
    ``(Hyper, Smoothed, Tuning)``. The measurement noise is kept above `noise_floor`: smooth
    records otherwise reach a higher likelihood by explaining every wiggle with drifting
    states and no noise at all, with meaningless, vanishing bands. `hold`: the parameters'
    drift held at `PARAM_DRIFT0` (the parameters known to be constant)."""
    limits = box(noise_floor, hold)
    first = to_device(np.repeat(np.asarray(starts), len(GRID_ORDER), axis=0))
    passes = [*((noise, GRID_MAX_ITER) for noise in noises), (noises[0], MAX_ITER)]
    for noise, budget in passes:
        rows = [(qo, PARAM_DRIFT0, noise) for _ in starts for qo in GRID_ORDER]
        sm, i, i_alt, scores = run_batch_shares(
            memory, u, y, mask, steps, horizon, rows, m0, p0, first, bounds, budget
        )
        if np.any(np.isfinite(np.asarray(scores))):
            break
    i = i if i >= 0 else i_alt
    if i < 0:
        raise ValueError("the tracker diverged from every starting order; check the data.")
    hyper = Hyper(*(to_device(np.log(float(v))) for v in rows[i]))
    if not np.isfinite(np.asarray(scores)[i]):
        # none converged: fall back on the best finite objective rather than giving up (the
        # pass kept only its index: run it again, the same computation)
        sm = smooth_from(memory, u, y, mask, steps, horizon, hyper, m0, p0, first[i], bounds)
    return climb(memory, u, y, mask, steps, horizon, m0, p0, bounds, limits, hyper, sm, rounds)


def climb(memory, u, y, mask, steps, horizon, m0, p0, bounds, limits, hyper, sm, rounds,
          radius=None, fatal=None):
    """From the smoothing `sm` at the intensities `hyper`, alternates a BFGS refinement of the
    intensities (within `limits`) on the likelihood of the model linearised at the mode and a
    re-smoothing from the mode, while the re-smoothed mode's own evidence rises. With
    `radius`, a trust region: each refinement stays within ``exp(±radius)`` of the current
    intensities, and a refinement that lowers the evidence halves the radius (down to a
    tenth of it) instead of ending the climb. With `fatal`, the name of an intensity whose
    edge disqualifies the result, the climb ends once `FATAL_EDGE_ROUNDS` accepted rounds in
    a row left that intensity at the top of `limits` (the caller rejects it there). Returns
    ``(Hyper, Smoothed, Tuning)``."""
    cand = (host_score(sm), hyper, sm)
    step = radius
    edged = 0
    for _ in range(rounds):
        if edged >= FATAL_EDGE_ROUNDS:
            break
        local = limits
        if step is not None:
            x = _host_hyper(cand[1])
            local = {k: (max(lo, v - step), min(hi, v + step)) if hi > lo else (lo, hi)
                     for (k, (lo, hi)), v in zip(limits.items(), x)}
        hyper = _refine(cand[1], cand[2], mask, steps, horizon, m0, p0, local)
        sm = iterated_smoother(
            memory, u, y, mask, steps, horizon, hyper, m0, p0, cand[2].theta, bounds, MAX_ITER
        )
        ll = host_score(sm)
        if not ll > cand[0]:
            if step is None or step / 2 < radius / 10:
                break
            step /= 2
            continue
        cand = (ll, hyper, sm)
        if fatal is not None:
            edged = edged + 1 if fatal in at_edges(_host_hyper(hyper), limits) else 0
    _, hyper, sm = cand
    x = _host_hyper(hyper)
    return hyper, sm, Tuning.of(x, at_edges(x, limits), sm.log_likelihood, True)


EDGE = 0.05  # an intensity within this fraction of its box's width (logs) of an end is at it


def at_edges(x, limits) -> tuple[str, ...]:
    """The names of the log-intensities `x` (in the order of `limits`) that sit at an edge of
    the box searched, `limits` (a box of zero width holds its coordinate: never at an edge).
    A drift at the lower edge is a finding (the data show no drift) and is named as such;
    the noise at either edge, or a drift at the upper one, is a problem (`diagnose`). The
    noise's box starts at its floor, so its lower edge is relative to that floor."""
    out = []
    for name, v in zip(limits, x):
        lo, hi = limits[name]
        if hi > lo and min(v - lo, hi - v) < EDGE * (hi - lo):
            out.append(name + (LOWER_EDGE if name != "noise" and v - lo < hi - v else ""))
    return tuple(out)


def held_order(memory, u, y, mask, steps, horizon, hyper, m0, p0, start, bounds, noise):
    """The order trajectory smoothed again with the tuned order drift but the parameters held
    (drift `PARAM_DRIFT0`) and the measurement noise at `noise` (the constant fit's misfit:
    held parameters leave more of it), from the constant-order fit `start`. With one input an
    order and drifting parameters trade off; where the tuned parameters drift, this is the
    order the data give without that drift. None if the smoothing does not converge."""
    held = Hyper(hyper.log_q_order, jnp.log(to_device(np.asarray(PARAM_DRIFT0, u.dtype))),
                 jnp.log(to_device(np.asarray(noise, u.dtype))), hyper.log_ar_var,
                 hyper.log_ar_time)
    sm = smooth_from(memory, u, y, mask, steps, horizon, held, m0, p0, start, bounds)
    if not bool(sm.converged):
        return None
    return to_device(order_of_np(np.asarray(sm.theta)[:, 0], bounds)[0])


def smooth_from(memory, u, y, mask, steps, horizon, hyper, m0, p0, start, bounds):
    """One smoothing at fixed intensities `hyper`, from the constant trajectory `start` (d,)."""
    start = np.asarray(start, np.dtype(u.dtype))
    nominal = to_device(np.broadcast_to(start, (u.shape[0], start.shape[0])))
    return iterated_smoother(
        memory, u, y, mask, steps, horizon, hyper, m0, p0, nominal, bounds, MAX_ITER
    )


def mixture(
    memory, u, y, mask, steps, horizon, tuning, m0, p0, starts, sm, bounds, span, hold=False,
    fit_noise=None, whiten=None,
):
    """The order's variance (N,) on the β scale from an evidence-weighted mixture (see
    `mix_modes`) of the tuned smoothing `sm` and of smoothings at the tuned intensities
    (`tuning`) from every constant start, and at those intensities with the order's drift
    scaled by each of `ALT_ORDER_DRIFT` (from at least `ORDER_DRIFT_BASE`), the parameters'
    set to each of `ALT_PARAM_DRIFT`, and the order held with the parameters drifting at
    those levels (from the time average of the tuned mode); with `hold` (the parameters
    known to be constant), none of the parameters' alternatives. Returns
    ``(variance, weights, envelope, drifting)``, the tuned run first; `envelope`:
    ``(lo, hi)`` (N,) on the β scale, the union of the ±2σ bands of the alternatives whose
    residuals pass a χ² test at 2σ at the noise variance `fit_noise` (or, for a coloured
    noise, under its `whiten`), or None; `drifting`: one of those has the parameters
    drifting."""
    qo, qp, *rest = tuning.values
    mean = np.mean(np.asarray(sm.theta)[:span], axis=0)
    rows = [(qo, qp, *rest)] * len(starts)
    if not hold:
        rows += [(qo, alt, *rest) for alt in ALT_PARAM_DRIFT]
        # the other explanation a single input allows: the order (nearly) constant, the
        # parameters drifting
        rows += [(float(np.exp(BOX["order_drift"][0])), alt, *rest) for alt in ALT_PARAM_DRIFT]
    base = max(qo, ORDER_DRIFT_BASE)
    drifts = np.clip(base * np.asarray(ALT_ORDER_DRIFT), *np.exp(BOX["order_drift"]))
    rows += [(float(q), qp, *rest) for q in drifts]
    firsts = np.concatenate(
        [np.asarray(starts), np.repeat(mean[None], len(rows) - len(starts), 0)]
    )
    betas, variances, scores, residuals = run_mode_shares(
        memory, u, y, mask, steps, horizon, rows, m0, p0, to_device(np.asarray(firsts, u.dtype)),
        bounds, MAX_ITER,
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
    drift_rows = range(first, first if hold else first + 2 * len(ALT_PARAM_DRIFT))
    if fit_noise is not None:
        # the alternatives only: `residuals` has no row for the tuned run (index 0). One with
        # the parameters drifting must also be within the evidence floor: those runs fit
        # almost any record, with the order's level free
        drifts = np.isin(np.arange(1, len(scores)), drift_rows)
        floor = _evidence_floor(scores[0])
        plausible = np.isfinite(scores[1:]) & (~drifts | (scores[1:] >= floor))
        passing = _fitting(residuals, mask, u.shape[1], fit_noise, whiten) & plausible
        for c in 1 + np.flatnonzero(passing):
            drifting |= c in drift_rows
            envelope = _widened(envelope, betas[c], variances[c])
    return variance, weights, envelope, drifting


def _fitting(residuals, mask, n, fit_noise, whiten=None):
    """Which runs' residuals (C, N) from the noise-free output pass the χ² test at 2σ
    (`chi2_fits`, with n parameters, the offset and the order taken from the samples' count)
    at the white noise variance `fit_noise`, or for a coloured noise under its `whiten`; (C,)
    booleans."""
    w = np.asarray(mask)
    dof = max(float(np.sum(w)) - n - 2, 1.0)
    res = np.asarray(residuals).T  # (N, C)
    chi2 = np.sum(w[:, None] * (res**2 / fit_noise if whiten is None else whiten(res) ** 2), 0)
    return np.asarray(chi2_fits(chi2, dof), bool)


def _evidence_floor(tuned):
    """The lowest Laplace evidence at which a run with the parameters drifting may widen the
    band: `ENVELOPE_EVIDENCE` below the tuned run's evidence `tuned`, or −∞ (no floor) where
    the tuned run did not converge."""
    return tuned - ENVELOPE_EVIDENCE if np.isfinite(tuned) else -np.inf


def _widened(envelope, beta, variance):
    """The envelope ``(lo, hi)`` (None: empty) widened to cover ``β ± 2σ``."""
    sd = np.sqrt(np.maximum(variance, 0.0))
    lo, hi = beta - 2 * sd, beta + 2 * sd
    if envelope is None:
        return lo, hi
    return np.minimum(envelope[0], lo), np.maximum(envelope[1], hi)


def level_profile(
    memory, u, y, mask, steps, horizon, tuning, m0, p0, sm, bounds, span, fit_noise,
    whiten=None, envelope=None,
):
    """The envelope ``(lo, hi)`` on the β scale (or None) widened by the ±2σ band of each
    smoothing, at the tuned intensities `tuning`, with the parameters held at one of
    `LEVEL_RATIOS` × their mean over the tuned mode `sm` (a prior of variance `LEVEL_PIN`
    on θ_0's parameters, which the parameters' floor drift then keeps) whose residuals pass
    the χ² test of `mixture`. Where the largest (smallest) ratio still fits, the profile goes
    on by factors of `LEVEL_STEP` up to `LEVEL_MAX` (down to its inverse) until one does not.
    Between the tuned scale (or a ratio that fits) and the nearest ratio that does not, it
    bisects on the log scale while the failing run's order is outside its fitting
    neighbour's ±2σ band, up to `LEVEL_SPLITS` times a side (`_level_next`). The order's level
    is not settled by the data where these smoothings fit; their bands then make the reported
    one cover that ridge."""
    if not LEVEL_RATIOS:
        return envelope
    n = u.shape[1]
    mean = np.mean(np.asarray(sm.theta)[:span], axis=0)
    hyper = _stack_hypers([tuning.values])

    def held_runs(ratios):
        runs = []
        for ratio in ratios:
            held = ratio * mean[1 : 1 + n]
            m, p = np.array(m0), np.array(p0)
            m[1 : 1 + n] = held
            p[1 : 1 + n, 1 : 1 + n] = np.diag(LEVEL_PIN * np.maximum(held * held, 1.0))
            start = mean.copy()
            start[1 : 1 + n] = held
            runs.append((to_device(m), to_device(p), start[None]))

        def call(lo, hi):
            return [
                smoother_modes(memory, u, y, mask, steps, horizon, hyper, m, p, start, bounds,
                               MAX_ITER)
                for m, p, start in runs[lo:hi]
            ]

        outs = [o for _, share in _in_threads(smoother_modes, len(runs), call,
                                               (u.shape, MAX_ITER)) for o in share]
        return (np.concatenate([o[k] for o in outs]) for k in range(4))

    # each ratio run: (fits, β (N,), σ of β (N,)); the tuned run is ratio 1, the anchor
    def sd(variance):
        return np.sqrt(np.maximum(variance, 0.0))

    tried = {1.0: (True, np.asarray(sm.theta)[:, 0], sd(np.asarray(sm.cov)[:, 0, 0]))}
    ratios = list(LEVEL_RATIOS)
    while ratios:
        betas, variances, scores, residuals = held_runs(ratios)
        fits = _fitting(residuals, mask, n, fit_noise, whiten) & np.isfinite(scores)
        for c in np.flatnonzero(fits):
            envelope = _widened(envelope, betas[c], variances[c])
        for r, f, b, v in zip(ratios, fits, betas, variances):
            tried[r] = (bool(f), b, sd(v))
        ratios = [r for side in (1, -1) for r in _level_next(tried, side, span)]
    return envelope


def _level_next(tried, side, span):
    """The held ratios to run next on one side of the tuned scale (``side`` +1: above 1, −1:
    below), from `tried` (ratio ↦ ``(fits, β, σ)``): past the outermost ratio, by
    `LEVEL_STEP` up to `LEVEL_MAX`, where it fits; and the log-midpoint between the nearest
    ratio that does not fit and its inner neighbour (one that fits, or 1), where the failing
    run's β is more than 2σ of the neighbour's from it (median over the first `span`
    samples) and the two are more than ``LEVEL_STEP``'s `LEVEL_SPLITS`-th halving apart."""
    x = {float(np.log(r)) * side: v for r, v in tried.items()}  # outward: x > 0
    own = sorted(k for k in x if k > 0)
    out = []
    if own and x[own[-1]][0] and own[-1] + np.log(LEVEL_STEP) <= np.log(LEVEL_MAX) + 1e-9:
        out.append(own[-1] + np.log(LEVEL_STEP))
    failing = [k for k in own if not x[k][0]]
    if failing:
        outer = failing[0]
        inner = max(k for k in x if k < outer)  # fits: the anchor 0, or a ratio that fits
        _, b_in, sd_in = x[inner]
        apart = np.median(np.abs(x[outer][1][:span] - b_in[:span])
                          / np.maximum(sd_in[:span], 1e-300))
        finest = np.log(LEVEL_STEP) / 2**LEVEL_SPLITS
        if apart > 2.0 and outer - inner > finest * (1 + 1e-9):
            out.append((outer + inner) / 2)
    return [float(np.exp(side * k)) for k in out]


def run_filter(memory, hyper, u, y, mask, steps, horizon, m0, p0, bounds, iterations=3):
    """The online iterated EKF over the whole record in one scan."""
    tracker = KalmanTracker(
        memory, hyper, jnp.asarray(horizon), m0, p0, bounds, iterations
    )
    return _scan_filter(tracker, u, y, steps, mask)


@eqx.filter_jit
def _scan_filter(tracker, u, y, steps, mask):
    @jax.checkpoint
    def body(state, x):
        return tracker.step(state, *x)

    _, out = lax.scan(body, tracker.init(u.shape[1]), (u, y, steps, mask))
    return out


def prior(num_inputs, dtype, coloured=False, offset_known=False):
    """Prior of θ_0 in normalised units, the same whatever the start: the order's β centred
    on the middle of the range, parameters and offset centred on zero, all wide; `coloured`:
    with a coloured noise's AR(1) part last, centred on zero (its variance, here 1, is set by
    the intensities: `Hyper.initial`); `offset_known`: the offset held at zero (variance
    `OFFSET_PIN`: the same program as an estimated offset)."""
    offset = OFFSET_PIN if offset_known else PRIOR_VAR
    var = [PRIOR_BETA_VAR] + [PRIOR_VAR] * num_inputs + [offset] + [1.0] * coloured
    return to_device(np.zeros(len(var), dtype)), to_device(np.diag(np.asarray(var, dtype)))


class TrackResult(eqx.Module):
    """Everything the tracker estimates, in the user's units (see `identify`)."""

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


def _coloured(
    memory, u, y, mask, steps, horizon, sm, tuning, starts, bounds, noise_floor, hold,
    offset_known=False,
):
    """The tracker with a coloured measurement noise (an AR(1) state, see `Hyper`), where the
    white-noise model's prediction errors are correlated beyond `correlation_limit`; kept when
    its evidence is higher by more than `COLOURED_EVIDENCE` and its correlation time is not at
    the top of its range. Its start: the drifts of the white-noise smoothing `sm` (its
    intensities `tuning`), the noise split evenly between a white and an AR(1) part, each
    correlation between samples of `RHO_STARTS` smoothed from the white mode (side by side in
    threads, `_in_threads`), the best by evidence (the first of equal ones); from there it climbs (`climb`, in a trust region, ended early where the
    correlation time stays at the top of its range). Returns ``(hyper, smoothed, tuning, m0, p0, starts)`` of the coloured model (the
    starts with the noise state), or None (white noise kept)."""
    fitted = np.asarray(mask) > 0
    r1, count = prediction_error_correlation(y, sm.y_pred, fitted)
    if not r1 > correlation_limit(count):
        return None
    step = float(np.median(np.asarray(steps)[fitted]))
    span = float(horizon)
    time_min = NOISE_TIME_MIN * step / span
    half = max(tuning.noise / 2, noise_floor)
    m0, p0 = prior(u.shape[1], u.dtype, coloured=True, offset_known=offset_known)
    theta = np.asarray(sm.theta)
    starts = np.concatenate([np.asarray(starts), np.zeros((len(starts), 1))], axis=1)
    nominal = to_device(np.concatenate([theta, np.zeros((theta.shape[0], 1))], axis=1))
    hypers = []
    for rho in RHO_STARTS:
        noise_time = float(np.clip(-step / np.log(rho) / span, 1.01 * time_min,
                                   0.99 * NOISE_TIME_MAX))
        values = (tuning.order_drift, tuning.parameter_drift, half, half, noise_time)
        hypers.append(Hyper(*(to_device(np.asarray(np.log(v), u.dtype)) for v in values)))

    def call(lo, hi):  # the starts are independent: side by side in threads
        return [jax.block_until_ready(iterated_smoother(
            memory, u, y, mask, steps, horizon, h, m0, p0, nominal, bounds, MAX_ITER
        )) for h in hypers[lo:hi]]

    runs = [smc for _, out in _in_threads(_coloured, len(hypers), call, (u.shape, MAX_ITER))
            for smc in out]
    best = None
    for hyper, smc in zip(hypers, runs):
        score = host_score(smc)
        if best is None or score > best[0]:
            best = (score, hyper, smc)
    _, hyper, smc = best
    hyper, smc, tuned = climb(memory, u, y, mask, steps, horizon, m0, p0, bounds,
                              box(noise_floor, hold, time_min), hyper, smc, rounds=CLIMB_ROUNDS,
                              radius=CLIMB_RADIUS, fatal="noise_time")
    # a correlation time at the top of its range: a slow drift of the output, not noise
    if "noise_time" in tuned.at_edge or not (
        tuned.log_likelihood > tuning.log_likelihood + COLOURED_EVIDENCE
    ):
        return None
    rho = float(np.exp(-step / (tuned.noise_time * span)))
    tuned = dataclasses.replace(tuned, noise_correlation=rho)
    return hyper, smc, tuned, m0, p0, starts


def track(
    memory, u, y, dt, bounds, *, smooth=True, hyper=None, mask=None, iterations=3, times=None,
    parameters="drifting", x0=None, batched=False,
):
    """The tracker on samples ``u`` (N, n), ``y`` (N,) with step `dt`, or at the sample
    `times` (then `dt` is None); see `identify`. ``parameters="constant"`` (or `hyper` with a
    parameter drift at most `PARAM_DRIFT0`): their drift held there, and the band conditional
    on it (no `trade_interval`). `x0`: the output's offset, known (held there) or None
    (estimated). `batched`: the first pass's and the mixture's runs through one vmapped
    program where that is faster (`batch_pays`; the same results to rounding)."""
    token = _batched.set(bool(batched))
    try:
        return _track(memory, u, y, dt, bounds, smooth, hyper, mask, iterations, times,
                      parameters, x0)
    finally:
        _batched.reset(token)


def _track(memory, u, y, dt, bounds, smooth, hyper, mask, iterations, times, parameters, x0):
    # parameters stated constant, or given a drift no larger than the floor (`noise=`)
    hold = parameters == "constant" or (
        hyper is not None and float(hyper["parameter_drift"]) <= PARAM_DRIFT0
    )
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
    alpha_c, _, rss, rms_phi = constant_fit(
        memory, to_device(un), yn, mask, bounds, offset=not known
    )
    if not np.all(rms_phi > 0):
        raise ValueError("the fractional integral of an input is zero: its parameter is undefined.")
    # regressors scaled to unit RMS at the constant order: p̃ = O(1) whatever the units
    un = to_device(un / np.asarray(rms_phi))
    p_scale = scales.y_scale / (np.asarray(scales.u_scale) * rms_phi)
    m0, p0 = prior(n, u.dtype, offset_known=known)
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
    starts = starting_trajectories(memory, un, yn, mask, bounds, alpha_c, offset=not known)
    dof = max(float(np.sum(np.asarray(mask))) - n - 2, 1.0)
    # the data's own noise level (second differences), capped by the constant fit's residual
    noise_data = noise_variance(np.asarray(yn)[np.asarray(mask) > 0])
    misfit = max(rss / dof, NOISE_MIN)
    noise0 = float(np.clip(noise_data, NOISE_MIN, misfit))
    # the noise cannot be much below what the data's second differences show
    noise_floor = max(NOISE_FLOOR * noise_data, NOISE_MIN)
    # first-pass noise levels, tried in turn until a run converges: the data's, then the
    # constant fit's misfit when much larger; the misfit first when the output shows no noise
    # at all (below the search box: a controlled signal), where the data's level stalls
    noises = (noise0,)
    if misfit >= MISFIT_RATIO * noise0:
        noises = (misfit, noise0) if noise_data < NOISE_MIN else (noise0, misfit)
    if hyper is None:
        hyper, sm, tuning = tune(
            memory, un, yn, mask, steps, horizon, m0, p0, starts, noises, bounds, noise_floor,
            hold=hold,
        )
    else:
        hyper = Hyper(
            jnp.log(to_device(float(hyper["order_drift"]))),
            jnp.log(to_device(float(hyper["parameter_drift"]))),
            jnp.log(to_device((float(hyper["noise_std"]) / scales.y_scale) ** 2)),
        )
        sm = smooth_from(memory, un, yn, mask, steps, horizon, hyper, m0, p0, starts[0], bounds)
        tuning = Tuning.of(_host_hyper(hyper), (), sm.log_likelihood, False)
    whiten = None
    if smooth and tuning.tuned:
        coloured = _coloured(
            memory, un, yn, mask, steps, horizon, sm, tuning, starts, bounds, noise_floor, hold,
            known,
        )
        if coloured is not None:
            hyper, sm, tuning, m0, p0, starts = coloured
            whiten = ar_whitener(steps, mask, horizon, tuning)
    alpha_held = None
    if smooth and tuning.tuned and tuning.parameter_drift > HELD_RATIO * PARAM_DRIFT0:
        alpha_held = held_order(
            memory, un, yn, mask, steps, horizon, hyper, m0, p0, starts[0], bounds,
            misfit if whiten is None else tuning.noise,
        )
    weights, envelope, drifting = None, None, False
    # the χ² tests of what fits, at the larger of the tuned noise and the data's own
    # (drifting states absorb noise)
    fit_noise = max(tuning.noise, noise_data)
    if smooth:
        theta, cov, y_hat_n, y_pred_n = sm.theta, sm.cov, None, sm.y_pred
        converged = bool(sm.converged)
        beta_var = np.asarray(cov)[:, 0, 0]
        if tuning.tuned:
            beta_var, weights, envelope, drifting = mixture(
                memory, un, yn, mask, steps, horizon, tuning, m0, p0, starts, sm, bounds,
                last + 1, hold, fit_noise, whiten,
            )
            # the order's level against the parameters' scale, where the parameters are
            # constant: stated so, or tuned to no more drift than `held_order` tolerates
            if hold or tuning.parameter_drift <= HELD_RATIO * PARAM_DRIFT0:
                envelope = level_profile(
                    memory, un, yn, mask, steps, horizon, tuning, m0, p0, sm, bounds, last + 1,
                    fit_noise, whiten, envelope,
                )
    else:
        # the online filter starts from the constant-order fit (a whole-record summary, like
        # the tuned intensities): from the neutral prior its first samples cannot place p
        out = run_filter(
            memory, hyper, un, yn, mask, steps, horizon, to_device(starts[0]), p0, bounds,
            iterations,
        )
        theta, cov, y_hat_n, y_pred_n = out.mean, out.cov, out.y_hat, out.y_pred
        converged = True
        beta_var = np.asarray(cov)[:, 0, 0]
    # the results assembled on the host (NumPy: no program compiled for them)
    theta, cov = np.asarray(theta), np.asarray(cov)
    if y_hat_n is None:
        y_hat_n = model_output(theta, np.asarray(sm.phi), n)
    beta_sd = np.sqrt(np.maximum(np.asarray(beta_var), 0.0))
    alpha, dalpha = order_of_np(theta[:, 0], bounds)
    alpha_std = dalpha * beta_sd
    lower = order_of_np(theta[:, 0] - 2 * beta_sd, bounds)[0]
    upper = order_of_np(theta[:, 0] + 2 * beta_sd, bounds)[0]
    if envelope is not None:
        lower = np.minimum(lower, order_of_np(envelope[0], bounds)[0])
        upper = np.maximum(upper, order_of_np(envelope[1], bounds)[0])
    trade = None if hold else trade_interval(
        memory, un, yn, mask, times, last, bounds, fit_noise, whiten, offset=not known
    )
    if trade is not None:  # the band covers the constant orders a drifting parameter allows
        lower, upper = np.minimum(lower, trade[0]), np.maximum(upper, trade[1])
    if trade is not None or envelope is not None:
        alpha_std = np.maximum(alpha_std, (upper - lower) / 4)
    scale = np.asarray(p_scale)
    var = np.maximum(np.diagonal(cov, axis1=1, axis2=2), 0.0)
    y_hat_n, y_pred_n = np.asarray(y_hat_n), np.asarray(y_pred_n)
    as_jax = to_device  # the fields are JAX arrays, as everywhere in vojax
    return TrackResult(
        alpha=as_jax(alpha),
        alpha_std=as_jax(alpha_std),
        alpha_lower=as_jax(lower),
        alpha_upper=as_jax(upper),
        p=as_jax(theta[:, 1 : 1 + n] * scale),
        p_std=as_jax(np.sqrt(var[:, 1 : 1 + n]) * scale),
        x0=as_jax(scales.y_ref if known else scales.y_ref + scales.y_scale * theta[-1, 1 + n]),
        x0_std=as_jax(0.0 if known else scales.y_scale * np.sqrt(var[-1, 1 + n])),
        y_hat=as_jax(scales.y_ref + scales.y_scale * y_hat_n),
        y_pred=as_jax(scales.y_ref + scales.y_scale * y_pred_n),
        converged=converged,
        tuning=tuning,
        constant_order=alpha_c,
        alpha_held=alpha_held,
        mixture_weights=None if weights is None else tuple(float(w) for w in weights),
        trade=trade,
        drift_covered=drifting,
    )
