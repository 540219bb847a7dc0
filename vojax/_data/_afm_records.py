"""Records from AFM force curves: of an AFM file (read by afmformats), or of a CSV export of
one (the columns ``time_s``, ``segment``, ``force_N`` and a height, with the spring constant
given), each through nanite's contact point (`_contact`) and cut to the segments and the
contact asked for."""

import dataclasses

import numpy as np

from .._values import flag
from ._errors import CurvesFailed, DataError
from ._record import _record

DERIVED = ("force_rise_N", "indentation_m", "contact_strain")
EXPORT_HEIGHTS = ("height_measured_m", "height_piezo_m")  # either: the measured one first
SPRING_CONSTANT = (1e-6, 1e4)  # N/m; outside these a unit mistake


@dataclasses.dataclass(frozen=True)
class AfmOptions:
    """How force curves become records: the `segments` kept, whether the samples before
    contact and after the tip leaves the sample are dropped (`from_contact`, `released`),
    the `tip` and `poisson` of the Hertz fit and the contact strain, the `contact` method,
    the `spring_constant` (N/m) of a CSV export and the force `baseline`'s correction
    (`_contact.BASELINES`)."""

    segments: tuple | None = None
    from_contact: bool = True
    tip: tuple | None = None
    poisson: float = 0.5
    contact: str | None = None
    spring_constant: float | None = None
    baseline: str | None = None

    @classmethod
    def checked(cls, segments=None, from_contact=True, tip=None, poisson=0.5, contact=None,
                spring_constant=None, baseline=None):
        from ._afm import check_tip
        from ._contact import check_baseline, check_contact

        tip = check_tip(tip, poisson)
        check_contact(contact, tip)
        if baseline is not None:
            baseline = check_baseline(baseline)
        flag(from_contact, "from_contact")
        if segments is not None:
            given = segments
            segments = None if isinstance(given, (str, bytes)) else (
                tuple(given) if hasattr(given, "__iter__") else None)
            if segments is None or not all(
                isinstance(k, (int, np.integer)) and not isinstance(k, bool) for k in segments
            ):
                raise TypeError(f"`segments` must be a list of segment numbers, got {given!r}.")
        if spring_constant is not None:
            lo, hi = SPRING_CONSTANT
            if isinstance(spring_constant, bool) or not (
                isinstance(spring_constant, (int, float)) and lo <= spring_constant <= hi
            ):
                raise ValueError(
                    f"the spring constant is in N/m, from {lo:g} to {hi:g}, got "
                    f"{spring_constant!r}."
                )
        return cls(segments, bool(from_contact), tip,
                   poisson, contact, None if spring_constant is None else float(spring_constant),
                   baseline)

    @property
    def export(self) -> bool:
        """Whether a CSV is read as an AFM export (any AFM option given but `from_contact`)."""
        return (self.segments is not None or self.tip is not None or self.contact is not None
                or self.spring_constant is not None or self.baseline is not None)

    def analyse(self, wanted) -> bool:
        """Whether the curves need nanite's contact point."""
        return bool(self.from_contact or set(DERIVED) & set(wanted) or self.tip is not None
                    or self.contact is not None or self.baseline is not None)


def file_records(path, wanted, afm, time, inputs, output, trim):
    """The records of an AFM file; `trim` is ``(trim_column, trim_below, strict, resample)``."""
    from ._afm import read_afm

    _check_wanted(path, wanted, afm)
    curves, failures = read_afm(path, tip=afm.tip, poisson=afm.poisson, contact=afm.contact,
                                analyse=afm.analyse(wanted), baseline=afm.baseline)
    records = []
    for cols, meta in curves:
        try:
            records.append(_cut(path, cols, meta, wanted, afm, time, inputs, output, trim))
        except DataError as e:  # this curve's samples; the others stand
            failures.append((meta["name"], str(e)))
    return _read_or_failed(path, records, failures)


def _read_or_failed(path, records, failures):
    """The records of a file's curves where all were read; `CurvesFailed` where some were;
    a `DataError` where none was (the curve's own reason for a file of one)."""
    if failures and records:
        raise CurvesFailed(path, records, failures)
    if len(failures) == 1:
        raise DataError(failures[0][1])
    if failures:
        raise DataError(f"{path}: none of its {len(failures)} curves could be read; the "
                        f"first's reason: {failures[0][1]}")
    return records


def export_records(path, header, rows, lines, decimal, group_by, wanted, afm, time, inputs,
                   output, trim):
    """The records of a CSV export of force curves (one per `group_by` value, else one)."""
    from ._afm import _curve
    from ._contact import check_baseline, check_contact
    from ._read import _column, row_groups

    present = [h for h in EXPORT_HEIGHTS if h in header]
    need = ["time_s", "segment", "force_N"]
    missing = [c for c in need if c not in header] + ([] if present else [EXPORT_HEIGHTS[0]])
    if missing:
        raise DataError(
            f"{path}: the AFM options are for AFM files and CSV exports of force curves, "
            f"which have the columns time_s, segment, force_N and "
            f"{' or '.join(EXPORT_HEIGHTS)}; {missing[0]!r} is not there."
        )
    if afm.spring_constant is None:
        raise DataError(
            f"{path}: a CSV export of a force curve needs its cantilever's spring constant "
            "(--spring-constant in N/m; spring_constant= in Python)."
        )
    _check_wanted(path, wanted, afm)
    raw = {c: _column(path, header, rows, lines, c, decimal=decimal) for c in need + present}
    groups = row_groups(path, header, rows, lines, group_by, single=path.stem)
    contact, baseline = check_contact(afm.contact, afm.tip), check_baseline(afm.baseline)
    names = {"time_s": "time", "segment": "segment", "force_N": "force",
             "height_measured_m": "height (measured)", "height_piezo_m": "height (piezo)"}
    records, failures = [], []
    for k, (name, idx) in enumerate(groups.items()):
        curve = _ExportCurve({names[c]: v[idx] for c, v in raw.items()},
                             {"spring constant": afm.spring_constant, "path": path, "enum": k})
        try:
            cols, meta = _curve(path, k, curve, name, afm.tip, afm.poisson, contact,
                                afm.analyse(wanted), baseline)
            records.append(_cut(path, cols, meta, wanted, afm, time, inputs, output, trim))
        except DataError as e:  # this curve's reason; the others stand
            failures.append((name, str(e)))
    return _read_or_failed(path, records, failures)


class _ExportCurve:
    """A force curve's columns as afmformats' curves hold them, for `_afm._curve`."""

    modality = "force-distance"

    def __init__(self, data, metadata):
        self.data, self.metadata = data, metadata
        self.columns = list(data)

    def __getitem__(self, key):
        return self.data[key]


def _check_wanted(path, wanted, afm):
    from ._afm import AFM_COLUMNS

    missing = [c for c in wanted if c not in AFM_COLUMNS]
    if missing:
        raise DataError(
            f"{path}: an AFM curve has no column {missing[0]!r} (columns: "
            f"{', '.join(AFM_COLUMNS)})."
        )
    if "contact_strain" in wanted and afm.tip is None:
        raise DataError(f"{path}: contact_strain needs a tip: --tip sphere:RADIUS_m, "
                        "cone:HALF_ANGLE_deg or pyramid:FACE_ANGLE_deg.")


def released(indentation, keep) -> int:
    """Where the tip leaves the sample: the first of the kept samples after the deepest
    indentation at which the `indentation` is back to 0 or below (the record's end where it
    never is)."""
    idx = np.flatnonzero(keep)
    if idx.size == 0:
        return indentation.size
    depth = np.asarray(indentation, float)[idx]
    deepest = int(np.argmax(depth))
    after = np.flatnonzero(depth[deepest:] <= 0)
    return int(idx[deepest + after[0]]) if after.size else indentation.size


def _cut(path, cols, meta, wanted, afm, time, inputs, output, trim):
    """One record from a curve's columns: the segments kept, from the contact on until the
    tip leaves the sample."""
    name = meta["name"]
    keep = np.ones(cols["time_s"].size, bool)
    if afm.segments is not None:
        keep &= np.isin(cols["segment"], np.asarray(list(afm.segments), float))
    if afm.from_contact:
        keep[: meta["contact_index"]] = False
        keep[released(cols["indentation_m"], keep):] = False
    idx = np.flatnonzero(keep)
    if idx.size < 3:
        raise DataError(f"{path}, curve {name!r}: fewer than 3 samples in the segments kept.")
    for c in dict.fromkeys(wanted):
        bad = np.flatnonzero(~np.isfinite(cols[c][idx]))
        if bad.size:
            raise DataError(f"{path}, curve {name!r}, sample {idx[bad[0]]}: {c} is not finite.")
    record = _record(path, name, cols, idx, np.arange(cols["time_s"].size) + 1, time, inputs,
                     output, *trim)
    return dataclasses.replace(record, afm=tuple((meta["afm"] or {}).items()))

