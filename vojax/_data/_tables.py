"""The batch's tables: `summary.csv` rebuilt from the records' summaries, read back and
written safely (no cell a spreadsheet would run as a formula)."""


import csv
import io
import json
import re

from .._io import atomic_path
from ._paths import record_folder


def strict_json(text):
    """`json.loads` refusing NaN and ±Infinity (vojax writes them as null): a summary that
    holds them was not written by this vojax, and is not taken as a result."""

    def refuse(constant):
        raise ValueError(f"a non-standard JSON number: {constant}")

    return json.loads(text, parse_constant=refuse)


def natural_key(name):
    """The order in which tables list records: runs of digits compared as numbers (P002-2
    before P002-10), the rest without regard to case, the exact name breaking ties."""
    parts = re.split(r"(\d+)", name)
    return [int(p) if i % 2 else p.casefold() for i, p in enumerate(parts)], name


def _summary_row(summary):
    row = {
        "record": summary["record"],
        "folder": record_folder(summary["record"]),
        "source": summary["source"],
        "samples": summary["samples"],
        "time_offset": summary.get("time_offset", 0.0),
    }
    if "kalman" in summary:  # the tracker's verdict and how far it holds, first
        part = summary["kalman"]
        row["verdict"] = part.get("verdict")
        row["breakdown_drift"] = part.get("breakdown_drift")
        row["reasons"] = ";".join(part.get("reasons") or ())
        row["next_steps"] = ";".join(part.get("next_steps") or ())
    for k, v in (summary.get("afm") or {}).items():  # nanite's contact and modulus
        row[f"afm_{k}"] = v
    if "disagreement" in summary:
        row["disagreement"] = summary["disagreement"]
    if "compare" in summary:
        block = summary["compare"]
        for k in ("best", "second", "bayes_factor"):
            row[f"compare_{k}"] = block.get(k)
        for name, w in (block.get("weight") or {}).items():
            row[f"compare_weight_{name}"] = w
    for part in ("kalman", "gradient", "refit"):
        if part not in summary:
            continue
        for k, v in summary[part].items():
            if isinstance(v, (int, float, bool, str)) or v is None:
                row[f"{part}_{k}"] = v
        for group in ("parameters_final", "parameters_final_stderr", "parameters", "parameters_stderr"):
            for name, v in (summary[part].get(group) or {}).items():
                row[f"{part}_{group}_{name}"] = v
    return row


def _write_summary_table(
    out_dir, records, folders, provenance, cache=None, failed=(), overwrite=True
):
    """``summary.csv``: one row per record of this run whose outputs are current and that
    has not failed in this run, by name. `cache` (a dict kept over a run) holds the rows of
    summaries already read, by path and modification time, so that rebuilding the table
    after every record reads only new files. ``overwrite=False`` keeps every row of the
    table already there that this run did not replace (it rewrites nothing it would not
    redo: a record it refused to redo keeps its row)."""
    rows = []
    cache = {} if cache is None else cache
    lost = {name for _, name, _ in failed}
    for r in sorted(records, key=lambda r: natural_key(r.name)):
        if r.name in lost:
            continue
        path = folders[r.name] / "summary.json"
        try:
            stamp = path.stat().st_mtime_ns
            if cache.get(path, (None,))[0] != stamp:
                summary = strict_json(path.read_text())
                current = summary.get("provenance", {}).get("hash") == provenance[r.name]["hash"]
                cache[path] = (stamp, _summary_row(summary) if current else None)
        except (OSError, ValueError):
            continue
        if cache[path][1] is not None:
            rows.append(cache[path][1])
    if not overwrite:  # a row of the table already there stays unless this run replaced it
        new = {row["record"] for row in rows}
        kept = [row for row in _read_table(out_dir / "summary.csv") if row["record"] not in new]
        rows = sorted(rows + kept, key=lambda row: natural_key(row["record"]))
    _write_table(out_dir / "summary.csv", rows)
    return rows


def _read_table(path):
    """The rows of a table `_write_table` wrote (text cells unquoted), or [] if none."""
    try:
        with open(path, newline="", encoding="utf-8") as f:
            rows = list(csv.DictReader(f))
    except (OSError, UnicodeDecodeError, csv.Error):
        return []

    def plain(value):  # the inverse of `_text_cell`: exactly one guard "'" comes off
        if isinstance(value, str) and value.startswith("'") and value[1:].startswith(GUARDED):
            return value[1:]
        return value

    return [
        {plain(k): (None if v == "" else plain(v)) for k, v in row.items()}
        for row in rows
        if row.get("record")
    ]

# a text cell starting with one of these is a formula to a spreadsheet (a record named
# "=HYPERLINK(…)" would run as one when the table is opened): it is written after a "'"
FORMULA_START = ("=", "+", "-", "@", "\t", "\r")
# a cell starting with the guard itself is guarded too, so that reading a table back takes
# off exactly what writing added: "'=1" is written "''=1" and read back as "'=1"
GUARDED = FORMULA_START + ("'",)


def _text_cell(value):
    if isinstance(value, str) and value.startswith(GUARDED):
        return "'" + value
    return value


def _write_table(path, rows):
    """Writes a CSV table atomically (an empty table is written as its header only); text
    that a spreadsheet would run as a formula is written after a ``'``."""
    fields = list(dict.fromkeys(k for row in rows for k in row)) or ["record"]
    buffer = io.StringIO()
    writer = csv.DictWriter(buffer, fieldnames=[_text_cell(f) for f in fields])
    writer.writeheader()
    writer.writerows({_text_cell(k): _text_cell(v) for k, v in row.items()} for row in rows)
    with atomic_path(path) as tmp, open(tmp, "w", newline="") as f:
        f.write(buffer.getvalue())
