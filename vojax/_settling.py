"""`settling_test`: the oscillation to superpose on a load that settles the order whatever
the parameters do, from the Fisher information with drifting parameters."""


import math

import numpy as np

from . import _validate as check
from ._design import Undetermined, fisher_information

_POSITIVE = ("a positive number", lambda v: 0 < v < math.inf)  # `_number`'s words and test


class SettlingTest:
    """An oscillation to superpose on a load so that the order is determined while the
    parameters drift slowly (`settling_test`): ``u + amplitude·sin(2π·frequency·(t − start))`` from
    `start` on, with `cycles` cycles to the end of the test, or a chirp whose frequency rises
    from `frequency` to `frequency_end` at the end (`phase`); `band`: the order's predicted
    ±2σ half-width with it, `band_without`: without it (∞ where the test alone does not
    determine the order), both with the parameters free to drift on hat functions (the
    Cramér–Rao bound: no estimator does better; the tracker's band also covers faster
    drift); `design`: its `fisher_information`. `expected`: the ±2σ half-width the tracker
    is expected to give with the oscillation, where the band it gave without it is known
    (`expect`), else None."""

    def __init__(self, amplitude, frequency, start, cycles, band, band_without, design,
                 fraction=None, frequency_end=None, end=None):
        self.amplitude, self.frequency, self.start, self.cycles = (
            amplitude, frequency, start, cycles)
        self.band, self.band_without, self.design = band, band_without, design
        self.expected = None
        self.fraction = fraction  # the amplitude over the input's RMS
        # a chirp: the frequency rises exponentially from `frequency` at `start` to this at
        # `end` (the test's last time); None: a sine
        self.frequency_end, self.end = frequency_end, end

    def inputs(self, u, times):
        """The planned inputs (N,) or (N, n) with the oscillation superposed on each input."""
        u = np.asarray(u, float)
        wave = np.where(times >= self.start, np.sin(self.phase(times - self.start)), 0.0)
        return u + self.amplitude * (wave if u.ndim == 1 else wave[:, None])

    def phase(self, tau):
        """The oscillation's phase at the times `tau` after its start: ``2π f τ`` for a sine;
        for a chirp from f₀ to f₁ over the time L to the end, whose frequency at τ is
        ``f₀ (f₁/f₀)^(τ/L)``, its integral ``2π f₀ L ((f₁/f₀)^(τ/L) − 1) / ln(f₁/f₀)``."""
        f0 = self.frequency
        if self.frequency_end is None:
            return 2 * np.pi * f0 * tau
        length, rate = self.end - self.start, math.log(self.frequency_end / f0)
        return 2 * np.pi * f0 * length * np.expm1(rate * tau / length) / rate

    def expect(self, band_now, exponent=None):
        """Sets and returns `expected`: the tracker's band with the oscillation, from its band
        on the record as it is, `band_now` (a median ±2σ half-width), as ``band_now ×
        (band / band_without)^exponent`` (`TrackerSettings.settling_exponent` by default,
        calibrated on the suite: the tracker's band also covers parameters drifting fast
        enough to follow the oscillation, so it narrows far less than the bound). None where
        the test without the oscillation does not determine the order (no ratio to scale)."""
        band_now = _number(band_now, "band_now", *_POSITIVE)
        if exponent is None:
            from ._settings import TrackerSettings

            exponent = TrackerSettings().settling_exponent
        exponent = _number(exponent, "exponent", "a number in [0, 1]", lambda v: 0 <= v <= 1)
        ratio = self.band / self.band_without
        self.expected = (band_now * ratio**exponent
                         if np.isfinite(ratio) and ratio > 0 else None)
        return self.expected

    def sentence(self, unit="") -> str:
        """The test in words, e.g. "an oscillation of 10 % of the load's RMS at 0.5 Hz from
        t = 20 s would give about ±0.03 with the parameters drifting slowly (…); the tracker,
        whose band also covers faster drift, about ±0.12". The first band is the Cramér–Rao
        bound with the parameters drifting on a few hat functions; the second the tracker's
        expected band (`expected`), where it is known, else a caution that it can be several
        times wider (`docs/calibration.md`, *The settling test's promise*)."""
        per = {"s": " Hz", "": " cycles per unit of time"}.get(unit, f" cycles per {unit}")
        size = (f"{100 * self.fraction:.0f} % of the load's RMS ({self.amplitude:.3g})"
                if self.fraction else f"{self.amplitude:.3g}")
        at = (f"at {self.frequency:.3g}{per}" if self.frequency_end is None else
              f"sweeping from {self.frequency:.3g} to {self.frequency_end:.3g}{per} (a chirp)")
        head = (f"an oscillation of {size} {at} from t = "
                f"{self.start:.3g}{' ' + unit if unit else ''} would give about ±{self.band:.2g} "
                "with the parameters drifting slowly (the best any estimator can do, under the "
                "model, at the noise measured")
        if self.expected is None:
            return head + "; the tracker's band, which also covers faster drift, can be "\
                "several times wider)"
        return head + f"); the tracker, whose band also covers faster drift, about " \
            f"±{self.expected:.2g}"

    def __repr__(self):
        end = "" if self.frequency_end is None else f"–{self.frequency_end:.3g}"
        return (f"SettlingTest(amplitude={self.amplitude:.3g}, "
                f"frequency={self.frequency:.3g}{end}, start={self.start:.3g}, band=±{self.band:.3g}, "
                f"band_without=±{self.band_without:.3g}"
                + ("" if self.expected is None else f", expected=±{self.expected:.3g}") + ")")


def settling_test(
    u, order, p, dt=None, *, t=None, noise_std, amplitude=0.1, cycles=(5, 10, 20, 40),
    starts=(0.0, 0.5), parameter_knots=8, order_drift=None, x0=True, memory="direct",
    order_range=(0.01, 0.99), pad_to=None, chirp=False, band_now=None,
) -> SettlingTest:
    """The oscillation to superpose on the load `u` (planned, or the one a record had) that
    best determines the order while the parameters are free to drift (on `parameter_knots`
    hat functions, as a gain): of a sine of `amplitude` × the input's RMS with each number of
    `cycles` from each start (a fraction of the test's span in `starts`), at least 8 samples
    a cycle, the one whose predicted order band (`fisher_information` with
    `parameter_knots`, and `order_drift` where given: the tracker's band at that drift) is
    narrowest. With `chirp`, each start also tries an exponential chirp from the fewest of
    `cycles` to the most (over the time to the end; the top at most one cycle in 8 samples),
    which needs no guess of the frequency that settles the order. `order`, `p`, `noise_std`:
    the hypothesised order (a number or a trajectory), parameters and noise, e.g. from
    `identify` on a first test. `pad_to`: as `fisher_information`'s (the same result; records
    padded alike share a program). `band_now`: the tracker's median ±2σ half-width on the
    record as it is (`Diagnostics.band_halfwidth`), from which the test's `expected` band is
    scaled (`SettlingTest.expect`); None: no expectation. Returns a `SettlingTest`."""
    u2 = np.asarray(check.samples(u, "u"), float)
    u2 = u2.reshape(u2.shape[0], -1)
    num = u2.shape[0]
    times = np.asarray(t, float) if t is not None else float(check.step(dt)) * np.arange(num)
    _number(amplitude, "amplitude", *_POSITIVE)
    if band_now is not None:
        _number(band_now, "band_now", *_POSITIVE)
    cycles = _numbers(cycles, "cycles", "one or more positive numbers",
                      lambda c: 0 < c < math.inf)
    starts = _numbers(starts, "starts", "one or more fractions of the span in [0, 1)",
                      lambda s: 0 <= s < 1)
    span = float(times[-1] - times[0])
    step = float(np.median(np.diff(times)))
    scale = float(np.sqrt(np.mean(u2**2)))
    if scale == 0:
        raise ValueError("`u` is zero throughout: the oscillation's amplitude is a fraction of "
                         "the load's RMS; give the planned load.")
    grid = dict(dt=dt, t=t, noise_std=noise_std, x0=x0, memory=memory,
                order_range=order_range, parameter_knots=parameter_knots,
                order_drift=order_drift, pad_to=pad_to)
    def band(inputs):  # the first call (the load alone) checks the order and its range
        try:
            return fisher_information(inputs, order, p, **grid)
        except Undetermined:  # the test does not determine the order at all
            return None

    without = band(u2)
    check.flag(chirp, "chirp")
    best, end = None, float(times[-1])
    for frac in starts:
        start = float(times[0] + frac * span)
        length = max(end - start, 1e-300)
        tries = [(count / length, None, count) for count in cycles]
        top = min(max(cycles) / length, 1 / (8 * step))  # at most one cycle in 8 samples
        if chirp and top > min(cycles) / length * (1 + 1e-9):
            tries.append((min(cycles) / length, top, None))
        for frequency, frequency_end, count in tries:
            if frequency * step > 1 / 8:  # fewer than 8 samples a cycle
                continue
            test = SettlingTest(amplitude * scale, frequency, start, count, np.inf, np.inf, None,
                                amplitude, frequency_end, end)
            if count is None:  # a chirp's cycles to the end
                test.cycles = float(test.phase(end - start) / (2 * np.pi))
            design = band(test.inputs(u2, times))
            if design is not None and (best is None or design.order_band < best.band):
                test.band, test.design = design.order_band, design
                test.band_without = np.inf if without is None else without.order_band
                best = test
    if best is None:
        raise ValueError("no oscillation of these cycles fits the sampling (8 samples a cycle "
                         "at least) or determines the order; sample faster or longer.")
    if band_now is not None:
        best.expect(band_now)
    return best


def _number(value, name, what, valid):
    """`value`, one Python or NumPy float or int (not a bool), as a float where `valid`, else
    a one-line error saying it must be `what`."""
    if isinstance(value, bool) or not isinstance(value, (int, float, np.floating)):
        raise TypeError(f"`{name}` must be {what}, got {value!r}.")
    if not valid(value):
        raise ValueError(f"`{name}` must be {what}, got {value!r}.")
    return float(value)


def _numbers(values, name, what, valid):
    """A number or a sequence of numbers, each `valid`, as a tuple of floats."""
    if values is None or isinstance(values, (str, bytes)):
        raise TypeError(f"`{name}` must be {what}, got {values!r}.")
    try:
        numbers = tuple(float(v) for v in np.atleast_1d(np.asarray(values, float)))
    except (TypeError, ValueError):
        raise TypeError(f"`{name}` must be {what}, got {values!r}.") from None
    if not numbers:
        raise ValueError(f"`{name}` must be {what}, got none.")
    for v in numbers:
        if not valid(v):
            raise ValueError(f"`{name}` must be {what}, got {v:g}.")
    return numbers
