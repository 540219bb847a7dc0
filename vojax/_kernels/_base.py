"""The interface every memory of the fractional integral implements."""

import abc

import equinox as eqx
import jax
import jax.numpy as jnp
from jax import lax

RULES = ("rectangle", "trapezoid")


class AbstractMemory(eqx.Module):
    """History of the inputs from which ``Φ(b, t_k)`` is read out at any order ``b``.

    A memory is used sample by sample:

        state = memory.init(num_inputs)
        for k in range(N):
            state, (phi_k, dphi_k) = memory.step(state, u[k], order[k])

    ``readout`` gives ``Φ(b, t_k)`` from the history ``u_0 … u_{k−1}`` (in ``state``) and the
    current sample ``u_k``; ``update`` appends ``u_k``. Only ``readout`` depends on the order, so
    ``step`` obtains ``∂Φ/∂b`` (eq. 14) as a forward-mode ``jax.jvp`` of the readout.
    """

    rule: eqx.AbstractVar[str]

    @abc.abstractmethod
    def init(self, num_inputs: int):
        """The state before sample 0."""

    @abc.abstractmethod
    def readout(self, state, u_k, b):
        """``Φ(b, t_k)``, shape ``(num_inputs,)``."""

    @abc.abstractmethod
    def update(self, state, u_k):
        """The state after sample ``k``."""

    @abc.abstractmethod
    def step_size(self, state):
        """``h_k = t_k − t_{k−1}``, the step ending at the current sample (at sample 0, the
        first step): what the laws driven by the memory integrate over."""

    def readout_and_sensitivity(self, state, u_k, b):
        """``(Φ, ∂Φ/∂b)`` at the current sample: a forward-mode ``jax.jvp`` of `readout`."""
        b = jnp.asarray(b, jnp.result_type(float))
        return jax.jvp(lambda bb: self.readout(state, u_k, bb), (b,), (jnp.ones_like(b),))

    def step(self, state, u_k, b):
        """Returns ``(new_state, (Φ, ∂Φ/∂b))`` at the current sample, with order ``b``."""
        return self.update(state, u_k), self.readout_and_sensitivity(state, u_k, b)

    def run(self, u, order, sensitivity: bool, unroll: int = 1):
        """``Φ`` (and ``∂Φ/∂b``) over a whole record ``u`` (N, n) with known orders (N,).

        One `lax.scan` of `step`, `unroll` samples per loop step; a memory may override it
        with an equivalent, faster schedule.
        """

        @jax.checkpoint
        def body(state, sample):
            u_k, b_k = sample
            if sensitivity:
                return self.step(state, u_k, b_k)
            return self.update(state, u_k), self.readout(state, u_k, b_k)

        return lax.scan(body, self.init(u.shape[1]), (u, order), unroll=unroll)[1]
