"""Closed forms of the constant-order laws: the relaxation modulus G(t), the creep compliance
J(t) and the complex modulus G*(ω), through the Mittag-Leffler function ``E_{α,β}(−x)``.

``E_{α,β}(−x)`` for ``x ≥ 0``, ``0 < α ≤ 1`` and β = 1, 2, 1 + α or 2 + α (the step and the
ramp responses of the laws, `vojax._models._respond`) is computed three ways, each where it
is accurate to a few units of rounding:

- ``x ≤ 0.5``: the power series ``Σ (−x)^k / Γ(αk + β)`` (the terms' sum of moduli is at
  most ``E_α(0.5) ≤ 2``, so cancellation costs at most a few ulps);
- ``x ≥ 10⁴``: the asymptotic series ``−Σ_{k≥1} (−x)^{−k} / Γ(β − αk)`` (its terms fall by
  about k/x each; for α < 1 there is no exponential part on the negative axis);
- between, for β = 1 and 2, an integral of a bounded, positive integrand. The spectral
  representation ``E_α(−t^α) = ∫_0^∞ e^{−rt} K(r) dr`` (K a positive density) with the
  substitution ``w = r x^{1/α}`` and an integration by parts gives

      E_α(−x) = (1/(απ)) ∫_0^∞ e^{−w} θ(w) dw,
      E_{α,2}(−x) = (1/(απ)) ∫_0^∞ (1 − e^{−w}(1 + w))/w² θ(w) dw,

  with ``θ(w) = atan2(sin(απ) w^α, x + cos(απ) w^α)``, which rises from 0 to απ (the second
  from ``t E_{α,2}(−t^α) = ∫_0^t E_α(−s^α) ds``). The integrands are computed by
  Gauss–Legendre panels graded geometrically towards ``w = 0`` (where θ grows like ``w^α``)
  and, for α > 1/2, towards ``w_c = (x/|cos απ|)^{1/α}``, where θ rises from about 0 to about
  απ over a relative width ``|tan απ|/α`` (a step at ``w = x`` when α = 1, which gives
  ``e^{−x}`` exactly). The second's tail beyond ``W_MAX`` is ``∫_0^{1/W_MAX} θ(1/v) dv``;
- β = 1 + α and 2 + α from β = 1 and 2 by ``E_{α,β+α}(−x) = (1/Γ(β) − E_{α,β}(−x))/x``
  (at x > 0.5 the difference loses less than a digit).
"""

import math

import numpy as np

from .._values import reals

SERIES_LIMIT = 0.5  # x up to this: the power series
ASYMPTOTIC_LIMIT = 1e4  # x from this: the asymptotic series
NODES = 16  # Gauss–Legendre nodes a panel
W_MAX = 1024.0  # the integral's end (e^{−1024} is below the smallest double)
GRADING = 60  # panels halving towards each graded point: down to 2^−60 of its scale

_GL_X, _GL_W = np.polynomial.legendre.leggauss(NODES)


def check_alpha(alpha, upper_open=False, name="alpha"):
    """The order `name` as a float in (0, 1] (or (0, 1) where `upper_open`)."""
    if isinstance(alpha, bool) or not isinstance(alpha, (int, float, np.floating)):
        raise TypeError(f"`{name}` (the order) must be a number, got {alpha!r}.")
    alpha = float(alpha)
    if not (0.0 < alpha < 1.0 if upper_open else 0.0 < alpha <= 1.0):
        raise ValueError(
            f"`{name}` (the order) must lie in (0, 1{')' if upper_open else ']'}, got {alpha!r}."
        )
    return alpha


def check_argument(x):
    """The argument x of E_α(−x) as a float array: real, finite and at least 0."""
    try:
        x = np.asarray(x)
    except ValueError:  # a ragged list
        x = np.asarray([np.nan])
    if x.dtype.kind not in "iuf" or not np.all(np.isfinite(x)) or np.any(x < 0):
        raise ValueError("the argument x of E_α(−x) must be finite and at least 0.")
    return x.astype(float)


def mittag_leffler(alpha, x, beta=1.0):
    """``E_{α,β}(−x)``, the Mittag-Leffler function at minus `x` (an array of numbers ≥ 0),
    for ``0 < α ≤ 1`` and β = 1 (the default, ``E_α``: 1 at x = 0, decreasing, ``e^{−x}`` at
    α = 1 and ``1/(x Γ(1 − α))`` for large x), 2, 1 + α or 2 + α. Accurate to a few units of
    rounding (see the module's description); NumPy, not traced by JAX."""
    alpha = check_alpha(alpha)
    if isinstance(beta, bool) or not isinstance(beta, (int, float, np.floating)):
        raise TypeError(f"beta must be a number, got {beta!r}.")
    beta = float(beta)
    base = 1.0 if beta in (1.0, 1.0 + alpha) else 2.0 if beta in (2.0, 2.0 + alpha) else None
    if base is None:
        raise ValueError(f"beta must be 1, 2, 1 + alpha or 2 + alpha, got {beta!r}.")
    plain, shifted = mittag_leffler_pair(alpha, x, base)
    return plain if beta == base else shifted


def mittag_leffler_pair(alpha, x, base):
    """``(E_{α,base}(−x), E_{α,base+α}(−x))`` for base 1 or 2, from one evaluation of the
    integral between the series (`mittag_leffler`)."""
    x = check_argument(x)
    plain, shifted = np.empty_like(x), np.empty_like(x)
    flat, p, s = x.ravel(), plain.ravel(), shifted.ravel()
    middle = (flat > SERIES_LIMIT) & (flat < ASYMPTOTIC_LIMIT)
    for mask, method in ((flat <= SERIES_LIMIT, _series), (flat >= ASYMPTOTIC_LIMIT, _asymptotic)):
        if mask.any():
            p[mask] = method(alpha, flat[mask], base)
            s[mask] = method(alpha, flat[mask], base + alpha)
    if middle.any():
        xm = flat[middle]
        p[middle] = _integral(alpha, xm, base)
        s[middle] = (1.0 / math.gamma(base) - p[middle]) / xm
    return plain, shifted


SERIES_BANDS = (1e-4, 1e-2, 0.1, SERIES_LIMIT)  # |x| up to each: the series cut to the terms it needs


def _series(alpha, x, beta=1.0, terms=80):
    """The power series ``Σ (−x)^k / Γ(αk + β)`` by Horner's scheme: `terms` terms, fewer
    where ``|x|`` is within one of `SERIES_BANDS`, whose bound then keeps every dropped
    term below 1e-17 (``1.2 |x|^k``: 1/Γ ≤ 1.13 on the positive axis)."""
    out = np.empty_like(x)
    lower = -1.0
    for upper in (*SERIES_BANDS, math.inf):
        band = (np.abs(x) > lower) & (np.abs(x) <= upper)
        cut = terms if upper == math.inf else math.ceil(math.log(1e-17 / 1.2) / math.log(upper))
        lower = upper
        if band.any():
            xb, total = x[band], np.zeros(np.count_nonzero(band))
            for j in range(min(cut, terms) - 1, -1, -1):
                total = total * -xb + _rgamma(alpha * j + beta)
            out[band] = total
    return out


def _asymptotic(alpha, x, beta=1.0, terms=12):
    coef = [_rgamma(beta - alpha * j) for j in range(1, terms + 1)]
    k = np.arange(1, terms + 1)
    return -(np.power.outer(-1.0 / x, k) * np.array(coef)).sum(axis=1)


def _rgamma(z):
    """1/Γ(z); below 1/2 by reflection, ``sin(πz) Γ(1 − z)/π`` with sin(πz) taken from z's
    distance to the nearest integer (exact), so that it keeps its digits near the poles."""
    if z >= 0.5:
        return 1.0 / math.gamma(z)
    n = round(z)
    return (-1) ** (n % 2) * math.sin(math.pi * (z - n)) * math.gamma(1.0 - z) / math.pi


def _integral(alpha, x, beta=1.0):
    """``E_{α,β}(−x)`` for β = 1 or 2 by the integrals of the module's description."""
    if alpha == 1.0:
        return np.exp(-x) if beta == 1.0 else -np.expm1(-x) / x
    # sin απ and cos απ from 1 − α (exact for α ≥ 1/2): near α = 1, απ's own rounding
    # would be most of sin απ's size
    if alpha > 0.5:
        s, c = math.sin((1 - alpha) * math.pi), -math.cos((1 - alpha) * math.pi)
    else:
        s, c = math.sin(alpha * math.pi), math.cos(alpha * math.pi)
    halves = 2.0 ** -np.arange(GRADING + 1)
    graded = 2.0 ** np.arange(-GRADING, 11)  # towards w = 0, up to W_MAX
    out = np.empty_like(x)
    for i, xi in enumerate(x):
        points = [0.0, *graded]
        rise = []
        if c < 0:  # the steep rise of θ near w_c (a step at α = 1)
            wc = (xi / -c) ** (1.0 / alpha)
            width = max(s / -c / alpha, 1e-17) * wc
            rise = [wc, *(wc - width * 2**20 * halves), *(wc + width * 2**20 * halves)]
        w, weight = _nodes(points + rise, W_MAX)
        wa = w**alpha
        theta = np.arctan2(s * wa, xi + c * wa)
        if beta == 1.0:
            total = np.sum(weight * np.exp(-w) * theta)
        else:  # the weight (1 − e^{−w}(1 + w))/w², then the tail beyond W_MAX in v = 1/w
            total = np.sum(weight * ramp_weight(w) * theta)
            tail = [0.0, *(graded / W_MAX**2)] + [1.0 / r for r in rise if r > W_MAX]
            v, weight = _nodes(tail, 1.0 / W_MAX)
            total += np.sum(weight * np.arctan2(s, xi * v**alpha + c))
        out[i] = total / (alpha * math.pi)
    return out


def _nodes(points, end):
    """Gauss–Legendre nodes and weights of the panels between the `points` inside [0, end]."""
    b = np.unique(np.clip(points, 0.0, end))
    lo, hi = b[:-1, None], b[1:, None]
    return 0.5 * (hi - lo) * _GL_X + 0.5 * (hi + lo), 0.5 * (hi - lo) * _GL_W


def ramp_weight(w, xp=np):
    """``(1 − e^{−w}(1 + w))/w²``: below 1 its series ``Σ (−1)^k (k+1) w^k/(k+2)!``, which
    keeps the digits the difference would lose; `xp`: the array namespace (NumPy or
    ``jax.numpy``)."""
    small = w < 1.0
    ws = xp.where(small, w, 0.0)
    series = sum((-1) ** k * (k + 1) / math.factorial(k + 2) * ws**k for k in range(24))
    wl = xp.where(small, 1.0, w)
    return xp.where(small, series, (-xp.expm1(-wl) - wl * xp.exp(-wl)) / wl**2)


def _inputs(model, grid, name, q, params):
    """The law's name, the grid (> 0) as an array, q in (0, 1) and its parameters, checked,
    and the functions ``(E_q(−x), Γ)`` to use: NumPy's, or JAX's where the grid, q or a
    parameter is a JAX array (traced: `jax.grad` and `jax.jit` go through; a traced value is
    not checked, a concrete one is)."""
    import jax

    if not any(isinstance(v, jax.Array) for v in (grid, q, *params.values())):
        q = check_alpha(q, upper_open=True, name="q")
        grid = reals(grid, name)
        _check_grid(grid, name)
        return type(model).__name__, grid, q, check_parameters(model, params), (
            mittag_leffler, math.gamma, _rotate)
    from ._closed_jax import gamma_jax, mittag_leffler_jax, rotate_jax

    def concrete(v):  # a concrete value as the NumPy route takes it (a scalar: a float)
        return float(v) if np.ndim(v) == 0 else v

    traced = lambda v: isinstance(v, jax.core.Tracer)  # noqa: E731
    if not traced(q):
        check_alpha(concrete(q), upper_open=True, name="q")
    if not traced(grid):
        _check_grid(reals(grid, name), name)
    # a traced parameter stands in as 1 (its name is still checked)
    check_parameters(model, {k: 1.0 if traced(v) else concrete(v) for k, v in params.items()})
    grid = jax.numpy.asarray(grid, dtype=jax.numpy.result_type(float))
    return type(model).__name__, grid, q, params, (mittag_leffler_jax, gamma_jax, rotate_jax)


def _rotate(omega, q, p):
    """``((iω)^q, p)``, NumPy's route of `complex_modulus`."""
    return (1j * omega) ** q, p


def _check_grid(grid, name):
    if grid.size == 0 or not np.all(np.isfinite(grid)) or np.any(grid <= 0):
        raise ValueError(f"`{name}` must hold finite numbers above 0.")


def check_parameters(model, params):
    """The law's physical parameters, each a number above 0, as floats; one sentence where
    one is missing, unknown or out of range."""
    names = set(type(model).names)
    if set(params) != names:
        raise TypeError(
            f"{type(model).__name__} takes the parameters {', '.join(sorted(names))} "
            f"(and q), got {', '.join(sorted(params)) or 'none'}."
        )
    for key, value in params.items():
        if isinstance(value, bool) or not isinstance(value, (int, float, np.floating)) or not (
            0 < value < math.inf
        ):
            raise ValueError(f"the parameter {key} must be a number above 0, got {value!r}.")
    return {k: float(v) for k, v in params.items()}


def relaxation_modulus(model, t, q, params):
    """G(t): the stress after a unit step of strain at t = 0."""
    law, t, q, p, (ml, gamma, _) = _inputs(model, t, "t", q, params)
    if law == "Springpot":
        return p["eta"] * t**-q / gamma(1 - q)
    if law == "KelvinVoigt":
        return p["k"] + p["eta"] * t**-q / gamma(1 - q)
    if law == "FractionalMaxwell":
        return p["E"] * ml(q, p["E"] / p["eta"] * t**q)
    return p["E0"] + p["E1"] * ml(q, p["E1"] / p["eta"] * t**q)


def creep_compliance(model, t, q, params):
    """J(t): the strain after a unit step of stress at t = 0."""
    law, t, q, p, (ml, gamma, _) = _inputs(model, t, "t", q, params)
    if law == "Springpot":
        return t**q / (p["eta"] * gamma(1 + q))
    if law == "KelvinVoigt":
        return (1 - ml(q, p["k"] / p["eta"] * t**q)) / p["k"]
    if law == "FractionalMaxwell":
        return 1 / p["E"] + t**q / (p["eta"] * gamma(1 + q))
    e0, e1, total = p["E0"], p["E1"], p["E0"] + p["E1"]
    rate = e0 * e1 / (total * p["eta"])
    return 1 / total + e1 / (e0 * total) * (1 - ml(q, rate * t**q))


def complex_modulus(model, omega, q, params):
    """G*(ω) = G'(ω) + i G''(ω), the stress of a strain ``e^{iωt}`` in the steady state."""
    law, omega, q, p, (_, _, rotate) = _inputs(model, omega, "omega", q, params)
    s, p = rotate(omega, q, p)
    if law == "Springpot":
        return p["eta"] * s
    if law == "KelvinVoigt":
        return p["k"] + p["eta"] * s
    if law == "FractionalMaxwell":
        return p["E"] * p["eta"] * s / (p["eta"] * s + p["E"])
    return p["E0"] + p["E1"] * p["eta"] * s / (p["eta"] * s + p["E1"])
