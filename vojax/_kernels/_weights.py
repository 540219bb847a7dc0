"""Exact product-integration weights of the Riemann–Liouville kernel (docs/method.md §3).

With ``t_k = k h`` and the order ``b`` taken at ``t_k``,

    Φ_k = exp(log_norm(b)) · Σ_m a_m(b, k) u_{k−m},

where ``log_norm`` is ``b ln h − ln Γ(b+2)`` for the trapezoid rule (u linear between samples;
the Diethelm weights) and ``b ln h − ln Γ(b+1)`` for the rectangle rule (u constant on
``[t_j, t_{j+1})``). The weights are differences of powers, ``(m+1)^e − 2m^e + (m−1)^e`` and
``m^b − (m−1)^b``; written that way they lose ``log10(m^2)`` digits at lag ``m`` (six at
``m = 1e3``), so at long lags they are evaluated as ``m^e`` times a binomial series in ``1/m``.
Every power is guarded at ``m = 0`` with the double ``where`` of ``jax.scipy.special.xlogy`` so
derivatives with respect to ``b`` stay finite there.
"""

import jax.numpy as jnp

from ._special import LGAMMA1P_CHEBYSHEV

RECTANGLE = "rectangle"
TRAPEZOID = "trapezoid"
# lags from which the binomial series replaces the plain differences, and its length
SERIES_FROM = 8  # the plain differences lose at most two digits below
SECOND_DIFFERENCE_TERMS = 9  # 64^{−9} < 1e-16
FIRST_WEIGHT_TERMS = 30  # 8^{−30}: a scalar, the length costs nothing


def power(m, e):
    """``m**e`` for ``m ≥ 0`` with ``0**e = 0`` and a finite derivative in ``e`` at ``m = 0``."""
    positive = m > 0
    safe = jnp.where(positive, m, 1.0)
    return jnp.where(positive, jnp.exp(e * jnp.log(safe)), 0.0)


def _binomials(e, count: int):
    """``[C(e, 0), …, C(e, count−1)]`` for a real ``e``."""
    out = [jnp.ones_like(e)]
    for j in range(1, count):
        out.append(out[-1] * (e - (j - 1)) / j)
    return out


def _poly(coefficients, x):
    """``Σ_i coefficients[i] x^i`` by Horner's rule."""
    acc = jnp.zeros_like(x) + coefficients[-1]
    for c in coefficients[-2::-1]:
        acc = acc * x + c
    return acc


def lgamma1p(b):
    """``ln Γ(1 + b)`` for ``0 ≤ b ≤ 1`` by its Chebyshev series (Clenshaw's recurrence).

    Agrees with `math.lgamma` to ~1e-16 absolute. It is one fused polynomial, where
    ``jax.scipy.special.gammaln`` and its derivative cost XLA:CPU a dozen kernels inside a scan.
    """
    t2 = 2.0 * (2.0 * b - 1.0)
    b1 = jnp.zeros_like(b)
    b2 = jnp.zeros_like(b)
    for c in LGAMMA1P_CHEBYSHEV[:0:-1]:
        b1, b2 = t2 * b1 - b2 + c, b1
    return 0.5 * t2 * b1 - b2 + LGAMMA1P_CHEBYSHEV[0]


def log_norm(b, dt, rule: str):
    """Logarithm of the factor in front of the weights: ``h^b / Γ(b+2)`` or ``h^b / Γ(b+1)``,
    for orders ``0 ≤ b ≤ 1``."""
    lg = lgamma1p(b)
    if rule == TRAPEZOID:
        lg = lg + jnp.log1p(b)  # Γ(b+2) = (b+1) Γ(b+1)
    return b * jnp.log(dt) - lg


def end_weights(b, rule: str):
    """Weights ``(a_0, a_1)`` of ``(u_k, u_{k−1})`` for the last step ``[t_{k−1}, t_k]`` alone."""
    if rule == TRAPEZOID:
        return jnp.ones_like(b), b
    return jnp.zeros_like(b), jnp.ones_like(b)


def _second_difference(m, v, e):
    """``(m+1)^e − 2m^e + (m−1)^e`` for lags ``m`` (≥ 1), given ``v[i] = (i−1)^e`` on the lags ±1."""
    plain = v[2:] - 2.0 * v[1:-1] + v[:-2]
    # m^e [(1+x)^e − 2 + (1−x)^e] = 2 m^e Σ_j C(e, 2j) x^{2j},  x = 1/m
    c = _binomials(e, 2 * SECOND_DIFFERENCE_TERMS + 2)[2::2]
    x2 = 1.0 / jnp.maximum(m, 1.0) ** 2
    series = 2.0 * v[1:-1] * x2 * _poly(c, x2)
    return jnp.where(m >= SERIES_FROM, series, plain)


def _first_difference(m, e):
    """``m^e − (m−1)^e`` for lags ``m ≥ 1``, as ``−m^e expm1(e log1p(−1/m))``."""
    safe = jnp.maximum(m, 2.0)
    far = -power(safe, e) * jnp.expm1(e * jnp.log1p(-1.0 / safe))
    return jnp.where(m >= 2, far, jnp.where(m == 1, 1.0, 0.0))


def _trapezoid_first(k, b):
    """Weight of ``u_0`` at sample ``k ≥ 1``: ``(k−1)^{b+1} − (k−1−b) k^b``."""
    plain = power(k - 1.0, b + 1.0) - (k - 1.0 - b) * power(k, b)
    # k^b [k((1−x)^{b+1} − 1) + b + 1] = k^b Σ_{j≥2} C(b+1, j) (−1)^j x^{j−1},  x = 1/k
    c = [cj * (-1.0) ** j for j, cj in enumerate(_binomials(b + 1.0, FIRST_WEIGHT_TERMS + 2))][2:]
    x = 1.0 / jnp.maximum(k, 1.0)
    series = power(k, b) * x * _poly(c, x)
    return jnp.where(k >= SERIES_FROM, series, plain)


def history_weights(num: int, k, b, rule: str):
    """Weights ``a_m`` for the lags ``m = 1 … num`` at sample ``k ≥ 1`` (zero beyond ``m = k``).

    The lag-0 weight is ``end_weights(b, rule)[0]``.
    """
    kf = jnp.asarray(k, b.dtype)
    lags = jnp.arange(1, num + 1, dtype=b.dtype)
    if rule == TRAPEZOID:
        v = power(jnp.arange(num + 2, dtype=b.dtype), b + 1.0)
        a = jnp.where(lags == kf, _trapezoid_first(kf, b), _second_difference(lags, v, b + 1.0))
    else:
        a = _first_difference(lags, b)
    return jnp.where(lags <= kf, a, 0.0)


# -- arbitrary nodes t_0 < t_1 < … (docs/method.md §3) --------------------------------------
# below this ratio x = h/A of an interval to its distance the weights are binomial series
GRID_SERIES_BELOW = 0.25
GRID_SERIES_TERMS = 28  # 0.25^28 < 1e-16


def _guarded_log(y):
    """``ln y`` for ``y > 0`` and ``−1`` where ``y = 0`` (the value is then unused), with a finite
    derivative in both branches."""
    positive = y > 0
    return jnp.where(positive, jnp.log(jnp.where(positive, y, 1.0)), -1.0)


def interval_weights(a, h, b, rule: str):
    """Exact weights of one interval ``[t_i, t_{i+1}]`` (``h = t_{i+1} − t_i``) in
    ``Φ(b, t_k) = 1/Γ(b) ∫ (t_k − τ)^{b−1} u(τ) dτ``, with ``a = t_k − t_i ≥ h``.

    **Returns:** ``(w_i, w_{i+1})``, the weights of ``u_i`` and ``u_{i+1}``: for ``"trapezoid"``
    ``u`` is linear on the interval, for ``"rectangle"`` it is ``u_i`` (then ``w_{i+1} = 0``).

    With ``x = h/a`` and ``y = 1 − x = (t_k − t_{i+1})/a``, the closed forms are

        total = a^b (1 − y^b)/Γ(b+1),
        w_{i+1} = a^b [1 − y^b (1 + b x)] / (x Γ(b+2)),   w_i = a^b [b x − y (1 − y^b)] / (x Γ(b+2)),

    written with ``expm1(b ln y)`` so that small orders keep their digits. For ``x`` below 1/4
    (long lags) they cancel like ``x²``, and the weights are the binomial series
    ``a^b x b/Γ(b+1) Σ_j C(b−1, j) (−x)^j c_j`` with ``c_j = 1/((j+1)(j+2))`` (for ``w_i``) and
    ``1/(j+2)`` (for ``w_{i+1}``), from ``∫_0^1 (1−v or v)(1 − x v)^{b−1} dv``.
    """
    x = h / a
    y = jnp.maximum(1.0 - x, 0.0)
    scale = jnp.exp(b * jnp.log(a) - lgamma1p(b))  # a^b / Γ(b+1)
    em = jnp.where(y > 0, jnp.expm1(b * _guarded_log(y)), -1.0)  # y^b − 1
    small = x < GRID_SERIES_BELOW
    xs = jnp.where(small, x, 0.0)
    binom = [cj * (-1.0) ** j for j, cj in enumerate(_binomials(b - 1.0, GRID_SERIES_TERMS))]
    if rule == TRAPEZOID:
        xc = jnp.where(small, 1.0, x)
        w_next = -(em + b * xc * (em + 1.0)) / (xc * (b + 1.0))
        w_this = (b * xc + y * em) / (xc * (b + 1.0))
        s_this = _poly([c / ((j + 1) * (j + 2)) for j, c in enumerate(binom)], xs)
        s_next = _poly([c / (j + 2) for j, c in enumerate(binom)], xs)
        w_this = jnp.where(small, xs * b * s_this, w_this)
        w_next = jnp.where(small, xs * b * s_next, w_next)
        return scale * w_this, scale * w_next
    s_total = _poly([c / (j + 1) for j, c in enumerate(binom)], xs)
    total = jnp.where(small, xs * b * s_total, -em)
    return scale * total, jnp.zeros_like(total)


def grid_weights(times, k, b, rule: str):
    """Weights of ``u_0 … u_{C−1}`` in ``Φ(b, t_k)`` on the nodes ``times`` (C,): exact
    product integration over ``[t_0, t_k]`` (`interval_weights`); zero from node ``k + 1`` on."""
    count = times.shape[0]
    t_k = times[k]
    left = times[:-1]
    h = times[1:] - left
    a = jnp.maximum(t_k - left, h)  # intervals beyond t_k are masked below
    w_this, w_next = interval_weights(a, h, b, rule)
    k = jnp.asarray(k)
    inside = jnp.arange(count - 1, dtype=k.dtype) < k
    w_this = jnp.where(inside, w_this, 0.0)
    w_next = jnp.where(inside, w_next, 0.0)
    zero = jnp.zeros((1,), w_this.dtype)
    return jnp.concatenate([w_this, zero]) + jnp.concatenate([zero, w_next])
