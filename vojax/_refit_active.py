"""The refit's nonlinear fit as it is run: the sign constraints as an active set around the
compiled solve (`_refit_solve._fit`), the padding that lets the laws share one compiled
program, and the restarts of a fit that did not settle."""

import jax.numpy as jnp
import numpy as np

from ._refit_profile import _profile_start
from ._refit_solve import _fit, _hold_worst

# a constant-order fit with fewer integrated inputs or direct regressors than these runs padded
# to them (zero columns, their coefficients held at 0), so that the four laws `compare` fits
# share one compiled program (the springpot, Kelvin–Voigt, Maxwell and Zener laws: 1–2 inputs,
# 0–1 direct regressors); a fit on knots is a program of its own anyway
PAD_INPUTS = 2
PAD_DIRECT = 1
# records longer than this are not padded with inputs: the zero input's scan of the memory
# costs a warm springpot refit about a third more (0.46 s → 0.68 s at 10,000 samples), more
# than one compilation (about 3 s) is worth to a record refitted more than a few times
PAD_INPUTS_UP_TO = 5_000


# the starts, as fractions of `order_bounds`, from which a fit that did not settle is run again
RESTARTS = (0.1, 0.3, 0.5, 0.7, 0.9)


def _settled_fit(mem, u2, v, big_y, sw, signs, num_knots, solver):
    """`_active_set` from `solver`'s start; where that fit did not converge, or its active set
    held every integrated input's coefficient at 0 (the order then moves nothing, and the
    solver stops where it started), it is run again from each of `RESTARTS` and the fit with
    the least weighted sum of squares is kept (the first of equals: the given start's).

    A constant order is then checked against its profile (`_profile_start`): where the
    coefficients alone fit better at another order, the solver stopped short (on a flat
    profile, or in the basin of its start), and it is run again from the profile's best order
    on its face; the fit with the least sum of squares is kept."""
    import optimistix as optx

    width = u2.shape[1]
    sw_np = np.asarray(sw)

    def settled(fit):
        out, active = fit
        return bool(out["result"] == optx.RESULTS.successful) and bool(active[:width].any())

    def rss(fit):
        return float(np.sum((sw_np * fit[0]["residuals"]) ** 2))

    best = _active_set(mem, u2, v, big_y, sw, signs, num_knots, solver)
    lo, hi = solver["bounds"]
    for fraction in () if settled(best) else RESTARTS:
        fit = _active_set(mem, u2, v, big_y, sw, signs, num_knots,
                          dict(solver, order0=lo + fraction * (hi - lo)))
        # a settled fit beats an unsettled one; among equals, the least sum of squares
        if (settled(fit), -rss(fit)) > (settled(best), -rss(best) * (1 - 1e-12)):
            best = fit
    # a constant order: checked against its profile, run again from the profile's best order
    start = None if num_knots > 1 else _profile_start(
        best[0]["profile"], mem, u2, v, big_y, sw, signs, solver, rss(best),
        float(best[0]["order"][0]))
    if start is None:
        return best
    fit = _active_set(mem, u2, v, big_y, sw, signs, num_knots,
                      dict(solver, order0=start[0]), active=start[1])
    return fit if rss(fit) < rss(best) else best


def _active_set(mem, u2, v, big_y, sw, signs, num_knots, solver, pad_direct=None,
                pad_inputs=None, active=None):
    """The nonlinear fit with the sign constraints as an active set: a coefficient whose free
    fit breaks its sign is held at 0 and the rest refitted, one at a time. Returns the fit's
    dictionary (NumPy arrays, the solver's result code) and the active flags (0 where held).

    A constant-order fit is padded with zero columns, their coefficients held at 0, up to
    `pad_inputs` (default `PAD_INPUTS`) integrated inputs (records up to `PAD_INPUTS_UP_TO`
    samples) and `pad_direct` (default `PAD_DIRECT`) direct regressors: the four laws of
    `compare` share one compiled program. `active` (default all 1) starts the active set with
    those coefficients held."""
    u_pad, v_pad, real = _padded(u2, v, num_knots, pad_inputs, pad_direct)
    wide, deep = u_pad.shape[1], v_pad.shape[1]
    active = np.ones(signs.size) if active is None else np.array(active, float)
    dtype = big_y.dtype
    while True:
        padded = np.zeros(wide + deep)
        padded[real] = active
        out = _fit(
            mem, u_pad, v_pad.astype(dtype), big_y, sw, padded.astype(dtype),
            np.asarray(solver["order0"], dtype), num_knots, solver["bounds"],
            solver["estimate"], np.asarray(solver["rtol"], dtype),
            np.asarray(solver["atol"], dtype), solver["max_steps"], solver["throw"],
        )
        # on the host from here (an eager JAX operation compiles a program of its own)
        out = {k: (v_ if k in ("result", "profile") else np.asarray(v_))
               for k, v_ in out.items()}
        out["p"], out["p_stderr"] = out["p"][real], out["p_stderr"][real]
        # the profile's grid (a constant order; else empty), with where the real columns
        # sit in it (the offset last)
        offset = np.arange(wide + deep, wide + deep + 1) if solver["estimate"] else []
        out["profile"] = (*out["profile"], np.r_[real, offset].astype(int))
        out["p_cov"] = out["p_cov"][np.ix_(real, real)]
        se = np.maximum(out["p_stderr"], np.finfo(float).tiny)
        if not _hold_worst(active, signs, out["p"], se):
            return out, active


def _padded(u2, v, num_knots, pad_inputs=None, pad_direct=None):
    """`u2` and `v` padded with zero columns as `_active_set` says, and where each real
    coefficient sits among the padded ones (the inputs', then the direct regressors')."""
    pad_direct = PAD_DIRECT if pad_direct is None else pad_direct
    pad_inputs = PAD_INPUTS if pad_inputs is None else pad_inputs
    n_all, width = u2.shape
    wide = max(width, pad_inputs) if num_knots == 1 and n_all <= PAD_INPUTS_UP_TO else width
    deep = max(v.shape[1], pad_direct) if num_knots == 1 else v.shape[1]
    u_pad = u2 if wide == width else jnp.asarray(
        np.concatenate([np.asarray(u2), np.zeros((n_all, wide - width))], axis=1), u2.dtype)
    v_pad = np.concatenate([np.asarray(v), np.zeros((n_all, deep - v.shape[1]))], axis=1)
    return u_pad, v_pad, np.r_[np.arange(width), wide + np.arange(v.shape[1])]
