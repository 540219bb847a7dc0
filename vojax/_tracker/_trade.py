"""The trade-off profile: with one input a drifting parameter can stand in for a moving order;
the constant orders with which a parameter free to drift (piecewise linear on hat functions)
explains the data as well as the best such fit."""

import dataclasses
import functools

import numpy as np

from ._explanations import Explanation, relative_drift
from ._mixture import chi2_fits
from ._model import beta_of_np
from ._start import least_squares, phi_columns


@dataclasses.dataclass(frozen=True)
class Profile:
    """What the trade-off profile leaves for moving orders (`vojax._tracker._moving`): the
    profiled constant orders `alphas` (A,) and their memory columns `memory` (A, N, n + n·k)
    (see `drift_profile`), the drift's hat functions `bases` (coarse, fine), each form that
    explains the data as ``(level, form, best χ², dof)`` (level 0 coarse, 1 fine; form 0 a
    gain, 1 inside the integral), the data `y` and `mask`, the noise's `whiten` (or None) and
    χ² `scale`, whether an `offset` is fitted, the fitted `span`, the order's `bounds`, the
    order's own hat functions `shape` (N, `trade_knots`) and the `settings`."""

    alphas: np.ndarray
    memory: np.ndarray
    bases: tuple
    forms: tuple
    y: np.ndarray
    mask: np.ndarray
    whiten: object
    offset: bool
    scale: float
    span: int
    bounds: tuple
    shape: np.ndarray
    settings: object


def hat_basis(times, last, knots):
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


def gain_design(phi, basis):
    """The design (N, n·k) of parameters drifting as a gain on the memory term: each input's
    memory `phi` (N, n) times each hat function of `basis` (N, k)."""
    return (phi[:, :, None] * basis[:, None, :]).reshape(phi.shape[0], -1)


def drift_profile(problem, alphas, fine, whiten=None, offset=True):
    """Weighted residual sums of squares (A, 2, 2) of least squares at each constant order of
    `alphas` with an offset (``offset=False``: known to be 0) and the parameters free to
    drift, ``p_j(t) = Σ_k a_jk B_k(t)``: on `trade_knots` knots, then on the hat functions
    `fine` (N, `trade_knots_fine`: those knots and their midpoints); each as a gain on the
    memory term (``y ≈ c + Σ a_jk B_k Φ_j``), then inside the integral
    (``y ≈ c + Σ a_jk I^α(B_k u_j)``); χ² where `whiten` is given (see `least_squares`).
    The integral is linear: the coarse hats' columns are sums of the fine ones'
    (`refinement`), so one run of the memory a constant order serves both. Returns the χ²,
    the designs: ``designs[a][knots][form]`` (N, n·k), a drifting coefficient a column, and
    each order's memory columns (A, N, n + n·k): the inputs', then the inputs times the fine
    hats'."""
    s = problem.settings
    u, y, mask, fine = (np.asarray(a) for a in (problem.u, problem.y, problem.mask, fine))
    num, n = u.shape
    k = fine.shape[1]
    r = refinement(s.trade_knots)
    coarse = fine @ r
    inside_u = (u[:, :, None] * fine[:, None, :]).reshape(num, n * k)
    # one block of `phi_block` = k + 1 columns an input: its own and its k drifting ones
    columns = np.concatenate([u, inside_u], axis=1)
    out, designs, memory = [], [], []
    for alpha in alphas:
        both = phi_columns(problem.memory, columns, alpha, s.phi_block)
        memory.append(both)
        phi, inside = both[:, :n], both[:, n:].reshape(num, n, k)
        row, design = [], []
        for basis, drifting in ((coarse, inside @ r), (fine, inside)):
            xs = [gain_design(phi, basis), drifting.reshape(num, -1)]
            row.append([least_squares(x, y, mask, whiten, offset)[0] for x in xs])
            design.append(xs)
        out.append(row)
        designs.append(design)
    return np.asarray(out), designs, np.stack(memory)


def penalised_system(x, y, mask, k, whiten=None, offset=True):
    """The weighted least-squares system of the design `x` (N, n·k), k drifting coefficients
    an input, with an offset column (``offset=False``: none) and, where given, `whiten`:
    ``(a, b, penalty, unit)``, the weighted columns and data, the penalty ``Σ_j ‖Δa_j‖²`` on
    each input's coefficients' first differences, and ``unit``, the ratio of the columns' and
    the penalty's traces that puts λ on the data's scale."""
    num = x.shape[0]
    n = x.shape[1] // k
    cols = np.concatenate([x, np.ones((num, 1))], axis=1) if offset else x
    yy = y
    if whiten is not None:
        cols, yy = whiten(cols), whiten(y)
    w = np.sqrt(np.asarray(mask, float))
    a_mat, b = cols * w[:, None], yy * w
    penalty, trace = _penalty(cols.shape[1], n, k)
    unit = np.trace(a_mat.T @ a_mat) / max(trace, 1e-300)
    return a_mat, b, penalty, unit


@functools.lru_cache(maxsize=64)
def _penalty(width, n, k):
    """The penalty matrix (width, width) on each input's coefficients' first differences
    (read-only: shared by every call of a shape) and its trace."""
    diff = np.diff(np.eye(k), axis=0)  # (k − 1, k): the coefficients' first differences
    penalty = np.zeros((width, width))
    for j in range(n):
        block = slice(j * k, (j + 1) * k)
        penalty[block, block] = diff.T @ diff
    penalty.flags.writeable = False
    return penalty, float(np.trace(penalty))


def least_drift(x, y, mask, basis, span, limit, scale, whiten=None, offset=True):
    """The least relative drift of the parameters ``p_j = basis @ a_j`` (`basis` (N, k), the
    design `x` (N, n·k) a coefficient a column) among fits whose χ² (the weighted residual sum
    of squares × `scale`) stays within `limit`: the smoothest fit (least squares with a
    penalty ``λ Σ_j ‖Δa_j‖²`` on the coefficients' differences, λ the largest that keeps the
    χ² within the limit, found by bisection in log λ) — ∞ where even the unpenalised fit
    exceeds the limit, and the drift of the constant parameters (0) where they fit within it.
    See `vojax._tracker._explanations.relative_drift`."""
    num, k = basis.shape
    n = x.shape[1] // k
    a_mat, b, penalty, unit = penalised_system(x, y, mask, k, whiten, offset)
    gram, rhs = a_mat.T @ a_mat, a_mat.T @ b

    def fit(lam):
        coef = np.linalg.lstsq(gram + lam * unit * penalty, rhs, rcond=None)[0]
        res = b - a_mat @ coef
        return float(res @ res) * scale, coef

    chi2, coef = fit(0.0)
    if not chi2 <= limit:
        return np.inf
    # the parameters constant (every a_j a multiple of ones: the hats sum to 1), fitted
    # exactly rather than as the λ → ∞ end of the ladder, whose χ² LAPACK builds differ on
    width = a_mat.shape[1]
    tie = np.zeros((width, n + (width - n * k)))
    for j in range(n):
        tie[j * k : (j + 1) * k, j] = 1.0
    tie[n * k :, n:] = np.eye(width - n * k)  # the offset, where fitted
    const = a_mat @ tie
    res = b - const @ np.linalg.lstsq(const, b, rcond=None)[0]
    if float(res @ res) * scale <= limit:
        return 0.0  # the parameters constant within the limit
    lo, hi = -12.0, 12.0  # log10 λ, in units of `unit`
    for _ in range(40):
        mid = (lo + hi) / 2
        c_mid, coef_mid = fit(10.0**mid)
        if c_mid <= limit:
            lo, coef = mid, coef_mid
        else:
            hi = mid
    params = np.stack([basis @ coef[j * k : (j + 1) * k] for j in range(n)], axis=1)
    return relative_drift(params, span)


def trade_interval(problem, noise, whiten=None, offset=True):
    """The constant orders ``(lo, hi)`` with which a drifting parameter explains the data as
    well as the best such fit (``Δχ² ≤ trade_chi2`` at the measurement variance `noise`, on
    the same scale as `y`, or under a coloured noise's `whiten`), over the forms (gain,
    inside) whose best fit passes a χ² test at 2σ (``χ² ≤ dof + 2√(2 dof)``); None when
    neither explains the data. Each form's drift is on `trade_knots` knots, or on
    `trade_knots_fine` where Akaike's criterion prefers them. ``offset=False``: the offset is
    known to be 0. Returns ``(interval, explanations)``: each grid order inside a form's
    interval as an `Explanation` of kind "trade", with the least drift its fits need
    (`least_drift`), and the `Profile` that moving orders start from."""
    s = problem.settings
    lo, hi = problem.bounds
    n = problem.n
    alphas = np.linspace(lo, hi, s.trade_orders + 2)[1:-1]
    fine = hat_basis(problem.times, problem.last, s.trade_knots_fine)
    chi2, designs, memory = drift_profile(problem, alphas, fine, whiten, offset)
    scale = 1.0 / noise if whiten is None else 1.0
    chi2 = chi2 * scale
    fitted = float(np.sum(np.asarray(problem.mask)))
    bases = (fine @ refinement(s.trade_knots), fine)
    y, mask = np.asarray(problem.y), np.asarray(problem.mask)
    found, explanations, forms = [], [], []
    for form in range(chi2.shape[2]):
        c, knots, level = chi2[:, 0, form], s.trade_knots, 0
        c_fine = chi2[:, 1, form]
        # the finer drift where its added coefficients pay for themselves (Akaike)
        if np.all(np.isfinite(c_fine)) and (
            c.min() - c_fine.min() > 2 * n * (s.trade_knots_fine - s.trade_knots)
        ):
            c, knots, level = c_fine, s.trade_knots_fine, 1
        dof = max(fitted - n * knots - 1, 1.0)
        if not np.all(np.isfinite(c)) or not chi2_fits(c.min(), dof):
            continue
        excess = c - c.min() - s.trade_chi2
        inside = np.flatnonzero(excess <= 0)

        def crossing(a, b):  # where Δχ² crosses the limit between grid orders a (in), b (out)
            return alphas[a] + (alphas[b] - alphas[a]) * -excess[a] / (excess[b] - excess[a])

        i, j = inside[0], inside[-1]
        found.append(lo if i == 0 else crossing(i, i - 1))
        found.append(hi if j == alphas.size - 1 else crossing(j, j + 1))
        limit = c.min() + s.trade_chi2
        forms.append((level, form, float(c.min()), dof))
        for a in inside:
            drift = least_drift(designs[a][level][form], y, mask, bases[level], problem.span,
                                limit, scale, whiten, offset)
            beta = np.full(y.shape[0], float(beta_of_np(alphas[a], problem.bounds)))
            explanations.append(Explanation("trade", beta, np.zeros_like(beta), float(c[a]),
                                            dof, np.nan, drift, accepted=True))
    interval = (float(min(found)), float(max(found))) if found else None
    profile = Profile(alphas, memory, bases, tuple(forms), y, mask, whiten, offset, scale,
                      problem.span, problem.bounds, hat_basis(problem.times, problem.last,
                                                              s.trade_knots), s)
    return interval, explanations, profile
