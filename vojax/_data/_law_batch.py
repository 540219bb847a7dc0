"""The paper's law on many records of one (padded) length at once: one vmapped scan, the
batch axis sharded over the available devices."""


import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from .._adaptive._bands import law_covariance
from .._adaptive._build import (
    DEFAULT_BOUNDS,
    assemble_law,
    auto_r0,
    law_identification,
    run_law,
)
from .._integral import make_memory
from .._stats import noise_variance
from ._pipeline import (
    adaptive_part,
    record_header,
)


def _sharded(x, mesh):
    """Places ``x`` with its leading (batch) axis split over the mesh's devices."""
    spec = jax.sharding.PartitionSpec("records", *([None] * (x.ndim - 1)))
    return jax.device_put(x, jax.sharding.NamedSharding(mesh, spec))


@eqx.filter_jit
def _law_batch(memory, us, ys, dt, gammas, lams, r0s, sigma2, alpha0):
    """The law and its band on a stack of records (one program per memory and shape)."""
    TRACES["law_batch"] += 1

    def one(u, y, gamma, lam, r0, s2):
        law = assemble_law(memory, dt, lam, gamma, alpha0, DEFAULT_BOUNDS, r0)
        out = run_law(law, u, y)
        var_alpha, var_p = law_covariance(law, u, y, s2)
        return out, var_alpha, var_p

    return jax.vmap(one)(us, ys, gammas, lams, r0s, sigma2)


TRACES = {"law_batch": 0}


def adaptive_batch(us, ys, dt, gammas, lams, r0s=None, *, alpha0=0.5, mesh=None, lengths=None):
    """The adaptive law on records of equal (padded) length at once: ``us`` (B, N, n), ``ys``
    (B, N), gains (B,), ``r0s`` (B, n, n) (default: each record's automatic ``R_0``, as
    `identify`). With `lengths` (B,), record b is its first ``lengths[b]`` samples, padded
    after its end (the law is causal: the padding does not reach the real samples' results;
    ``R_0`` and the noise level come from the real samples). Returns ``((law outputs, var α̂,
    var p̂), x0)`` with a leading batch axis, over all N samples; the variances are the law's
    band, as in `identify`. ``y − y[0]`` is identified (Remark 4), as `identify` does."""
    num = us.shape[1]
    lengths = np.full(us.shape[0], num) if lengths is None else np.asarray(lengths)
    memory = make_memory("exponential", dt, num, rule="trapezoid", order_range=DEFAULT_BOUNDS)
    if r0s is None:
        r0s = np.stack(
            [
                auto_r0(u, dt, alpha0, "exponential", "trapezoid", 1e-10, DEFAULT_BOUNDS, num=k,
                        mem=memory)
                for u, k in zip(us, lengths)
            ]
        )
    x0 = ys[:, :1]
    sigma2 = np.array([noise_variance(y[:k] - y[0]) for y, k in zip(ys, lengths)])
    args = [np.asarray(a) for a in (us, ys - x0, gammas, lams, r0s, sigma2)]
    # the stack grows to a power of two (and a multiple of the devices) by repeating its last
    # record, whose copies are dropped below: a few stack sizes, so a few compilations
    devices = 1 if mesh is None else mesh.devices.size
    size = 1 << max(len(us) - 1, 0).bit_length()
    size += (-size) % devices
    if size > len(us):
        args = [np.concatenate([a, np.repeat(a[-1:], size - len(us), axis=0)]) for a in args]
    args = [jnp.asarray(a) for a in args]
    if mesh is not None:
        args = [_sharded(a, mesh) for a in args]
    dtype = args[0].dtype
    out = _law_batch(memory, args[0], args[1], jnp.asarray(dt, dtype), *args[2:],
                     jnp.asarray(alpha0, dtype))
    return jax.tree_util.tree_map(lambda a: np.asarray(a)[: us.shape[0]], out), np.asarray(x0)


def _pad_to(a, num, value):
    """``a`` (N, …) extended to ``num`` rows with ``value``."""
    a = np.asarray(a)
    tail = np.full((num - a.shape[0],) + a.shape[1:], value, dtype=a.dtype)
    return np.concatenate([a, tail])


def _columns_from_batch(r, y, names, physical, batch, x0, i, gains, model, method, area, length):
    num = r.time.size  # the record's own samples, not its bucket's padding
    out, var_alpha, var_p = jax.tree_util.tree_map(lambda a: a[i][:num], batch)
    res = law_identification(
        out, var_alpha, var_p, float(x0[i, 0]), gains[0], gains[1], 0.5, r.dt, DEFAULT_BOUNDS,
        "exponential", host=True, y=y,
    )
    cols, part = adaptive_part(res, y, physical)
    columns = {"time": r.time, "file_time": r.time + r.time_offset, **cols, "y": y,
               "y_hat": np.asarray(res.y_hat)}
    summary = record_header(r, model, method, area, length)
    summary["parameter_names"] = names
    summary["gradient"] = part
    return columns, summary
