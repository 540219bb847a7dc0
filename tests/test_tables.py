"""Tables a lab can trust: strict JSON and the umask, messages that name the option, floats
that round-trip and non-finite cells left blank, no spreadsheet formulas, natural order,
disjoint bands reported with what the data support."""

import csv
import os
import subprocess
import sys

import numpy as np
import pytest

from vojax._data._tables import natural_key

from .helpers import run_cli
from .test_data_cli import _springpot_csv
from .test_outputs import BASE, _strict


@pytest.mark.slow
def test_json_is_strict_and_files_honour_the_umask(tmp_path):
    work = tmp_path / "w"
    work.mkdir()
    _springpot_csv(work / "r.csv", n=50)
    env = {k: v for k, v in os.environ.items() if k != "XLA_FLAGS"}
    for mask, mode in ((0o022, 0o644), (0o077, 0o600)):
        out = f"out{mask:o}"
        proc = subprocess.run(
            [sys.executable, "-c",
             f"import os, sys; os.umask({mask}); from vojax._cli import main; "
             f"sys.exit(main(['batch', 'r.csv', *{BASE!r}, '--out', '{out}', '--method', 'both',"
             " '--gamma', '0.5']))"],
            cwd=work, env=env, capture_output=True, text=True,
        )
        assert proc.returncode == 0, proc.stderr
        files = [p for p in (work / out).rglob("*") if p.is_file() and not p.name.startswith(".")]
        assert len(files) >= 4
        assert {p.stat().st_mode & 0o777 for p in files} == {mode}
        for p in (work / out).rglob("*.json"):
            _strict(p.read_text())


@pytest.mark.parametrize(
    "args, message",
    [
        (["--length", "1e-300"], "--length 1e-300 makes the strain reach"),
        (["--area", "1e-300"], "--area 1e-300 makes the stress reach"),
    ],
)
def test_messages_name_the_option(tmp_path, args, message):
    _springpot_csv(tmp_path / "r.csv", n=40)
    proc = run_cli("identify", "r.csv", *BASE[:-1], "--out", "o", *args, cwd=tmp_path)
    assert proc.returncode == 1 and message in proc.stderr and "Traceback" not in proc.stderr
    assert not (tmp_path / "o" / "summary.json").exists()


def test_demo_refuses_settings_that_diverge(tmp_path):
    proc = run_cli("demo", "--lam", "1000", "--out", "d", cwd=tmp_path)
    assert proc.returncode == 1 and "diverged at sample" in proc.stderr
    assert not (tmp_path / "d" / "summary.json").exists()


def test_identification_table_round_trips_floats_and_leaves_non_finite_blank(tmp_path):
    """`write_table`: every finite number reads back bit for bit (float32 columns as their
    float64 value), a NaN or ±inf is an empty cell, and the header keeps the column order."""
    from vojax._data._pipeline import write_table

    rng = np.random.default_rng(3)
    a = rng.standard_normal(50) * 10.0 ** rng.integers(-300, 300, 50)
    a[[0, 7, 9]] = [np.nan, np.inf, -np.inf]
    columns = {"time": np.arange(50) * 0.1, "a": a, "b": rng.random(50).astype(np.float32)}
    write_table(tmp_path, columns)
    with open(tmp_path / "identification.csv", newline="") as f:
        reader = csv.reader(f)
        assert next(reader) == ["time", "a", "b"]
        rows = list(reader)
    assert len(rows) == 50
    for k, row in enumerate(rows):
        for name, cell in zip(columns, row):
            value = float(columns[name][k])
            if np.isfinite(value):
                assert float(cell) == value and cell == repr(value)
            else:
                assert cell == ""
    with pytest.raises(ValueError, match="png, svg or pdf"):
        write_table(tmp_path, columns, "jpg")


def test_disjoint_bands_of_two_estimators_are_reported_with_what_the_data_support():
    """`disagreement`: the median bands over the second half, the tracker's against the
    refit's interval: overlapping gives "", disjoint one sentence naming both bands and
    which the data support: the tracker's order where it is identified and the refit's
    residuals are correlated, `compare` where they are white, neither where the tracker
    does not identify the order or the paper's law ran."""
    from vojax._data._pipeline import disagreement

    n = 40
    lower = np.r_[np.full(n // 2, 0.1), np.full(n // 2, 0.30)]  # the first half does not count
    columns = {"alpha": np.full(n, 0.32), "alpha_lower": lower, "alpha_upper": lower + 0.04}
    refit = {"order_lower": 0.36, "order_upper": 0.4, "residual_correlation": 0.97}
    summary = {"kalman": {"method": "kalman", "verdict": "identified"}, "refit": refit}
    text = disagreement(columns, summary)
    assert "the tracker ([0.3, 0.34]" in text and "refit ([0.36, 0.4])" in text
    assert "the data support the tracker's order" in text and "lag-1 0.97" in text
    refit["residual_correlation"] = 0.5  # at the warning's limit: not correlated
    text = disagreement(columns, summary)
    assert "residuals are white (lag-1 0.50)" in text and "vojax compare" in text
    for verdict, said in (
        ("not identified", "does not identify the order"),
        ("conditional", "identifies the order only under a bound on the parameters' drift"),
    ):
        summary["kalman"]["verdict"] = verdict
        text = disagreement(columns, summary)
        assert f"report neither: the tracker {said}, and the refit's interval" in text, verdict
    refit["order_lower"] = 0.33
    assert disagreement(columns, summary) == ""
    summary["gradient"] = summary.pop("kalman")
    refit.update(order_lower=0.1, order_upper=0.29, residual_correlation=0.99)
    text = disagreement(columns, summary)
    assert text.startswith("the paper's law") and "report neither" in text
    assert "no confidence band" in text and "the data support" not in text


def test_tables_do_not_carry_spreadsheet_formulas(tmp_path):
    """A record named like a formula is written after a "'" in summary.csv (a spreadsheet
    would otherwise run it); numbers, negative ones included, are written as they are."""
    import csv

    from vojax._data._batch import _write_table

    rows = [{"record": "=HYPERLINK(\"http://x\")", "source": "@a", "value": -1.5},
            {"record": "plain-name", "source": "+b", "value": 2.0}]
    _write_table(tmp_path / "summary.csv", rows)
    with open(tmp_path / "summary.csv", newline="") as f:
        back = list(csv.DictReader(f))
    assert back[0]["record"] == "'=HYPERLINK(\"http://x\")" and back[0]["source"] == "'@a"
    assert back[0]["value"] == "-1.5" and back[1]["record"] == "plain-name"
    assert back[1]["source"] == "'+b"


def test_records_are_listed_in_natural_order():
    """Tables list records as a person counts: the numbers inside a name compared as numbers
    (P002-2 before P002-10), letters without regard to case, the exact name breaking ties."""
    names = ["P002-10", "p002-3", "P002-2", "P002-1b", "P002-1", "a10", "A9", "a9", "x", "x0",
             "007", "7", "0.5", "0.10"]
    got = sorted(names, key=natural_key)
    assert got == ["0.5", "0.10", "007", "7", "A9", "a9", "a10", "P002-1", "P002-1b", "P002-2",
                   "p002-3", "P002-10", "x", "x0"]
