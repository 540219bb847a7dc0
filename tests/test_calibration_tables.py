"""The calibration suite's scores and tables (`scripts/calibration_tables.py`): each score of a
record against its closed form on a band placed by hand, the tables' counts on rows made by
hand, and the results files' tables written again from their rows."""

import json
from pathlib import Path

import numpy as np
import pytest

from .helpers import load_script

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def tables():
    return load_script("calibration_tables")


def _case(n=200):
    t = np.linspace(0.0, 1.0, n)
    return dict(t=t, alpha=0.4 + 0.1 * t)


def test_a_band_offset_by_a_known_error_scores_as_its_closed_form(tables):
    """The estimate off the truth by 0.03 with σ 0.02 (z = 1.5 at every sample), the band ±0.05
    about it on the first 40 % of the second half, ±0.02 after (holds the truth, then misses
    it): coverage 0.4, z RMS 1.5, order RMS 0.03; identified and below one half, so
    confidently wrong. The conditional band, ±0.05 throughout, holds it everywhere; with a
    breakdown drift of 0.2 above the true 0.1 and its coverage 1, no false promise."""
    case = _case()
    n = case["t"].size
    half = case["t"] > 0.5
    alpha = case["alpha"] + 0.03
    std = np.full(n, 0.02)
    second = np.flatnonzero(half)
    wide = np.zeros(n, bool)
    wide[: second[0] + int(0.4 * second.size)] = True
    width = np.where(wide, 0.05, 0.02)
    out = (alpha, std, alpha - width, alpha + width, True, "", dict(
        verdict="conditional", breakdown_drift=0.2,
        conditional=(alpha, std, alpha - 0.05, alpha + 0.05)))
    case["true_drift"] = 0.1
    row = tables.score(case, out)
    inside = np.sum(wide & half)
    assert row["count"] == second.size
    assert row["inside"] == inside
    assert row["coverage"] == pytest.approx(inside / second.size)
    assert 0.38 < row["coverage"] < 0.42
    assert row["z_rms"] == pytest.approx(1.5)
    assert row["rms"] == pytest.approx(0.03)
    assert row["wrong"] is True
    assert row["c_coverage"] == 1.0 and row["c_z_rms"] == pytest.approx(1.5)
    assert row["false_promise"] is False


def _row(method, family, identified, coverage, z=1.0, rms=0.01, count=100):
    inside = int(round(coverage * count))
    return dict(method=method, family=family, identified=identified, coverage=inside / count,
                inside=inside, count=count, z_rms=z, rms=rms,
                wrong=bool(identified and inside / count < 0.5))


def test_the_table_counts_the_identified_records_short_of_the_coverage_asked(tables):
    """Four identified records at coverage 1.0, 0.85 (not short), 0.84 (short of 0.85, not
    confidently wrong) and 0.30 (both), a refused one at 0.10 (counted in neither): the
    family's row reads identified 4/5, confidently wrong 1/4, short 2/4; the coverage over
    the identified (100 + 85 + 84 + 30)/400, over all (+10)/500."""
    rows = [_row("tracker", "white", True, 1.0), _row("tracker", "white", True, 0.85),
            _row("tracker", "white", True, 0.84), _row("tracker", "white", True, 0.30, z=3.0),
            _row("tracker", "white", False, 0.10)]
    lines = tables._stated_table(rows, ["tracker"], ["white"])
    head = [c.strip() for c in lines[0].strip("|").split("|")]
    assert head[-1] == f"coverage short of {tables.SHORT_OF} (of identified)"
    assert tables.SHORT_OF == 0.85
    for line in lines[2:]:  # the family and the pooled row
        cells = [c.strip() for c in line.strip("|").split("|")]
        assert len(cells) == len(head)
        assert cells[3] == "4/5 (0.80)"
        assert float(cells[4]) == pytest.approx(299 / 400, abs=0.005)
        assert float(cells[5]) == pytest.approx(309 / 500, abs=0.005)
        assert float(cells[6]) == 1.0  # the identified's median z RMS
        assert cells[8] == "1/4" and cells[9] == "2/4"


@pytest.mark.parametrize("name", ["bench_calibration_held_out", "bench_calibration_draws_0_11",
                                  "bench_calibration_clock"])
def test_each_results_files_tables_are_those_of_its_rows(tables, name, tmp_path):
    """The tables of a results file are what its rows give (`retable` writes them again,
    the file unchanged); the default's pooled row on the held-out draws has as many records
    short of 0.85 as its rows count directly."""
    source = ROOT / "scripts" / "results" / f"{name}.txt"
    copy = tmp_path / source.name
    copy.write_text(source.read_text())
    copy.with_suffix(".json").write_text(source.with_suffix(".json").read_text())
    assert tables.retable(copy) == source.read_text()
    rows = json.loads(source.with_suffix(".json").read_text())
    ident = [r for r in rows if r["method"] == "tracker" and r["identified"]]
    short = sum(r["coverage"] < 0.85 for r in ident)
    pooled = next(line for line in source.read_text().splitlines()
                  if line.startswith("| tracker | pooled | ") and "(" in line)
    assert pooled.rstrip(" |").endswith(f"| {short}/{len(ident)}")


def test_a_results_file_without_a_table_is_refused(tables, tmp_path):
    path = tmp_path / "empty.txt"
    path.write_text("# a header and no table\n")
    path.with_suffix(".json").write_text("[]")
    with pytest.raises(ValueError, match="no table"):
        tables.retable(path)


def test_the_reach_table_splits_the_confidently_wrong_by_their_stated_reach(tables):
    """Under a stated constant, six records: identified and right with a reach of 0.02,
    identified and wrong with reaches of 0.05 and 0.1 below their true drift 0.2 (warned),
    wrong with a reach of 0.3 above its true drift 0.2 (not warned), wrong with no reach
    found (∞: not warned, no reach stated), and a refused one whose reach counts nowhere.
    The family's row: identified 5/6, reach stated 4/5 at the median of 0.02, 0.05, 0.1,
    0.3 (0.075), wrong 4/5, warned 2/4, not warned 2/4; the free tracker's row is not counted. Under a drift
    bound only a reach beyond it is stated."""
    def row(identified, wrong, reach, drift, method="tracker-constant"):
        return dict(method=method, family="drift", identified=identified, wrong=wrong,
                    breakdown_drift=reach, true_drift=drift)

    rows = [row(True, False, 0.02, 0.2), row(True, True, 0.05, 0.2), row(True, True, 0.1, 0.2),
            row(True, True, 0.3, 0.2), row(True, True, np.inf, 0.2),
            row(False, False, 0.01, 0.2), row(True, True, 0.05, 0.2, method="tracker")]
    lines = tables._reach_table(rows, ["tracker-constant"], ["drift"])
    family = [c.strip() for c in lines[2].strip("|").split("|")]
    assert family == ["tracker-constant", "drift", "5/6", "4/5", "0.075", "4/5", "2/4", "2/4"]
    assert len(lines) == 4  # the header, its rule, the family and the pooled row
    # under a drift bound of 0.3 a reach of 0.2 is within it, not stated (the verdict line
    # says nothing), and a wrong answer with it is not warned; 0.4 is stated
    bounded = [dict(row(True, True, 0.2, 0.5, method="tracker-stated"), stated=0.3),
               dict(row(True, False, 0.4, 0.1, method="tracker-stated"), stated=0.3)]
    cells = [c.strip() for c in tables._reach_table(bounded, ["tracker-stated"], ["drift"])[2]
             .strip("|").split("|")]
    assert cells[3:] == ["1/2", "0.4", "1/2", "0/1", "1/1"]
