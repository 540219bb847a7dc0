"""`simulate`: the true system in its integral form (12)."""

import jax
import jax.numpy as jnp

from . import _validate as check
from ._integral import fractional_integral


def simulate(
    u, order, p, dt=None, *, t=None, x0=0.0, rule: str = "trapezoid", memory: str = "direct", **memory_options
):
    """Output of ``x(t) − x(0) = 1/Γ(α(t)) ∫_0^t (t−τ)^{α(t)−1} p(τ)ᵀ u(τ) dτ`` (eq. 12).

    The order is taken at the evaluation time and a time-varying ``p`` stays inside the integral,
    as in the simulation study (34). Noise is the caller's: for the study's ``ν ~ N(0, 0.25)``,
    ``y = x + 0.5 * jax.random.normal(jax.random.key(0), x.shape)``.

    **Arguments:** `u` ``(N,)`` or ``(N, n)``; `order` scalar or ``(N,)`` in (0, 1); `p` ``(n,)``
    or ``(N, n)``; `dt` > 0 or `t` the sample times (exactly one, as in
    `fractional_integral`); `x0` the initial output; `rule`, `memory` as in
    `fractional_integral`.

    **Returns:** ``x`` of shape ``(N,)``.
    """
    u = check.samples(u, "u")
    u2 = check.columns(u)
    p = jnp.asarray(check.float_array(p, "p"))
    n = u2.shape[1]
    if p.shape not in ((n,), (u2.shape[0], n)) and not (p.ndim == 0 and n == 1):
        raise ValueError(
            f"`p` must have shape ({n},) or ({u2.shape[0]}, {n}) to match `u`, got shape {p.shape}."
        )
    check.check_finite(p, "p")
    x0 = check.samples(jnp.reshape(jnp.asarray(
        x0 if isinstance(x0, jax.Array) else check.real(x0, "x0"), jnp.result_type(float)),
        (1,)), "x0")[0]
    drive = jnp.sum(u2 * p, axis=-1) if p.ndim else u2[:, 0] * p
    return x0 + fractional_integral(drive, order, dt, t=t, rule=rule, memory=memory, **memory_options)
