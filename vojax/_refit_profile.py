"""The refit's check of a constant order against its profile: the least sum of squares over
the coefficients at each order, their signs kept, read over the whole range of orders.

Where the fit barely depends on the order (a hold after a ramp), Levenberg–Marquardt's damping
shrinks the order's step to nothing and the solver stops where it started, reporting success.
Where the profile has two minima, the solver finds the one whose basin holds its start. The
profile is read at a grid of orders over `order_bounds` with the fit; a local minimum of the
grid in another basin is narrowed, and where it fits better than the fit, the solver is run
again from there on the profile's face (the coefficients its signs hold at 0)."""

import itertools
import math

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from ._integral import order_map
from ._refit_inputs import BOUND_MARGIN

# orders of the profile's grid over the order's range, and of each narrowing round (evenly
# over the bracket, its ends included)
PROFILE_ORDERS = 17
# the fit stopped short of the least squares where the profile fits better than it by more
# than this fraction of its sum of squares (well above the rounding of a sum of squares, and
# below the 3e-3 and 1e-4 gains of the stalled and local myocardium fits it finds)
PROFILE_GAIN = 1e-8
# the rounds narrow a bracket to this fraction of the range of orders
PROFILE_TOL = 1e-9
# coefficients with a sign beyond this many are not profiled (2^k faces per order)
PROFILE_MAX_SIGNED = 8


def _profile_orders(bounds):
    """The profile's grid: `PROFILE_ORDERS` orders evenly over `bounds`, half `BOUND_MARGIN`
    inside them (where the order's logit is finite)."""
    lo, hi = bounds
    inset = 0.5 * BOUND_MARGIN * (hi - lo)
    return np.linspace(lo + inset, hi - inset, PROFILE_ORDERS)


def _reductions(phi_of, v, big_y, sw, orders, estimate):
    """At each constant order of `orders` (G,): the weighted design ``A = [Φ, v, 1]·√w`` as
    ``A = QR``, returning ``R`` (G, P, P), ``c = Qᵀ(√w y)`` (G, P) and the part of
    ``√w y`` outside A's columns, ``‖√w y − Q c‖²`` (G,). The least squares over any subset
    S of the columns is then ``rest + min_p ‖c − R_S p‖²``: a P×|S| problem. Traced (inside
    `_refit_solve._fit`, whose order map `phi_of` it shares, and `_reduced`)."""
    num = big_y.shape[0]
    ysw = big_y * sw

    def one(order):
        phi = phi_of(jnp.full((num,), order, big_y.dtype))
        parts = [phi, v] + ([jnp.ones((num, 1), phi.dtype)] if estimate else [])
        q, r = jnp.linalg.qr(jnp.concatenate(parts, 1) * sw[:, None])
        c = q.T @ ysw
        return r, c, jnp.sum((ysw - q @ c) ** 2)

    return jax.lax.map(one, jnp.asarray(orders, big_y.dtype))


@eqx.filter_jit
def _reduced(mem, u2, v, big_y, sw, orders, estimate):
    """`_reductions` at `orders` of a narrowing round (a program of its own, compiled only
    where the grid that comes with the fit finds a basin to narrow)."""
    return _reductions(order_map(mem, u2), v, big_y, sw, orders, estimate)


def _best_face(r, c, rest, signs, real):
    """The least sum of squares of ``c ≈ R p`` (plus `rest`) over the columns `real` with
    ``signs_j p_j ≥ 0`` for the coefficients (`real`'s first ``signs.size``; the rest, the
    offset, free): of all subsets of the signed coefficients held at 0, the least squares of
    those whose free fit keeps its signs (a convex problem: its optimum is one of them).
    Returns ``(rss, active)``, active 0 where held."""
    count = signs.size
    signed = np.flatnonzero(signs != 0)
    best, face = math.inf, np.ones(count)
    for held in itertools.product((False, True), repeat=signed.size):
        active = np.ones(count)
        active[signed[list(held)]] = 0.0
        keep = np.r_[np.flatnonzero(active), np.arange(count, real.size)]
        p = np.linalg.lstsq(r[:, real[keep]], c, rcond=None)[0]
        free = keep[keep < count]
        if np.any(signs[free] * p[: free.size] < 0):
            continue
        rss = rest + float(np.sum((c - r[:, real[keep]] @ p) ** 2))
        if rss < best:
            best, face = rss, active
    return best, face


def _profile_start(grid, mem, u2, v, big_y, sw, signs, solver, fit_rss, fit_order):
    """Where a constant-order fit (`fit_order`, sum of squares `fit_rss`) stopped short of its
    profile's least squares: ``(order, active)``, the best order found and the face there;
    else None (also where more than `PROFILE_MAX_SIGNED` coefficients are signed).

    `grid` is `_reductions` at `_profile_orders(bounds)`, computed with the fit on its
    padded columns, and the places of the real ones (the offset last). Each of the
    grid's local minima is narrowed (`_narrowed`) where its bracket (its two neighbours) does
    not hold the fit's order, or where it already fits better than the fit: a narrow basin
    between grid orders is found when the grid samples its slopes."""
    if np.count_nonzero(signs) > PROFILE_MAX_SIGNED or not np.isfinite(fit_rss):
        return None
    lo, hi = solver["bounds"]

    def faces(r, c, rest, real):
        return [_best_face(r[g], c[g], float(rest[g]), signs, real) for g in range(len(rest))]

    plain = np.arange(u2.shape[1] + v.shape[1] + bool(solver["estimate"]))

    def evaluate(orders):  # unpadded: the narrowing's program is one of its own anyway
        return faces(*(np.asarray(x) for x in _reduced(
            mem, u2, jnp.asarray(v, big_y.dtype), big_y, sw, jnp.asarray(orders, big_y.dtype),
            solver["estimate"])), plain)

    orders = _profile_orders(solver["bounds"])
    *reductions, real = grid
    values = faces(*(np.asarray(x) for x in reductions), real)
    rss = np.array([value for value, _ in values])
    best = (fit_rss * (1 - PROFILE_GAIN), None, None)
    last = PROFILE_ORDERS - 1
    for k in range(PROFILE_ORDERS):
        a, b = orders[max(k - 1, 0)], orders[min(k + 1, last)]
        if rss[k] > rss[max(k - 1, 0)] or rss[k] > rss[min(k + 1, last)]:
            continue  # not a local minimum of the grid
        if a <= fit_order <= b and not rss[k] < best[0]:
            continue  # the fit's own basin, where the fit is at least as good
        found = _narrowed(evaluate, a, b, (rss[k], orders[k], values[k][1]),
                          PROFILE_TOL * (hi - lo))
        if found[0] < best[0]:
            best = found
    return None if best[1] is None else (best[1], best[2])


def _narrowed(evaluate, a, b, best, tol):
    """Rounds of `PROFILE_ORDERS` orders over ``[a, b]``, each narrowed to the two intervals
    about its best order, until ``b − a ≤ tol``. Returns the best ``(rss, order, active)``
    read, `best` included."""
    while b - a > tol:
        orders = np.linspace(a, b, PROFILE_ORDERS)
        values = evaluate(orders)
        k = int(np.argmin([value for value, _ in values]))
        if values[k][0] < best[0]:
            best = (values[k][0], float(orders[k]), values[k][1])
        a, b = orders[max(k - 1, 0)], orders[min(k + 1, PROFILE_ORDERS - 1)]
    return best
