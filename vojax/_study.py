"""The paper's simulation study (34), as data: inputs, true order and parameters."""

import math

import numpy as np

from ._simulate import simulate
from ._values import real

STUDY_DT = 0.05
STUDY_DURATION = 300.0
STUDY_NOISE_STD = 0.5  # ν ~ N(0, 0.25): variance 0.25
MAX_STUDY_SAMPLES = 2_000_000  # the longest study drawn (its signals held in memory)


def study_signals(dt: float = STUDY_DT, duration: float = STUDY_DURATION):
    """``t``, ``u`` (N, 2), ``α*`` (N,) and ``p*`` (N, 2) of eq. (34) on ``t_k = k·dt``
    up to `duration` (at most `MAX_STUDY_SAMPLES` steps)."""
    dt, duration = (real(v, name) for v, name in ((dt, "dt"), (duration, "duration")))
    if not (0 < dt < math.inf and 0 < duration < math.inf):
        raise ValueError(f"`dt` and `duration` must be positive finite numbers, got {dt!r} and "
                         f"{duration!r}.")
    if duration / dt > MAX_STUDY_SAMPLES:
        raise ValueError(f"`duration` / `dt` must be at most {MAX_STUDY_SAMPLES:,} steps, got "
                         f"{duration / dt:.3g}.")
    t = np.arange(int(round(duration / dt)) + 1) * dt
    u = np.stack([np.sin(0.5 * t), np.cos(0.2 * t)], axis=1)
    alpha = 0.15 * np.exp(-0.02 * t) * (np.cos(0.2 * t) + 2) + 0.4
    step = np.where(t >= 150, 1 - np.exp(-0.1 * (t - 150)), 0.0)
    p = np.stack([3 + 4 * step, -5 * np.ones_like(t)], axis=1)
    return t, u, alpha, p


def simulate_study(
    dt: float = STUDY_DT, seed: int = 0, *, noise_std: float = STUDY_NOISE_STD, memory="exponential"
):
    """Simulates (34) exactly as the paper states it and adds the measurement noise.

    **Returns:** a dict with ``t``, ``u``, ``alpha``, ``p``, ``x`` (noise-free) and ``y``.
    """
    if isinstance(dt, bool) or not isinstance(dt, (int, float)) or not (
            STUDY_DURATION / 2e6 <= dt <= 10.0):
        raise ValueError(f"`dt` must be a step from {STUDY_DURATION / 2e6:g} to 10 s (at most "
                         f"2e6 samples over the study's {STUDY_DURATION:g} s), got {dt!r}.")
    if isinstance(noise_std, bool) or not isinstance(noise_std, (int, float)) or not (
            0 <= noise_std < math.inf):
        raise ValueError(f"`noise_std` must be a finite number ≥ 0, got {noise_std!r}.")
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ValueError(f"`seed` must be a whole number ≥ 0, got {seed!r}.")
    t, u, alpha, p = study_signals(dt)
    x = simulate(
        u,
        alpha,
        p,
        dt,
        memory=memory,
        order_range=(0.05, 0.95) if memory == "exponential" else (0.01, 0.99),
    )
    # NumPy's generator: JAX's random bits for a key changed between releases (0.5), NumPy's
    # PCG64 stream has not, so a seed names the same realisation with any JAX
    noise = noise_std * np.random.default_rng(seed).standard_normal(x.shape)
    return dict(t=t, u=u, alpha=alpha, p=p, x=np.asarray(x), y=np.asarray(x) + noise)


def rms(a, mask=None):
    a = np.asarray(a)
    if mask is not None:
        a = a[mask]
    return float(np.sqrt(np.mean(np.square(a))))


def study_errors(t, alpha_true, p_true, result):
    """The figures of merit of the study: RMS order errors and parameter errors."""
    e = np.asarray(result.alpha) - alpha_true
    ep = np.asarray(result.p) - p_true
    return {
        "order_rms_t_gt_50": rms(e, t > 50),
        "order_rms_last_100s": rms(e, t > t[-1] - 100),
        "order_rms_t_200_300": rms(e, (t >= 200) & (t <= 300)),
        "p_rms_t_gt_50": rms(ep, t > 50),
        "p1_rms_t_gt_50": rms(ep[:, 0], t > 50),
        "p2_rms_t_gt_50": rms(ep[:, 1], t > 50),
    }


def band_coverage(t, alpha_true, result, after=50.0):
    """The fraction of the samples after `after` s whose true order lies in the result's ±2σ
    band, and the band's median half-width there."""
    m = np.asarray(t) > after
    lo, hi = np.asarray(result.alpha_lower)[m], np.asarray(result.alpha_upper)[m]
    truth = np.asarray(alpha_true)[m]
    return {
        "band_coverage_t_gt_50": float(np.mean((truth >= lo) & (truth <= hi))),
        "band_halfwidth_t_gt_50": float(np.median(hi - lo) / 2),
    }
