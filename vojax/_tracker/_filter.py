"""The online tracker: an iterated extended Kalman filter, one sample per `step`.

At each sample the measurement is linearised at the predicted state, the update is computed,
and the linearisation is repeated at the updated state (`iterations` times in all): the
memory's readout is cheap at any order, so re-reading ``Φ(α, t_k)`` at the refined order costs
only the readout, not the history.
"""

import equinox as eqx
import jax
import jax.numpy as jnp
from jaxtyping import Array, Float, Int

from .._kernels import AbstractMemory
from ._kalman import update
from ._model import Hyper, linearise


class FilterState(eqx.Module):
    memory: eqx.Module
    mean: Float[Array, " d"]  # predicted mean of θ_k
    cov: Float[Array, "d d"]
    k: Int[Array, ""]


class FilterOutput(eqx.Module):
    mean: Float[Array, " d"]  # E[θ_k | y_0 … y_k]
    cov: Float[Array, "d d"]
    y_pred: Float[Array, ""]  # c + pᵀΦ at the predicted state, before y_k is used
    y_hat: Float[Array, ""]  # … at the updated state


class KalmanTracker(eqx.Module):
    """Iterated EKF of the tracker's model (see `vojax._tracker._model`), in normalised units.

    **Arguments:** `memory` (designed for `bounds`), `hyper` (`Hyper`), `steps` (N,) the
    sample spacings ``t_{k+1} − t_k``, `horizon` (the record length T), `m0`, `p0` (prior of
    θ_0), `bounds` (the order range), `iterations` (linearisations per sample).
    """

    memory: AbstractMemory
    hyper: Hyper
    horizon: Float[Array, ""]
    m0: Float[Array, " d"]
    p0: Float[Array, "d d"]
    bounds: tuple[float, float] = eqx.field(static=True)
    iterations: int = eqx.field(static=True, default=3)

    def init(self, num_inputs: int) -> FilterState:
        return FilterState(self.memory.init(num_inputs), self.m0, self.p0, jnp.asarray(0))

    def step(self, state: FilterState, u_k, y_k, step_k, mask_k=1.0):
        """Sample k with input ``u_k`` (n,), normalised output ``y_k`` and the spacing
        ``step_k = t_{k+1} − t_k`` to the next sample; returns ``(state, FilterOutput)``."""
        n = u_k.shape[0]
        prior_mean, prior_cov = state.mean, state.cov
        r = self.hyper.r

        def linear_at(theta):
            phi, dphi = self.memory.readout_and_sensitivity(state.memory, u_k, self._alpha(theta))
            h0, jac = linearise(theta, phi, dphi, self.bounds)
            return h0, jac

        theta = prior_mean
        for i in range(self.iterations):
            h0, jac = linear_at(theta)
            if i == 0:
                y_pred = h0  # the prediction before y_k is used
            z = y_k - h0 + jnp.dot(jac, theta)
            mean, cov, *_ = update(prior_mean, prior_cov, jac, z, r, mask_k)
            theta = mean
        phi, _ = self.memory.readout_and_sensitivity(state.memory, u_k, self._alpha(theta))
        y_hat = theta[-1] + jnp.dot(theta[1 : 1 + n], phi)
        q = self.hyper.process(jnp.reshape(step_k, (1,)), self.horizon, n)[0]
        new = FilterState(self.memory.update(state.memory, u_k), mean, cov + jnp.diag(q), state.k + 1)
        return new, FilterOutput(mean, cov, y_pred, y_hat)

    def _alpha(self, theta):
        lo, hi = self.bounds
        return lo + (hi - lo) * jax.nn.sigmoid(theta[0])
