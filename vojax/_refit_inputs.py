"""The checks and arrays of a `refit`'s inputs: the offset's and the order's options, the
step load at an origin, the samples' weights, the coefficients' signs, the direct regressors."""

import jax.numpy as jnp
import numpy as np

from . import _validate as check

# a knot this fraction of `order_bounds`' range from a bound is at it (`Refit.at_bound`); a
# start on a bound is moved this far inside, where the order's logit is finite
BOUND_MARGIN = 1e-3


def _check_x0(x0, origin) -> bool:
    """Whether the offset is estimated; says what is wrong with `x0` and `origin`."""
    estimate = isinstance(x0, str)
    if estimate and x0 != "estimate":
        raise ValueError(f"`x0` must be 'estimate', None (y[0]) or a number, got {x0!r}.")
    if origin is not None and x0 is None:
        raise ValueError("with `origin`, `x0` is the output at the origin: 'estimate' it or give it.")
    return estimate


def _start(order0, bounds) -> float:
    """The solver's start: `order0` checked against `order_bounds` and, where it lies on a bound,
    moved `BOUND_MARGIN` of the range inside (both solvers work where the order's logit is
    finite)."""
    a0 = float(np.asarray(check.step(order0, "order0")))
    if not bounds[0] <= a0 <= bounds[1]:
        raise ValueError(f"`order0` must lie inside `order_bounds` {tuple(bounds)}, got {a0}.")
    margin = BOUND_MARGIN * (bounds[1] - bounds[0])
    return min(max(a0, bounds[0] + margin), bounds[1] - margin)


def _num_knots(order, num):
    """The order's knots: 1 (``"constant"``), K, or None for a fixed (N,) order."""
    if isinstance(order, str):
        if order != "constant":
            raise ValueError(
                f"`order` must be 'constant', a number of knots ≥ 2, or an (N,) array, got {order!r}."
            )
        return 1
    if isinstance(order, (int, np.integer)) and not isinstance(order, bool):
        if order < 1 or order > num // 2:
            raise ValueError(
                f"`order` as a number of knots must be in [1, {num // 2}], got {order}."
            )
        return int(order)
    return None


def _from_origin(origin, t, times, u2, v, y, w):
    """The grid of the fit and the arrays with the step load at `origin` prepended (one more
    sample, the inputs held at their first values, weight 0); unchanged without one."""
    if origin is None:
        return t, u2, v, y, w
    origin = check.real(origin, "origin")
    if not np.isfinite(origin) or origin >= times[0]:
        raise ValueError(
            f"`origin` must be a finite time before the first sample ({times[0]:g}), got {origin}."
        )
    grid = np.concatenate([[origin], times])
    return (grid, jnp.concatenate([u2[:1], u2]), np.concatenate([v[:1], v]),
            jnp.concatenate([y[:1], y]), np.concatenate([[0.0], w]))


def _weights(num, mask, weights, window, relative, times, y):
    """The weight of each sample's squared residual (NumPy): the product of the mask, the
    user's weights, the fit window and, for relative residuals, ``1/y²``."""
    from ._validate import check_mask, window_mask

    w = np.ones(num)
    if mask is not None:
        w = w * check_mask(mask, num, 0)
    if weights is not None:
        arr = np.asarray(check.float_array(weights, "weights"))
        if arr.shape != (num,):
            raise ValueError(f"`weights` must have shape ({num},), got shape {arr.shape}.")
        if not np.all(np.isfinite(arr)) or np.any(arr < 0):
            raise ValueError("`weights` must be finite and non-negative.")
        w = w * arr
    if window is not None:
        w = w * window_mask(window, times)
    if relative:
        y = np.asarray(y)
        zero = (w > 0) & (y == 0)
        if np.any(zero):
            raise ValueError(
                f"relative residuals divide by y, which is 0 at fitted sample {int(np.argmax(zero))}; "
                "leave that sample out (`window`, `mask`) or use absolute residuals."
            )
        w = w / np.where(w > 0, y, 1.0) ** 2
    return w


def _signs(p_signs, count):
    if p_signs is None:
        return np.zeros(count)
    arr = check.reals(p_signs, "p_signs")
    if arr.shape != (count,) or not np.all(np.isin(arr, (-1.0, 0.0, 1.0))):
        raise ValueError(
            f"`p_signs` must hold {count} values of +1 (≥ 0), −1 (≤ 0) or 0 (free), one per "
            f"coefficient, got {p_signs!r}."
        )
    return arr


def _direct_regressors(direct, num):
    if direct is None:
        return np.zeros((num, 0))
    v = np.asarray(check.samples(direct, "direct"))
    v = v[:, None] if v.ndim == 1 else v
    if v.shape[0] != num:
        raise ValueError(
            f"`direct` must have {num} samples like `u`, got shape {v.shape}."
        )
    return v
