"""The tracker's start: least squares at a constant order, the constant-order fit, and the
constant trajectories the smoother starts from."""

import equinox as eqx
import jax.numpy as jnp
import numpy as np

from .._xla import to_device
from ._model import beta_of_np, order_of_np


@eqx.filter_jit
def _phi_constant(memory, x, alpha):
    """``Φ`` of the input columns `x` (N, block) at the constant order `alpha`."""
    return memory.run(x, jnp.full((x.shape[0],), alpha, x.dtype), False)


def phi_columns(memory, x, alpha, block):
    """``Φ`` (N, m) of each column of `x` (N, m) at the constant order `alpha`, in blocks of
    `block` columns (the last padded with zeros): the constant fit and the trade-off's
    profile share one compiled program whatever the number of inputs, and one scan of the
    memory costs about the same for one column as for nine."""
    x = np.asarray(x)
    num, m = x.shape
    padded = np.zeros((num, -(-m // block) * block), x.dtype)
    padded[:, :m] = x
    a = to_device(np.asarray(alpha, x.dtype))
    return np.concatenate(
        [np.asarray(_phi_constant(memory, to_device(padded[:, j : j + block]), a))
         for j in range(0, padded.shape[1], block)],
        axis=1,
    )[:, :m]


def least_squares(x, y, mask, whiten=None, offset=True):
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


def constant_profile(memory, u, y, mask, alpha, block, offset=True):
    """Residual sum of squares and ``[p, c]`` of the least-squares fit at a constant order,
    and the RMS of each column of ``Φ`` (`u`, `y`, `mask`: host arrays); ``offset=False``:
    ``c`` known to be 0."""
    phi = phi_columns(memory, u, alpha, block)
    rss, coef = least_squares(phi, y, mask, offset=offset)
    return rss, coef, np.sqrt(np.sum(mask[:, None] * phi**2, 0) / np.sum(mask))


def constant_fit(memory, u, y, mask, bounds, settings, offset=True):
    """Constant-order least squares with offset (``offset=False``: the offset known to be 0):
    a grid of `settings.constant_grid` orders in β, then `settings.golden_steps` steps of
    golden-section search in β between the best grid point's neighbours. Returns ``(α, coef,
    rss, rms of Φ columns)``."""
    num_grid, block = settings.constant_grid, settings.phi_block
    betas = np.linspace(-4.5, 4.5, num_grid)
    u, y, mask = (np.asarray(a) for a in (u, y, mask))  # once, not at each of ~40 orders

    def at(beta):
        alpha, _ = order_of_np(beta, bounds)
        return constant_profile(memory, u, y, mask, alpha, block, offset)

    values = [float(at(b)[0]) for b in betas]
    i = int(np.nanargmin(values))
    lo, hi = betas[max(i - 1, 0)], betas[min(i + 1, num_grid - 1)]
    ratio = (np.sqrt(5.0) - 1) / 2
    a, b = hi - ratio * (hi - lo), lo + ratio * (hi - lo)
    fa, fb = float(at(a)[0]), float(at(b)[0])
    for _ in range(settings.golden_steps):
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


def starting_trajectories(problem, alpha_c, offset=True):
    """Constant-order trajectories to start the smoother from: the constant fit's order (kept
    off the flat ends of the logistic map) and `settings.start_orders` across the range, each
    with its least-squares parameters and offset (``offset=False``: 0). Returns (S, d)."""
    lo, hi = problem.bounds
    orders = problem.settings.start_orders
    frac = (alpha_c - lo) / (hi - lo)
    # always the same number of starts: one compiled program for every record of a shape
    fracs = [float(np.clip(frac, orders[0], orders[-1])), *orders]
    u, y, mask = (np.asarray(a) for a in (problem.u, problem.y, problem.mask))
    out = []
    for f in fracs:
        alpha = lo + (hi - lo) * f
        _, coef, _ = constant_profile(problem.memory, u, y, mask, alpha,
                                      problem.settings.phi_block, offset)
        out.append(np.concatenate([[float(beta_of_np(alpha, problem.bounds))], np.asarray(coef)]))
    return np.stack(out)
