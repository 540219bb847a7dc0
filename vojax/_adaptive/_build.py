"""The paper's law assembled on a designed memory, run over a record in one scan, and its
result as an `Identification`."""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jax import lax

from .._diagnostics import diagnose
from .._identification import Identification
from .._integral import make_memory, scan_memory
from .._stats import lag1_correlation
from ._law import AdaptiveLaw
from ._lsff import LSFF
from ._order import OrderGradient

DEFAULT_BOUNDS = (0.05, 0.95)  # the law's projection
PAPER_LAM = 0.9


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


def build_law(
    dt, num_steps, *, lam, gamma, alpha0, alpha_bounds, memory, rule, r0=None, tol=1e-10,
    times=None,
):
    """The `AdaptiveLaw` of Theorem 1 with its memory designed for the order bounds; on the
    sample `times` when given (then `dt` is the nominal step, the steps come from the memory)."""
    mem = make_memory(
        memory, None if times is not None else dt, num_steps, rule=rule, tol=tol,
        order_range=alpha_bounds, times=times,
    )
    return assemble_law(mem, dt, lam, gamma, alpha0, alpha_bounds, r0)


def assemble_law(memory, dt, lam, gamma, alpha0, alpha_bounds, r0=None):
    """The `AdaptiveLaw` on a designed memory; numbers may be arrays (traced)."""
    dt_arr = jnp.asarray(dt, jnp.result_type(float))
    return AdaptiveLaw(
        memory,
        LSFF(jnp.asarray(lam, dt_arr.dtype), dt_arr, r0),
        OrderGradient(
            jnp.asarray(gamma, dt_arr.dtype),
            dt_arr,
            jnp.asarray(alpha0, dt_arr.dtype),
            alpha_bounds,
        ),
    )


def nominal_step(dt, t):
    """The step that sets the scale of gains and forgetting: `dt`, or the median step of `t`."""
    return float(np.asarray(dt)) if t is None else float(np.median(np.diff(np.asarray(t))))


def auto_r0(u2, dt, alpha0, memory, rule, tol, bounds, *, num=None, mem=None, times=None):
    """``R_0`` worth one sample of information at the initial order: ``h·diag(mean φ²)`` with
    ``φ = Φ(α̂(0), t)``. It scales with the inputs, so the law does not depend on their units.
    With `num`, ``u2`` is a record of `num` samples padded after its end (the mean covers the
    real samples; the memory is causal); `mem` is a memory already designed for ``u2``."""
    size = u2.shape[0]
    num = size if num is None else int(num)
    if mem is None:
        mem = make_memory(
            memory, None if times is not None else dt, size, rule=rule, tol=tol,
            order_range=bounds, times=times,
        )
    phi = np.asarray(scan_memory(mem, jnp.asarray(u2), jnp.full((size,), float(alpha0)), False))
    with np.errstate(over="ignore"):
        power = np.mean(phi[:num] ** 2, axis=0)
    if not np.all(np.isfinite(power)):
        raise ValueError(
            "the inputs' fractional integrals overflow float64 when squared (values near "
            "1e154 or beyond): rescale the inputs (another unit) or give `r0`."
        )
    if not np.all(power > 0):
        j = int(np.argmin(power))
        raise ValueError(f"input column {j} of `u` is zero everywhere: its parameter is undefined.")
    return jnp.asarray(float(dt) * np.diag(power))


def law_identification(
    out, var_alpha, var_p, x0, gamma, lam, alpha0, dt, bounds, memory, at_edge=(), host=False,
    y=None,
) -> Identification:
    """An `Identification` from the law's outputs (of ``y − x0``) and the variances of its
    estimates (`vojax._adaptive._bands.law_covariance`); shared by `identify` and the batch.
    With the measured `y`, the diagnostics hold the correlation of its prediction errors.
    ``host=True`` keeps its arrays in NumPy (the batch: each new record length would compile
    the conversions to device arrays)."""
    # on the host, in NumPy: eager JAX operations would compile once per record length
    alpha = np.asarray(out.alpha)
    alpha_std = np.sqrt(np.maximum(np.asarray(var_alpha), 0.0))
    lo, hi = bounds
    lower = np.clip(alpha - 2 * alpha_std, lo, hi)
    upper = np.clip(alpha + 2 * alpha_std, lo, hi)
    correlation = float("nan")
    if y is not None:
        pred = np.asarray(out.y_pred) + float(x0)
        correlation = lag1_correlation((np.asarray(y)[: pred.shape[0]] - pred)[1:])
    # the law's sampling spread passes the order's whole range: its linearisation is unstable
    wild = np.flatnonzero(~(alpha_std <= hi - lo))
    diagnostics = diagnose(
        alpha, lower, upper, bounds, True, at_edge, calibrated=False, correlation=correlation,
        unstable_from=int(wild[0]) if wild.size else None,
    )
    dtype = alpha.dtype
    x0 = np.asarray(x0, dtype)
    put = (lambda a, dtype=None: np.asarray(a, dtype)) if host else jnp.asarray
    return Identification(
        alpha=put(alpha),
        alpha_std=put(alpha_std),
        alpha_lower=put(lower),
        alpha_upper=put(upper),
        p=put(out.p),
        p_std=put(np.sqrt(np.maximum(np.asarray(var_p), 0.0))),
        y_hat=put(np.asarray(out.y_hat) + x0),
        y_pred=put(np.asarray(out.y_pred) + x0),
        x0=put(x0, dtype),
        x0_std=put(0.0, dtype),
        dp=put(out.dp),
        Lambda=put(out.Lambda),
        gamma=put(gamma, dtype),
        lam=put(lam, dtype),
        alpha0=put(alpha0, dtype),
        dt=put(dt, dtype),
        alpha_bounds=bounds,
        memory=memory,
        method="gradient",
        diagnostics=diagnostics,
        y=None if y is None else put(np.asarray(y)[: alpha.shape[0]], dtype),
    )
