"""One recorded test (`Record`) and its clock: the time column checked, resampled when asked,
and a record cut from a file's columns."""

import dataclasses

import numpy as np

from ._errors import DataError

UNIFORM_RTOL = 1e-6  # relative spread of the time steps below which a grid counts as uniform


RESAMPLE_LIMIT = 1_000_000  # the most samples `resample` may create from one record


# `resample` refuses a step more than this many times the record's shortest step: the samples
# of a fast phase (a loading ramp) would be smoothed away
RESAMPLE_MAX_RATIO = 4.0


@dataclasses.dataclass(frozen=True)
class Record:
    """One recorded test, on its own clock.

    ``time`` (N,) from 0 at the first sample (``time_offset`` is the file's time there),
    ``inputs`` (N, n) in the order of ``input_names``, ``output`` (N,); ``uniform`` says
    whether the steps are equal (to 1e-6), and ``dt`` is the step (the median step when not).
    ``source`` is the file, ``name`` the record (the file's stem or the group's value);
    ``resampled`` is the relative spread of the original time steps when the record was
    resampled (``resample=``). ``afm`` holds, for a force curve, nanite's contact point and
    Young's modulus (pairs of name and value, `dict(rec.afm)`). `grid` gives the keyword for vojax's functions:
    ``vojax.identify(rec.inputs, rec.output, **rec.grid)``.
    """

    name: str
    source: str
    time: np.ndarray
    inputs: np.ndarray
    output: np.ndarray
    input_names: tuple[str, ...]
    output_name: str
    dt: float
    resampled: float | None = None
    time_name: str = "time"
    uniform: bool = True
    time_offset: float = 0.0
    units: tuple[tuple[str, str], ...] = ()
    afm: tuple[tuple[str, object], ...] = ()

    @property
    def grid(self) -> dict:
        """``{"dt": dt}`` on a uniform clock, ``{"t": time}`` otherwise."""
        return {"dt": self.dt} if self.uniform else {"t": self.time}


TIME_LIMIT = 1e100  # the largest time (in the file's unit) a record may hold


def _clock(path, name, t, columns: dict, lines, strict: bool, resample=None):
    """Checks the time column; resamples the record onto a uniform grid only when asked.

    **Returns:** ``(time, columns, dt, spread, uniform)``."""
    label = f"{path}, record {name!r}" if name else str(path)
    for key, values in {"time": t, **columns}.items():
        bad = ~np.isfinite(values)
        if np.any(bad):
            i = int(np.argmax(bad))
            raise DataError(f"{label}, line {lines[i]}, column {key!r}: value is NaN or infinite.")
    if t.size < 3:
        many = "1 sample" if t.size == 1 else f"{t.size} samples"
        raise DataError(f"{label}: only {many}; at least 3 are needed.")
    far = np.abs(t) > TIME_LIMIT
    if np.any(far):
        i = int(np.argmax(far))
        raise DataError(
            f"{label}, line {lines[i]}: the time {float(t[i]):g} is beyond ±{TIME_LIMIT:g} "
            "(its differences and products would overflow): give the time in other units."
        )
    steps = np.diff(t)
    if np.any(steps <= 0):
        i = int(np.argmax(steps <= 0)) + 1
        raise DataError(
            f"{label}, line {lines[i]}: time does not increase ({float(t[i - 1])!r} then "
            f"{float(t[i])!r})."
        )
    dt = float(np.median(steps))
    spread = float(np.max(np.abs(steps - dt)) / dt)
    if resample is not None:
        return _resample(label, t, columns, float(resample), steps, spread)
    if spread <= UNIFORM_RTOL:
        return t, columns, dt, None, True
    if strict:
        raise DataError(
            f"{label}: time steps vary by {100 * spread:.3g} % of the median step {dt:g} (--strict)."
        )
    return t, columns, dt, None, False  # used as recorded: the kernels take any clock


def _resample(label, t, columns, step, steps, spread):
    """Linear resampling onto ``t_0 + k·step``, refused where it would lose a phase or
    create more than `RESAMPLE_LIMIT` samples."""
    if not np.isfinite(step) or step <= 0:
        raise DataError(f"--resample must be a positive step, got {step}.")
    with np.errstate(over="ignore"):  # a tiny step over a long record: inf, refused below
        many = np.floor((t[-1] - t[0]) / step + 1e-9) + 1
    if not many <= RESAMPLE_LIMIT:
        raise DataError(
            f"{label}: --resample {step:g} makes "
            f"{f'{int(many):,}' if many < 1e15 else f'{many:.3g}'} samples of a record "
            f"{t[-1] - t[0]:g} "
            f"long (the limit is {RESAMPLE_LIMIT:,}); use a larger step, or leave --resample "
            "out: irregular clocks are used as recorded."
        )
    count = int(many)
    shortest = int(np.argmin(steps))
    if step > RESAMPLE_MAX_RATIO * steps[shortest]:
        raise DataError(
            f"{label}: the file has steps of {steps[shortest]:g} (at time {t[shortest]:g}), "
            f"{step / steps[shortest]:.3g} times shorter than --resample {step:g}: resampling "
            f"would smooth away what happens there. Use --resample ≤ "
            f"{RESAMPLE_MAX_RATIO * steps[shortest]:g}, or leave it out: irregular clocks "
            "are used as recorded."
        )
    grid = t[0] + step * np.arange(count)
    return grid, {k: np.interp(grid, t, v) for k, v in columns.items()}, step, spread, True


def _record(path, name, cols, idx, lines, time, inputs, output, trim_column, trim_below,
            strict, resample):
    """One `Record` from the rows `idx` of the columns `cols` (`lines`: each row's line in
    the file, for messages)."""
    t = cols[time][idx]
    rec_lines = lines[idx]
    if trim_column:
        keep = np.flatnonzero(np.abs(cols[trim_column][idx]) >= trim_below)
        if keep.size == 0:
            raise DataError(
                f"{path}, record {name!r}: no sample has |{trim_column}| ≥ {trim_below}."
            )
        idx, t, rec_lines = idx[keep[0] :], t[keep[0] :], rec_lines[keep[0] :]
    data = {c: cols[c][idx] for c in dict.fromkeys([*inputs, output])}
    grid, data, dt, spread, uniform = _clock(path, name, t, data, rec_lines, strict, resample)
    return Record(
        name=name or path.stem,
        source=str(path),
        time=grid - grid[0],
        inputs=np.stack([data[c] for c in inputs], axis=1),
        output=data[output],
        input_names=tuple(inputs),
        output_name=output,
        dt=dt,
        resampled=spread,
        time_name=time,
        uniform=uniform,
        time_offset=float(grid[0]),
    )
