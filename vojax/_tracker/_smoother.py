"""The iterated extended Kalman smoother: Gauss–Newton on the posterior mode of the whole
trajectory, with the bands from the curvature at the mode.

Each iteration linearises the measurement at the nominal trajectory θ̄ (one memory scan gives
``Φ`` and ``∂Φ/∂b`` at every sample's order), runs the linear filter and the RTS smoother of the
linearised model — whose smoothed mean is the Gauss–Newton point of the negative log posterior
— and moves towards it with a step that is halved until the posterior improves. At
convergence the linearised model's smoothed covariances are the Laplace approximation of the
posterior marginals, and its innovation likelihood that of the marginal likelihood used to
tune the noise intensities.
"""

import equinox as eqx
import jax.numpy as jnp
from jax import lax
from jaxtyping import Array, Bool, Float, Int

from ._kalman import kalman_filter, rts_smoother
from ._model import Hyper, linearise, objective, order_of

REL_TOL = 1e-9  # relative decrease of the objective below which the iteration stops


class Smoothed(eqx.Module):
    theta: Float[Array, "N d"]  # the posterior mode
    cov: Float[Array, "N d d"]  # smoothed covariances at the mode (linearised)
    filtered_mean: Float[Array, "N d"]  # causal estimates of the final linearised filter
    filtered_cov: Float[Array, "N d d"]
    y_pred: Float[Array, " N"]  # one-step predictions of the final linearised filter
    phi: Float[Array, "N n"]  # Φ at the mode's orders
    objective: Float[Array, ""]
    log_likelihood: Float[Array, ""]  # innovation log-likelihood of the linearised model
    jacobian: Float[Array, "N d"]  # H at the mode
    pseudo: Float[Array, " N"]  # the linearised measurements z = y − h(θ̄) + H θ̄
    converged: Bool[Array, ""]
    iterations: Int[Array, ""]


def _regressors(memory, u, theta, bounds):
    alpha, _ = order_of(theta[:, 0], bounds)
    return memory.run(u, alpha, True)


def _linear_pass(theta, phi, dphi, y, mask, r, q, m0, p0, bounds):
    h0, jac = linearise(theta, phi, dphi, bounds)
    z = y - h0 + jnp.sum(jac * theta, axis=-1)
    filtered = kalman_filter(jac, z, r, q, m0, p0, mask)
    return filtered, rts_smoother(filtered, q), jac, z


@eqx.filter_jit
def iterated_smoother(
    memory, u, y, mask, steps, horizon, hyper: Hyper, m0, p0, nominal, bounds, max_iter: int
) -> Smoothed:
    """Runs the Gauss–Newton iteration from the trajectory `nominal` (N, d)."""
    n = u.shape[1]
    q = hyper.process(steps, horizon, n)
    r = hyper.r
    p0_inv = jnp.linalg.inv(p0)

    def cost(theta, phi):
        return objective(theta, phi, y, mask, r, q, m0, p0_inv)

    phi, dphi = _regressors(memory, u, nominal, bounds)
    start = (nominal, phi, dphi, cost(nominal, phi), jnp.ones(()), jnp.asarray(jnp.inf), 0)

    def cond(carry):
        *_, step, rel, i = carry
        return (i < max_iter) & (rel > REL_TOL) & (step > 1e-6)

    def body(carry):
        theta, phi, dphi, value, step, rel, i = carry
        _, (ms, _), _, _ = _linear_pass(theta, phi, dphi, y, mask, r, q, m0, p0, bounds)
        cand = theta + step * (ms - theta)
        phic, dphic = _regressors(memory, u, cand, bounds)
        valc = cost(cand, phic)
        ok = jnp.isfinite(valc) & (valc <= value)
        pick = lambda a, b: jnp.where(ok, a, b)  # noqa: E731
        new_rel = jnp.where(ok, (value - valc) / jnp.maximum(jnp.abs(valc), 1.0), rel)
        new_step = jnp.where(ok, jnp.minimum(1.0, 2.0 * step), 0.5 * step)
        return (
            pick(cand, theta),
            pick(phic, phi),
            pick(dphic, dphi),
            pick(valc, value),
            new_step,
            new_rel,
            i + 1,
        )

    theta, phi, dphi, value, step, rel, iters = lax.while_loop(cond, body, start)
    filtered, (_, cov), jac, z = _linear_pass(theta, phi, dphi, y, mask, r, q, m0, p0, bounds)
    y_pred = y - filtered.innovation
    return Smoothed(
        theta=theta,
        cov=cov,
        filtered_mean=filtered.mean,
        filtered_cov=filtered.cov,
        y_pred=y_pred,
        phi=phi,
        objective=value,
        log_likelihood=filtered.log_likelihood,
        jacobian=jac,
        pseudo=z,
        # no further decrease, or none possible along the Gauss–Newton direction
        converged=(rel <= REL_TOL) | (step <= 1e-6),
        iterations=iters,
    )


def linearised_log_likelihood(hyper: Hyper, jac, z, mask, steps, horizon, m0, p0):
    """Innovation log-likelihood of the model linearised at a fixed trajectory, as a function
    of the noise intensities (differentiable: one filter scan)."""
    q = hyper.process(steps, horizon, jac.shape[1] - 2)
    return kalman_filter(jac, z, hyper.r, q, m0, p0, mask).log_likelihood
