"""Recorded tests in: CSV (header row, ``#`` comments) or NPZ, one record or many per file."""

import dataclasses
from pathlib import Path

import numpy as np

from .. import _validate as check
from ._afm_records import AfmOptions, export_records, file_records
from ._errors import CurvesFailed
from ._errors import DataError as DataError
from ._read import MAX_SAMPLES as MAX_SAMPLES
from ._read import _column as _column
from ._read import _npz_column as _npz_column
from ._read import _read_csv as _read_csv
from ._read import row_groups
from ._record import Record as Record
from ._record import _record
from ._scales import Scales


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
    contact: str | None = None,
    spring_constant: float | None = None,
    baseline: str | None = None,
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
      point found with nanite (see the command line's docs). `segments`: the segments to keep
      (e.g. ``[0, 1]``, the approach and the hold; default all); `from_contact`: drop the
      samples before the contact point and after the tip leaves the sample (the first
      sample after the deepest indentation at which it is back to 0 or below; default);
      `tip`: ``("sphere", R)`` with R in m,
      ``("cone", θ)`` with the half-angle or ``("pyramid", θ)`` with the face angle in
      degrees, and `poisson`, for ``contact_strain`` and nanite's Hertz fit of the loading
      (its Young's modulus is in each record's ``afm``); `contact`: ``"fit"`` (that fit's
      free contact point, the default with a tip) or a nanite estimator
      (``"deviation_from_baseline"``, the default without one; the others in
      ``vojax.io.POC_METHODS``). A CSV export of force curves (the columns ``time_s``,
      ``segment``, ``force_N`` and ``height_measured_m`` or ``height_piezo_m``; one curve per
      `group_by` value) is read the same way when any of these options or
      `spring_constant` (the cantilever's, N/m, which the export needs) is given.
      `baseline`: how the force's baseline is corrected before the contact point is found,
      ``"offset"`` (its mean before contact, the default) or ``"tilt"`` (also a slope
      against the tip position, fitted before contact and subtracted over the approach: an
      optical lever's virtual deflection; nanite's ``correct_force_slope``).
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

    **Returns:** a list of `Record`. **Raises:** `DataError` naming file, record, line, column;
    where some curves of an AFM file cannot be read (no contact point, a Hertz fit that does
    not converge) and others can, `vojax.io.CurvesFailed`, a `DataError` holding the records
    read (``error.records``) and each other curve's reason (``error.failures``).
    """
    inputs = column_names(time, inputs, output, group_by)
    if resample is not None:
        resample = check.real(resample, "resample")
    pairs = check_units(units, [time, *inputs, output])
    scales = Scales.checked(strain_from_length, length_column, area_column, time, inputs,
                            output, group_by)
    afm = AfmOptions.checked(segments, from_contact, tip, poisson, contact, spring_constant,
                             baseline)
    def finished(records):
        return [scales.apply(dataclasses.replace(r, units=pairs)) for r in records]

    try:
        return finished(_read_records(
            path, time, inputs + scales.columns, output, group_by, strict, resample,
            trim_column, trim_below, delimiter, decimal, afm,
        ))
    except CurvesFailed as e:  # the curves that were read, finished as the others would be
        e.records = finished(e.records)
        raise


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
                  trim_below, delimiter, decimal, afm):
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
    from ._afm import is_afm

    trim = (trim_column, trim_below, strict, resample)
    if is_afm(path):
        if group_by:
            raise DataError(f"{path}: --group-by is for long-format CSV files; each force "
                            "curve of an AFM file is a record.")
        if afm.spring_constant is not None:
            raise DataError(f"{path}: an AFM file gives its own spring constant; "
                            "--spring-constant is for a CSV export of a force curve.")
        return file_records(path, wanted, afm, time, inputs, output, trim)
    if path.suffix.lower() == ".npz" and afm.export:
        raise DataError(f"{path}: --segments, --tip, --contact and --spring-constant are for "
                        "AFM files and CSV exports of force curves, not NPZ.")
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
        if afm.export:
            return export_records(path, header, rows, lines, decimal, group_by, wanted, afm,
                                  time, inputs, output, trim)
        cols = {
            c: _column(path, header, rows, lines, c, decimal=decimal) for c in dict.fromkeys(wanted)
        }
        groups = row_groups(path, header, rows, lines, group_by)
    return [
        _record(path, name, cols, idx, lines, time, inputs, output, trim_column, trim_below,
                strict, resample)
        for name, idx in groups.items()
    ]
