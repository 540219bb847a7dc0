"""Checks of user input made before tracing: one sentence naming the argument."""

import jax
import jax.numpy as jnp
import numpy as np

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
        dtype = np.asarray(x).dtype
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


def choice(value, allowed, name: str):
    if value not in allowed:
        raise ValueError(f"`{name}` must be one of {', '.join(map(repr, allowed))}, got {value!r}.")
    return value


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


def count(value, name: str, low: int, high: int) -> int:
    """A whole number within ``[low, high]`` (a bool is not one)."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise TypeError(f"`{name}` must be a whole number, got {value!r}.")
    if not low <= int(value) <= high:
        raise ValueError(f"`{name}` must be from {low:,} to {high:,}, got {int(value):,}.")
    return int(value)


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
