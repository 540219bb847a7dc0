"""Checks of user input made before tracing: one sentence naming the argument."""

import jax
import jax.numpy as jnp
import numpy as np

from ._kernels import RULES
from ._values import choice as choice
from ._values import count as count
from ._values import flag as flag
from ._values import real as real
from ._values import reals as reals
from ._xla import to_device

MEMORIES = ("direct", "exponential")


def _is_concrete(x) -> bool:
    return not isinstance(x, jax.core.Tracer)


def require_x64():
    """vojax computes in float64; JAX's default is float32, and the library does not change
    JAX's global settings on import. Refuse to run silently in single precision."""
    if not jax.config.jax_enable_x64:
        raise RuntimeError(
            "vojax needs float64: call jax.config.update('jax_enable_x64', True) before using it "
            "(vojax does not change JAX's settings itself)."
        )


def float_array(x, name: str):
    require_x64()
    if isinstance(x, (str, bytes)) or x is None:
        raise TypeError(f"`{name}` must be a real floating-point array, got {type(x).__name__}.")
    dtype = getattr(x, "dtype", None)
    if dtype is None:
        dtype = reals(x, name).dtype if _ragged(x) else np.asarray(x).dtype
    if not (jnp.issubdtype(dtype, jnp.floating)):
        if jnp.issubdtype(dtype, jnp.integer) and np.ndim(x) == 0:
            pass  # a Python/NumPy integer scalar such as dt=1 is fine
        else:
            raise TypeError(
                f"`{name}` must have a real floating-point dtype, got {np.dtype(dtype).name}."
            )
    if isinstance(x, jax.Array):  # on the device already, or traced
        return jnp.asarray(x, dtype=jnp.result_type(float))
    # a host value moves by a transfer (`to_device`), not by a compiled conversion
    return to_device(np.asarray(x, dtype=np.float64))


def _ragged(x) -> bool:
    try:
        np.asarray(x)
    except ValueError:
        return True
    return False


def columns(u):
    """Samples ``u`` (N,) or (N, n) as (N, n), without an eager JAX operation on a concrete
    array (each would compile a program of its own on a first call)."""
    if u.ndim == 2:
        return u
    return u[:, None] if isinstance(u, jax.core.Tracer) else to_device(np.asarray(u)[:, None])


def check_finite(x, name: str):
    if _is_concrete(x) and not bool(np.all(np.isfinite(np.asarray(x)))):
        bad = np.argwhere(~np.isfinite(np.asarray(x)))[0]
        raise ValueError(
            f"`{name}` contains NaN or inf (first at index {tuple(int(i) for i in bad)})."
        )


def samples(u, name: str = "u"):
    """``u`` as a float array of shape ``(N,)`` or ``(N, n)``, finite, with ``N ≥ 1``."""
    arr = float_array(u, name)
    if arr.ndim not in (1, 2):
        raise ValueError(f"`{name}` must have shape (N,) or (N, n), got shape {arr.shape}.")
    if arr.shape[0] < 1 or (arr.ndim == 2 and arr.shape[1] < 1):
        raise ValueError(
            f"`{name}` must hold at least one sample of at least one channel, got shape {arr.shape}."
        )
    check_finite(arr, name)
    return arr


def step(dt, name: str = "dt"):
    """A positive, finite scalar step."""
    arr = float_array(dt, name)
    if arr.ndim != 0:
        raise ValueError(f"`{name}` must be a scalar, got shape {arr.shape}.")
    if _is_concrete(arr):
        value = float(arr)
        if not np.isfinite(value) or value <= 0:
            raise ValueError(f"`{name}` must be a positive finite number, got {value}.")
    return arr


def order(order, num_samples: int, name: str = "order", bounds=(0.0, 1.0), closed=False):
    """A scalar or ``(N,)`` order with values strictly inside ``bounds``, returned as ``(N,)``."""
    arr = float_array(order, name)
    if arr.ndim == 0:
        arr = jnp.full((num_samples,), arr)
    elif arr.ndim != 1 or arr.shape[0] != num_samples:
        raise ValueError(
            f"`{name}` must be a scalar or have shape ({num_samples},) to match the samples, "
            f"got shape {arr.shape}."
        )
    check_finite(arr, name)
    if _is_concrete(arr):
        values = np.asarray(arr)
        lo, hi = bounds
        outside = (values < lo) | (values > hi) if closed else (values <= lo) | (values >= hi)
        if np.any(outside):
            i = int(np.argmax(outside))
            brackets = "[{}, {}]" if closed else "({}, {})"
            raise ValueError(
                f"`{name}` must lie in {brackets.format(lo, hi)}, got {float(values[i])!r} at "
                f"sample {i}."
            )
    return arr


def interval(bounds, name: str, within=(0.0, 1.0)):
    """A pair ``lo < hi`` strictly inside ``within``."""
    try:
        lo, hi = (float(b) for b in bounds)
    except (TypeError, ValueError):
        raise TypeError(f"`{name}` must be a pair of numbers (lo, hi), got {bounds!r}.") from None
    if not (within[0] < lo < hi < within[1]):
        raise ValueError(
            f"`{name}` must satisfy {within[0]} < lo < hi < {within[1]}, got ({lo}, {hi})."
        )
    return lo, hi


def positive(value, name: str, upper=None):
    """A positive finite scalar (strictly below ``upper`` when given)."""
    arr = step(value, name)
    if upper is not None and _is_concrete(arr) and float(arr) >= upper:
        raise ValueError(f"`{name}` must be below {upper}, got {float(arr)}.")
    return arr


def times(t, num_samples: int, name: str = "t"):
    """Sample times: a finite, strictly increasing ``(N,)`` float array matching the samples."""
    arr = float_array(t, name)
    if arr.ndim != 1 or arr.shape[0] != num_samples:
        raise ValueError(
            f"`{name}` must have shape ({num_samples},) to match the samples, got shape {arr.shape}."
        )
    if num_samples < 2:
        raise ValueError(f"`{name}` must hold at least 2 sample times, got {num_samples}.")
    check_finite(arr, name)
    if _is_concrete(arr):
        steps = np.diff(np.asarray(arr))
        if np.any(steps <= 0):
            i = int(np.argmax(steps <= 0))
            raise ValueError(
                f"`{name}` must be strictly increasing, but t[{i + 1}] = {float(arr[i + 1])!r} "
                f"follows t[{i}] = {float(arr[i])!r}."
            )
    return arr


def grid(dt, t, num_samples: int):
    """Exactly one of the step ``dt`` and the sample times ``t``, checked; returns them as
    given (a NumPy grid stays on the host for the exponential memory's design)."""
    if (dt is None) == (t is None):
        raise TypeError(
            "give exactly one of `dt` (a uniform step) and `t` (the sample times), "
            + ("got neither." if dt is None else "got both.")
        )
    if t is None:
        step(dt)
    else:
        times(t, num_samples)
    return dt, t


def law_settings(lam, alpha0, alpha_bounds, memory, rule):
    """The settings of a record's fit that need no record: λ, α̂(0) inside the order bounds,
    the memory and the rule. Returns the bounds as checked."""
    if lam is not None and not isinstance(lam, str):
        positive(lam, "lam")
    bounds = interval(alpha_bounds, "alpha_bounds")
    a0 = (
        float(np.asarray(step(alpha0, "alpha0")))
        if not isinstance(alpha0, jax.core.Tracer)
        else None
    )
    if a0 is not None and not bounds[0] <= a0 <= bounds[1]:
        raise ValueError(f"`alpha0` must lie inside `alpha_bounds` {bounds}, got {a0}.")
    choice(memory, MEMORIES, "memory")
    choice(rule, RULES, "rule")
    return bounds


def check_options(u, y, dt, lam, alpha0, alpha_bounds, memory, rule, x0, r0, *, t=None):
    """Validates the arguments shared by `identify`, `tune_gains` and `refit` (the grid: the
    step `dt`, or the sample times `t` where given); returns prepared arrays."""
    u = samples(u, "u")
    u2 = columns(u)
    y = samples(y, "y")
    if y.ndim != 1:
        raise ValueError(f"`y` must have shape (N,), got shape {y.shape}.")
    if y.shape[0] != u2.shape[0]:
        raise ValueError(
            f"`u` and `y` must have the same number of samples, got {u2.shape[0]} and {y.shape[0]}."
        )
    if u2.shape[0] < 3:
        raise ValueError(f"`u` and `y` must hold at least 3 samples, got {u2.shape[0]}.")
    for name, arr in (("u", u2), ("y", y)):
        magnitude(arr, name)
    if _is_concrete(y) and np.ptp(np.asarray(y)) == 0:
        raise ValueError(
            f"`y` is {float(np.asarray(y)[0]):g} at every sample: there is no response to fit."
        )
    if _is_concrete(u2):
        silent = ~np.any(np.asarray(u2) != 0, axis=0)
        if np.any(silent):
            j = int(np.argmax(silent))
            raise ValueError(
                f"input {j + 1} of `u` is 0 at every sample: nothing it drives can be "
                "identified (its parameter is undetermined); leave that input out."
            )
    grid(dt, t, u2.shape[0])
    bounds = law_settings(lam, alpha0, alpha_bounds, memory, rule)
    if x0 is None:  # (NumPy on concrete data: an eager slice would compile per length)
        x0 = y[0] if isinstance(y, jax.core.Tracer) else to_device(np.asarray(y)[0])
    else:
        x0 = magnitude(scalar(x0, "x0"), "x0", tiny=True)
    if isinstance(r0, str):
        if r0 != "auto":
            raise ValueError(f"`r0` must be 'auto', None or an (n, n) matrix, got {r0!r}.")
    elif r0 is not None:
        r0 = jnp.asarray(spd_matrix(r0, "r0", u2.shape[1]), jnp.result_type(float))
    return u2, y, bounds, x0, r0


def spd_matrix(value, name: str, n: int):
    """An ``(n, n)`` symmetric positive definite matrix (a traced one: its shape only),
    as a NumPy array. Symmetric to rounding: ``|M − Mᵀ| ≤ 1e-10 max|M|`` (an eigenvalue
    routine for symmetric matrices reads one triangle and would pass the other unseen)."""
    if isinstance(value, jax.core.Tracer):
        if value.shape != (n, n):
            raise ValueError(f"`{name}` must have shape ({n}, {n}), got {value.shape}.")
        return value
    m = np.asarray(reals(value, name), np.float64)
    if m.shape != (n, n):
        raise ValueError(f"`{name}` must have shape ({n}, {n}), got {m.shape}.")
    if not np.all(np.isfinite(m)):
        raise ValueError(f"`{name}` must be finite, got a NaN or an infinity.")
    if np.max(np.abs(m - m.T)) > 1e-10 * np.max(np.abs(m)):
        raise ValueError(f"`{name}` must be symmetric, got one whose entries differ from its "
                         f"transpose's by up to {np.max(np.abs(m - m.T)):.3g}.")
    if np.any(np.linalg.eigvalsh(m) <= 0):
        raise ValueError(f"`{name}` must be symmetric positive definite, got a least "
                         f"eigenvalue of {np.min(np.linalg.eigvalsh(m)):.3g}.")
    return m


def window_mask(window, times):
    """The fit window ``(from, to)`` as a 0/1 mask: 1 at the samples with
    ``from ≤ t_k ≤ to`` (`times` on the host); an end given as None is open. Refuses anything
    but a pair of times with from < to."""
    def end(v, open_end):
        if v is None:
            return open_end
        if isinstance(v, bool):
            raise TypeError
        return float(v)

    try:
        first, last = window
        lo, hi = end(first, -np.inf), end(last, np.inf)
    except (TypeError, ValueError):
        raise TypeError(f"`window` must be a pair of times (from, to), got {window!r}.") from None
    if not lo < hi:  # NaN fails too
        raise ValueError(f"`window` must satisfy from < to, got ({lo}, {hi}).")
    times = np.asarray(times, dtype=float)
    return ((times >= lo) & (times <= hi)).astype(float)


def check_mask(mask, num, num_inputs):
    """A 0/1 mask of shape (N,) with enough fitted samples; returns it as a NumPy array."""
    arr = reals(mask, "mask")
    if arr.shape != (num,):
        raise ValueError(f"`mask` must have shape ({num},), got {arr.shape}.")
    if not np.all((arr == 0) | (arr == 1)):
        raise ValueError("`mask` must hold only 0 (not fitted) and 1 (fitted).")
    if arr.sum() < num_inputs + 3:
        raise ValueError(
            f"`mask` leaves {int(arr.sum())} fitted samples; at least {num_inputs + 3} are needed."
        )
    return arr


def known_offset(x0) -> float:
    """`x0` as a finite Python float (the tracker's known output offset), checked as the
    law's is (`_scalar`)."""
    return float(magnitude(scalar(x0, "x0"), "x0", tiny=True))


MAGNITUDES = (1e-100, 1e100)  # a signal's largest magnitude outside these is refused: its
# squares (in sums of squares, covariances, the noise's variance) leave float64


def magnitude(x, name, tiny=False):
    """`x` unchanged where its largest magnitude is 0 or lies within `MAGNITUDES` (or below,
    where `tiny`: an offset of 1e-200 is 0 in effect); a `ValueError` saying to change the
    units otherwise. Traced values pass."""
    if not _is_concrete(x):
        return x
    size = float(np.max(np.abs(np.asarray(x)))) if np.size(x) else 0.0
    lo, hi = MAGNITUDES
    if size > hi or (0 < size < lo and not tiny):
        raise ValueError(
            f"`{name}`'s largest magnitude is {size:.3g}, outside [{lo:g}, {hi:g}]: express "
            "it in other units (its squares would leave float64)."
        )
    return x


def scalar(x, name):
    if isinstance(x, (str, bytes, bool)) or x is None:  # jnp.asarray("0") would take it
        raise ValueError(f"`{name}` must be a number, got {x!r}.")
    try:
        arr = jnp.asarray(x, jnp.result_type(float))
    except (TypeError, ValueError):
        raise ValueError(f"`{name}` must be a number, got {x!r}.") from None
    if arr.ndim != 0:
        raise ValueError(f"`{name}` must be a scalar, got shape {arr.shape}.")
    if not isinstance(arr, jax.core.Tracer) and not np.isfinite(float(arr)):
        raise ValueError(f"`{name}` must be finite, got {float(arr)}.")
    return arr


def first_bad(*arrays):
    """Index of the first sample at which any of the arrays is not finite, or None."""
    bad = np.zeros(np.shape(arrays[0])[0], bool)
    for a in arrays:
        a = np.asarray(a)
        bad |= ~np.isfinite(a.reshape(a.shape[0], -1)).all(axis=1)
    return int(np.argmax(bad)) if bad.any() else None


def record_arguments(u, y, dt, t, *, output="y", call="identify"):
    """``(u, y, dt, t)``, a `Record` in `u` unpacked onto its own clock: its inputs, its
    output, and its step or its times. A `Record` carries its clock: `y`, `dt` or `t` given
    with it is an error (a step would lose a non-uniform clock without a word). `output`
    names `y` in the messages, `call` the function."""
    from ._data._records import Record

    if not isinstance(u, Record):
        if y is None:
            raise TypeError(
                f"`{output}` (the measured output) is missing; or pass a Record alone, "
                f"{call}(record)."
            )
        return u, y, dt, t
    given = [name for name, v in ((output, y), ("dt", dt), ("t", t)) if v is not None]
    if given:
        raise ValueError(
            f"a Record carries its own output and clock: leave out {', '.join(given)} "
            f"({call}(record)), or pass record.inputs and record.output with its grid."
        )
    grid = u.grid
    return u.inputs, u.output, grid.get("dt"), grid.get("t")
