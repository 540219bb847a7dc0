"""Closed forms written independently of autodiff, for cross-checks (CI and users' own data).

Everything here is plain NumPy, O(N²), and meant for records of up to a few thousand samples.
It applies eq. (14),

    ∂Φ/∂b = −ψ(b) Φ + 1/Γ(b) ∫_0^t ln(t−τ) (t−τ)^{b−1} u(τ) dτ,

to the same product-integration quadrature as the kernels: the log-weighted integrals of each
interpolation basis function are taken exactly (they are the b-derivatives of the exact weights,
written out by hand). For the exponential memory the readout is differentiated with the
closed-form ``c_j'(b)`` of docs/method.md §4. `lsff_sensitivity` is the corrected closed form (26).
Each function checks its arguments as the library's own do (a `TypeError` or `ValueError` that
names the argument), whatever JAX's float64 setting.
"""

import numpy as np

from ._kernels._special import digamma, lgamma
from ._values import flag as check_flag
from ._xla import x64_scope

__all__ = ["fractional_integral", "order_sensitivity", "lsff", "lsff_sensitivity"]

MIN_CLOSED_ORDER = 1e-6  # the least order (14)'s closed form is evaluated at (see below)


def _pow(m, e):
    m = np.asarray(m, float)
    return np.where(m > 0, np.abs(m) ** e, 0.0)


def _binomials(e: float, count: int):
    """``C(e, j)`` and ``dC(e, j)/de`` for ``j = 0 … count−1``."""
    c, dc = [1.0], [0.0]
    for j in range(1, count):
        c.append(c[-1] * (e - j + 1) / j)
        dc.append(dc[-1] * (e - j + 1) / j + c[-2] / j)
    return np.array(c), np.array(dc)


def _trapezoid_weights(m, k: int, e: float):
    """Diethelm weights in the lag ``m`` and their e-derivatives (e = b + 1), by the same binomial
    series as the kernels at long lags (``m ≥ 8``), by differences of powers below."""
    lnm = np.log(np.maximum(m, 1.0))
    a = np.zeros_like(m)
    da = np.zeros_like(m)
    # (m+1)^e − 2m^e + (m−1)^e = 2 m^e Σ_{j≥1} C(e,2j) m^{−2j}
    c, dc = _binomials(e, 60)
    far = m >= 8
    x2 = 1.0 / np.maximum(m, 1.0)[:, None] ** 2
    powers = x2 ** np.arange(1, 30)[None, :]
    me = _pow(m, e)
    a[far] = (2 * me[:, None] * powers * c[2::2][None, :29]).sum(1)[far]
    da[far] = (lnm * a + (2 * me[:, None] * powers * dc[2::2][None, :29]).sum(1))[far]
    near = ~far
    mm = m[near]
    a[near] = _pow(mm + 1, e) - 2 * _pow(mm, e) + _pow(mm - 1, e)
    da[near] = _pow_log(mm + 1, e) - 2 * _pow_log(mm, e) + _pow_log(mm - 1, e)
    # the weight of u_0 (lag k): k^{e−1} Σ_{j≥2} C(e,j)(−1)^j k^{1−j}
    if k >= 8:
        sign = (-1.0) ** np.arange(60)
        xs = float(k) ** (1 - np.arange(60.0))
        kb = float(k) ** (e - 1)
        series = (c[2:] * sign[2:] * xs[2:]).sum()
        a[-1] = kb * series
        da[-1] = kb * np.log(k) * series + kb * (dc[2:] * sign[2:] * xs[2:]).sum()
    else:
        b = e - 1
        a[-1] = _pow(k - 1, e) - (k - 1 - b) * _pow(k, b)
        da[-1] = _pow_log(k - 1, e) + _pow(k, b) - (k - 1 - b) * _pow_log(k, b)
    return a, da


def _rectangle_weights(m, b: float):
    """``m^b − (m−1)^b`` as ``−m^b expm1(b log1p(−1/m))`` and its b-derivative."""
    safe = np.maximum(m, 2.0)
    mb = safe**b
    a = np.where(m >= 2, -mb * np.expm1(b * np.log1p(-1 / safe)), np.where(m == 1, 1.0, 0.0))
    da = np.log(safe) * a - mb * (1 - 1 / safe) ** b * np.log1p(-1 / safe)
    return a, np.where(m >= 2, da, 0.0)


def _pow_log(m, e):
    m = np.asarray(m, float)
    safe = np.where(m > 0, m, 1.0)
    return np.where(m > 0, safe**e * np.log(safe), 0.0)


def _weights(k: int, b: float, h: float, rule: str):
    """Unnormalised weights ∫ (t_k−τ)^{b−1} ℓ_j(τ) dτ for the lags m = 0…k (j = k − m), and
    their log-weighted twins ∫ ln(t_k−τ) (t_k−τ)^{b−1} ℓ_j(τ) dτ (their b-derivatives)."""
    m = np.arange(k + 1, dtype=float)
    if rule == "trapezoid":
        a, da = _trapezoid_weights(m, k, b + 1)
        a[0], da[0] = 1.0, 0.0
        scale = h**b / (b * (b + 1))
        dscale = np.log(h) - 1 / b - 1 / (b + 1)
    else:
        a, da = _rectangle_weights(m, b)
        scale = h**b / b
        dscale = np.log(h) - 1 / b
    return scale * a, scale * (dscale * a + da)


def _as_2d(u, order):
    u = np.asarray(u, float)
    squeeze = u.ndim == 1
    u2 = u[:, None] if squeeze else u
    order = np.broadcast_to(np.asarray(order, float), (u2.shape[0],))
    return u2, order, squeeze


def _direct(u, order, dt, rule):
    u2, order, squeeze = _as_2d(u, order)
    phi = np.zeros_like(u2)
    dphi = np.zeros_like(u2)
    for k in range(1, u2.shape[0]):
        b = order[k]
        w, lw = _weights(k, b, dt, rule)
        inv_gamma = np.exp(-lgamma(b))
        phi[k] = inv_gamma * (w @ u2[k::-1])
        dphi[k] = -digamma(b) * phi[k] + inv_gamma * (lw @ u2[k::-1])  # eq. (14)
    return (phi[:, 0], dphi[:, 0]) if squeeze else (phi, dphi)


def _exponential(u, order, dt, rule, tol, order_range):
    from ._kernels import ExponentialMemory

    u2, order, squeeze = _as_2d(u, order)
    mem = ExponentialMemory.design(dt, u2.shape[0], rule=rule, tol=tol, order_range=order_range)
    log_s = np.asarray(mem.log_s)
    base = np.exp(np.asarray(mem.log_readout))  # Δx (1+e^{−x_j}) e^{−s_j h}
    decay, wp, wc = (np.asarray(a) for a in (mem.decay, mem.weight_previous, mem.weight_current))
    history = np.zeros((log_s.size, u2.shape[1]))
    phi = np.zeros_like(u2)
    dphi = np.zeros_like(u2)
    for k in range(1, u2.shape[0]):
        b = order[k]
        # the last interval, exactly: eq. (14) on the weights of u_{k−1}, u_k
        w, lw = _weights(1, b, dt, rule)
        inv_gamma = np.exp(-lgamma(b))
        near = w @ u2[[k, k - 1]]
        dnear = -digamma(b) * inv_gamma * near + inv_gamma * (lw @ u2[[k, k - 1]])
        s_pow = np.exp((1 - b) * log_s)
        c = np.sin(np.pi * b) / np.pi * base * s_pow
        dc = np.cos(np.pi * b) * base * s_pow - log_s * c  # c_j'(b), docs/method.md §4
        phi[k] = inv_gamma * near + c @ history
        dphi[k] = dnear + dc @ history
        history = decay[:, None] * history + wp[:, None] * u2[k - 1] + wc[:, None] * u2[k]
    return (phi[:, 0], dphi[:, 0]) if squeeze else (phi, dphi)


def _both(u, order, dt, rule, memory, tol, order_range):
    from ._integral import _prepare

    # the checks of `vojax.fractional_integral` (one sentence for each bad argument), in
    # float64 whatever JAX's setting (this module is NumPy); the computation below stays the
    # independent NumPy one
    with x64_scope(True):
        _prepare(u, order, dt, None, rule, memory, tol, order_range)
    if memory == "direct":
        return _direct(u, order, float(dt), rule)
    return _exponential(u, order, float(dt), rule, tol, tuple(order_range))


def fractional_integral(
    u, order, dt, *, rule="trapezoid", memory="direct", tol=1e-10, order_range=(0.01, 0.99)
):
    """``Φ(b_k, t_k)`` by the same quadrature as `vojax.fractional_integral`, in NumPy."""
    return _both(u, order, dt, rule, memory, tol, order_range)[0]


def order_sensitivity(
    u, order, dt, *, rule="trapezoid", memory="direct", tol=1e-10, order_range=(0.01, 0.99)
):
    """Closed form (14) of ``∂Φ/∂b`` on the same quadrature as `vojax.order_sensitivity`, for
    orders from `MIN_CLOSED_ORDER` (below it the form's two terms, each of size about 1/b,
    cancel: at b = 1e-20 nothing of the answer is left)."""
    _, dphi = _both(u, order, dt, rule, memory, tol, order_range)  # `order` checked there
    if np.min(np.asarray(order, float)) < MIN_CLOSED_ORDER:
        raise ValueError(f"`order` must be at least {MIN_CLOSED_ORDER:g} for the closed form "
                         "(14), whose two terms cancel below it: use vojax.order_sensitivity.")
    return dphi


def _checked_lsff(phi, dphi, y, dt, lam, r0):
    """The LSFF's arguments as NumPy arrays and floats, each checked as `vojax.identify`
    checks its own: `phi` (N, n) and `dphi` (its shape; None: not given) finite, `y` (N,),
    the step `dt` and the forgetting rate `lam` positive, `r0` None or (n, n) symmetric
    positive definite."""
    from . import _validate as check

    with x64_scope(True):  # the library's checks need float64; this module is NumPy
        phi = np.asarray(check.columns(check.magnitude(check.samples(phi, "phi"), "phi")))
        dt, lam = float(check.step(dt)), float(check.positive(lam, "lam"))
        if dphi is not None:
            dphi = np.asarray(check.columns(check.samples(dphi, "dphi")))
        y = np.asarray(check.magnitude(check.samples(y, "y"), "y"))
    if dphi is not None and dphi.shape != phi.shape:
        raise ValueError(f"`dphi` must have the shape of `phi`, {phi.shape}, got {dphi.shape}.")
    if y.shape != (phi.shape[0],):
        raise ValueError(f"`y` must have shape ({phi.shape[0]},), one value per row of `phi`, "
                         f"got {y.shape}.")
    n = phi.shape[1]
    if r0 is None:
        return phi, dphi, y, dt, lam, np.eye(n)
    return phi, dphi, y, dt, lam, check.spd_matrix(r0, "r0", n)


def lsff(phi, y, dt, lam, r0=None):
    """Batch LSFF estimate of eq. (23), sample by sample: ``p_k = R_k⁻¹ Q_k`` (docs/method.md §3).

    ``R_k = Σ_{j≤k} h f^{k−j} φ_j φ_jᵀ + f^k R_0`` and ``Q_k = Σ_{j≤k} h f^{k−j} y_j φ_j`` with
    ``f = e^{−λh}``, built as explicit sums (not by recursion). Returns ``p`` (N, n).
    """
    phi, _, y, dt, lam, r0 = _checked_lsff(phi, None, y, dt, lam, r0)
    f = np.exp(-lam * dt)
    out = np.zeros_like(phi)
    for k in range(phi.shape[0]):
        g = dt * f ** (k - np.arange(k + 1))
        r = (phi[: k + 1] * g[:, None]).T @ phi[: k + 1] + f**k * r0
        q = (phi[: k + 1] * (g * y[: k + 1])[:, None]).sum(0)
        out[k] = np.linalg.solve(r, q)
    return out


def lsff_sensitivity(phi, dphi, y, dt, lam, r0=None, *, printed=False):
    """Closed form (26) of ``∂p/∂β`` along a uniform shift of the order history (docs/method.md §1, §3).

    Corrected: ``∂P/∂β = −P (∫ e^{−λ(t−τ)} (φ ∂φᵀ/∂β + ∂φ/∂β φᵀ) dτ) P``. With ``printed=True``
    the paper's misprint ``φ ∂pᵀ/∂β`` stands in place of ``φ ∂φᵀ/∂β`` (with ∂p/∂β from the
    previous sample, the only way the printed form can be evaluated), for the demonstration
    that it disagrees with autodiff. Returns ``∂p/∂β`` (N, n).
    """
    if dphi is None:
        raise TypeError("`dphi` (∂φ/∂β, shaped like `phi`) must be given, got None.")
    phi, dphi, y, dt, lam, r0 = _checked_lsff(phi, dphi, y, dt, lam, r0)
    n = phi.shape[1]
    printed = check_flag(printed, "printed")
    f = np.exp(-lam * dt)
    out = np.zeros_like(phi)
    dp_prev = np.zeros(n)
    dp_hist = np.zeros_like(phi)
    for k in range(phi.shape[0]):
        g = dt * f ** (k - np.arange(k + 1))
        r = (phi[: k + 1] * g[:, None]).T @ phi[: k + 1] + f**k * r0
        q = (phi[: k + 1] * (g * y[: k + 1])[:, None]).sum(0)
        dq = (dphi[: k + 1] * (g * y[: k + 1])[:, None]).sum(0)
        partner = dp_hist[: k + 1] if printed else dphi[: k + 1]
        dr = (phi[: k + 1] * g[:, None]).T @ partner + (dphi[: k + 1] * g[:, None]).T @ phi[: k + 1]
        big_p = np.linalg.inv(r)
        d_big_p = -big_p @ dr @ big_p
        out[k] = d_big_p @ q + big_p @ dq  # eq. (26)
        dp_prev = out[k]
        if printed and k + 1 < phi.shape[0]:
            dp_hist[k + 1] = dp_prev
    return out
