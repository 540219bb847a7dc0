"""Exact responses of the constant-order laws to a loading history: the strain of a stress
history and the stress of a strain history (`AbstractViscoelasticModel.strain_response`,
`.stress_response`).

Every law here is ``ε = c σ + I^q(a σ + b ε)`` from rest (each law's `coefficients`), so in Laplace
variables the strain of a stress is ``(c s^q + a)/(s^q − b)`` times it and the stress of a
strain its inverse. The history ``f`` is taken linear between its samples and 0 before the
first, which it reaches by a step at ``t_0`` (as vojax's integrals take it); it is then a
sum of one step and ramps,

    f(t) = f_0 H(t − t_0) + Σ_j s_j [(t − t_j)_+ − (t − t_{j+1})_+],   s_j = Δf_j / Δt_j,

and the response is the same sum of the law's step response ``S`` and ramp response
``R = ∫ S``. Both are closed forms (`kernels`): for ``(A s^q + B)/(s^q + ν)``

    S(t) = A E_q(−ν t^q) + B t^q E_{q,1+q}(−ν t^q),
    R(t) = A t E_{q,2}(−ν t^q) + B t^{1+q} E_{q,2+q}(−ν t^q),

and, for the stress of a law without a spring in series (springpot, Kelvin–Voigt),
``(s^q + λ)/a``: ``S = (t^{−q}/Γ(1−q) + λ)/a`` and ``R = (t^{1−q}/Γ(2−q) + λ t)/a``. The
response is therefore exact for such a history to the rounding of the Mittag-Leffler
function — no step size, no start-up error at the ``t^q`` cusp. The kernels are needed at
every lag ``t_n − t_j``: N of them on a uniform step, where the sum is a convolution (taken
by FFT for long records, N log N); on other clocks N²/2, summed directly in chunks of
`CHUNK` lags, except that the part of a clock uniform from some sample on (block means
after a first sample alone, a test's start put before a uniform record) is again a
convolution. Where many arguments fall between its series, the Mittag-Leffler function is
taken from a table built once an order (`vojax._models._ml_table`); the response then
agrees with the quadrature's to about 1e-12 of its scale (2e-13 in
`scripts/bench_responses.py`, at most 2.4e-12 in `tests/test_ml_table.py`).
"""

import math

import numpy as np

from ._closed import check_alpha, check_parameters
from ._ml_table import pair

STRAIN, STRESS = "strain", "stress"  # the response asked for


def _ratio_kernels(q, big_a, big_b, nu):
    """S and R of ``(A s^q + B)/(s^q + ν)`` as functions of the lags (≥ 0)."""

    def step(lags):
        tq = lags**q
        e1, e1q = pair(q, nu * tq, 1.0)  # E_{q,1}, E_{q,1+q}
        return big_a * e1 + big_b * tq * e1q

    def ramp(lags):
        tq = lags**q
        e2, e2q = pair(q, nu * tq, 2.0)  # E_{q,2}, E_{q,2+q}
        return lags * (big_a * e2 + big_b * tq * e2q)

    return step, ramp


def _derivative_kernels(q, a, lam):
    """S and R of ``(s^q + λ)/a`` as functions of the lags (S is infinite at lag 0)."""

    def step(lags):
        with np.errstate(divide="ignore"):
            return (lags**-q / math.gamma(1.0 - q) + lam) / a

    def ramp(lags):
        return (lags ** (1.0 - q) / math.gamma(2.0 - q) + lam * lags) / a

    return step, ramp


def kernels(model, q, params, given):
    """The law's step and ramp responses, functions of the lag, for the history `given`."""
    a, b, c = model.coefficients(**params)
    if given == STRESS:  # the strain of a stress: (c s^q + a)/(s^q − b)
        return _ratio_kernels(q, c, a, -b)
    if c != 0.0:  # the stress of a strain: (1/c)(s^q − b)/(s^q + a/c)
        return _ratio_kernels(q, 1.0 / c, -b / c, a / c)
    return _derivative_kernels(q, a, -b)


def respond(model, history, dt, t, q, params, given):
    """The response of the law to `history` on the clock `dt` or `t` (see the module)."""
    name = STRESS if given == STRESS else STRAIN
    f, times = check_history(history, dt, t, name)
    q = check_alpha(q, upper_open=True, name="q")
    params = check_parameters(model, params)
    with np.errstate(over="ignore", invalid="ignore"):
        out = (_uniform(model, f, float(dt), q, params, given) if t is None
               else _general(model, f, times, q, params, given))
    if not np.all(np.isfinite(out[1:])) or np.isnan(out[0]):
        raise ValueError(
            f"the {STRAIN if given == STRESS else STRESS} overflows double precision: the "
            f"{name}, the clock or the parameters are too large for one another."
        )
    return out


def check_history(history, dt, t, name):
    """The loading history (N,) as a finite host array with N ≥ 2 and its clock, `dt` (a
    positive number) or `t` (strictly increasing, one time a sample; exactly one of them):
    ``(history, times or None)``, or one sentence saying what is wrong."""
    f = _host_array(history, name)
    if f.ndim != 1 or f.shape[0] < 2:
        raise ValueError(f"`{name}` must have shape (N,) with N ≥ 2, got shape {f.shape}.")
    if (dt is None) == (t is None):
        raise TypeError("give exactly one of `dt` (a uniform step) and `t` (the sample times), "
                        + ("got neither." if dt is None else "got both."))
    if t is None:
        if isinstance(dt, bool):
            raise TypeError(f"`dt` must be a number, got {dt!r}.")
        h = _host_array(dt, "dt")
        if h.ndim != 0 or not h > 0:
            raise ValueError(f"`dt` must be a positive finite number, got {dt!r}.")
        return f, None
    times = _host_array(t, "t")
    if times.shape != f.shape:
        raise ValueError(f"`t` must have shape {f.shape} to match `{name}`, got {times.shape}.")
    if np.any(np.diff(times) <= 0):
        i = int(np.argmax(np.diff(times) <= 0))
        raise ValueError(f"`t` must be strictly increasing, but t[{i + 1}] = "
                         f"{times[i + 1]!r} follows t[{i}] = {times[i]!r}.")
    return f, times


def _general(model, f, times, q, params, given):
    """`respond` on any clock: where the clock is uniform from its `m`-th sample on
    (`_uniform_from`), the ramps switched on there are a convolution (as `_uniform`'s); the
    first `m` ramps are summed at their own lags, `CHUNK` lags at a time."""
    num = f.shape[0]
    step, ramp = kernels(model, q, params, given)
    slopes = np.diff(f) / np.diff(times)
    head = _uniform_from(times)
    out = _first_step(f[0], step, times - times[0])
    # Σ_{j<m} s_j [R(t_n − t_j) − R(t_n − t_{j+1})], the ramp on at t_j and off at t_{j+1}
    cols = head + 1  # the lags to t_0 … t_m (R is 0 at lags ≤ 0)
    rows = max(1, CHUNK // cols)
    for r in range(0, num if head else 0, rows):
        lag = np.maximum(times[r:r + rows, None] - times[None, :cols], 0.0)
        ramp_at = ramp(lag)
        out[r:r + rows] += (ramp_at[:, :-1] - ramp_at[:, 1:]) @ slopes[: cols - 1]
    if head < num - 1:  # the rest: lags (n − j) h from t_m on
        h = (times[-1] - times[head]) / (num - 1 - head)
        pulse = np.diff(ramp(h * np.arange(num - head)))
        out[head + 1:] += _convolve(slopes[head:], pulse)[: num - 1 - head]
    return out


# the lags of the direct sum evaluated at once (2 MB an array: 27 MB at the peak of a
# 2,000-sample log-spaced clock, where one matrix of every lag held 32 MB)
CHUNK = 2**18
# a clock whose samples lie within this fraction of its step of a uniform one is taken as
# uniform there: its lags are then off by at most twice that, far below any record's jitter
UNIFORM_TOLERANCE = 1e-9


def _uniform_from(times):
    """The first sample from which the clock is uniform to `UNIFORM_TOLERANCE` of its step:
    each later step that of the last, and each later sample that far from its place on the
    uniform clock (N − 1 where there is no such part of two steps or more)."""
    num = times.shape[0]
    steps = np.diff(times)
    bad = np.abs(steps - steps[-1]) > 2 * UNIFORM_TOLERANCE * steps[-1]
    head = int(np.flatnonzero(bad)[-1]) + 1 if bad.any() else 0
    if head >= num - 2:
        return num - 1
    h = (times[-1] - times[head]) / (num - 1 - head)
    off = times[head:] - (times[head] + h * np.arange(num - head))
    return head if np.max(np.abs(off)) <= UNIFORM_TOLERANCE * h else num - 1


def _host_array(x, name):
    """`x` as a finite NumPy float array, or one sentence saying what is wrong."""
    try:
        arr = np.asarray(x, dtype=float)
    except (TypeError, ValueError):
        raise TypeError(f"`{name}` must be numbers, got {type(x).__name__}.") from None
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"`{name}` must be finite: it holds NaN or inf.")
    return arr


def _uniform(model, f, h, q, params, given):
    """`respond` on ``t_k = k h``: the lags are ``k h``, the sum a convolution."""
    num = f.shape[0]
    lags = h * np.arange(num)
    step, ramp = kernels(model, q, params, given)
    slopes = np.diff(f) / h
    # the ramp on at t_j and off at t_{j+1}: R(kh) − R((k−1)h) at lag k = n − j ≥ 1
    pulse = np.diff(ramp(lags))
    out = np.zeros(num)
    out[1:] = _convolve(slopes, pulse)[: num - 1]
    return out + _first_step(f[0], step, lags)


# above this many products a convolution is taken by FFT (N log N; its rounding, a few units
# of 1e-16 of the largest partial sum, is that of the direct sum's order): the convolution of
# 1e6 samples in about a second (the kernels' Mittag-Leffler evaluations then dominate, 400 s)
DIRECT_PRODUCTS = 2**22


def _convolve(a, b):
    """The full linear convolution of `a` and `b` (`np.convolve`), by FFT when long."""
    if a.size * b.size <= DIRECT_PRODUCTS:
        return np.convolve(a, b)
    n = a.size + b.size - 1
    m = 1 << (n - 1).bit_length()
    return np.fft.irfft(np.fft.rfft(a, m) * np.fft.rfft(b, m), m)[:n]


def _first_step(f0, step, lags):
    """The step from 0 to ``f_0`` at ``t_0`` (nothing where ``f_0 = 0``, even where S is
    infinite, and S is then not evaluated)."""
    return f0 * step(lags) if f0 != 0.0 else np.zeros_like(lags)
