"""Moving orders in the trade-off. Where a constant order outside the band fits the data with
some drift of the parameters (the breakdown drift of `vojax._tracker._band`), an order that
moves may need less: the breakdown drift is the least over both.

The order is taken piecewise linear on the drift's `trade_knots` coarse knots, its second
half's mean placed just outside the band (`moving_offsets`). Its shape is fitted by
Levenberg–Marquardt while the drifting parameters are solved for at each shape by penalised
least squares (variable projection, its Jacobian exact: `penalised_jacobian`); the penalty
on their drift is raised, as in `least_drift`, while the χ² stays within `trade_chi2` of the
best fit of the moving orders (or of the constant ones, where that is lower). The moves of
the answer itself keep a shape fitted to these data, which lowered their best fit: that
best is first raised by the freedom the answer's drifts fit (`moving_limit`). The memory
columns at a moving order are interpolated across the profiled constant orders (4-point
Lagrange): the order acts where the memory is evaluated, so sample i's column at a
trajectory is its column at the constant order the trajectory has there.
"""

import numpy as np

from ._band import outside
from ._explanations import Explanation, relative_drift
from ._model import beta_of_np
from ._trade import gain_design, penalised_system, refinement

LADDER = 10.0 ** np.arange(-6.0, 5.0)  # penalties on the drift tried, in its unit, rising
TARGET_WEIGHT = 1e3  # the second half's mean held at its target: 1e-3 off costs χ² 1
LM_ITERATIONS = 15  # Levenberg–Marquardt iterations of one shape fit
LM_TOL = 0.05  # … ending where a step lowers the χ² by less than this


def columns_at(profile, alpha, columns=slice(None), slopes=False):
    """The memory columns (N, n + n·k) at the order trajectory `alpha` (N,), or those of
    `columns`: each sample's from the four profiled constant orders about its order
    (Lagrange), the trajectory kept within the profiled range. ``slopes=True``: also their
    derivatives with respect to each sample's order (the interpolant's; 0 where the
    trajectory is held at the range's ends)."""
    grid = profile.alphas
    h = grid[1] - grid[0]
    a = np.clip(alpha, grid[0], grid[-1])
    j = np.clip(np.floor((a - grid[0]) / h).astype(int) - 1, 0, grid.size - 4)
    x = (a - grid[j]) / h
    rows = np.arange(a.size)
    d = [x - node for node in range(4)]
    memory = profile.memory[:, :, columns]
    out, slope = 0.0, 0.0
    for m in range(4):
        o = [node for node in range(4) if node != m]
        w = d[o[0]] / (m - o[0]) * (d[o[1]] / (m - o[1])) * (d[o[2]] / (m - o[2]))
        near = memory[j + m, rows]
        out = out + w[:, None] * near
        if slopes:  # d w / d x: the product rule over the three factors
            f = [d[q] / (m - q) for q in o]
            dw = f[1] * f[2] / (m - o[0]) + f[0] * f[2] / (m - o[1]) + f[0] * f[1] / (m - o[2])
            slope = slope + dw[:, None] * near
    if not slopes:
        return out
    held = (alpha < grid[0]) | (alpha > grid[-1])
    return out, np.where(held[:, None], 0.0, slope / h)


def design(profile, alpha, level, form, slopes=False):
    """The design (N, n·k) of the drifting parameters at the order trajectory `alpha`: on the
    coarse (`level` 0) or the fine hat functions, as a gain on the memory term (`form` 0) or
    inside the integral (see `vojax._tracker._trade.drift_profile`). ``slopes=True``: also
    its derivative with respect to each sample's order (the design is linear in the memory
    columns)."""
    num, width = profile.memory.shape[1:]
    k = profile.bases[1].shape[1]
    n = width // (k + 1)
    if form == 0:
        both = columns_at(profile, alpha, slice(0, n), slopes)
        return _maybe(slopes, both, lambda c: gain_design(c, profile.bases[level]))

    def inside(c):
        c = c.reshape(num, n, k)
        if level == 0:
            c = c @ refinement(profile.settings.trade_knots)
        return c.reshape(num, -1)

    return _maybe(slopes, columns_at(profile, alpha, slice(n, None), slopes), inside)


def _maybe(slopes, both, linear):
    """`linear` applied to the columns, or to the columns and their slopes."""
    return (linear(both[0]), linear(both[1])) if slopes else linear(both)


def system_of(profile, x, level):
    """`penalised_system` of the design `x` on `level`'s hat functions, with the profile's
    data, mask, whitener and offset."""
    return penalised_system(x, profile.y, profile.mask, profile.bases[level].shape[1],
                            profile.whiten, profile.offset)


def penalised_fit(profile, x, level, lam, drift=True, system=None):
    """The drifting parameters' penalised least squares on the design `x` at the penalty
    `lam`: ``(residuals, χ², drift)``, the residuals (whitened, × √scale) with the penalty's
    rows appended (their squares sum to the penalised objective), the χ² of the data alone,
    and the parameters' relative drift over the fitted span (``drift=False``: None, for the
    shape fit's residuals). `system`: `system_of` the design, where already built."""
    basis = profile.bases[level]
    k = basis.shape[1]
    n = x.shape[1] // k
    a_mat, b, penalty, unit = system_of(profile, x, level) if system is None else system
    coef = np.linalg.lstsq(a_mat.T @ a_mat + lam * unit * penalty, a_mat.T @ b, rcond=None)[0]
    res = (b - a_mat @ coef) * np.sqrt(profile.scale)
    steps = np.concatenate([np.diff(coef[j * k : (j + 1) * k]) for j in range(n)])
    rows = np.sqrt(lam * unit * profile.scale) * steps
    if not drift:
        return np.concatenate([res, rows]), float(res @ res), None
    params = np.stack([basis @ coef[j * k : (j + 1) * k] for j in range(n)], axis=1)
    return np.concatenate([res, rows]), float(res @ res), relative_drift(params, profile.span)


def penalised_jacobian(profile, x, dx, level, lam, system=None):
    """The derivatives (R, m) of `penalised_fit`'s residuals (``drift=False``) with respect
    to m parameters of the design, given its derivatives `dx` (m, N, n·k): the coefficients
    differentiated through their normal equations, the penalty's unit through the columns'
    trace (variable projection, exact). `system`: as in `penalised_fit`."""
    k = profile.bases[level].shape[1]
    a_mat, b, penalty, unit = system_of(profile, x, level) if system is None else system
    da = dx
    if profile.offset:
        da = np.concatenate([da, np.zeros(da.shape[:2] + (1,))], axis=2)
    if profile.whiten is not None:  # the whitener runs along the samples
        da = np.moveaxis(profile.whiten(np.moveaxis(da, 0, 1)), 1, 0)
    da = da * np.sqrt(np.asarray(profile.mask, float))[None, :, None]  # (m, N, W)
    mat = a_mat.T @ a_mat + lam * unit * penalty
    coef = np.linalg.lstsq(mat, a_mat.T @ b, rcond=None)[0]
    dunit = unit * 2.0 * (da.reshape(da.shape[0], -1) @ a_mat.ravel()) / np.sum(a_mat**2)
    cross = np.matmul(a_mat.T, da).transpose(0, 2, 1)  # (m, W, W): dAᵀ A
    dmat = cross + cross.transpose(0, 2, 1) + lam * dunit[:, None, None] * penalty
    rhs = (b @ da - dmat @ coef).T  # (W, m)
    dcoef = np.linalg.lstsq(mat, rhs, rcond=None)[0]
    dres = -((da @ coef).T + a_mat @ dcoef) * np.sqrt(profile.scale)
    n = x.shape[1] // k

    def steps(c):  # each input's coefficients' first differences, as in `penalised_fit`
        return np.concatenate([np.diff(c[j * k : (j + 1) * k], axis=0) for j in range(n)])

    root = np.sqrt(lam * unit * profile.scale)
    slope = np.sqrt(lam * profile.scale) * dunit / (2.0 * np.sqrt(unit)) if lam > 0 else 0.0
    drows = slope * steps(coef)[:, None] + root * steps(dcoef)
    return np.concatenate([dres, drows])


def _at_shape(profile, shape, theta, level, form, base, lo, hi):
    """The design, its slopes and `system_of` it at the shape `theta` (the order ``base +
    shape @ theta``, kept within the profiled orders [`lo`, `hi`])."""
    x, dx = design(profile, np.clip(base + shape @ theta, lo, hi), level, form, slopes=True)
    return x, dx, system_of(profile, x, level)


def _last(fn):
    """`fn` of one array, its last answer kept: the shape fit asks for the residuals and
    then, where the step is taken, for the Jacobian at the same θ."""
    kept = []

    def call(theta):
        key = np.asarray(theta).tobytes()
        if not kept or kept[0] != key:
            kept[:] = [key, fn(theta)]
        return kept[1]

    return call


def levenberg(fun, jac, theta, lo, hi, iterations=LM_ITERATIONS, tol=LM_TOL):
    """Levenberg–Marquardt on the residuals `fun` (θ), their Jacobian `jac` (θ), from
    `theta`, every θ kept within [`lo`, `hi`]: at most `iterations` steps, ending where a
    step lowers the squared residuals by less than `tol` (χ² units in the shape fit)."""
    theta = np.clip(theta, lo, hi)
    r = fun(theta)
    cost, mu = float(r @ r), 1e-2
    for _ in range(iterations):
        j = jac(theta)
        grad, hess = j.T @ r, j.T @ j
        for _ in range(8):
            damped = hess + mu * np.diag(np.diag(hess) + 1e-12)
            trial = np.clip(theta - np.linalg.lstsq(damped, grad, rcond=None)[0], lo, hi)
            r_trial = fun(trial)
            if float(r_trial @ r_trial) < cost:
                break
            mu *= 10.0
        else:
            break  # no step lowers the cost
        gain = cost - float(r_trial @ r_trial)
        theta, r, cost, mu = trial, r_trial, float(r_trial @ r_trial), mu / 10.0
        if gain < tol:
            break
    return theta


def moving_orders(profile, band, half, stated=False, freedom=np.nan):
    """Moving orders outside `band` ``(alpha, lower, upper, std)`` (the conditional band; its
    second half from `half`) that fit the data with the least drift of the parameters each
    form of the trade-off profile allows: `Explanation` s of kind "moving". Each is a move of
    the answer's projection on the order's hats, or with `moving_base` of the answer itself
    (the part of its shape the hats cannot follow, a step, kept under every move), or
    ``"both"``: each search's orders; ``"stated"``: both where the call states the
    parameters (`stated`: constant or a drift bound), else the projection's. `freedom`: the
    freedom the answer's drifts fit (its smoothing's `Explanation.freedom`; NaN unknown),
    the slack its own moves get with ``moving_limit="freedom"``."""
    band, theta0, answer = start_of(profile, band)
    projected = np.zeros_like(answer)
    mode = profile.settings.moving_base
    if mode == "stated":
        mode = "both" if stated else False
    bases = {False: [projected], True: [answer], "both": [projected, answer]}[mode]
    return [e for base in bases for row in profile.forms
            for e in _moves(profile, band, half, theta0, base, row,
                            freedom if base is answer else None)]


def start_of(profile, band):
    """Where `moving_orders` starts: `band` on the fitted span, the answer's projection on
    the order's hats (their weights θ₀) and the part of the answer they cannot follow (N,),
    0 beyond the span."""
    span, shape = profile.span, profile.shape
    band = tuple(np.asarray(a)[:span] for a in band)
    theta0 = np.linalg.lstsq(shape[:span], band[0], rcond=None)[0]
    answer = np.zeros(shape.shape[0])
    answer[:span] = band[0] - shape[:span] @ theta0
    return band, theta0, answer


def _slack(limit, freedom, hats):
    """What `_moves` adds to the search's own best fit before it takes the lower of that and
    the form's best constant-order fit (`moving_limit` `limit`): 0 for the projection's moves
    (`freedom` None) and with ``"own"``; for the answer's, with ``"freedom"``, the freedom its
    drifts fit less the `hats`' (0 where unknown), with ``"trade"`` ∞ (the constant orders'
    fit alone)."""
    if freedom is None or limit == "own":
        return 0.0
    if limit == "trade":
        return np.inf
    return max(freedom - hats, 0.0) if np.isfinite(freedom) else 0.0


def _moves(profile, band, half, theta0, base, form_row, freedom=None):
    """`moving_orders` moved from the hats' shape `theta0`, the order ``base + shape @ θ``, in
    one form of the trade-off profile (`form_row`: its level, form, best χ² and dof): the
    targets are set on the hats' part of the second half's mean order, `base`'s part kept.
    The moves fit within `trade_chi2` of the search's own best fit where that is below the
    form's best constant-order fit, else of the latter. `freedom`: where `base` is the
    answer's shape (fitted to these data), the freedom its drifts fit (NaN unknown; None:
    `base` is no answer's). With ``moving_limit="freedom"`` the search's own best is raised
    by that freedom less the hats' (the search fits those itself): about the χ² by which
    fitting it lowered the answer's own; with ``"trade"`` the form's best alone is the bar."""
    s, span, shape = profile.settings, profile.span, profile.shape
    lo, hi = float(profile.alphas[0]), float(profile.alphas[-1])
    weights = shape[half:span].mean(axis=0)  # θ ↦ the second half's mean order (hats' part)
    kept = base[half:span].mean()
    edges = ((-1.0, band[1][half:].mean() - kept), (1.0, band[2][half:].mean() - kept))
    level, form, best, dof = form_row
    found = []
    at = _last(lambda theta: _at_shape(profile, shape, theta, level, form, base, lo, hi))

    def fit(theta, lam, drift=True):
        x, _, system = at(theta)
        return penalised_fit(profile, x, level, lam, drift, system)

    def jac(theta, lam):  # the order at sample i moves with θ_j as shape[i, j]
        x, dx, system = at(theta)
        return penalised_jacobian(profile, x, dx[None] * shape.T[:, :, None], level, lam,
                                  system)

    bar = best  # the form's best constant-order fit, or the search's own best raised by
    slack = _slack(s.moving_limit, freedom, shape.shape[1])  # its slack where lower
    if np.isfinite(slack):  # ("trade": ∞, its own best not fitted)
        free = levenberg(lambda th: fit(th, 0.0, False)[0], lambda th: jac(th, 0.0), theta0,
                         lo, hi)
        bar = min(best, fit(free, 0.0, False)[1] + slack)
    limit = bar + s.trade_chi2
    for sign, edge in edges:
        for offset in s.moving_offsets:
            target = edge + sign * offset  # the hats' part of the second half's mean
            if not lo < target + kept < hi:  # the order's own mean there
                continue
            theta, least = np.clip(theta0 + target - weights @ theta0, lo, hi), None
            for lam in LADDER:
                def resid(th, lam=lam, target=target):
                    return np.append(fit(th, lam, False)[0],
                                     TARGET_WEIGHT * (weights @ th - target))

                def resid_jac(th, lam=lam):
                    return np.vstack([jac(th, lam), TARGET_WEIGHT * weights])

                theta = levenberg(resid, resid_jac, theta, lo, hi)
                alpha = np.clip(base + shape @ theta, lo, hi)
                _, chi2, drift = fit(theta, lam)
                if chi2 > limit:
                    break
                if outside(alpha[:span], band, half):
                    least = (alpha, chi2, drift)
            if least is not None:
                alpha, chi2, drift = least
                beta = beta_of_np(alpha, profile.bounds)
                found.append(Explanation("moving", beta, np.zeros_like(beta), chi2, dof,
                                         np.nan, drift, accepted=True))
    return found
