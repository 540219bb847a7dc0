"""Sum-of-exponentials memory: O(M) state and work per sample (docs/method.md §4).

    (t−τ)^{b−1}/Γ(b) = sin(πb)/π ∫_0^∞ s^{−b} e^{−s(t−τ)} ds ≈ Σ_j c_j(b) e^{−s_j (t−τ)}

with McLean's substitution ``s = exp(x − e^{−x})/T`` and the trapezoid rule in ``x``. The modes
``s_j`` do not depend on ``b``; only the readout weights ``c_j(b)`` do, so one set of modal
states serves every order in the design range. The last step is integrated exactly with the
product weights at the current order; the modes carry the older history, whose lags are ≥ h.
"""

import functools
import math

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jax import lax
from jaxtyping import Array, Float, Int

from .._xla import to_device
from ._base import AbstractMemory
from ._special import digamma, lgamma
from ._weights import TRAPEZOID, end_weights, log_norm

DEFAULT_TOL = 1e-10
DEFAULT_ORDER_RANGE = (0.01, 0.99)
# largest order-free history (samples × modes × inputs) stored whole for repeated readouts:
# 2^23 numbers, 64 MB; longer records are scanned sample by sample at every evaluation instead
HISTORY_LIMIT = 2**23


def _solve_x(target: float) -> float:
    """Solves ``x − e^{−x} = target`` (the map is increasing) by bisection."""
    lo, hi = -50.0, max(target, 0.0) + 50.0
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if mid - math.exp(-mid) < target:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


def _phi1(x, xp=np):
    """``(1 − e^{−x})/x``, accurate for small ``x`` (``xp``: NumPy on the host, or jax.numpy)."""
    small = x <= 1e-8
    return xp.where(small, 1.0 - x / 2, -xp.expm1(-x) / xp.where(small, 1.0, x))


def _phi2(x, xp=np):
    """``(1 − e^{−x}(1+x))/x² = ∫_0^1 v e^{−xv} dv``, by its series below 0.5."""
    big = x >= 0.5
    xb = xp.where(big, x, 1.0)
    direct = (-xp.expm1(-xb) - xb * xp.exp(-xb)) / xb**2
    xs = xp.where(big, 0.0, x)
    series = xp.zeros_like(x)
    term = xp.ones_like(x)
    for n in range(20):
        series = series + term / (n + 2)
        term = term * (-xs) / (n + 1)
    return xp.where(big, direct, series)


def modal_weights(s, h, rule: str, xp=np):
    """Exact weights ``(w_prev, w_cur)`` of ``u_{k−1}`` and ``u_k`` in the modal history over one
    step ``[t_{k−1}, t_k]`` of length ``h``: ``∫ e^{−s(t_k−τ)} u(τ) dτ`` with ``u`` linear
    (trapezoid) or held at ``u_{k−1}`` (rectangle)."""
    x = s * h
    if rule == TRAPEZOID:
        w_prev = h * _phi2(x, xp)
        return w_prev, h * _phi1(x, xp) - w_prev
    return h * _phi1(x, xp), xp.zeros_like(x)


def _kernel_error(log_s, log_q, orders, lags):
    """Worst relative error of the modal kernel and of its b-derivative over the given grid."""
    b = orders[:, None, None]
    t = lags[None, :, None]
    c = np.sin(np.pi * b) / np.pi * np.exp(log_q + (1.0 - b) * log_s - np.exp(log_s) * t)
    approx = c.sum(-1)
    dapprox = ((np.pi / np.tan(np.pi * b) - log_s) * c).sum(-1)
    lg = lgamma(orders)[:, None]
    exact = np.exp((orders[:, None] - 1.0) * np.log(lags[None, :]) - lg)
    psi = digamma(orders)[:, None]
    dexact = exact * (np.log(lags[None, :]) - psi)
    err = np.max(np.abs(approx - exact) / exact)
    derr = np.max(np.abs(dapprox - dexact) / np.abs(exact))
    return float(err), float(derr)


def design_modes(
    dt: float,
    num_steps: int,
    tol: float = DEFAULT_TOL,
    order_range: tuple[float, float] = DEFAULT_ORDER_RANGE,
):
    """Chooses the exponential modes for lags ``h … (N−1)h`` (``h = dt``) and orders in
    ``order_range``.

    **Returns:** a dict of NumPy arrays ``log_s`` (ln s_j), ``log_q`` (ln of Δx(1+e^{−x_j}))
    and the measured worst relative kernel error ``error`` and b-derivative error
    ``derivative_error`` over a grid of lags and orders (cached by `design_span`).
    """
    return design_span(
        float(dt), max(num_steps - 1, 2) * float(dt), float(tol), tuple(map(float, order_range))
    )


@functools.lru_cache(maxsize=64)
def design_span(
    h: float,
    horizon: float,
    tol: float = DEFAULT_TOL,
    order_range: tuple[float, float] = DEFAULT_ORDER_RANGE,
):
    """`design_modes` for lags from ``h`` (the smallest step) to ``horizon`` (the record's
    length): the design of a non-uniform grid."""
    b_lo, b_hi = order_range
    dx = 1.3 * math.pi**2 / math.log(40.0 / tol)
    margin = 0.0
    for _ in range(12):
        # left tail: (s T)^{1−b} ≤ tol for the largest order; right tail: e^{−s h} ≤ tol
        x_lo = _solve_x(math.log(tol) / (1.0 - b_hi) - 1.0 - margin)
        x_hi = _solve_x(math.log((math.log(1.0 / tol) + 3.0 + margin) * horizon / h))
        x = x_lo + dx * np.arange(int(math.ceil((x_hi - x_lo) / dx)) + 1)
        log_s = x - np.exp(-x) - math.log(horizon)
        log_q = math.log(dx) + np.log1p(np.exp(-x))
        orders = np.linspace(b_lo, b_hi, 17)
        lags = np.geomspace(h, horizon, 240)
        err, derr = _kernel_error(log_s, log_q, orders, lags)
        if err <= tol:
            return dict(log_s=log_s, log_q=log_q, error=err, derivative_error=derr)
        dx *= 0.93
        margin += 1.0
    raise ValueError(
        f"could not design exponential modes reaching tol={tol:g} for orders in {order_range} "
        f"(best relative kernel error {err:.2g}); use a larger tol or a narrower order range."
    )


class ExponentialState(eqx.Module):
    history: Float[Array, "M n"]  # H_j(k−1) = ∫_0^{t_{k−1}} e^{−s_j(t_{k−1}−τ)} u(τ) dτ
    previous: Float[Array, " n"]  # u_{k−1}
    k: Int[Array, ""]


class ExponentialMemory(AbstractMemory):
    """Sum-of-exponentials memory with the last step exact (docs/method.md §4).

    Build it with `ExponentialMemory.design(dt, num_steps, ...)` for a uniform step, or
    `ExponentialMemory.design_grid(times, ...)` for arbitrary increasing sample times; the modes
    are chosen on the host for the smallest step, the record's length, the tolerance and the
    order range. On a grid each step ``h_k = t_k − t_{k−1}`` decays the modes by
    ``e^{−s_j h_k}`` and weights the new samples exactly (`modal_weights`), in the scan.
    """

    dt: Float[Array, ""]  # the step (uniform), or the smallest step (grid)
    log_s: Float[Array, " M"]
    log_q: Float[Array, " M"]  # ln(Δx (1+e^{−x_j})): the quadrature weights of the modes
    log_readout: Float[Array, " M"]  # log_q − s_j h: weight base, one step decayed (uniform)
    decay: Float[Array, " M"]  # e^{−s_j h} (uniform)
    weight_previous: Float[Array, " M"]  # exact modal weight of u_{k−1} over [t_{k−1}, t_k]
    weight_current: Float[Array, " M"]  # … and of u_k
    steps: Float[Array, " N"] | None  # h_k = t_k − t_{k−1} of a grid (h_0 unused); None: uniform
    order_range: tuple[float, float] = eqx.field(static=True)
    rule: str = eqx.field(static=True, default="trapezoid")

    @classmethod
    def _build(cls, modes, h, steps, rule, order_range) -> "ExponentialMemory":
        log_s = modes["log_s"]
        s = np.exp(log_s)
        w_prev, w_cur = modal_weights(s, h, rule)
        return cls(
            dt=to_device(np.float64(h)),
            log_s=to_device(log_s),
            log_q=to_device(modes["log_q"]),
            log_readout=to_device(modes["log_q"] - s * h),
            decay=to_device(np.exp(-s * h)),
            weight_previous=to_device(w_prev),
            weight_current=to_device(w_cur),
            steps=steps,
            order_range=tuple(map(float, order_range)),
            rule=rule,
        )

    @classmethod
    def design(
        cls,
        dt: float,
        num_steps: int,
        *,
        rule: str = "trapezoid",
        tol: float = DEFAULT_TOL,
        order_range: tuple[float, float] = DEFAULT_ORDER_RANGE,
    ) -> "ExponentialMemory":
        """Designs the modes for a uniform step (see `design_modes`) and returns the memory."""
        modes = design_modes(float(dt), int(num_steps), float(tol), tuple(map(float, order_range)))
        return cls._build(modes, float(dt), None, rule, order_range)

    @classmethod
    def design_grid(
        cls,
        times,
        *,
        rule: str = "trapezoid",
        tol: float = DEFAULT_TOL,
        order_range: tuple[float, float] = DEFAULT_ORDER_RANGE,
    ) -> "ExponentialMemory":
        """Designs the modes for the increasing sample times ``times`` (N,), N ≥ 2, on the host:
        lags from the smallest step to ``t_{N−1} − t_0`` (see `design_span`)."""
        t = np.asarray(times, dtype=float)
        steps = np.diff(t)
        h_min = float(steps.min())
        horizon = max(float(t[-1] - t[0]), 2.0 * h_min)
        modes = design_span(h_min, horizon, float(tol), tuple(map(float, order_range)))
        grid_steps = to_device(np.concatenate([steps[:1], steps]))  # h_0: a placeholder
        return cls._build(modes, h_min, grid_steps, rule, order_range)

    def _step_terms(self, k):
        """``(h, log_readout, decay, w_prev, w_cur)`` of the step ending at sample ``k``."""
        if self.steps is None:
            return self.dt, self.log_readout, self.decay, self.weight_previous, self.weight_current
        h = self.steps[k]
        s = jnp.exp(self.log_s)
        w_prev, w_cur = modal_weights(s, h, self.rule, jnp)
        return h, self.log_q - s * h, jnp.exp(-s * h), w_prev, w_cur

    @property
    def num_modes(self) -> int:
        return self.log_s.shape[0]

    def init(self, num_inputs: int) -> ExponentialState:
        dtype = self.decay.dtype
        return ExponentialState(
            jnp.zeros((self.num_modes, num_inputs), dtype),
            jnp.zeros((num_inputs,), dtype),
            jnp.asarray(0, jnp.int32),
        )

    def readout(self, state: ExponentialState, u_k, b):
        h, log_readout, *_ = self._step_terms(state.k)
        a0, a1 = end_weights(b, self.rule)
        last = jnp.exp(log_norm(b, h, self.rule)) * (a0 * u_k + a1 * state.previous)
        c = jnp.sin(jnp.pi * b) / jnp.pi * jnp.exp(log_readout + (1.0 - b) * self.log_s)
        older = jnp.matmul(c, state.history, precision=lax.Precision.HIGHEST)
        return jnp.where(state.k > 0, last + older, 0.0)

    def step_size(self, state: ExponentialState):
        return self.dt if self.steps is None else self.steps[state.k]

    def update(self, state: ExponentialState, u_k) -> ExponentialState:
        # no interval ends at sample 0: its contribution is gated off by a factor, not a
        # select (a select over the whole state costs XLA:CPU a copy per step)
        started = (state.k > 0).astype(state.history.dtype)
        _, _, decay, w_prev, w_cur = self._step_terms(state.k)
        increment = w_prev[:, None] * state.previous[None, :] + w_cur[:, None] * u_k[None, :]
        history = decay[:, None] * state.history + started * increment
        return ExponentialState(history, u_k, state.k + 1)

    # -- the whole record at once: the modal history is order-free ------------------------

    def histories(self, u):
        """The modal history ``H(k−1)`` that sample ``k`` reads, for every sample of ``u`` (N, n).

        ``H(k) = e^{−s h} H(k−1) + w_prev u_{k−1} + w_cur u_k`` (no interval ends at sample 0)
        does not depend on the order, so it is computed once per record, as an associative
        linear recurrence (`lax.associative_scan`: log₂N vectorised sweeps, no loop over
        samples), and read out at any orders by `readout_histories`.

        **Returns:** ``(H, previous)``: ``H`` (N, M, n), and ``previous`` (N, n) the sample
        before each (0 before sample 0).
        """
        num, width = u.shape
        previous = jnp.concatenate([jnp.zeros((1, width), u.dtype), u[:-1]])
        _, _, decay, w_prev, w_cur = self._record_terms(num)
        increment = (
            w_prev[:, :, None] * previous[:, None, :] + w_cur[:, :, None] * u[:, None, :]
        ).at[0].set(0.0)  # sample 0 ends no interval
        decay = jnp.broadcast_to(decay[:, :, None], (num, self.num_modes, 1))
        # (a, b) is the affine map H ↦ a H + b; `combine` applies the earlier map first
        combine = lambda x, y: (x[0] * y[0], y[0] * x[1] + y[1])  # noqa: E731
        _, after = lax.associative_scan(combine, (decay, increment), axis=0)
        return jnp.concatenate([jnp.zeros_like(after[:1]), after[:-1]]), previous

    def readout_histories(self, h, previous, u, order):
        """``Φ(order[k], t_k)`` for every sample at once from `histories`' ``(H, previous)``: a
        contraction over the modes with no sequential dependency; equal to `run` to rounding."""
        b = order
        h_k, log_readout, *_ = self._record_terms(b.shape[0])
        a0, a1 = end_weights(b, self.rule)
        last = jnp.exp(log_norm(b, h_k, self.rule))[:, None] * (
            a0[:, None] * u + a1[:, None] * previous
        )
        c = (jnp.sin(jnp.pi * b) / jnp.pi)[:, None] * jnp.exp(
            log_readout + (1.0 - b)[:, None] * self.log_s[None, :]
        )
        older = jnp.einsum("km,kmn->kn", c, h, precision=lax.Precision.HIGHEST)
        return (last + older).at[0].set(0.0)

    def _record_terms(self, num: int):
        """`_step_terms` of every sample: ``h`` (N,) and the modal terms (N, M)."""
        if self.steps is None:
            terms = (self.log_readout, self.decay, self.weight_previous, self.weight_current)
            h = jnp.broadcast_to(self.dt, (num,))
            return h, *(jnp.broadcast_to(a[None, :], (num, self.num_modes)) for a in terms)
        h = self.steps[:num]
        s = jnp.exp(self.log_s)[None, :]
        w_prev, w_cur = modal_weights(s, h[:, None], self.rule, jnp)
        return h, self.log_q[None, :] - s * h[:, None], jnp.exp(-s * h[:, None]), w_prev, w_cur

    def history_fits(self, num: int, width: int, limit: int | None = None) -> bool:
        """Whether the whole order-free history of a record of this shape is stored: at most
        `limit` numbers (default `HISTORY_LIMIT`)."""
        return num * self.num_modes * width <= (HISTORY_LIMIT if limit is None else limit)
