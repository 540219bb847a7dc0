"""`vojax batch`'s progress: the bar only on a terminal, the time left paced on the records
after the first, the summary table's share of a long batch."""

import sys

import pytest

from .test_data_cli import _springpot_csv


def test_time_left_is_paced_after_the_first_record():
    """The first record of a batch also compiles: the time left is paced on the records after
    it (3 s each here, after a first one of 40 s), none is guessed after one record, and 0
    is left at the end."""
    from vojax._progress import time_left

    assert time_left(40.0, 40.0, 1, 10) is None
    assert time_left(46.0, 40.0, 3, 10) == pytest.approx(3.0 * 7)
    assert time_left(67.0, 40.0, 10, 10) == 0.0


def test_progress_bar_only_on_a_terminal_unless_asked(tmp_path, monkeypatch):
    """``progress=None`` draws the bar when stderr is a terminal and nothing otherwise; the
    bar counts the records done, failed and up to date; True/False force it; anything else
    is refused before a file is written."""
    import io

    from vojax._data import load_records
    from vojax.io import run_batch

    class Terminal(io.StringIO):
        def isatty(self):
            return True

    data = tmp_path / "data"
    data.mkdir()
    for i in range(3):
        _springpot_csv(data / f"r{i}.csv", n=40, q=0.4)
    records = [
        r for p in sorted(data.glob("r*.csv"))
        for r in load_records(p, time="time_s", inputs=["stress"], output="strain")
    ]
    settings = dict(method="refit", record_figures=False)
    for where, progress, drawn in (("a", None, True), ("b", False, False)):
        terminal = Terminal()
        monkeypatch.setattr(sys, "stderr", terminal)
        run_batch(records, tmp_path / where, progress=progress, **settings)
        assert ("vojax batch: 3/3 done" in terminal.getvalue()) is drawn, terminal.getvalue()
    pipe = io.StringIO()
    monkeypatch.setattr(sys, "stderr", pipe)
    run_batch(records[:2], tmp_path / "a", progress=None, **settings)  # up to date, no bar
    assert pipe.getvalue() == ""
    run_batch(records, tmp_path / "a", progress=True, **settings)
    assert "vojax batch: 0/0 done" in pipe.getvalue() and "0 failed, 3 up to date" in pipe.getvalue()
    with pytest.raises(TypeError, match="progress"):
        run_batch(records, tmp_path / "c", progress="yes", **settings)
    assert not (tmp_path / "c").exists()


def test_the_bars_time_left_is_paced_on_the_records_after_the_first(monkeypatch):
    """A batch of 10 whose first record takes 30 s (it compiles) and each later one 10 s: after
    three records the bar says about 70 s left (the pace after the first, 10 s, times the 7
    left), however often it is redrawn; the first record's time is stamped once."""
    import io

    from vojax import _progress

    clock = [0.0]
    monkeypatch.setattr(_progress.time, "perf_counter", lambda: clock[0])
    monkeypatch.setattr(_progress.sys, "stderr", io.StringIO())
    bar = _progress.Bar(10, True)
    for now in (30.0, 40.0, 50.0):
        clock[0] = now
        bar.update()
    assert bar._counts().endswith("about 70 s left")
    clock[0] = 55.0
    bar.update(0, failed=1)  # a redraw halfway through the fourth record
    assert bar._counts() == "1 failed, 0 up to date; about 88 s left"  # (55 − 30)/2 × 7


def test_the_summary_table_takes_at_most_its_share_of_a_long_batch():
    """summary.csv is rebuilt during a run at most once a second, and, where a rebuild is
    slow (every row is written: 0.27 s at 3,200 rows), only after 20 times its duration: the
    table's share of a map of thousands of curves stays at 5 % instead of growing with the
    rows (about 25 % at 3,000 curves before)."""
    from vojax._data._batch import Throttle

    due = Throttle(1.0, 0.05, now=0.0)
    assert not due.due(0.99) and due.due(1.01)
    due.ran(1.0, 1.01)  # a fast rebuild: once a second
    assert not due.due(2.0) and due.due(2.02)
    due.ran(2.0, 2.25)  # 0.25 s: the next 5 s after its end
    assert not due.due(7.2) and due.due(7.3)
    due.ran(7.3, 7.31)  # fast again: once a second again
    assert not due.due(8.3) and due.due(8.32)
