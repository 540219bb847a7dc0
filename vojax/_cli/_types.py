"""The command line's argument types: each turns one option's text into a value or says in one
sentence what is wrong."""

import argparse
import math


class CLIError(Exception):
    """A problem the user can fix; printed as one sentence."""


class _Parser(argparse.ArgumentParser):
    """An unknown option or a bad value: one line, exit 1, as every other bad input (argparse
    would print its usage and exit 2, the code of a batch with failed records). Options are
    taken only as spelled in full: argparse would read ``vojax check --out x`` as
    ``--output x`` (a command without --out) and go on."""

    def __init__(self, *args, **kwargs):
        kwargs.setdefault("allow_abbrev", False)
        super().__init__(*args, **kwargs)

    def error(self, message):
        self.exit(1, f"vojax: error: {message} (see {self.prog} --help).\n")


BIG = 1e300  # numbers beyond this (or below its inverse, for sizes) overflow in arithmetic


def _number(text):
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None


def _positive(text: str):
    """A size (area, length, step, tolerance): finite, > 0, within 1e-300…1e300."""
    value = _number(text)
    if not (1.0 / BIG <= value <= BIG):
        raise argparse.ArgumentTypeError(
            f"expected a positive number between 1e-300 and 1e300, got {text!r}"
        )
    return value


def _parameters(text):
    """--parameters: free (or drifting), constant, or a drift bound ≥ 0."""
    from .._tracker._estimator import parameters_statement

    text = text.strip()
    try:
        value = text if text in ("free", "drifting", "constant") else float(text)
        return parameters_statement(value)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected free, constant or a drift bound such as 0.1, got {text!r}"
        ) from None


def _finite(text: str):
    """A time or a threshold: finite, within ±1e300."""
    value = _number(text)
    if not abs(value) <= BIG:
        raise argparse.ArgumentTypeError(f"expected a finite number, got {text!r}")
    return value


NOISE_KEYS = ("order_drift", "parameter_drift", "noise_std")


def _noise(text: str) -> dict:
    """The tracker's noise intensities, ``order_drift=…,parameter_drift=…,noise_std=…``:
    each key once, each value a positive finite number."""
    pairs = [part.partition("=") for part in text.split(",")]
    keys = [k.strip() for k, _, _ in pairs]
    if sorted(keys) != sorted(NOISE_KEYS) or any(not eq for _, eq, _ in pairs):
        raise argparse.ArgumentTypeError(
            f"expected order_drift=…,parameter_drift=…,noise_std=… (each once), got {text!r}"
        )
    out = {}
    for key, _, value in pairs:
        try:
            number = float(value)
        except ValueError:
            number = math.nan
        if not 0.0 < number <= BIG:
            raise argparse.ArgumentTypeError(
                f"{key.strip()} must be a positive finite number, got {value.strip()!r}"
            )
        out[key.strip()] = number
    return {k: out[k] for k in NOISE_KEYS}


def _fraction(text: str):
    """A relative tolerance: in (0, 1)."""
    value = _number(text)
    if not 0.0 < value < 1.0:
        raise argparse.ArgumentTypeError(f"expected a number between 0 and 1, got {text!r}")
    return value


def _order(text: str):
    value = _number(text)
    if not 0.0 < value < 1.0:
        raise argparse.ArgumentTypeError(f"expected an order between 0 and 1, got {text!r}")
    return value


def _count(text: str):
    """A non-negative integer below 2^63 (a seed, a number of samples)."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a whole number, got {text!r}") from None
    if not 0 <= value < 2**63:
        raise argparse.ArgumentTypeError(f"expected a whole number from 0 to 2^63 - 1, got {text!r}")
    return value


def _delimiter(text: str):
    value = {"tab": "\t", "\\t": "\t", "comma": ",", "semicolon": ";"}.get(text, text)
    if value not in (",", ";", "\t"):
        raise argparse.ArgumentTypeError(f"expected ',', ';' or tab, got {text!r}")
    return value


def _rate(text: str):
    return None if text == "auto" else _gain(text)


def _gain(text: str):
    if text == "auto":
        return "auto"
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected a positive number or 'auto', got {text!r}"
        ) from None
    if not value > 0:
        raise argparse.ArgumentTypeError(f"expected a positive number, got {text!r}")
    return value


def _segments(text: str):
    try:
        values = tuple(int(v) for v in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected comma-separated segment numbers (0, 1, …), got {text!r}"
        ) from None
    if any(v < 0 for v in values):
        raise argparse.ArgumentTypeError(f"segment numbers are 0 or more, got {text!r}")
    return values


def _units(text: str):
    """``--units stress=kPa,time=ms`` as a dict."""
    out = {}
    for part in text.split(","):
        column, eq, unit = part.partition("=")
        if not eq or not column.strip() or not unit.strip():
            raise argparse.ArgumentTypeError(
                f"expected COLUMN=UNIT pairs separated by commas (stress=kPa,time=ms), got {text!r}"
            )
        out[column.strip()] = unit.strip()
    return out


def _bounds(text: str):
    """``--alpha-bounds LO,HI``: two orders with 0 < LO < HI < 1."""
    try:
        lo, hi = (float(v) for v in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected two orders LO,HI such as 0.05,0.95, got {text!r}"
        ) from None
    if not 0 < lo < hi < 1:
        raise argparse.ArgumentTypeError(f"expected 0 < LO < HI < 1, got {text!r}")
    return lo, hi


def _order_list(text: str):
    try:
        values = tuple(float(v) for v in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected comma-separated numbers, got {text!r}") from None
    if not all(0 < v < 1 for v in values):
        raise argparse.ArgumentTypeError(f"every order must lie in (0, 1), got {text!r}")
    return values
