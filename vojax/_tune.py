"""`tune_gains`: choose the order gain γ and forgetting factor λ from the data alone."""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jax import lax

from . import _validate as check
from ._adaptive._build import DEFAULT_BOUNDS, assemble_law
from ._integral import make_memory
from ._validate import check_options

TRACES = {"tune": 0}
# the refinement differentiates through the law in blocks of samples, each block checkpointed:
# reverse mode keeps one law state per block and the states of one block, not one per sample
BLOCK = 1024
MAX_GRID = 200  # the most points of the γ or λ grid (each grid point is a run of the law)
GAMMA_DECADES = (-2.0, 4.0)  # the γ grid: 10^-2…10^4 of 1/(mean((y−x0)²)·T), T the record's span


def _block(num: int) -> int:
    """The block length for a record of `num` samples: `BLOCK`, or the record when shorter."""
    return min(BLOCK, num)


class _TuneData(eqx.Module):
    """One record as the tuner sees it; arrays only, so that one compiled program serves
    every record of the same (padded) length."""

    memory: eqx.Module
    u: jax.Array  # (N, n), padded after the end
    y: jax.Array  # (N,) y − x0, padded
    weights: jax.Array  # (N,) 1 on the predicted samples, 0 on burn-in and padding
    lag: jax.Array  # D, samples
    r0: jax.Array
    dt: jax.Array
    alpha0: jax.Array
    bounds: tuple[float, float] = eqx.field(static=True)
    ring: int = eqx.field(static=True)  # ≥ max(D, block): the p̂'s the grid's loss keeps


def _law(log_gamma, log_lam, data: _TuneData):
    return assemble_law(
        data.memory, data.dt, jnp.exp(log_lam), jnp.exp(log_gamma), data.alpha0, data.bounds,
        data.r0,
    )


def _lagged_loss(log_gamma, log_lam, data: _TuneData):
    """Mean of ``(y_k − p̂_{k−D}ᵀφ_k)²`` over the weighted samples, over the mean of ``y_k²``.

    For differentiation: the law runs in checkpointed blocks of `BLOCK` samples, so reverse mode
    stores a law state per block (and one block's states at a time), and only ``p̂`` and ``φ``
    per sample."""
    law = _law(log_gamma, log_lam, data)
    num, width = data.u.shape
    size = _block(num)
    blocks = -(-num // size)
    extra = blocks * size - num  # zero inputs after the end: the law is causal
    u = jnp.concatenate([data.u, jnp.zeros((extra, width), data.u.dtype)])
    y = jnp.concatenate([data.y, jnp.zeros((extra,), data.y.dtype)])

    def step(state, sample):
        state, out = law.step(state, *sample)
        return state, (out.p, out.phi)

    @jax.checkpoint
    def block(state, samples):
        return lax.scan(jax.checkpoint(step), state, samples)

    shape = lambda a: a.reshape(blocks, size, *a.shape[1:])  # noqa: E731
    _, (p, phi) = lax.scan(block, law.init(width), (shape(u), shape(y)))
    p, phi = p.reshape(-1, width)[:num], phi.reshape(-1, width)[:num]
    # p̂ of D samples earlier; the rows rolled round from the end have zero weight (k < D)
    pred = jnp.sum(jnp.roll(p, data.lag, axis=0) * phi, axis=1)
    w = data.weights
    return jnp.sum(w * (pred - data.y) ** 2) / jnp.sum(w * data.y**2)


def _streamed_loss(log_gamma, log_lam, data: _TuneData):
    """`_lagged_loss` accumulated block by block, for the grid (no derivative): the law runs in
    blocks of `BLOCK` samples, and between blocks only the last `ring` estimates p̂ are kept, so
    memory does not grow with the record (and the per-sample loop carries the law's state only)."""
    law = _law(log_gamma, log_lam, data)
    num, width = data.u.shape
    length = _block(num)
    blocks = -(-num // length)
    extra = blocks * length - num  # zero weight after the end
    pad = lambda a: jnp.concatenate([a, jnp.zeros((extra, *a.shape[1:]), a.dtype)])  # noqa: E731
    shape = lambda a: pad(a).reshape(blocks, length, *a.shape[1:])  # noqa: E731
    size = data.ring

    def step(state, sample):
        state, out = law.step(state, *sample)
        return state, (out.p, out.phi)

    def block(carry, samples):
        state, ring, total, start = carry
        u_b, y_b, w_b = samples
        state, (p, phi) = lax.scan(step, state, (u_b, y_b))
        k = start + jnp.arange(length, dtype=start.dtype)
        back = k - data.lag  # the sample whose p̂ predicts sample k
        own = jnp.clip(back - start, 0, length - 1)
        lagged = jnp.where(
            (back >= start)[:, None], p[own], ring[jnp.mod(back, size)]
        )
        lagged = jnp.where((back >= 0)[:, None], lagged, 0.0)
        total = total + jnp.sum(w_b * (jnp.sum(lagged * phi, axis=1) - y_b) ** 2)
        ring = ring.at[jnp.mod(k, size)].set(p)  # size ≥ the block: no index repeats
        return (state, ring, total, start + length), None

    ring = jnp.zeros((size, width), data.u.dtype)
    zero = jnp.zeros((), data.y.dtype)
    start = jnp.zeros((), data.lag.dtype)
    (_, _, total, _), _ = lax.scan(
        block, (law.init(width), ring, zero, start),
        (shape(data.u), shape(data.y), shape(data.weights)),
    )
    w = data.weights
    return total / jnp.sum(w * data.y**2)


@eqx.filter_jit
def _grid_losses(data: _TuneData, log_gammas, log_lams):
    TRACES["tune"] += 1
    return jax.vmap(_streamed_loss, in_axes=(0, 0, None))(log_gammas, log_lams, data)


@eqx.filter_jit
def _refine(data: _TuneData, z0, ref, free, fixed, steps: int):
    """BFGS from ``z0`` in coordinates relative to ``ref``; returns ``(log γ, log λ)`` and the loss."""
    import optimistix as optx  # imported where it is used: 0.07 s of `import vojax`

    TRACES["tune"] += 1

    def absolute(z):  # relative coordinates → (log γ, log λ)
        return free * (z + ref) + fixed

    solution = optx.minimise(
        lambda z, d: _lagged_loss(*absolute(z), d),
        optx.BFGS(rtol=1e-4, atol=1e-6),
        z0,
        args=data,
        max_steps=steps,
        throw=False,
    )
    z = absolute(solution.value)
    return z, _lagged_loss(z[0], z[1], data)


class Gains(eqx.Module):
    """Result of `tune_gains`: the chosen ``gamma`` and ``lam``, the prediction error ``loss``
    there, and the coarse grid that was searched (``grid_gamma``, ``grid_lam``, ``grid_loss``)."""

    gamma: float
    lam: float
    loss: float
    grid_gamma: np.ndarray
    grid_lam: np.ndarray
    grid_loss: np.ndarray
    refined: bool
    at_edge: tuple[str, ...] = ()


def tune_gains(
    u,
    y,
    dt=None,
    *,
    t=None,
    alpha0=0.5,
    alpha_bounds=DEFAULT_BOUNDS,
    memory: str = "exponential",
    rule: str = "trapezoid",
    x0=None,
    r0="auto",
    lam=None,
    tol: float = 1e-10,
    burn_in: float = 0.1,
    lag: float = 0.1,
    num_gamma: int = 13,
    num_lam: int = 8,
    refine_steps: int = 20,
    pad_to: int | None = None,
) -> Gains:
    """Picks ``(γ, λ)`` by minimising the identifier's lagged output prediction error.

    The loss is the mean of ``(y_k − p̂_{k−D}ᵀ φ(α̂_k, t_k))²`` over the record after its first
    `burn_in` fraction, normalised by the mean of ``(y − x0)²``, with ``D`` the `lag` fraction
    of the record (10 % by default). Each sample is predicted with parameters that have not seen
    it, so fitting the noise is not rewarded; and the lag matters: with fast forgetting, p̂ moves
    to absorb a wrong order (order and parameters compensate), which a one-step prediction
    cannot see but a prediction ``D`` samples ahead can. A coarse grid comes first (``γ`` over six decades,
    1e-2 to 1e4 of ``1/(mean((y−x0)²)·T)``, the scale at which ``γ Λ e`` moves the order by
    O(1) over the record's span ``T``, so that the search is the same in any units; ``λ`` from
    ``0.3/T`` to ``0.3/dt`` (the median step on a grid `t`), or the given `lam` alone), all runs in one vmapped scan. From the best grid point,
    BFGS on ``(log γ, log λ)`` with ``jax.grad`` through the checkpointed scan refines it; the
    refinement is kept only when it lowers the loss. Starting from the grid keeps the search out
    of the chattering region, where the loss is large and its gradient meaningless.

    **Arguments:** as `identify` (less `gamma` and `lam`), plus the grid sizes and the number of
    refinement steps (0 to skip). `pad_to`: run on the record padded to this many samples
    (the loss weighs only the real ones), so that records of different lengths share one
    compiled program; the result equals the unpadded one to the memory's accuracy.

    **Returns:** a `Gains`.
    """
    search = _prepare(
        u, y, dt, t=t, alpha0=alpha0, alpha_bounds=alpha_bounds, memory=memory, rule=rule, x0=x0,
        r0=r0, lam=lam, tol=tol, burn_in=burn_in, lag=lag, num_gamma=num_gamma,
        num_lam=num_lam, pad_to=pad_to,
    )
    grid = _grid_losses(search.data, *search.grid_arrays())
    z0, ref, free, fixed = search.start(np.asarray(grid))
    refined = _refine(search.data, z0, ref, free, fixed, int(refine_steps)) if refine_steps > 0 else None
    return search.choose(np.asarray(grid), refined)


class _Search(eqx.Module):
    """A record prepared for the search: its data, its grid, and what the choice needs."""

    data: _TuneData
    log_gammas: np.ndarray  # (num_gamma, num_lam) grid of ln γ
    log_lams: np.ndarray
    gammas: np.ndarray  # the grid's axes
    lams: np.ndarray
    scale: float
    lam_given: bool = eqx.field(static=True)

    def grid_arrays(self):
        return jnp.asarray(self.log_gammas.ravel()), jnp.asarray(self.log_lams.ravel())

    def _best(self, grid):
        """The grid shaped (γ, λ) with non-finite losses as +∞, and its best point's index."""
        grid = np.where(np.isfinite(grid), grid, np.inf).reshape(self.log_gammas.shape)
        return grid, np.unravel_index(np.argmin(grid), grid.shape)

    def start(self, grid):
        """BFGS's start (the best grid point), in coordinates relative to the data's scale (so
        the search does not depend on the units of u and y); λ is tuned only when not given."""
        _, (i, j) = self._best(grid)
        best = np.array([self.log_gammas[i, j], self.log_lams[i, j]])
        ref = np.array([np.log(self.scale), 0.0])
        free = np.array([1.0, 0.0 if self.lam_given else 1.0])
        fixed = (1.0 - free) * best
        return tuple(jnp.asarray(a) for a in (best - ref, ref, free, fixed))

    def choose(self, grid, refined) -> Gains:
        """The best grid point, or the refinement when it lowers the loss inside the box."""
        g, lm = self.log_gammas, self.log_lams
        grid, (i, j) = self._best(grid)
        best = (float(g[i, j]), float(lm[i, j]))
        best_loss = float(grid[i, j])
        done = False
        if refined is not None:
            z, value = np.asarray(refined[0]), float(refined[1])
            # stay within the searched box: the gradient may point out of it in flat regions
            inside = g.min() <= z[0] <= g.max() and lm.min() <= z[1] <= lm.max()
            if np.isfinite(value) and value < best_loss and inside:
                best, best_loss, done = (float(z[0]), float(z[1])), value, True
        edge = 0.05 * np.log(10.0)  # within 5 % of a decade of the box's edge
        at_edge = tuple(
            name
            for name, v, axis in (("gamma", best[0], g), ("lam", best[1], lm))
            if axis.max() > axis.min() and min(v - axis.min(), axis.max() - v) < edge
        )
        return Gains(
            gamma=float(np.exp(best[0])),
            lam=float(np.exp(best[1])),
            loss=best_loss,
            grid_gamma=self.gammas,
            grid_lam=self.lams,
            grid_loss=grid,
            refined=done,
            at_edge=at_edge,
        )


def _prepare(
    u, y, dt, *, t=None, alpha0=0.5, alpha_bounds=DEFAULT_BOUNDS, memory="exponential",
    rule="trapezoid", x0=None, r0="auto", lam=None, tol=1e-10, burn_in=0.1, lag=0.1,
    num_gamma=13, num_lam=8, pad_to=None,
) -> _Search:
    """Validates a record and lays out its search (host side, in NumPy)."""
    from ._adaptive._build import nominal_step

    u2, y, bounds, x0, r0 = check_options(
        u, y, dt, lam, alpha0, alpha_bounds, memory, rule, x0, r0, t=t
    )
    if t is not None and pad_to is not None:
        raise ValueError("`pad_to` pads a uniform record; it cannot be used with `t`.")
    if isinstance(lam, str):  # the law's own check lets text through for `LawEstimator`'s
        raise ValueError(f"`lam` must be a positive number or None, got {lam!r}.")
    burn_in, lag = check.real(burn_in, "burn_in"), check.real(lag, "lag")
    if not 0 <= burn_in < 1:
        raise ValueError(f"`burn_in` must be in [0, 1), got {burn_in}.")
    if not 0 <= lag < 0.5:
        raise ValueError(f"`lag` must be in [0, 0.5), got {lag}.")
    num_gamma = check.count(num_gamma, "num_gamma", 2, MAX_GRID)
    num_lam = check.count(num_lam, "num_lam", 2, MAX_GRID)
    u2, y, x0 = np.asarray(u2), np.asarray(y), float(x0)
    n = u2.shape[0]
    big_y = y - x0
    d = max(1, int(round(lag * n)))
    start = max(int(burn_in * n), d)
    if n - start < 2:
        raise ValueError(f"the record is too short to tune gains: {n} samples.")
    scale = 1.0 / max(float(np.mean(big_y**2)), 1e-300)
    step = nominal_step(dt, t)
    horizon = max((n - 1) * step if t is None else float(np.ptp(np.asarray(t))), step)
    # padded to `pad_to` samples (after the end: the law is causal, so the real samples'
    # outputs do not see the padding) with the loss weighted to the real samples: one
    # compiled program serves every record length of a bucket
    size = n if pad_to is None else int(pad_to)
    if size < n:
        raise ValueError(f"`pad_to` ({size}) is shorter than the record ({n} samples).")
    weights = np.zeros(size)
    weights[start:n] = 1.0
    mem = make_memory(memory, dt, size, rule=rule, tol=tol, order_range=bounds, times=t)
    u_padded = np.concatenate([u2, np.zeros((size - n, u2.shape[1]))])
    if isinstance(r0, str):
        from ._adaptive._build import auto_r0

        r0 = auto_r0(u_padded, step, alpha0, memory, rule, tol, bounds, num=n, mem=mem)
    data = _TuneData(
        memory=mem,
        u=jnp.asarray(u_padded),
        y=jnp.asarray(np.concatenate([big_y, np.zeros(size - n)])),
        weights=jnp.asarray(weights, u2.dtype),
        lag=jnp.asarray(d),
        r0=jnp.asarray(r0, u2.dtype),
        dt=jnp.asarray(step, u2.dtype),
        alpha0=jnp.asarray(alpha0, u2.dtype),
        bounds=bounds,
        ring=max(int(np.ceil(lag * size)), _block(size)),
    )
    # γ Λ e moves the order by O(γ·mean((y−x0)²)·T) over the record's span T: the box is
    # 1e-2…1e4 of that, so it does not depend on the units of y or of time
    gammas = scale / horizon * np.logspace(*GAMMA_DECADES, num_gamma)
    # forgetting horizons from 3 records (no forgetting) to 3 samples
    lams = np.geomspace(0.3 / horizon, 0.3 / step, num_lam) if lam is None else np.array([float(lam)])
    g, lm = np.meshgrid(np.log(gammas), np.log(lams), indexing="ij")
    return _Search(data, g, lm, gammas, lams, scale / horizon, lam is not None)
