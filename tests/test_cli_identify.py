"""`vojax identify` on recorded datasets, end to end: its outputs, the compilation cache, one
sentence per error, one name per estimator, its options (parameters, max points, units) and
a folder of records (order bounds: `tests/test_cli_recordings.py`)."""

import csv
import json
import os
import subprocess
import sys
import warnings

import numpy as np
import pytest

import vojax
from vojax._data import load_records
from vojax._steps import say

from .helpers import SHARED_DATA as DATA
from .helpers import fresh_cli
from .test_data_cli import _springpot_csv

DT = 0.1


@pytest.mark.parametrize(
    "method",
    ["gradient", pytest.param("kalman", marks=pytest.mark.slow), "refit",
     pytest.param("gradient+refit", marks=pytest.mark.slow),
     pytest.param("kalman+refit", marks=pytest.mark.slow)],
)
def test_cli_identify_end_to_end(tmp_path, method):
    _springpot_csv(tmp_path / "test.csv")
    proc = fresh_cli(
        "identify",
        "test.csv",
        "--time",
        "time_s",
        "--input",
        "stress",
        "--output",
        "strain",
        "--out",
        "out",
        "--method",
        method,
        *(["--gamma", "0.5"] if method.startswith("gradient") else []),
        *(["--parameters", "constant"] if method == "kalman+refit" else []),
        cwd=tmp_path,
    )
    assert proc.returncode == 0, proc.stderr
    out = tmp_path / "out"
    with open(out / "identification.csv") as f:
        rows = list(csv.reader(f))
    band = ["alpha", "alpha_lower", "alpha_upper", "eta"]
    if method.startswith("kalman"):  # the tracker's conditional answer too
        band += ["alpha_conditional", "alpha_conditional_lower", "alpha_conditional_upper"]
    expected = ["time", "file_time"] + (band if method != "refit" else []) + ["y"]
    expected += ["y_hat"] if method != "refit" else []
    if method.endswith("refit"):
        expected += ["refit_alpha", "refit_alpha_lower", "refit_alpha_upper", "refit_y_hat"]
    assert rows[0] == expected and len(rows) == 151
    values = np.array([[float(v) if v else np.nan for v in r] for r in rows[1:]])
    assert np.all(np.isfinite(values[1:]))  # η is undefined (empty) only at sample 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["samples"] == 150 and summary["model"] == "springpot"
    # one name per estimator: the summary's blocks are named as --method names them
    assert set(summary) & {"kalman", "gradient", "refit"} == set(method.split("+"))
    assert summary["method"] == method
    if method.endswith("refit"):
        r = summary["refit"]
        assert r["converged"] and not r["at_bound"]
        assert abs(r["order"] - 0.35) < 1e-6
        assert abs(r["parameters"]["eta"] - 4.0) < 1e-5
        assert r["order_lower"] < r["order"] < r["order_upper"]
        assert abs(r["x0"]) < 1e-6  # noise-free, starts at 0
        # η = 1/p: its error by the delta method is p's relative error times η
        rel = r["p_stderr"][0] / r["p"][0]
        assert r["parameters_stderr"]["eta"] == pytest.approx(rel * r["parameters"]["eta"], rel=1e-9)
    if method.startswith("gradient"):  # the law's band is never a confidence band
        a = summary["gradient"]
        assert "no_confidence" in a["reasons"] and "kalman" in a["next_steps"]
    for key in set(summary) & {"kalman", "gradient"}:
        a = summary[key]
        if a["message"]:  # said on stderr in the command's words: the verdict line, why,
            # then each next step numbered on a line of its own
            said = say(a["finding"], a["next_steps"], "cli")
            steps = said.split(". Next: ")[1].split("; (") if ". Next: " in said else []
            lines = proc.stderr.splitlines()
            head = next(i for i, line in enumerate(lines) if line.startswith(
                "vojax: warning: ") and line.endswith(a.get("answer") or "identified"))
            assert lines[head + 1] == f"  why: {a['finding']}."
            if steps:
                assert lines[head + 2] == "  next steps:"
                for k, step in enumerate(steps, 1):
                    text = step.split(") ", 1)[1]
                    assert lines[head + 2 + k] == f"    ({k}) {text}"
            assert "='" not in proc.stderr  # no Python keyword (method='kalman', …)
    if method.startswith("gradient"):
        assert "use --method kalman for an order with a confidence band" in proc.stderr
    if method.startswith("kalman"):
        a = summary["kalman"]
        assert a["method"] == "kalman" and a["converged"]
        assert a["parameter_model"] == ("constant" if method == "kalman+refit" else "free")
        assert a["verdict"] in ("identified", "conditional", "not identified")
        assert a["identified"] == (a["verdict"] == "identified")
        assert a["answer"].startswith(f"{a['verdict']}: α ")
        assert a["answer"] in proc.stdout  # the command's line says it
        assert abs(a["alpha_final"] - 0.35) < max(3 * a["alpha_final_std"], 1e-3)
        assert abs(a["parameters_final"]["eta"] - 4.0) < 0.05
    assert (out / "identification.png").read_bytes()[:4] == b"\x89PNG"


@pytest.mark.slow
def test_cli_compilation_cache_is_used_and_changes_nothing(tmp_path):
    """With VOJAX_COMPILATION_CACHE a folder, the command keeps its compiled programs there and
    a second run, loading them, writes the same numbers; with it off, nothing is kept."""
    _springpot_csv(tmp_path / "test.csv", n=60)
    base = ["identify", "test.csv", "--time", "time_s", "--input", "stress", "--output", "strain",
            "--method", "refit"]
    runs = {}
    for name, cache in (("first", tmp_path / "cache"), ("second", tmp_path / "cache"),
                        ("off", "off")):
        env = {k: v for k, v in os.environ.items() if k != "XLA_FLAGS"}
        env["VOJAX_COMPILATION_CACHE"] = str(cache)
        env["XDG_CACHE_HOME"] = str(tmp_path / "xdg")  # where the default cache would go
        proc = subprocess.run(
            [sys.executable, "-m", "vojax", *base, "--out", name], cwd=tmp_path,
            capture_output=True, text=True, env=env,
        )
        assert proc.returncode == 0, proc.stderr
        runs[name] = (tmp_path / name / "identification.csv").read_text()
        kept = sorted(p.name for p in (tmp_path / "cache").iterdir())
        if name == "first":
            assert any(k.startswith("jit__fit") for k in kept), kept
            first = kept
        else:  # the second run found everything; off kept nothing anywhere
            assert kept == first
    assert runs["second"] == runs["first"] == runs["off"]
    assert not (tmp_path / "xdg" / "vojax").exists()


@pytest.mark.parametrize(
    "args, message",
    [
        (["missing.csv"], "no such file"),
        (["test.csv", "--area", "-1"], "argument --area: expected a positive number"),
        (["test.csv", "--trim-column", "stress"], "--trim-column and --trim-below go together"),
        (["two.csv", "--model", "kelvin-voigt", "--input", "stress2"], "takes one --input"),
    ],
)
def test_cli_identify_errors_are_one_sentence(tmp_path, args, message):
    _springpot_csv(tmp_path / "test.csv", n=20)
    lines = (tmp_path / "test.csv").read_text().splitlines()  # a second stress column
    (tmp_path / "two.csv").write_text("\n".join(
        line if line.startswith("#")
        else f"{line},{line.split(',')[1].replace('stress', 'stress2')}"
        for line in lines
    ) + "\n")
    base = ["--time", "time_s", "--input", "stress", "--output", "strain", "--out", "out"]
    proc = fresh_cli("identify", *args[:1], *base, *args[1:], cwd=tmp_path)
    assert proc.returncode == 1, proc.stderr
    assert message in proc.stderr and "Traceback" not in proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1


@pytest.mark.slow
@pytest.mark.skipif(
    not (DATA / "oca-shear-staircase").is_dir(), reason="../shared/data is not present"
)
def test_real_adhesive_record_identifies(tmp_path):
    path = DATA / "oca-shear-staircase" / "oca_shear_relaxation_1.csv"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # its time steps are uneven: resampled
        rec = load_records(
            path, time="time_s", inputs=["nominal_shear_stress_kPa"], output="shear_strain"
        )[0]
    from vojax._data._pipeline import identify_record

    columns, summary = identify_record(rec, method="gradient+refit")
    # a springpot describes the adhesive's staircase to a few per cent of its strain range
    assert summary["gradient"]["nrmse"] < 0.05 and summary["refit"]["nrmse"] < 0.05
    assert 0.05 < summary["refit"]["order"] < 0.95 and summary["refit"]["converged"]


def test_one_default_and_one_name_per_estimator(capsys):
    """`vojax.identify`, `vojax.io.identify_record` and the CLI's identify and batch default to
    the same method, named alike; the earlier CLI names still parse, with a note saying what
    they mean now, and an unknown name is refused naming the choices."""
    import inspect

    from vojax._cli import build_parser
    from vojax._data._pipeline import METHODS, canonical_method

    default = inspect.signature(vojax.identify).parameters["method"].default
    assert default == "kalman"
    assert inspect.signature(vojax.io.identify_record).parameters["method"].default == default
    parser = build_parser()
    base = ["f.csv", "--time", "t", "--input", "u", "--output", "y", "--out", "o"]
    for command in ("identify", "batch"):
        assert parser.parse_args([command, *base]).method == default
        for name in METHODS:
            assert parser.parse_args([command, *base, "--method", name]).method == name
    assert parser.parse_args(["identify", *base, "--method", "adaptive"]).method == "gradient"
    assert parser.parse_args(["batch", *base, "--method", "both"]).method == "gradient+refit"
    assert "--method adaptive is now called gradient" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        parser.parse_args(["identify", *base, "--method", "law"])
    assert "--method must be one of kalman, gradient" in capsys.readouterr().err
    with pytest.raises(ValueError, match="`method` must be one of"):
        canonical_method("tracker")


def test_parameters_option_sets_the_tracker_only(tmp_path):
    """--parameters (the tracker's) with the paper's law or the refit alone is refused in one
    line before anything is written, as `identify(parameters=...)` with the law is."""
    _springpot_csv(tmp_path / "test.csv")
    base = ["test.csv", "--time", "time_s", "--input", "stress", "--output", "strain"]
    for command, method in (("identify", "gradient"), ("batch", "refit")):
        proc = fresh_cli(command, *base, "--out", "o", "--method", method, "--parameters",
                         "constant", cwd=tmp_path)
        assert proc.returncode == 1 and proc.stderr.count("\n") == 1, proc.stderr
        assert f"--parameters sets the tracker, which --method {method} does not run" in proc.stderr
    assert not (tmp_path / "o").exists()
    from vojax._data._batch import run_batch
    from vojax._data._records import load_records

    records = load_records(tmp_path / "test.csv", time="time_s", inputs=["stress"], output="strain")
    with pytest.raises(ValueError, match="--parameters sets the tracker"):
        run_batch(records, tmp_path / "b", model="springpot", method="refit", gamma=None, lam=None,
                  parameters="constant")
    with pytest.raises(ValueError, match="--parameters sets the tracker"):
        vojax.io.identify_record(records[0], method="gradient+refit", parameters="constant")


def test_max_points_option_blocks_a_record_and_is_checked(tmp_path):
    """--max-points (the tracker's) fits a record as block means and still writes every
    sample, recording the block in summary.json; out of range, or with a method that runs no
    tracker, it is refused in one line before anything is written."""
    _springpot_csv(tmp_path / "test.csv")
    base = ["test.csv", "--time", "time_s", "--input", "stress", "--output", "strain"]
    for extra, text in (
        (["--method", "gradient", "--max-points", "500"],
         "--max-points sets the tracker, which --method gradient does not run"),
        (["--max-points", "99"], "--max-points must be from 100 to 50,000, got 99"),
    ):
        proc = fresh_cli("identify", *base, "--out", "o", *extra, cwd=tmp_path)
        assert proc.returncode == 1 and proc.stderr.count("\n") == 1, proc.stderr
        assert text in proc.stderr
    assert not (tmp_path / "o").exists()
    proc = fresh_cli("identify", *base, "--out", "o", "--max-points", "100", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    with open(tmp_path / "o" / "identification.csv") as f:
        assert len(list(csv.reader(f))) == 151
    kalman = json.loads((tmp_path / "o" / "summary.json").read_text())["kalman"]
    # the same record through the API: the same blocks and model error
    t, stress, strain = _springpot_csv(tmp_path / "again.csv")
    res = vojax.identify(stress, strain, DT, max_points=100, warn=False)
    assert kalman["block"] == res.diagnostics.block == 2
    assert kalman["block_error"] == pytest.approx(res.diagnostics.block_error, rel=1e-6)
    assert kalman["identified"] == res.diagnostics.identified


def test_a_batch_takes_a_folder_and_names_each_record_folder(tmp_path):
    """`vojax batch FOLDER` reads the folder's .csv and .npz files (not its subfolders');
    summary.csv names each record's output folder; a folder without data is an error."""
    from vojax._data._paths import record_folder

    data = tmp_path / "data"
    data.mkdir()
    for k in range(2):
        _springpot_csv(data / f"Spec {k}.csv", n=30)
    (data / "notes.txt").write_text("not data")
    (data / "sub").mkdir()
    _springpot_csv(data / "sub" / "deeper.csv", n=30)
    proc = fresh_cli("batch", "data", "--time", "time_s", "--input", "stress", "--output", "strain",
                     "--method", "refit", "--out", "out", "--quiet", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    with open(tmp_path / "out" / "summary.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert [r["record"] for r in rows] == ["Spec 0", "Spec 1"]
    for r in rows:
        assert r["folder"] == record_folder(r["record"])
        assert (tmp_path / "out" / r["folder"] / "summary.json").is_file()
    (tmp_path / "empty").mkdir()
    proc = fresh_cli("batch", "empty", "--time", "t", "--input", "u", "--output", "y",
                     "--out", "o2", cwd=tmp_path)
    assert proc.returncode == 1 and "without CSV, NPZ or AFM files" in proc.stderr


@pytest.mark.slow
def test_the_batch_counts_the_records_it_does_not_identify(tmp_path):
    """The closing line says how many records the tracker did not identify, as summary.csv's
    `kalman_identified` column does: a clean springpot (its η stated constant) is identified,
    an output of pure noise is not."""
    t, stress, strain = _springpot_csv(tmp_path / "unused.csv", n=150)
    rng = np.random.default_rng(0)
    for name, y in (("clean", strain + 0.01 * np.ptp(strain) * rng.standard_normal(150)),
                    ("noise", rng.standard_normal(150))):
        with open(tmp_path / f"{name}.csv", "w") as f:
            f.write("time_s,stress,strain\n")
            f.writelines(f"{a!r},{b!r},{c!r}\n" for a, b, c in zip(t.tolist(), stress.tolist(), y.tolist()))
    proc = fresh_cli("batch", "clean.csv", "noise.csv", "--time", "time_s", "--input", "stress",
                     "--output", "strain", "--out", "out", "--quiet", "--parameters", "constant",
                     cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    with open(tmp_path / "out" / "summary.csv", newline="") as f:
        rows = {r["record"]: r for r in csv.DictReader(f)}
    flags = {name: r["kalman_identified"] for name, r in rows.items()}
    assert flags == {"clean": "True", "noise": "False"}
    assert "2 computed" in proc.stdout and "1 of them with the order not identified" in proc.stdout
    # the verdict, its reach and its reasons lead each row, as each record's summary has them
    assert rows["clean"]["verdict"] == "identified" and rows["noise"]["verdict"] != "identified"
    for name, r in rows.items():
        summary = json.loads((tmp_path / "out" / r["folder"] / "summary.json").read_text())
        assert r["verdict"] == summary["kalman"]["verdict"]
        assert r["reasons"] == ";".join(summary["kalman"]["reasons"])
        assert r["next_steps"] == ";".join(summary["kalman"]["next_steps"])
    assert rows["noise"]["next_steps"] and not rows["clean"]["next_steps"]
    # a drift bound on the command line is the tracker's statement, in its summary
    proc = fresh_cli("identify", "clean.csv", "--time", "time_s", "--input", "stress", "--output",
                     "strain", "--out", "bounded", "--parameters", "0.2", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    summary = json.loads((tmp_path / "bounded" / "summary.json").read_text())
    assert summary["kalman"]["parameter_model"] == 0.2
    proc = fresh_cli("identify", "clean.csv", "--time", "time_s", "--input", "stress", "--output",
                     "strain", "--out", "bad", "--parameters", "-1", cwd=tmp_path)
    assert proc.returncode != 0 and "--parameters" in proc.stderr


def test_units_label_the_figures_and_change_no_number(tmp_path, capsys, monkeypatch):
    """``--units stress=kPa,strain=1`` puts the units on the figure's axes and in
    summary.json and changes no number; a malformed spec or a column the record does not use
    is refused in one line, before anything is identified."""
    from vojax import _plotting_record
    from vojax._cli import main

    _springpot_csv(tmp_path / "s.csv", n=60)
    labels = []
    real = _plotting_record._save

    def keep(fig, path, **kw):
        if path.name.startswith("identification"):
            labels.append((fig.axes[0].get_ylabel(), fig.axes[2].get_ylabel()))
        real(fig, path, **kw)

    monkeypatch.setattr(_plotting_record, "_save", keep)
    args = ["identify", str(tmp_path / "s.csv"), "--time", "time_s", "--input", "stress",
            "--output", "strain", "--method", "refit"]
    assert main([*args, "--out", str(tmp_path / "a")]) == 0
    assert main([*args, "--units", "stress=kPa, strain=1", "--out", str(tmp_path / "b")]) == 0
    assert labels == [("strain", "stress"), ("strain (1)", "stress (kPa)")]
    a, b = (json.loads((tmp_path / d / "summary.json").read_text()) for d in "ab")
    assert "units" not in a and b["units"] == {"strain": "1", "stress": "kPa"}
    assert a["refit"]["order"] == b["refit"]["order"]
    assert (tmp_path / "a" / "identification.csv").read_bytes() == (
        tmp_path / "b" / "identification.csv"
    ).read_bytes()
    capsys.readouterr()
    with pytest.raises(SystemExit):
        main([*args, "--units", "stress", "--out", str(tmp_path / "c")])
    assert "COLUMN=UNIT" in capsys.readouterr().err
    assert main([*args, "--units", "force=N", "--out", str(tmp_path / "d")]) == 1
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "--units names 'force'" in err
    assert not (tmp_path / "d").exists()
    with pytest.raises(ValueError, match="short printable"):
        load_records(tmp_path / "s.csv", time="time_s", inputs=["stress"], output="strain",
                     units={"stress": "k\nPa"})
    (rec,) = load_records(tmp_path / "s.csv", time="time_s", inputs=["stress"],
                          output="strain", units={"time_s": "ms"})
    assert rec.units == (("time_s", "ms"),)
