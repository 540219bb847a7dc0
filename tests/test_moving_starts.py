"""The table of `scripts/moving_starts.py` on rows made by hand: for each tolerance on the
kept part, the answer searches that would still run and those skipped whose least drift
was more than 10 % below the projected one's, drifts below the floor counted as none."""

import pytest

from .helpers import load_script


@pytest.fixture(scope="module")
def starts():
    return load_script("moving_starts")


def _row(index, *searches):
    return dict(family="drift", index=index, true_drift=0.2, verdict="identified",
                breakdown_drift=0.1, searches=[list(s) for s in searches])


def test_a_tolerance_counts_the_searches_it_skips_that_would_have_found_less(starts):
    rows = [_row(0, (0.004, 0.30, 0.10)),  # lower, skipped from a tolerance of 0.005 on
            _row(1, (0.008, 0.30, 0.29)),  # within 10 %: never counted
            _row(2, (0.02, 1e-8, 3e-9)),  # both below the floor: the same drift
            _row(3, (0.04, 0.50, 0.20), (0.001, 0.2, 0.4))]  # a second fit, higher
    lines = starts.table(rows)
    by_tol = {line.split(" | ")[0].strip("| "): line.split(" | ")[1:] for line in lines[2:8]}
    assert by_tol["0"] == ["5/5", "0 |"]
    assert by_tol["0.005"] == ["3/5", "1 (drift 0) |"]
    assert by_tol["0.01"] == ["2/5", "1 (drift 0) |"]
    assert by_tol["0.02"] == ["1/5", "1 (drift 0) |"]
    assert by_tol["0.05"] == ["0/5", "2 (drift 0, drift 3) |"]
    assert "4 records, 5 pairs" in lines[-1]
    assert "below the projected one's on 2, more than 10% above on 1" in lines[-1]
    assert "(3 pairs), the two least drifts still differ by more than 10% on 2" in lines[-1]


def test_each_fit_pairs_its_projected_and_answer_searches(starts):
    log = [[(0.0, 0.5), (0.0, 0.3), (0.02, 0.4), (0.02, 0.6)], [],  # no forms: no searches
           [(0.0, 0.1), (0.01, 0.05)]]
    assert starts._pairs(log) == [[0.02, 0.3, 0.4], [0.01, 0.1, 0.05]]


def test_the_restarts_table_counts_fits_whose_random_starts_find_no_less(starts):
    rows = [dict(_row(0, (0.01, 0.30, 0.10), (0.0, 0.2, 0.2)), restarts=[[0.29, 0.31], [0.1]]),
            dict(_row(1, (0.02, 1e-8, 0.2)), restarts=[[3e-9, 0.4]]),  # both at the floor
            _row(2, (0.03, 0.5, 0.5))]  # no restarts: not in the table
    lines = starts.restart_table(rows)
    assert lines[3] == "| drift 0 | 0.200 | 0.010 | 0.300 | 0.100 | 0.290 – 0.310 |"
    assert len(lines) == 2 + 1 + 3 + 2
    assert lines[-1].endswith("below its least drift on 2 of 3 fits.")
    assert starts.restart_table([_row(3, (0.0, 0.1, 0.1))]) == []
