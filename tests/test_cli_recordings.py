"""The command line on recordings as they come: irregular clocks used as recorded, the test's
origin, fit windows, order-0 models, sign constraints and order bounds, each equal to the
library call."""

import csv
import json
import math

import numpy as np
import pytest

import vojax
from vojax._cli import main
from vojax._data import load_records

from .helpers import run_cli
from .test_data_cli import _springpot_csv

COLUMNS = ["--time", "t", "--input", "stress", "--output", "strain"]


def _write(path, t, stress, strain):
    with open(path, "w") as f:
        f.write("t,stress,strain\n")
        for row in zip(t, stress, strain):
            f.write(",".join(repr(float(v)) for v in row) + "\n")
    return str(path)


def _summary(folder):
    return json.loads((folder / "summary.json").read_text())


def test_log_spaced_creep_with_its_origin(tmp_path):
    """A creep file logged on a log-spaced clock from 10 s, loaded at t = 0: the CLI uses the
    samples as recorded (no resampling) and `--origin 0` gives the library's refit with
    ``t`` and ``origin`` (the record's clock starts at its first sample, 10 s in the file)."""
    t = np.geomspace(10.0, 1e6, 150)
    strain = 0.02 + 1.5 * t**0.2 / math.gamma(1.2) * (1 + 1e-3 * np.sin(np.arange(150)))
    path = _write(tmp_path / "creep.csv", t, np.full(t.size, 3.0), strain)
    out = tmp_path / "out"
    assert main(["identify", path, *COLUMNS, "--method", "refit", "--origin", "0", "--out", str(out)]) == 0
    s = _summary(out)
    assert s["uniform_clock"] is False and s["samples"] == 150
    fit = vojax.refit(np.full(t.size, 3.0), strain, t=t - 10.0, origin=-10.0, p_signs=(1,))
    assert s["refit"]["order"] == pytest.approx(float(fit.order[0]), rel=1e-10)
    assert s["refit"]["parameters"]["eta"] == pytest.approx(1 / float(fit.p[0]), rel=1e-10)
    assert abs(s["refit"]["order"] - 0.2) < 1e-3
    table = np.genfromtxt(out / "identification.csv", delimiter=",", names=True)
    np.testing.assert_allclose(table["time"], t - 10.0, rtol=1e-15)
    # the file's own time kept beside the record's clock, and the shift stated
    np.testing.assert_allclose(table["file_time"], t, rtol=1e-15)
    assert s["time_offset"] == 10.0


def _ramp_hold_file(tmp_path):
    dt = 0.05
    t = dt * np.arange(300)
    stress = np.minimum(t / 1.0, 1.0) * 2.0
    strain = np.asarray(vojax.simulate(stress, 0.3, np.array([0.7]), dt))
    strain = strain + np.where(t < 1.0, 0.2 * strain, 0.0)  # another law during the ramp
    return _write(tmp_path / "ramp.csv", t + 5.0, stress, strain), t, stress, strain


def test_fit_window_in_the_files_time(tmp_path):
    """``--fit-from 6`` in the file's time (5 s before the record's clock) fits the hold phase
    only: the library's refit with ``window=(1, ∞)`` on the record's clock."""
    path, t, stress, strain = _ramp_hold_file(tmp_path)
    out = tmp_path / "out"
    assert main(["identify", path, *COLUMNS, "--method", "refit", "--fit-from", "6", "--out", str(out)]) == 0
    fit = vojax.refit(stress, strain, 0.05, window=(1.0, np.inf), p_signs=(1,))
    s = _summary(out)
    assert s["refit"]["order"] == pytest.approx(float(fit.order[0]), rel=1e-10)
    assert abs(s["refit"]["order"] - 0.3) < 1e-6  # the hold phase is the springpot's


def test_maxwell_and_signs_from_the_command_line(tmp_path, capsys):
    """`--model maxwell` refits with its spring as the order-0 regressor; with another method
    it is refused naming the option; so are the refit's options with the tracker alone."""
    dt = 0.02
    t = dt * np.arange(400)
    stress = 1.0 + 0.5 * np.sin(1.3 * t)
    strain = np.asarray(vojax.simulate(stress, 0.35, np.array([0.5]), dt)) + stress / 4.0
    path = _write(tmp_path / "maxwell.csv", t, stress, strain)
    out = tmp_path / "out"
    assert main(["identify", path, *COLUMNS, "--model", "maxwell", "--method", "refit", "--out", str(out)]) == 0
    s = _summary(out)["refit"]
    assert s["parameters"]["E"] == pytest.approx(4.0, rel=1e-6)
    assert s["parameters"]["eta"] == pytest.approx(2.0, rel=1e-6)
    assert s["p_at_bound"] == [False, False]
    assert main(["identify", path, *COLUMNS, "--model", "maxwell", "--out", str(tmp_path / "o2")]) == 1
    assert "add --method refit" in capsys.readouterr().err
    assert main(["identify", path, *COLUMNS, "--origin", "-1", "--out", str(tmp_path / "o3")]) == 1
    assert "--origin sets the refit, which --method kalman does not run" in capsys.readouterr().err


def test_kelvin_voigt_keeps_k_non_negative(tmp_path):
    """Data whose free Kelvin–Voigt fit has k < 0: the CLI holds k at 0 (its bound), says so,
    and the order and η are the springpot's fit of the same data."""
    dt = 0.05
    t = dt * np.arange(300)
    stress = 1.0 + 0.4 * np.sin(0.9 * t)
    x = np.asarray(vojax.simulate(stress, 0.4, np.array([1.0]), dt))
    strain = x + 0.02 * x * np.sin(2.3 * t)
    free = vojax.refit(np.stack([stress, strain], 1), strain, dt)
    assert float(free.p[1]) > 0  # k = −p₂/p₁ < 0 without the constraint
    path = _write(tmp_path / "kv.csv", t, stress, strain)
    out = tmp_path / "out"
    assert main(["identify", path, *COLUMNS, "--model", "kelvin-voigt", "--method", "refit", "--out", str(out)]) == 0
    s = _summary(out)["refit"]
    assert s["p_at_bound"] == [False, True] and s["parameters"]["k"] == 0.0
    spring = vojax.refit(stress, strain, dt)
    assert s["order"] == pytest.approx(float(spring.order[0]), rel=1e-8)
    assert s["parameters"]["eta"] == pytest.approx(1 / float(spring.p[0]), rel=1e-8)


def test_batch_runs_irregular_records_on_their_clock(tmp_path):
    """A folder with two uniform records and one on an irregular clock: all three computed;
    the irregular one equals `identify_record` on it alone."""
    from vojax._data._pipeline import identify_record

    rng = np.random.default_rng(0)
    files = []
    for i, jitter in enumerate((0.0, 0.0, 0.3)):
        steps = 0.05 * (1 + jitter * rng.uniform(-1, 1, 199))
        t = np.concatenate([[0.0], np.cumsum(steps)])
        stress = 1.0 + 0.5 * np.sin(0.8 * t + i)
        strain = np.asarray(vojax.simulate(stress, 0.4, np.array([0.8]), t=t))
        files.append(_write(tmp_path / f"r{i}.csv", t, stress, strain))
    out = tmp_path / "out"
    assert main(["batch", *files, *COLUMNS, "--method", "refit", "--quiet", "--figures", "overview", "--out", str(out)]) == 0
    (rec,) = vojax.load_records(files[2], time="t", inputs=["stress"], output="strain")
    assert not rec.uniform
    _, alone = identify_record(rec, method="refit")
    s = _summary(out / "r2")
    assert s["refit"]["order"] == pytest.approx(alone["refit"]["order"], rel=1e-10)
    assert abs(s["refit"]["order"] - 0.4) < 1e-6


def test_an_undetermined_parameter_is_written_not_failed(tmp_path):
    """A hold of constant strain fitted alone (offset estimated) leaves the order undetermined:
    the record is written (the interval spans the bounds, the figure draws no band for an
    infinite error, without a warning), not reported as a failure."""
    t = np.concatenate([np.linspace(0.0, 1.0, 41), 1.0 + np.geomspace(0.01, 100.0, 199)])
    strain = np.minimum(t, 1.0) * 0.2
    stress = 20.0 * strain + 40.0 * 0.2 * (t**0.7 - np.where(t > 1, t - 1, 0.0) ** 0.7) / math.gamma(1.7)
    path = _write(tmp_path / "hold.csv", t, stress, strain)
    out = tmp_path / "out"
    args = ["identify", path, *COLUMNS, "--model", "kelvin-voigt", "--method", "refit",
            "--fit-from", "1.0", "--out", str(out)]
    assert main(args) == 0
    s = _summary(out)["refit"]
    assert s["order_lower"] < 0.1 and s["order_upper"] > 0.9
    # the strain is constant over the window: both coefficients are 0 exactly (not ±1e-16 by
    # the machine's rounding), so η = 1/p and k = −p₁/p₀ are undetermined, written as null
    assert s["p"] == [0.0, 0.0]
    assert s["parameters"] == {"eta": None, "k": None}
    assert s["parameters_undetermined"] == ["eta", "k"]
    assert (out / "identification.png").is_file()


def test_record_figure_with_an_infinite_error_warns_nothing(tmp_path):
    """`record_figure` draws a parameter whose standard error is inf (undetermined) as a line
    without a band; under the tests' warnings-as-errors a NaN transform would fail here."""
    from vojax._plotting_record import record_figure

    t = np.linspace(0.0, 10.0, 50)
    columns = {"time": t, "y": np.sin(t), "refit_alpha": np.full(50, 0.5),
               "refit_alpha_lower": np.full(50, 0.01), "refit_alpha_upper": np.full(50, 0.99),
               "refit_y_hat": np.sin(t)}
    summary = {"record": "r", "model": "kelvin-voigt", "output_column": "strain",
               "input_columns": ["stress"], "parameter_names": ["eta", "k"],
               "refit": {"parameters": {"eta": 40.0, "k": 20.0},
                         "parameters_stderr": {"eta": float("inf"), "k": 3.0}}}
    record_figure(columns, summary, np.sin(t)[:, None], tmp_path / "f.png")
    assert (tmp_path / "f.png").stat().st_size > 0


def test_alpha_bounds_bind_every_estimator_from_python_and_the_command_line(tmp_path):
    """``--alpha-bounds LO,HI`` is the order's range of every estimator the command runs, as
    `vojax.identify(alpha_bounds=…)` and `vojax.refit(order_bounds=…)` in Python: a springpot
    of order 0.35 searched in [0.5, 0.9] sits at 0.5 on both routes (each estimator's
    default range would find 0.35), through `identify` and through the batch (whose law
    otherwise runs vmapped at its default range)."""
    _springpot_csv(tmp_path / "test.csv")
    (rec,) = load_records(tmp_path / "test.csv", time="time_s", inputs=["stress"],
                          output="strain")
    bounds = (0.5, 0.9)
    common = ("--time", "time_s", "--input", "stress", "--output", "strain",
              "--alpha-bounds", "0.5,0.9", "--gamma", "0.5")
    proc = run_cli("identify", "test.csv", *common, "--method", "gradient+refit", "--out", "o",
                   cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    batch = run_cli("batch", "test.csv", *common, "--method", "gradient+refit", "--out", "b",
                    "--figures", "overview", "--quiet", cwd=tmp_path)
    assert batch.returncode == 0, batch.stderr
    law = vojax.identify(rec, method="gradient", gamma=0.5, alpha_bounds=bounds, warn=False)
    fit = vojax.refit(rec, order_bounds=bounds, p_signs=(1,), warn=False)
    assert float(fit.order[0]) == pytest.approx(0.5, abs=1e-3)  # the bound binds
    assert float(np.min(law.alpha)) >= 0.5 and float(np.max(law.alpha)) <= 0.9
    for folder in (tmp_path / "o", tmp_path / "b" / "test"):
        with open(folder / "identification.csv") as f:
            rows = list(csv.DictReader(f))
        alpha = np.array([float(r["alpha"]) for r in rows])
        refit_alpha = np.array([float(r["refit_alpha"]) for r in rows])
        np.testing.assert_allclose(alpha, np.asarray(law.alpha), rtol=0, atol=1e-9)
        np.testing.assert_allclose(refit_alpha, np.asarray(fit.order), rtol=0, atol=1e-9)
        settings = json.loads((folder / "summary.json").read_text())["provenance"]["settings"]
        assert settings["alpha_bounds"] == [0.5, 0.9]
    bad = run_cli("identify", "test.csv", *common[:-4], "--alpha-bounds", "0.9,0.5", "--out", "p",
                  cwd=tmp_path)
    assert bad.returncode != 0 and "expected 0 < LO < HI < 1" in bad.stderr
    assert len(bad.stderr.strip().splitlines()) == 1 and not (tmp_path / "p").exists()
