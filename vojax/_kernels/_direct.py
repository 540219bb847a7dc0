"""Direct product integration: the whole history is re-read at every sample, O(k) work."""

import equinox as eqx
import jax.numpy as jnp
from jax import lax
from jaxtyping import Array, Float, Int

from ._base import AbstractMemory
from ._weights import end_weights, grid_weights, history_weights, log_norm


class DirectState(eqx.Module):
    # u_j is stored at row capacity − 1 − j, so the rows from capacity − k on read
    # u_{k−1}, u_{k−2}, …, u_0, 0, … : lag order, ready for a contiguous dynamic slice.
    buffer: Float[Array, "2*capacity n"]
    k: Int[Array, ""]


class DirectMemory(AbstractMemory):
    """Exact product integration over the whole history (docs/method.md §3); the reference memory.

    **Arguments:**

    - `dt`: the sampling step ``h > 0``.
    - `capacity`: the largest number of samples the memory will be stepped through.
    - `rule`: ``"trapezoid"`` or ``"rectangle"``.
    """

    dt: Float[Array, ""]
    capacity: int = eqx.field(static=True)
    rule: str = eqx.field(static=True, default="trapezoid")

    def init(self, num_inputs: int) -> DirectState:
        dtype = jnp.asarray(self.dt).dtype
        return DirectState(
            jnp.zeros((2 * self.capacity, num_inputs), dtype), jnp.asarray(0, jnp.int32)
        )

    def readout(self, state: DirectState, u_k, b):
        n = self.capacity
        past = lax.dynamic_slice_in_dim(state.buffer, n - state.k, n, axis=0)
        a = history_weights(n, state.k, b, self.rule)
        a0, _ = end_weights(b, self.rule)
        total = a0 * u_k + jnp.matmul(a, past, precision=lax.Precision.HIGHEST)
        phi = jnp.exp(log_norm(b, self.dt, self.rule)) * total
        return jnp.where(state.k > 0, phi, 0.0)

    def step_size(self, state: DirectState):
        return self.dt

    def update(self, state: DirectState, u_k) -> DirectState:
        row = self.capacity - 1 - state.k
        buffer = lax.dynamic_update_slice_in_dim(state.buffer, u_k[None, :], row, axis=0)
        return DirectState(buffer, state.k + 1)


class GridState(eqx.Module):
    buffer: Float[Array, "capacity n"]  # row j holds u_j once sample j has been seen
    k: Int[Array, ""]


class GridDirectMemory(AbstractMemory):
    """Exact product integration over the whole history on arbitrary increasing sample times
    (docs/method.md §3): the weights of every interval are computed from the times at each
    sample, O(k) work at sample k like `DirectMemory`, which it equals on a uniform grid.

    **Arguments:**

    - `times`: the sample times ``t_0 < t_1 < …`` (C,); the integral starts at ``t_0``.
    - `rule`: ``"trapezoid"`` or ``"rectangle"``.
    """

    times: Float[Array, " capacity"]
    rule: str = eqx.field(static=True, default="trapezoid")

    @property
    def capacity(self) -> int:
        return self.times.shape[0]

    def init(self, num_inputs: int) -> GridState:
        return GridState(
            jnp.zeros((self.capacity, num_inputs), self.times.dtype), jnp.asarray(0, jnp.int32)
        )

    def readout(self, state: GridState, u_k, b):
        w = grid_weights(self.times, state.k, b, self.rule)
        # rows from k on are still zero in the buffer: sample k enters through u_k
        history = jnp.matmul(w, state.buffer, precision=lax.Precision.HIGHEST)
        return history + w[state.k] * u_k

    def step_size(self, state: GridState):
        k = jnp.maximum(state.k, 1)
        return self.times[k] - self.times[k - 1]

    def update(self, state: GridState, u_k) -> GridState:
        buffer = lax.dynamic_update_slice_in_dim(state.buffer, u_k[None, :], state.k, axis=0)
        return GridState(buffer, state.k + 1)
