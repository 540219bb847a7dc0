"""Recorded tests in: CSV (header row, ``#`` comments) or NPZ, one record or many per file."""

import dataclasses
from pathlib import Path

import numpy as np

from ._errors import DataError as DataError
from ._read import MAX_SAMPLES as MAX_SAMPLES
from ._read import _column as _column
from ._read import _npz_column as _npz_column
from ._read import _read_csv as _read_csv
from ._scales import Scales

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
    resampled (``resample=``). `grid` gives the keyword for vojax's functions:
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
        raise DataError(f"{label}: only {t.size} samples; at least 3 are needed.")
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


def load_records(
    path,
    *,
    time: str,
    inputs: list[str],
    output: str,
    group_by: str | None = None,
    strict: bool = False,
    resample: float | None = None,
    trim_column: str | None = None,
    trim_below: float | None = None,
    delimiter: str = ",",
    decimal: str = ".",
    segments=None,
    from_contact: bool = True,
    tip=None,
    poisson: float = 0.5,
    units: dict | None = None,
    strain_from_length: float | None = None,
    length_column: str | None = None,
    area_column: str | None = None,
) -> list[Record]:
    """Reads the records of one CSV, NPZ or AFM file.

    **Arguments:**

    - `time`, `inputs`, `output`: column names (NPZ: array names).
    - `group_by`: a column naming the record in a long-format file (e.g. ``specimen``); rows
      of a record need not be contiguous but keep their order.
    - `strict`: reject a non-uniform time column (by default it is used as recorded: vojax's
      kernels integrate exactly between any increasing sample times).
    - `resample`: a step: resample every record linearly onto a uniform grid of this step;
      refused (`DataError`) when that makes more than 1,000,000 samples, or when the file has
      steps more than 4 times shorter (a fast phase, such as a loading ramp, would be lost).
    - `trim_column`, `trim_below`: drop the leading samples while ``|column| < trim_below``
      (e.g. force before contact); the time is re-zeroed at the first kept sample.
    - `delimiter`: the CSV's field separator, ``","`` (default), ``";"`` or ``"\t"``;
      `decimal`: ``"."`` (default) or ``","`` (a decimal comma, with another delimiter).
    - AFM files (``.jpk-force``, ``.jpk-force-map``, ``.jpk-qi-data``, ``.jpk-qi-series``,
      ``.ibw``, ``.h5``; read with `afmformats`, ``pip install "vojax[afm]"``): one record per
      force curve, with the columns ``time_s``, ``segment`` (0 the approach, 1 the hold, then
      the retract), ``force_N``, ``height_measured_m``, ``height_piezo_m`` as in the file, and
      ``force_rise_N`` (F − F₀), ``indentation_m`` and ``contact_strain`` from the contact
      point (see the command line's docs). `segments`: the segments to keep (e.g. ``[0, 1]``,
      the approach and the hold; default all); `from_contact`: drop the samples before the
      contact point (default); `tip`: ``("sphere", R)`` with R in m or ``("cone", θ)`` with
      the half-angle in degrees, and `poisson`, for ``contact_strain``.
    - `units`: the units of columns whose names do not end in one, for the figures' axis
      labels, e.g. ``{"stress": "kPa", "time": "ms"}`` (a name such as ``stress_kPa`` already
      says it). They change no number.
    - `strain_from_length`: the rest length ``L₀`` of a specimen whose `output` column is its
      length ``L`` (in that column's unit): the output becomes the strain ``(L − L₀)/L₀``,
      named ``strain`` (unit 1). Every length must be above 0.
    - `length_column`, `area_column`: columns whose value at a record's first sample is its
      specimen's initial length ``l`` and contact area ``a`` (e.g. the tool gap of each
      specimen in a long-format file, which then shrinks as the tool moves in): the output
      becomes the engineering strain ``d/l`` (named ``strain``, unit 1) and the one input
      the stress ``F/a`` (named ``stress``), as eq. (35) with a number per record. Each must
      be above 0 there.

    **Returns:** a list of `Record`. **Raises:** `DataError` naming file, record, line, column.
    """
    inputs = column_names(time, inputs, output, group_by)
    pairs = check_units(units, [time, *inputs, output])
    scales = Scales.checked(strain_from_length, length_column, area_column, time, inputs,
                            output, group_by)
    return [scales.apply(dataclasses.replace(r, units=pairs)) for r in _read_records(
        path, time, inputs + scales.columns, output, group_by, strict, resample, trim_column,
        trim_below, delimiter, decimal, segments, from_contact, tip, poisson,
    )]


def column_names(time, inputs, output, group_by=None) -> list[str]:
    """The input columns as a list (a single name may be given as a string), each role's
    name checked: text, the inputs distinct, and no column in two roles (the output as its
    own input fits itself perfectly and says nothing)."""
    if isinstance(inputs, str):
        inputs = [inputs]
    try:
        inputs = list(inputs)
    except TypeError:
        raise TypeError(
            f"`inputs` must be a column name or a list of them, got {inputs!r}."
        ) from None
    named = dict(time=time, output=output) | ({} if group_by is None else dict(group_by=group_by))
    for role, name in [*named.items(), *(("inputs", n) for n in inputs)]:
        if not isinstance(name, str) or not name:
            raise TypeError(f"`{role}` must name a column (a non-empty string), got {name!r}.")
    if not inputs:
        raise ValueError("`inputs` must name at least one column.")
    twice = sorted({n for n in inputs if inputs.count(n) > 1})
    if twice:
        raise ValueError(f"the column {twice[0]!r} is given twice as an input.")
    for role, name in named.items():
        if name in inputs:
            raise ValueError(
                f"the column {name!r} is both an input and the {role.replace('_', ' ')}."
            )
    if len(set(named.values())) < len(named):
        roles = ", ".join(f"{r}={n!r}" for r, n in named.items())
        raise ValueError(f"one column is given two roles: {roles}.")
    return inputs


def check_units(units, columns) -> tuple[tuple[str, str], ...]:
    """`units` ({column: unit}) checked against the record's columns, as sorted pairs."""
    if units is None:
        return ()
    if not isinstance(units, dict):
        raise TypeError(f"`units` must be a dict of column: unit, got {type(units).__name__}.")
    for column, unit in units.items():
        if column not in columns:
            raise ValueError(
                f"`units` names {column!r}, which is not the time, an input or the output "
                f"column ({', '.join(columns)})."
            )
        if not isinstance(unit, str) or not unit.strip() or len(unit) > 24 or not unit.isprintable():
            raise ValueError(
                f"the unit of {column!r} must be a short printable text, got {unit!r}."
            )
    return tuple(sorted((c, u.strip()) for c, u in units.items()))


def _read_records(path, time, inputs, output, group_by, strict, resample, trim_column,
                  trim_below, delimiter, decimal, segments, from_contact, tip, poisson):
    """The records of one file, as `load_records` describes (without `units`)."""
    if delimiter not in (",", ";", "\t"):
        raise ValueError(f"`delimiter` must be ',', ';' or a tab, got {delimiter!r}.")
    if decimal not in (".", ","):
        raise ValueError(f"`decimal` must be '.' or ',', got {decimal!r}.")
    if decimal == "," and delimiter == ",":
        raise ValueError("a decimal comma needs another delimiter (';' or a tab).")
    path = Path(path)
    if path.is_dir():
        raise DataError(f"{path}: is a folder, not a CSV or NPZ file.")
    if not path.is_file():
        raise DataError(f"{path}: no such file.")
    wanted = [time, *inputs, output] + ([trim_column] if trim_column else [])
    from ._afm import check_tip, is_afm

    check_tip(tip, poisson)
    if is_afm(path):
        if group_by:
            raise DataError(f"{path}: --group-by is for long-format CSV files; each force "
                            "curve of an AFM file is a record.")
        return _afm_records(path, wanted, segments, from_contact, tip, poisson, time, inputs,
                            output, trim_column, trim_below, strict, resample)
    if segments is not None or tip is not None:
        raise DataError(f"{path}: --segments and --tip are for AFM files, not CSV or NPZ.")
    if path.suffix.lower() == ".npz":
        if group_by:
            raise DataError(f"{path}: --group-by is for long-format CSV files, not NPZ.")
        try:
            # opened here: np.load leaves its own handle open when the zip is unreadable
            with open(path, "rb") as handle, np.load(handle, allow_pickle=False) as data:
                missing = [c for c in wanted if c not in data.files]
                if missing:
                    raise DataError(
                        f"{path}: no array {missing[0]!r} (arrays: {', '.join(data.files)})."
                    )
                cols = {c: _npz_column(path, data, c) for c in dict.fromkeys(wanted)}
        except DataError:
            raise
        except Exception as e:  # noqa: BLE001 - truncated, not a zip, a bad header: one line
            text = str(e).splitlines()[0] if str(e) else type(e).__name__
            raise DataError(f"{path}: not a readable NPZ file ({text}).") from None
        lengths = {len(v) for v in cols.values()}
        if len(lengths) != 1:
            raise DataError(f"{path}: arrays {', '.join(wanted)} have different lengths.")
        groups = {"": np.arange(len(cols[time]))}
        lines = np.arange(len(cols[time])) + 1
    else:
        header, rows, lines = _read_csv(path, delimiter)
        lines = np.array(lines)
        cols = {
            c: _column(path, header, rows, lines, c, decimal=decimal) for c in dict.fromkeys(wanted)
        }
        if group_by:
            keys = _column(path, header, rows, lines, group_by, numeric=False)
            groups = {k: np.flatnonzero(keys == k) for k in dict.fromkeys(keys)}
        else:
            groups = {"": np.arange(len(rows))}
    return [
        _record(path, name, cols, idx, lines, time, inputs, output, trim_column, trim_below,
                strict, resample)
        for name, idx in groups.items()
    ]


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


def _afm_records(path, wanted, segments, from_contact, tip, poisson, time, inputs, output,
                 trim_column, trim_below, strict, resample):
    from ._afm import AFM_COLUMNS, read_afm

    missing = [c for c in wanted if c not in AFM_COLUMNS]
    if missing:
        raise DataError(
            f"{path}: an AFM file has no column {missing[0]!r} (columns: {', '.join(AFM_COLUMNS)})."
        )
    if "contact_strain" in wanted and tip is None:
        raise DataError(f"{path}: contact_strain needs a tip: --tip sphere:RADIUS_m or "
                        "cone:HALF_ANGLE_deg.")
    records = []
    for cols, meta in read_afm(path, tip=tip, poisson=poisson):
        name = meta["name"]
        keep = np.ones(cols["time_s"].size, bool)
        if segments is not None:
            keep &= np.isin(cols["segment"], np.asarray(list(segments), float))
        derived = {"force_rise_N", "indentation_m", "contact_strain"} & set(wanted)
        if (from_contact or derived) and meta["contact_index"] is None:
            raise DataError(
                f"{path}, curve {name!r}: no contact point found (the approach's force never "
                "stays above its baseline); use --no-contact with the file's own columns."
            )
        if from_contact:
            keep[: meta["contact_index"]] = False
        idx = np.flatnonzero(keep)
        if idx.size < 3:
            raise DataError(f"{path}, curve {name!r}: fewer than 3 samples in the segments kept.")
        for c in dict.fromkeys(wanted):
            bad = np.flatnonzero(~np.isfinite(cols[c][idx]))
            if bad.size:
                raise DataError(
                    f"{path}, curve {name!r}, sample {idx[bad[0]]}: {c} is not finite."
                )
        records.append(
            _record(path, name, cols, idx, np.arange(cols["time_s"].size) + 1, time, inputs,
                    output, trim_column, trim_below, strict, resample)
        )
    return records
