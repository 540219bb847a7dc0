"""The signals a record's columns stand for: a strain from a recorded length
(``(L − L₀)/L₀``), or from a displacement over the specimen's initial length read from a
column, and a stress from a force over the initial area read from a column (eq. 35 with a
number per record: the column's value at the record's first sample)."""

import dataclasses
import math

import numpy as np

from ._errors import DataError


@dataclasses.dataclass(frozen=True)
class Scales:
    """What `load_records` turns the output and the input into: `rest` the rest length of
    `strain_from_length`, `length` and `area` the columns whose value at a record's first
    sample is its specimen's initial length and area (read as extra inputs, `columns`, then
    taken out)."""

    rest: float | None = None
    length: str | None = None
    area: str | None = None

    @classmethod
    def checked(cls, rest, length, area, time, inputs, output, group_by):
        """The options checked against each other and against the record's columns."""
        rest = _rest_length(rest)
        for name, value in (("length_column", length), ("area_column", area)):
            if value is None:
                continue
            if not isinstance(value, str) or not value:
                raise TypeError(f"`{name}` must name a column (a non-empty string), got {value!r}.")
            if value in (time, output, group_by, *inputs):
                raise ValueError(f"`{name}` {value!r} is already the time, the output, an "
                                 "input or the group column.")
        if rest is not None and length is not None:
            raise ValueError("`strain_from_length` and `length_column` both make the strain; "
                             "give one.")
        if length is not None and length == area:
            raise ValueError(f"the column {length!r} is given as both the length and the area.")
        if area is not None and len(inputs) != 1:
            raise ValueError(f"`area_column` divides the one input (a force) by the area; "
                             f"{len(inputs)} inputs are given.")
        return cls(rest, length, area)

    @property
    def columns(self) -> list[str]:
        return [c for c in (self.length, self.area) if c is not None]

    def apply(self, record):
        """The record with its output as a strain and its input as a stress, as asked."""
        inputs = np.asarray(record.inputs, float)
        count = inputs.shape[1] - len(self.columns)
        extra = dict(zip(self.columns, inputs[:, count:].T))
        names = tuple(record.input_names[:count])
        output, output_name = np.asarray(record.output, float), record.output_name
        units = dict(record.units)
        if self.rest is not None:
            output, output_name = _strain_of_length(record, output, self.rest), "strain"
        if self.length is not None:
            output = output / _initial(record, self.length, extra[self.length])
            output_name = "strain"
        inputs = inputs[:, :count]
        if self.area is not None:
            inputs = inputs / _initial(record, self.area, extra[self.area])
            units.pop(names[0], None)
            names = ("stress",)
        if self.rest is not None or self.length is not None:  # the output made a strain
            units.pop(record.output_name, None)
            units["strain"] = "1"
        return dataclasses.replace(record, inputs=inputs, input_names=names, output=output,
                                   output_name=output_name, units=tuple(sorted(units.items())))


def _rest_length(value) -> float | None:
    """`strain_from_length` checked: None, or a positive finite number."""
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise TypeError(f"`strain_from_length` must be a number (a length), got {value!r}.")
    if not 0.0 < float(value) < math.inf:
        raise ValueError(
            f"`strain_from_length` must be a positive finite length, got {float(value)!r}."
        )
    return float(value)


def _strain_of_length(record, length, rest):
    """``(L − rest)/rest`` of the output, a length that must stay above 0."""
    low = int(np.argmin(length))
    if not length[low] > 0.0:
        raise DataError(
            f"{record.source}, record {record.name!r}: {record.output_name} reaches "
            f"{length[low]:g} at t = {record.time[low] + record.time_offset:g}; a strain from "
            "a length needs lengths above 0 (is the output a displacement? then use a "
            "length scale)."
        )
    return (length - rest) / rest


def _initial(record, name, values):
    """Column `name`'s value at the record's first sample (the specimen's initial length or
    area, which engineering strain and stress divide by), above 0."""
    value = float(values[0])
    if not value > 0.0:
        raise DataError(f"{record.source}, record {record.name!r}: {name} is {value:g} at its "
                        "first sample; a length or an area must be above 0.")
    return value
