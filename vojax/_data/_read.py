"""Reading a file's columns: CSV text and NPZ arrays, checked before they are used."""


import csv
import io
from pathlib import Path

import numpy as np

from ._errors import DataError

MAX_SAMPLES = 100_000_000  # a column longer than this is refused before it is read


def _npz_column(path, data, name):
    """One array of an NPZ file as float64 (N,), its header checked before its data are read:
    real numbers (bool, integer or float), one dimension (or (N, 1)), at most `MAX_SAMPLES`,
    and as many bytes as the header declares."""
    member = f"{name}.npy"
    with data.zip.open(member) as f:
        version = np.lib.format.read_magic(f)
        read = (
            np.lib.format.read_array_header_1_0 if version == (1, 0)
            else np.lib.format.read_array_header_2_0
        )
        shape, _, dtype = read(f)
        offset = f.tell()
    size = int(np.prod(shape, dtype=object)) if shape else 1
    if dtype.kind not in "biuf":
        what = {"c": "complex", "M": "date-time", "m": "time-delta", "U": "text", "S": "bytes",
                "O": "object", "V": "structured"}.get(dtype.kind, dtype.kind)
        raise DataError(f"{path}: array {name!r} holds {what} values ({dtype}); it must be real numbers.")
    if sum(1 for n in shape if n != 1) > 1:
        raise DataError(f"{path}: array {name!r} has shape {shape}; it must be one column of samples.")
    if size > MAX_SAMPLES:
        raise DataError(f"{path}: array {name!r} declares {size} samples, more than {MAX_SAMPLES}.")
    if offset + size * dtype.itemsize > data.zip.getinfo(member).file_size:
        raise DataError(
            f"{path}: array {name!r} is truncated (its header declares {size} samples)."
        )
    return np.asarray(data[name], dtype=float).ravel()


def _read_csv(path: Path, delimiter=","):
    """Header and rows of a CSV file. Blank lines, and lines starting with ``#`` before the
    header, are skipped; a UTF-8 byte-order mark is removed. Errors name the file and line."""
    try:
        with open(path, newline="", encoding="utf-8-sig") as f:
            text = f.read()
    except UnicodeDecodeError:
        raise DataError(f"{path}: not a text CSV file (not UTF-8).") from None
    except PermissionError:
        raise DataError(f"{path}: not readable (permission denied).") from None
    lines, header_seen = [], False
    # lines end at \n, \r\n or \r only, as the csv module's do (str.splitlines also ends
    # them at a form feed or U+2028, which a text cell may hold)
    for i, line in enumerate(io.StringIO(text, newline="")):
        if not line.strip():
            continue
        if line.lstrip().startswith("#"):
            if header_seen:
                raise DataError(
                    f"{path}, line {i + 1}: starts with '#' after the header; comments are "
                    "allowed only before the header row."
                )
            continue
        header_seen = True
        lines.append((i + 1, line))
    if not lines:
        raise DataError(f"{path}: no header row (the file is empty or only comments).")
    # a long field (a note, an embedded trace) in a column vojax does not read is no error:
    # the csv module's limit (128 kB by default) is raised while this file is read
    limit = csv.field_size_limit()
    csv.field_size_limit(max(limit, len(text) + 1))
    try:
        reader = csv.reader([line for _, line in lines], delimiter=delimiter)
        header = next(reader)
        rows = list(reader)
    except csv.Error as e:
        raise DataError(f"{path}: not a readable CSV file ({e}).") from None
    finally:
        csv.field_size_limit(limit)
    seen = set()
    for name in header:
        if name in seen:
            raise DataError(
                f"{path}, line {lines[0][0]}: the column name {name!r} appears twice in the header."
            )
        seen.add(name)
    return header, rows, [n for n, _ in lines[1:]]


def _column(path, header, rows, line_numbers, name, numeric=True, decimal="."):
    if name not in header:
        spaced = [h for h in header if h.strip() == name]
        if spaced:
            raise DataError(
                f"{path}: no column {name!r}; the header has {spaced[0]!r}, with spaces around "
                "the name (remove them, or pass the name with its spaces)."
            )
        separators = [c for c, say in ((";", "';'"), ("\t", "tab"), (",", "','")) if
                      len(header) == 1 and c in header[0]]
        if separators:
            say = {";": "';'", "\t": "tab", ",": "','"}[separators[0]]
            raise DataError(
                f"{path}: no column {name!r}: the header is one column holding {say}; the file "
                f"is separated by {say}: pass --delimiter {say} (delimiter= in Python)."
            )
        raise DataError(f"{path}: no column {name!r} (columns: {', '.join(header)}).")
    j = header.index(name)
    values = []
    for row, line in zip(rows, line_numbers):
        if j >= len(row):
            raise DataError(
                f"{path}, line {line}: row has {len(row)} fields, column {name!r} is field {j + 1}."
            )
        if not numeric:
            values.append(row[j])  # a record's name is kept exactly: ' pad ' is not 'pad'
            continue
        text = row[j].strip()
        try:
            values.append(float(text.replace(",", ".") if decimal == "," else text))
        except ValueError:
            hint = ""
            if decimal != "," and _is_number(text.replace(",", ".")):
                hint = "; for decimal commas pass --decimal , (decimal=',' in Python)"
            raise DataError(
                f"{path}, line {line}, column {name!r}: {text!r} is not a number{hint}."
            ) from None
    return np.array(values, dtype=object if not numeric else float)


def _is_number(text) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def row_groups(path, header, rows, lines, group_by, single=""):
    """The rows of each record: by the value of the column `group_by` (in order of first
    appearance; a record's rows need not be contiguous), or all rows under `single`."""
    if not group_by:
        return {single: np.arange(len(rows))}
    keys = _column(path, header, rows, lines, group_by, numeric=False)
    return {k: np.flatnonzero(keys == k) for k in dict.fromkeys(keys)}
