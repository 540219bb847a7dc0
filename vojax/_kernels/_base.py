"""The interface every memory of the fractional integral implements."""

import abc

import equinox as eqx
import jax
import jax.numpy as jnp

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

    def step(self, state, u_k, b):
        """Returns ``(new_state, (Φ, ∂Φ/∂b))`` at the current sample, with order ``b``."""
        b = jnp.asarray(b, jnp.result_type(float))
        phi, dphi = jax.jvp(lambda bb: self.readout(state, u_k, bb), (b,), (jnp.ones_like(b),))
        return self.update(state, u_k), (phi, dphi)
