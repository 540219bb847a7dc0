"""Checks of plain Python values (numbers, flags, counts, choices), each refusal one
sentence naming the argument; no JAX here (the closed forms use them too)."""

import numpy as np


def choice(value, allowed, name: str):
    if value not in allowed:
        raise ValueError(f"`{name}` must be one of {', '.join(map(repr, allowed))}, got {value!r}.")
    return value


def _short(value) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def reals(value, name: str) -> np.ndarray:
    """`value` as a NumPy float array; text, None, complex, object or ragged values are
    refused with a `TypeError` naming `name` (NumPy's own message names nothing)."""
    if isinstance(value, (str, bytes)) or value is None:
        raise TypeError(f"`{name}` must be a number or an array of numbers, got {_short(value)}.")
    try:
        arr = np.asarray(value)
    except ValueError:  # a ragged list
        raise TypeError(f"`{name}` must be a number or a rectangular array of numbers, got "
                        f"{_short(value)}.") from None
    if arr.dtype.kind not in "fiub":
        raise TypeError(f"`{name}` must hold real numbers, got {_short(value)} "
                        f"(dtype {arr.dtype}).")
    return arr.astype(float)


def real(value, name: str) -> float:
    """One real number (a bool is not one) as a Python float; NaN and inf pass (the caller's
    range says what is allowed)."""
    if isinstance(value, (bool, np.bool_)):
        raise TypeError(f"`{name}` must be a number, got {value!r}.")
    arr = reals(value, name)
    if arr.ndim != 0:
        raise TypeError(f"`{name}` must be one number, got an array of shape {arr.shape}.")
    return float(arr)


def flag(value, name: str) -> bool:
    """True or False (a NumPy bool too); anything else, even if truthy, is refused."""
    if not isinstance(value, (bool, np.bool_)):
        raise TypeError(f"`{name}` must be True or False, got {value!r}.")
    return bool(value)


def count(value, name: str, low: int, high: int) -> int:
    """A whole number within ``[low, high]`` (a bool is not one)."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise TypeError(f"`{name}` must be a whole number, got {value!r}.")
    if not low <= int(value) <= high:
        raise ValueError(f"`{name}` must be from {low:,} to {high:,}, got {int(value):,}.")
    return int(value)
