"""The loading protocol that determines the order best: a search over a protocol's
parameters for the smallest predicted band (`fisher_information`'s bound)."""

import jax.numpy as jnp
import numpy as np

from . import _validate as check
from ._design import _check_design, _hats, _jacobian, fisher_information

# the longest test planned: its times and Jacobian columns are held in memory (about 80 MB
# at this length); a longer one is planned on a coarser grid
MAX_SAMPLES = 1_000_000


def optimal_protocol(
    protocol,
    start,
    lower,
    upper,
    order,
    p,
    dt,
    *,
    noise_std,
    knots: int = 1,
    num_samples: int,
    criterion: str = "order",
    x0: bool = True,
    memory: str = "direct",
    order_range=(0.01, 0.99),
    parameter_knots: int | None = None,
    max_steps: int = 200,
):
    """The parameters of a loading protocol that make the order best determined.

    `protocol(params, t)` gives the inputs (N,) or (N, n) at the times ``t = k·dt``
    (k < `num_samples`) for the parameters `params` (k,), written with `jax.numpy` (it is
    differentiated); `start` (k,), or several starts (S, k), and `lower`, `upper` (k,): the
    first guesses and the limits (the search runs on a logistic map of the box, so the
    limits hold exactly). The criterion is ``"order"`` (A-optimal for the order: the mean
    predicted variance of α(t) over the second half of the test) or ``"D"`` (D-optimal: the
    information's log-determinant, every quantity). With `parameter_knots` the parameters are free to drift as in
    `fisher_information` (a gain on the memory term on this many hat functions): the
    protocol that determines the order whatever the parameters do. Minimised by BFGS
    (optimistix) from each start; the best of their ends is returned (a criterion with
    several minima needs several starts).

    **Returns:** ``(params, Design)``: the best parameters found and `fisher_information` of
    the protocol they give (with the same `knots` and `parameter_knots`; with
    ``parameter_knots=8``, ``knots=1`` and `x0`, `Design.expected` is the band the tracker
    is expected to give on it).

    **Raises:** `ValueError` for an argument out of range, or a protocol whose inputs at
    `start` are not finite or not of shape (N,) or (N, n) with one parameter in `p` per input.
    """
    import jax
    import optimistix as optx

    from ._integral import make_memory

    if criterion not in ("order", "D"):
        raise ValueError(f"`criterion` must be 'order' or 'D', got {criterion!r}.")
    lo, hi, x = (np.atleast_1d(check.reals(a, name))
                 for a, name in ((lower, "lower"), (upper, "upper"), (start, "start")))
    if (lo.ndim != 1 or lo.size == 0 or hi.shape != lo.shape or not np.all(lo < hi)
            or x.ndim > 2 or x.shape[-1] != lo.size or x.size == 0):
        raise ValueError("`lower` and `upper` must have one shape (k,), with lower < upper, and "
                         "`start` the shape (k,) or (S, k).")
    x = x.reshape(-1, lo.size)
    if not np.all((lo < x) & (x < hi)):
        raise ValueError("`start` must lie strictly inside (lower, upper).")
    if not (isinstance(num_samples, (int, np.integer)) and not isinstance(num_samples, bool)
            and 4 <= num_samples <= MAX_SAMPLES):
        raise ValueError(f"`num_samples` must be an integer from 4 to {MAX_SAMPLES:,}, got "
                         f"{num_samples!r}.")
    order_range = check.interval(order_range, "order_range")
    max_steps = check.count(max_steps, "max_steps", 1, 100_000)
    check.flag(x0, "x0")
    check.order(order, int(num_samples), bounds=order_range)
    t = float(check.step(dt)) * np.arange(num_samples)
    n = _inputs_at_start(protocol, x[0], t)
    pj, _ = _check_design(p, n, int(num_samples), noise_std, knots, None, parameter_knots)
    noise_std = float(noise_std)  # an integer as large as 2**63 overflows a traced int
    mem = make_memory(memory, float(dt), num_samples, order_range=order_range)
    hats, _ = _hats(t, int(knots))
    drift_hats = (None if parameter_knots is None  # the constant part is p itself
                  else jnp.asarray(_hats(t, int(parameter_knots))[0][:, 1:]))
    half = num_samples // 2
    b = jnp.broadcast_to(jnp.asarray(order, float), (num_samples,))
    hats_j = jnp.asarray(hats)

    def params_of(z):
        return lo + (hi - lo) * jax.nn.sigmoid(z)

    def loss(z, _):
        u = jnp.asarray(protocol(params_of(z), jnp.asarray(t)), float)
        u2 = u.reshape(num_samples, -1)
        jac = _jacobian(mem, u2, b, jnp.asarray(pj), hats_j, x0, drift_hats)
        info = jac.T @ jac / noise_std**2
        scale = jnp.sqrt(jnp.diag(info))
        unit = info / jnp.outer(scale, scale)
        if criterion == "D":
            return -(jnp.linalg.slogdet(unit)[1] + 2 * jnp.sum(jnp.log(scale)))
        cov = jnp.linalg.inv(unit) / jnp.outer(scale, scale)
        k = hats_j.shape[1]
        var = jnp.einsum("ni,ij,nj->n", hats_j[half:], cov[:k, :k], hats_j[half:])
        return jnp.log(jnp.mean(var))

    solver = optx.BFGS(rtol=1e-8, atol=1e-8)
    ends = [optx.minimise(loss, solver, jnp.log((guess - lo) / (hi - guess)),
                          max_steps=max_steps, throw=False).value for guess in x]
    pick = 0
    if len(ends) > 1:  # the best end by the criterion (NaN where a search failed)
        values = np.array([float(loss(z, None)) for z in ends])
        pick = int(np.argmin(np.where(np.isnan(values), np.inf, values)))
    best = np.asarray(params_of(ends[pick]))
    u = np.asarray(protocol(jnp.asarray(best), jnp.asarray(t)), float)
    design = fisher_information(u, order, pj, dt, noise_std=noise_std, knots=knots, x0=x0,
                                memory=memory, order_range=order_range,
                                parameter_knots=parameter_knots)
    return best, design


def _inputs_at_start(protocol, start, t):
    """The number of inputs `protocol` gives at `start`, whose output is checked as `u` is
    (`check.samples`: finite, of shape (N,) or (N, n)) and for the N times `t`."""
    name = "protocol(start, t)"
    try:
        u = check.samples(np.asarray(protocol(jnp.asarray(start), jnp.asarray(t)), float), name)
    except TypeError as err:  # the call itself, or its output not numbers
        raise ValueError(f"`{name}` failed: {err}") from err
    if u.shape[0] != t.size:
        raise ValueError(f"`{name}` must give {t.size} samples (one per time), got {u.shape}.")
    return 1 if u.ndim == 1 else u.shape[1]
