"""Properties over generated inputs (hypothesis): record names, the CSV loader and the
command line's option parsing hold for every input, not only for the cases listed in the
other tests."""

import argparse
import math
import tempfile
from pathlib import Path

import numpy as np
import pytest

hypothesis = pytest.importorskip("hypothesis")
from hypothesis import example, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

from vojax._data import DataError, load_records  # noqa: E402
from vojax._data._paths import MAX_LEN, RESERVED, record_folder  # noqa: E402

FAST = settings(max_examples=150, deadline=None, derandomize=True)


@FAST
@given(st.lists(st.text(min_size=1, max_size=200), min_size=2, max_size=8, unique=True))
@example(["con.1", "aux.txt", "NUL.csv", "lpt9.x", "summary.csv.bak"])  # Windows devices
def test_record_folders_are_distinct_safe_names(names):
    """Distinct record names give distinct folders, also on a case-insensitive file system;
    a folder name never leaves its parent, hides itself, or takes a name the batch or
    Windows reserves."""
    folders = [record_folder(n) for n in names]
    assert len({f.lower() for f in folders}) == len(names)
    for f in folders:
        assert f and "/" not in f and "\\" not in f and "\0" not in f
        assert not f.startswith(".") and len(f) <= MAX_LEN + 11
        assert f.lower() not in RESERVED and f.split(".")[0].lower() not in RESERVED


finite = st.floats(min_value=-1e12, max_value=1e12, allow_nan=False, allow_infinity=False)


@FAST
@given(
    st.lists(st.floats(min_value=1e-6, max_value=1e3), min_size=3, max_size=40),
    st.data(),
)
def test_csv_round_trip_and_a_bad_cell_names_its_line(steps, data):
    """Any finite values with strictly increasing times (written as repr, the shortest
    exact form) load back exactly, the clock restarting at 0; one cell that is not a
    number is a `DataError` naming the file, its line and its column."""
    t = np.cumsum([0.0, *steps])
    t = t[np.concatenate([[True], np.diff(t) > 0])]  # rounding may merge steps
    if t.size < 3:
        return
    n = t.size
    u = np.array(data.draw(st.lists(finite, min_size=n, max_size=n)))
    y = np.array(data.draw(st.lists(finite, min_size=n, max_size=n)))
    rows = ["time,force,disp"] + [f"{float(a)!r},{float(b)!r},{float(c)!r}" for a, b, c in zip(t, u, y)]
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "r.csv"
        path.write_text("\n".join(rows) + "\n")
        (rec,) = load_records(path, time="time", inputs=["force"], output="disp")
        np.testing.assert_array_equal(rec.time, t - t[0])
        np.testing.assert_array_equal(rec.inputs[:, 0], u)
        np.testing.assert_array_equal(rec.output, y)
        k = data.draw(st.integers(1, n))
        word = data.draw(st.sampled_from(["abc", "1,5", "--", "0x1g", "1e", "NaN?"]))
        cells = rows[k].split(",")
        cells[2] = f'"{word}"'
        rows[k] = ",".join(cells)
        path.write_text("\n".join(rows) + "\n")
        with pytest.raises(DataError, match=f"line {k + 1}, column 'disp'") as info:
            load_records(path, time="time", inputs=["force"], output="disp")
        assert str(path) in str(info.value) and "\n" not in str(info.value)


numbers = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from([0.0, -0.0, 5e-324, 1e-308, 1e-300, 1e300, 1e308, math.inf, -math.inf]),
)


@FAST
@given(numbers)
def test_numeric_options_accept_exactly_their_range(x):
    """Each option type takes exactly its documented range and refuses the rest with an
    argparse error (one line), never another exception."""
    from vojax._cli import _count, _finite, _fraction, _positive

    text = repr(x)
    for parse, ok in (
        (_positive, 1e-300 <= x <= 1e300),
        (_finite, abs(x) <= 1e300),
        (_fraction, 0 < x < 1),
    ):
        if ok:
            assert parse(text) == x
        else:
            with pytest.raises(argparse.ArgumentTypeError):
                parse(text)
    with pytest.raises(argparse.ArgumentTypeError):
        _count(text)  # a float's repr is never a whole number


@FAST
@given(st.one_of(st.integers(), st.text(max_size=30)))
def test_seeds_and_method_names_parse_or_are_refused(value):
    from vojax._cli import _count
    from vojax._data._pipeline import ALIASES, METHODS, canonical_method

    text = str(value)
    try:
        number = int(text)
    except ValueError:
        number = None
    if number is not None and 0 <= number < 2**63:
        assert _count(text) == number
    else:
        with pytest.raises(argparse.ArgumentTypeError):
            _count(text)
    if text in METHODS or text in ALIASES:
        assert canonical_method(text) in METHODS
    else:
        with pytest.raises(ValueError, match="`method` must be one of"):
            canonical_method(text)


@FAST
@given(st.lists(st.text(max_size=30), min_size=1, max_size=6, unique=True))
@example(["'=1", "=1", "''x", "'", "'plain", "-2", "@a", "\tx"])
def test_tables_read_back_exactly_what_was_written(names):
    """summary.csv's formula guard round-trips: every name (a leading quote, a formula
    character, both) is read back exactly, so a re-run with ``--no-overwrite`` finds each
    record's row again and never adds a second one."""
    from vojax._data._tables import _read_table, _write_summary_table, _write_table

    names = [n for n in names if n and "\0" not in n and "\r" not in n]
    hypothesis.assume(names)
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp)
        rows = [{"record": n, "source": n, "value": float(k)} for k, n in enumerate(names)]
        _write_table(out / "summary.csv", rows)
        back = _read_table(out / "summary.csv")
        assert [(r["record"], r["source"]) for r in back] == [(n, n) for n in names]
        for _ in range(3):  # re-runs that redo nothing keep exactly one row per record
            kept = _write_summary_table(out, [], {}, {}, overwrite=False)
            assert sorted(r["record"] for r in kept) == sorted(names)
