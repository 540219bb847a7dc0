"""The strain of a fitted law, solved exactly (`AbstractViscoelasticModel.fitted_strain`).

A constant-order `refit` of a law's regressors fits ``ε ≈ x0 + c σ + I^q(a σ + b ε)`` with the
*measured* strain inside the integral where the law feeds its strain back (Kelvin–Voigt,
Zener: ``b ≠ 0``); its `y_hat` is then not the strain the fitted law predicts. Here the fitted
law is solved for the strain from the stress alone. With ``e = ε − x0`` the law reads
``e = c σ + I^q(a σ + b e) + I^q(b x0)``; by linearity ``e`` is the law's response to the
stress from rest (`respond`) plus ``w = I^q(b x0 + b w)``, whose solution is
``w = x0 (E_q(b τ^q) − 1)`` (``D^q(x0 + w) = b (x0 + w)`` from ``x0``), τ the time since the
test's start. So

    ε(t) = x0 E_q(b τ^q) + [the law's strain response to σ from rest](t),

exact for a stress linear between its samples, as `strain_response` is.
"""

import numpy as np

from ._ml_table import pair
from ._respond import _uniform_from, check_history

# the most lags an exact solve sums directly for a reported residual (`compare`'s rows, the
# batch's nrmse): 5e7 take 7.7 s on a log-spaced clock of 7,071 samples, about what a law's
# refits take there; a uniform clock needs N lags at any length (1e6 samples: 0.9 s)
EXACT_SOLVE_LAGS = 5e7


def too_costly(times):
    """Why the exact solve on the clock `times` (None: a uniform step) is not made (the lags
    it would sum directly, those of the samples before the clock turns uniform, exceed
    `EXACT_SOLVE_LAGS`), or None."""
    if times is None:
        return None
    num = np.asarray(times).shape[0]
    head = _uniform_from(np.asarray(times, dtype=float))
    if head * num <= EXACT_SOLVE_LAGS:
        return None
    return (f"its law solved exactly on this clock ({head} of its {num} samples before it "
            f"turns uniform) would sum {head * num:.2g} lags")


def _law(a, b, c):
    """The law with the coefficients ``(a, b, c)`` and its physical parameters: a springpot
    (``b = c = 0``), Kelvin–Voigt (``c = 0``), Maxwell (``b = 0``) or Zener; `ValueError`
    where they are not physical (η ≤ 0, a negative spring, the Zener's E1 ≤ 0)."""
    from ._viscoelastic import FractionalMaxwell, FractionalZener, KelvinVoigt, Springpot

    e0 = -b / a if a > 0 else float("nan")
    zener_e1 = 1.0 / c - e0 if c > 0 else float("inf")
    if not (a > 0 and b <= 0 and c >= 0 and zener_e1 > 0):
        raise ValueError(
            f"the fitted law is not physical (ε = {c:.4g} σ + I^q({a:.4g} σ + {b:.4g} ε) needs "
            "the first coefficient > 0, the second ≤ 0, the third ≥ 0, and a Zener spring E1 > 0); "
            "refit with `p_signs=model.p_signs`."
        )
    eta = 1.0 / a
    if c == 0.0:
        return (Springpot(), dict(eta=eta)) if b == 0.0 else (KelvinVoigt(), dict(eta=eta, k=e0))
    if b == 0.0:
        return FractionalMaxwell(), dict(eta=eta, E=1.0 / c)
    return FractionalZener(), dict(eta=zener_e1 * c / a, E0=e0, E1=zener_e1)


def fitted_strain(model, fit, stress, dt, t, origin):
    """See `AbstractViscoelasticModel.fitted_strain`."""
    if not hasattr(fit, "order") or not hasattr(fit, "p") or not hasattr(fit, "x0"):
        raise TypeError(f"`fit` must be a `vojax.Refit`, got {type(fit).__name__}.")
    order = np.asarray(fit.order, dtype=float)
    if order.ndim != 1 or order.size == 0 or not np.all(order == order[0]):
        raise ValueError(
            "`fit` has an order that varies along the record; only a constant-order fit "
            "(`refit(..., order='constant')`) is a law that can be solved in closed form."
        )
    p = np.asarray(fit.p, dtype=float)
    if p.shape != (len(model.p_signs),):
        raise ValueError(
            f"`fit` has {p.size} coefficients, a {type(model).__name__} fit has "
            f"{len(model.p_signs)}: refit `model.inputs(stress, strain)` with "
            "`direct=model.direct(stress)`."
        )
    stress, times = check_history(stress, dt, t, "stress")
    a, b, c = (float(v) for v in model._law_coefficients(p))
    x0, q = float(np.asarray(fit.x0)), float(order[0])
    if a == 0.0 and b == 0.0 and c >= 0.0:  # both memory terms held at 0: a spring alone
        return x0 + c * stress
    law, params = _law(a, b, c)
    if origin is not None:  # the test started there, the stress held at its first value
        if isinstance(origin, bool) or not isinstance(origin, (int, float, np.floating)):
            raise TypeError(f"`origin` must be a number, got {origin!r}.")
        origin = float(origin)
        if times is None:
            times = float(dt) * np.arange(stress.shape[0])
        if not origin < times[0]:
            raise ValueError(f"`origin` must be a time before the first sample ({times[0]:g}), "
                             f"got {origin!r}.")
        strain = law.strain_response(np.concatenate([stress[:1], stress]),
                                     t=np.concatenate([[origin], times]), q=q, **params)[1:]
        since = times - origin
    else:
        strain = law.strain_response(stress, dt, t=times, q=q, **params)
        since = (float(dt) * np.arange(stress.shape[0]) if times is None else times - times[0])
    if b == 0.0 or x0 == 0.0:
        return strain + x0
    return strain + x0 * pair(q, -b * since**q, 1.0)[0]  # E_q(b τ^q), tabulated where many
