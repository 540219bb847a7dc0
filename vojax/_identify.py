"""`identify`: the adaptive law of Theorem 1 driven over a record in one jit-compiled scan."""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jax import lax
from jaxtyping import Array, Float

from . import _validate as check
from ._adaptive import LSFF, AdaptiveLaw, OrderGradient
from ._integral import make_memory
from ._kernels import RULES

DEFAULT_BOUNDS = (0.05, 0.95)


class Identification(eqx.Module):
    """What `identify` returns: the estimates at every sample and the settings used.

    - `alpha` (N,): the identified order α̂ (the order used at each sample).
    - `p` (N, n): the identified parameters p̂.
    - `dp` (N, n): ∂p/∂β along a uniform order shift (26).
    - `y_hat` (N,): the identified output x̂ = x0 + p̂ᵀφ(α̂, t) (eq. 25).
    - `y_pred` (N,): the a-priori prediction x0 + p̂_{k−1}ᵀφ(α̂, t_k), made before y_k is used.
    - `Lambda` (N,): Λ of eq. (30).
    - `gamma`, `lam`, `alpha0`, `x0`, `dt`: the settings used.
    """

    alpha: Float[Array, " N"]
    p: Float[Array, "N n"]
    dp: Float[Array, "N n"]
    y_hat: Float[Array, " N"]
    y_pred: Float[Array, " N"]
    Lambda: Float[Array, " N"]
    gamma: Float[Array, ""]
    lam: Float[Array, ""]
    alpha0: Float[Array, ""]
    x0: Float[Array, ""]
    dt: Float[Array, ""]
    alpha_bounds: tuple[float, float] = eqx.field(static=True)
    memory: str = eqx.field(static=True)


TRACES = {"scan": 0}


@eqx.filter_jit
def run_law(law: AdaptiveLaw, u, y):
    """Runs ``law`` over samples ``u`` (N, n) and outputs ``y`` (N,) in one ``lax.scan``."""
    TRACES["scan"] += 1

    @jax.checkpoint
    def body(state, sample):
        return law.step(state, *sample)

    _, out = lax.scan(body, law.init(u.shape[1]), (u, y))
    return out


def build_law(dt, num_steps, *, lam, gamma, alpha0, alpha_bounds, memory, rule, r0=None, tol=1e-10):
    """The `AdaptiveLaw` of Theorem 1 with its memory designed for the order bounds."""
    mem = make_memory(memory, dt, num_steps, rule=rule, tol=tol, order_range=alpha_bounds)
    dt_arr = jnp.asarray(dt, jnp.result_type(float))
    return AdaptiveLaw(
        mem,
        LSFF(jnp.asarray(lam, dt_arr.dtype), dt_arr, r0),
        OrderGradient(
            jnp.asarray(gamma, dt_arr.dtype),
            dt_arr,
            jnp.asarray(alpha0, dt_arr.dtype),
            alpha_bounds,
        ),
    )


def check_options(u, y, dt, lam, alpha0, alpha_bounds, memory, rule, x0, r0):
    """Validates the arguments shared by `identify` and `tune_gains`; returns prepared arrays."""
    u = check.samples(u, "u")
    u2 = u[:, None] if u.ndim == 1 else u
    y = check.samples(y, "y")
    if y.ndim != 1:
        raise ValueError(f"`y` must have shape (N,), got shape {y.shape}.")
    if y.shape[0] != u2.shape[0]:
        raise ValueError(
            f"`u` and `y` must have the same number of samples, got {u2.shape[0]} and {y.shape[0]}."
        )
    check.step(dt)
    if lam is not None:
        check.positive(lam, "lam")
    bounds = check.interval(alpha_bounds, "alpha_bounds")
    a0 = (
        float(np.asarray(check.step(alpha0, "alpha0")))
        if not isinstance(alpha0, jax.core.Tracer)
        else None
    )
    if a0 is not None and not bounds[0] <= a0 <= bounds[1]:
        raise ValueError(f"`alpha0` must lie inside `alpha_bounds` {bounds}, got {a0}.")
    check.choice(memory, check.MEMORIES, "memory")
    check.choice(rule, RULES, "rule")
    x0 = y[0] if x0 is None else _scalar(x0, "x0")
    if r0 is not None:
        r0 = jnp.asarray(r0, jnp.result_type(float))
        n = u2.shape[1]
        if r0.shape != (n, n):
            raise ValueError(f"`r0` must have shape ({n}, {n}), got {r0.shape}.")
        if not isinstance(r0, jax.core.Tracer) and np.any(np.linalg.eigvalsh(np.asarray(r0)) <= 0):
            raise ValueError("`r0` must be symmetric positive definite.")
    return u2, y, bounds, x0, r0


def _scalar(x, name):
    arr = jnp.asarray(x, jnp.result_type(float))
    if arr.ndim != 0:
        raise ValueError(f"`{name}` must be a scalar, got shape {arr.shape}.")
    if not isinstance(arr, jax.core.Tracer) and not np.isfinite(float(arr)):
        raise ValueError(f"`{name}` must be finite, got {float(arr)}.")
    return arr


def identify(
    u,
    y,
    dt,
    *,
    lam=0.9,
    gamma=0.01,
    alpha0=0.5,
    alpha_bounds=DEFAULT_BOUNDS,
    memory: str = "exponential",
    rule: str = "trapezoid",
    x0=None,
    r0=None,
    tol: float = 1e-10,
) -> Identification:
    """Identifies the order α(t) and parameters p of ``D^{α(t)} x = pᵀu`` online (Theorem 1).

    Runs the law (29)–(30) in the exact discrete form of NOTES §3 over the whole record in one
    jit-compiled `lax.scan`: LSFF with forgetting ``λ`` for ``p``, the order-gradient law with
    gain ``γ`` and projection onto `alpha_bounds` for ``α``, and ``∂p/∂β`` by forward-mode
    autodiff of the LSFF step.

    **Arguments:**

    - `u`: inputs, ``(N,)`` or ``(N, n)``; `y`: measured output ``(N,)``; `dt`: the step.
    - `lam`: forgetting factor λ > 0 (the paper's 0.9); larger forgets faster.
    - `gamma`: order gain γ > 0, or ``"auto"`` to choose ``(γ, λ)`` by `tune_gains`. The law is
      sensitive to it: too large and α̂ chatters between the bounds.
    - `alpha0`: α̂(0), inside `alpha_bounds`; `alpha_bounds`: the projection interval ⊂ (0, 1).
    - `memory`: ``"exponential"`` (O(1) per sample) or ``"direct"``; `rule`: the quadrature.
    - `x0`: the initial output; ``None`` takes ``y[0]`` (Remark 4: the law sees ``y − x0``).
    - `r0`: initial information matrix ``R_0`` (identity by default: ``P(0) = I``).
    - `tol`: accuracy of the exponential memory.

    **Returns:** an `Identification`.
    """
    if isinstance(gamma, str) and gamma != "auto":
        raise ValueError(f"`gamma` must be a positive number or 'auto', got {gamma!r}.")
    # validate once, before any (possibly long) tuning; the law and the tuner share the settings
    u2, y, bounds, x0, r0 = check_options(u, y, dt, lam, alpha0, alpha_bounds, memory, rule, x0, r0)
    shared = dict(alpha0=alpha0, alpha_bounds=bounds, memory=memory, rule=rule, r0=r0, tol=tol)
    if isinstance(gamma, str):  # "auto", checked above
        from ._tune import tune_gains

        gains = tune_gains(u2, y, dt, x0=x0, **shared)
        gamma, lam = gains.gamma, gains.lam
    check.positive(gamma, "gamma")
    law = build_law(dt, u2.shape[0], lam=lam, gamma=gamma, **shared)
    out = run_law(law, u2, y - x0)
    return Identification(
        alpha=out.alpha,
        p=out.p,
        dp=out.dp,
        y_hat=out.y_hat + x0,
        y_pred=out.y_pred + x0,
        Lambda=out.Lambda,
        gamma=law.order.gamma,
        lam=law.lsff.lam,
        alpha0=law.order.alpha0,
        x0=x0,
        dt=law.lsff.dt,
        alpha_bounds=bounds,
        memory=memory,
    )
