"""User-facing fractional integral and its order sensitivity."""

import equinox as eqx
import jax
import numpy as np

from . import _validate as check
from ._custom_types import Array, OrderLike, Samples
from ._kernels import RULES, AbstractMemory, DirectMemory, ExponentialMemory, GridDirectMemory
from ._kernels._exponential import DEFAULT_ORDER_RANGE, DEFAULT_TOL

# number of traces of each entry point, for the tests (a Python side effect at trace time)
TRACES = {"scan": 0}


def make_memory(
    memory: str,
    dt,
    num_steps: int,
    *,
    rule: str = "trapezoid",
    tol: float = DEFAULT_TOL,
    order_range=DEFAULT_ORDER_RANGE,
    times=None,
) -> AbstractMemory:
    """Builds the memory named by ``memory`` (``"direct"`` or ``"exponential"``) for a uniform
    step ``dt``, or for the sample times ``times`` (then ``dt`` is ``None``)."""
    check.choice(rule, RULES, "rule")
    check.choice(memory, check.MEMORIES, "memory")
    if times is not None:
        return _grid_memory(memory, times, num_steps, rule, tol, order_range)
    if memory == "direct":
        return DirectMemory(dt=check.step(dt), capacity=int(num_steps), rule=rule)
    if isinstance(dt, jax.core.Tracer):
        raise TypeError(
            "`dt` must be a concrete number for memory='exponential' "
            "(its modes are designed on the host); pass it as a static value."
        )
    check.step(dt)
    dt = float(np.asarray(dt))
    check.positive(tol, "tol", upper=1e-2)
    tol = float(np.asarray(tol))
    order_range = check.interval(order_range, "order_range")
    return ExponentialMemory.design(
        float(dt), num_steps, rule=rule, tol=tol, order_range=order_range
    )


def _grid_memory(memory, times, num_steps, rule, tol, order_range):
    checked = check.times(times, int(num_steps))
    if memory == "direct":
        return GridDirectMemory(times=checked, rule=rule)
    if isinstance(times, jax.core.Tracer):
        raise TypeError(
            "`t` must be concrete for memory='exponential' (its modes are designed on the "
            "host from the steps); pass it as a static value."
        )
    check.positive(tol, "tol", upper=1e-2)
    return ExponentialMemory.design_grid(
        np.asarray(times), rule=rule, tol=float(np.asarray(tol)),
        order_range=check.interval(order_range, "order_range"),
    )


def _order_in_design(memory: AbstractMemory, order):
    if isinstance(memory, ExponentialMemory):
        lo, hi = memory.order_range
        if not isinstance(order, jax.core.Tracer):
            check.order(order, order.shape[0], bounds=(lo, hi), closed=True)
        order = eqx.error_if(
            order,
            (order < lo) | (order > hi),
            f"`order` left the exponential memory's design range [{lo}, {hi}]; widen `order_range`.",
        )
    return order


@eqx.filter_jit
def scan_memory(memory: AbstractMemory, u, order, sensitivity: bool):
    """Runs ``memory`` over the samples ``u`` (N, n) at orders ``order`` (N,) in one scan.

    Returns ``Φ`` (N, n), and ``∂Φ/∂b`` as well when ``sensitivity`` is true.
    """
    TRACES["scan"] += 1
    return memory.run(u, order, sensitivity)


@eqx.filter_jit
def scan_memory_orders(memory: AbstractMemory, u, orders, unroll: int = 1):
    """``Φ`` (K, N, n) of the samples ``u`` (N, n) at each of the K order trajectories
    ``orders`` (K, N): the K scans run as one (a batched carry), which costs on a CPU about
    what one scan costs where the per-sample launch of XLA's kernels, not arithmetic, sets
    the time. `unroll`: samples per step of the compiled loop (fewer launches, a larger
    program). Equal to K calls of `scan_memory` to rounding."""
    TRACES["scan"] += 1
    return jax.vmap(lambda order: memory.run(u, order, False, unroll))(orders)


def order_map(memory: AbstractMemory, u, history_limit: int | None = None):
    """The function ``(order, sensitivity=False) ↦ Φ`` (or ``(Φ, ∂Φ/∂b)``) of a fixed record
    ``u`` (N, n), for evaluating at many order trajectories (an optimisation loop).

    With the exponential memory, the order-free modal history is computed here, once, and each
    evaluation is a vectorised readout (`ExponentialMemory.histories`); records whose history
    would exceed `history_limit` numbers (default `HISTORY_LIMIT`), and the direct memory, scan
    the record per evaluation (bounded memory). Call it inside the traced function that loops, so that the history is a
    constant of the loop.
    """
    if isinstance(memory, ExponentialMemory) and memory.history_fits(*u.shape, history_limit):
        h, previous = memory.histories(u)

        def phi(order):
            return memory.readout_histories(h, previous, u, order)

        def evaluate(order, sensitivity: bool = False):
            if not sensitivity:
                return phi(order)
            return jax.jvp(phi, (order,), (jax.numpy.ones_like(order),))

        return evaluate
    return lambda order, sensitivity=False: memory.run(u, order, sensitivity)


def _prepare(u, order, dt, t, rule, memory, tol, order_range):
    u = check.samples(u)
    squeeze = u.ndim == 1
    u2 = check.columns(u)
    order = check.order(order, u2.shape[0])
    dt, t = check.grid(dt, t, u2.shape[0])
    mem = make_memory(
        memory, dt, u2.shape[0], rule=rule, tol=tol, order_range=order_range, times=t
    )
    order = _order_in_design(mem, order)
    return u2, order, mem, squeeze


def fractional_integral(
    u: Samples,
    order: OrderLike,
    dt=None,
    *,
    t=None,
    rule: str = "trapezoid",
    memory: str = "direct",
    tol: float = DEFAULT_TOL,
    order_range=DEFAULT_ORDER_RANGE,
) -> Array:
    """Variable-order Riemann–Liouville integral ``φ(β, t_k)`` of eq. (18) at the sample times:
    ``t_k = k·dt``, or any strictly increasing ``t``.

    ``φ_k = 1/Γ(b_k) ∫_{t_0}^{t_k} (t_k − τ)^{b_k − 1} u(τ) dτ`` with ``b_k = order[k]``: the
    order is taken at the evaluation time (docs/method.md §1) and the integral starts at the
    first sample. It is done by product integration with exact weights for the interpolant of
    ``u`` named by ``rule``, on uniform and non-uniform grids alike (docs/method.md §3).

    **Arguments:**

    - `u`: samples, shape ``(N,)`` or ``(N, n)``.
    - `order`: scalar or ``(N,)``, every value in ``(0, 1)``.
    - `dt`: the sampling step, > 0; or
    - `t`: the sample times ``(N,)``, strictly increasing (log-spaced, irregular, …), N ≥ 2.
      Give exactly one of `dt` and `t`.
    - `rule`: ``"trapezoid"`` (u linear between samples, error O(h²)) or ``"rectangle"``
      (u constant on ``[t_j, t_{j+1})``, error O(h)).
    - `memory`: ``"direct"`` (whole history re-read, O(k) at sample k) or ``"exponential"``
      (sum of exponentials, O(M) per sample, docs/method.md §4).
    - `tol`: relative accuracy of the exponential memory's kernel over the record.
    - `order_range`: the orders the exponential memory is designed for; an order outside it is
      an error.

    **Returns:** an array shaped like `u`; sample 0 is 0.
    """
    u2, order, mem, squeeze = _prepare(u, order, dt, t, rule, memory, tol, order_range)
    phi = scan_memory(mem, u2, order, False)
    return phi[:, 0] if squeeze else phi


def order_sensitivity(
    u: Samples,
    order: OrderLike,
    dt=None,
    *,
    t=None,
    rule: str = "trapezoid",
    memory: str = "direct",
    tol: float = DEFAULT_TOL,
    order_range=DEFAULT_ORDER_RANGE,
) -> Array:
    """Order sensitivity ``∂φ/∂β`` of eq. (14): ``∂Φ/∂b`` at ``b = order[k]``, by ``jax.jvp``.

    Same arguments as `fractional_integral`; the derivative is forward-mode autodiff through the
    same kernel, so it is exact for the quadrature in use. The closed form (14) of the same
    quadrature is `vojax.reference.order_sensitivity`.

    **Returns:** an array shaped like `u`.
    """
    u2, order, mem, squeeze = _prepare(u, order, dt, t, rule, memory, tol, order_range)
    _, dphi = scan_memory(mem, u2, order, True)
    return dphi[:, 0] if squeeze else dphi
