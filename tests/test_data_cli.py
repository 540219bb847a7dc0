"""Recorded datasets in, identification out: the loader and `vojax identify`."""

import csv
import json
import os
import re
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

import vojax
from vojax._data import DataError, load_records
from vojax._steps import say

DATA = Path(__file__).resolve().parents[2] / "shared" / "data"
DT = 0.1


def _springpot_csv(path, *, n=150, q=0.35, eta=4.0, extra_rows=(), time=None, comment=True):
    t = np.arange(n) * DT if time is None else time
    stress = np.minimum(t, 3.0) + 0.1 * np.sin(3 * t)
    strain = np.asarray(vojax.simulate(stress, q, np.array([1.0 / eta]), DT))
    with open(path, "w", newline="") as f:
        if comment:
            f.write("# synthetic springpot test, written by the test suite\n")
        w = csv.writer(f)
        w.writerow(["time_s", "stress", "strain"])
        for row in zip(t, stress, strain):
            w.writerow([repr(float(v)) for v in row])
        for row in extra_rows:
            w.writerow(row)
    return t, stress, strain


def _cli(*args, cwd):
    env = {k: v for k, v in os.environ.items() if k != "XLA_FLAGS"}
    return subprocess.run(
        [sys.executable, "-m", "vojax", *args], cwd=cwd, capture_output=True, text=True, env=env
    )


def test_loader_reads_groups_trims_and_resamples(tmp_path):
    path = tmp_path / "long.csv"
    with open(path, "w") as f:
        f.write("# comment\nspecimen,t,F,d\n")
        for name, offset in (("a", 0.0), ("b", 1.0)):
            for k in range(10):
                f.write(f"{name},{k * 0.5},{0.0 if k < 2 else k + offset},{k * 0.1}\n")
    recs = load_records(
        path,
        time="t",
        inputs=["F"],
        output="d",
        group_by="specimen",
        trim_column="F",
        trim_below=0.5,
    )
    assert [r.name for r in recs] == ["a", "b"]
    assert recs[0].time.size == 8 and recs[0].time[0] == 0.0 and recs[0].dt == 0.5
    assert recs[1].inputs[0, 0] == 3.0
    t = np.r_[0.0, 0.1, 0.25, 0.3, 0.4, 0.5]
    path2 = tmp_path / "uneven.csv"
    with open(path2, "w") as f:
        f.write("t,F,d\n" + "".join(f"{x},{2 * x},{x}\n" for x in t))
    # an irregular clock is kept as recorded (no resampling, no warning)
    rec = load_records(path2, time="t", inputs=["F"], output="d")[0]
    assert not rec.uniform and rec.dt == pytest.approx(0.1)
    np.testing.assert_array_equal(rec.time, t)
    np.testing.assert_array_equal(rec.grid["t"], t)
    with pytest.raises(DataError, match="time steps vary by 50 %.*--strict"):
        load_records(path2, time="t", inputs=["F"], output="d", strict=True)
    # resampling only when asked: onto t_0 + k·step, linear in between
    rec = load_records(path2, time="t", inputs=["F"], output="d", resample=0.1)[0]
    assert rec.uniform and rec.grid == {"dt": 0.1} and rec.resampled == pytest.approx(0.5)
    np.testing.assert_allclose(rec.time, 0.1 * np.arange(6), atol=1e-15)
    np.testing.assert_allclose(rec.inputs[:, 0], 2 * rec.time, atol=1e-14)
    # … refused where it would smooth away the short steps, or make too many samples
    with pytest.raises(DataError, match=r"steps of 0\.05 \(at time 0\.25\).*--resample ≤ 0\.2"):
        load_records(path2, time="t", inputs=["F"], output="d", resample=0.3)
    with pytest.raises(DataError, match="makes 5,000,001 samples.*limit is 1,000,000"):
        load_records(path2, time="t", inputs=["F"], output="d", resample=1e-7)


@pytest.mark.parametrize(
    "content, match",
    [
        ("t,F\n0,1\n0.1,2\n0.2,3\n", r"no column 'd' \(columns: t, F\)"),
        ("t,F,d\n0,1,0\n0.1,x,0\n0.2,3,0\n", r"line 3, column 'F': 'x' is not a number"),
        ("t,F,d\n0,1,0\n0.1,nan,0\n0.2,3,0\n", r"line 3, column 'F': value is NaN"),
        ("t,F,d\n0,1,0\n0.2,2,0\n0.1,3,0\n", r"line 4: time does not increase"),
        ("# only a comment\n", "no header row"),
        ("t,F,F,d\n0,1,2,0\n0.1,2,3,0\n0.2,3,4,0\n", r"line 1: the column name 'F' appears twice"),
        ("t, F,d\n0,1,0\n0.1,2,0\n0.2,3,0\n", r"the header has ' F', with spaces around the name"),
        ("t,F,d\n0,1,0\n#0.1,2,0\n0.2,3,0\n", r"line 3: starts with '#' after the header"),
    ],
)
def test_loader_errors_name_file_line_and_column(tmp_path, content, match):
    path = tmp_path / "bad.csv"
    path.write_text(content)
    with pytest.raises(DataError, match=match):
        load_records(path, time="t", inputs=["F"], output="d")


def test_a_decimal_comma_is_named_where_it_would_read(tmp_path):
    """A cell that reads as a number with its comma taken as the decimal point gets the hint
    (the option in both interfaces); one that would not ('x', '1,2,3') does not; with the
    option the file reads, its values exact."""
    path = tmp_path / "de.csv"
    path.write_text("t;F;d\n0,0;1,5;0\n0,1;2,5;0,25\n0,2;3,5;0,5\n")
    with pytest.raises(DataError, match=r"'0,0' is not a number; for decimal commas pass "
                       r"--decimal , \(decimal=',' in Python\)"):
        load_records(path, time="t", inputs=["F"], output="d", delimiter=";")
    rec = load_records(path, time="t", inputs=["F"], output="d", delimiter=";", decimal=",")[0]
    np.testing.assert_array_equal(rec.inputs[:, 0], [1.5, 2.5, 3.5])
    np.testing.assert_array_equal(rec.output, [0.0, 0.25, 0.5])
    bad = tmp_path / "bad.csv"
    bad.write_text("t;F;d\n0;1,2,3;0\n0.1;x;0\n0.2;3;0\n")
    with pytest.raises(DataError, match=r"'1,2,3' is not a number\.$"):
        load_records(bad, time="t", inputs=["F"], output="d", delimiter=";")


def test_loader_bom_folders_and_exact_names(tmp_path):
    path = tmp_path / "bom.csv"
    path.write_bytes("\ufefft,F,d\n0,1,0\n0.1,2,0\n0.2,3,0\n".encode("utf-8"))
    rec = load_records(path, time="t", inputs=["F"], output="d")[0]  # the BOM is not part of 't'
    assert rec.time.size == 3
    with pytest.raises(DataError, match="is a folder, not a CSV or NPZ file"):
        load_records(tmp_path, time="t", inputs=["F"], output="d")
    long = tmp_path / "long.csv"
    long.write_text("s,t,F,d\n" + "".join(f"{n},{k * 0.1},{k + 1},{k}\n" for n in (" pad ", "pad") for k in range(4)))
    names = [r.name for r in load_records(long, time="t", inputs=["F"], output="d", group_by="s")]
    assert names == [" pad ", "pad"]


def test_area_and_length_give_eta_in_the_users_units(tmp_path):
    """Force F and displacement d with σ = F/a, ε = d/l, σ = η D^q ε: `--area a --length l`
    returns η itself (swapping them, or ignoring either, gives another number)."""
    a, ell, eta, q = 2.0, 5.0, 4.0, 0.35
    t = np.arange(150) * DT
    force = np.minimum(t, 3.0) + 0.1 * np.sin(3 * t)
    strain = np.asarray(vojax.reference.fractional_integral(force / a, q, DT)) / eta
    with open(tmp_path / "fd.csv", "w") as f:
        f.write("time_s,F,d\n" + "".join(f"{x!r},{y!r},{z!r}\n" for x, y, z in zip(t.tolist(), force.tolist(), (ell * strain).tolist())))
    proc = _cli(
        "identify", "fd.csv", "--time", "time_s", "--input", "F", "--output", "d", "--out", "o",
        "--method", "refit", "--area", str(a), "--length", str(ell), cwd=tmp_path,
    )
    assert proc.returncode == 0, proc.stderr
    refit = json.loads((tmp_path / "o" / "summary.json").read_text())["refit"]
    assert refit["order"] == pytest.approx(q, abs=1e-6)
    assert refit["parameters"]["eta"] == pytest.approx(eta, rel=1e-5)


def test_npz_records(tmp_path):
    t = np.arange(50) * DT
    np.savez(tmp_path / "r.npz", t=t, F=np.sin(t), d=np.cos(t))
    rec = load_records(tmp_path / "r.npz", time="t", inputs=["F"], output="d")[0]
    assert rec.name == "r" and rec.inputs.shape == (50, 1) and rec.dt == pytest.approx(DT)


@pytest.mark.parametrize(
    "method",
    ["gradient", pytest.param("kalman", marks=pytest.mark.slow), "refit",
     pytest.param("gradient+refit", marks=pytest.mark.slow),
     pytest.param("kalman+refit", marks=pytest.mark.slow)],
)
def test_cli_identify_end_to_end(tmp_path, method):
    _springpot_csv(tmp_path / "test.csv")
    proc = _cli(
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
    proc = _cli("identify", *args[:1], *base, *args[1:], cwd=tmp_path)
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
        proc = _cli(command, *base, "--out", "o", "--method", method, "--parameters",
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
        proc = _cli("identify", *base, "--out", "o", *extra, cwd=tmp_path)
        assert proc.returncode == 1 and proc.stderr.count("\n") == 1, proc.stderr
        assert text in proc.stderr
    assert not (tmp_path / "o").exists()
    proc = _cli("identify", *base, "--out", "o", "--max-points", "100", cwd=tmp_path)
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


def _hostile_npz(folder):
    """NPZ files a loader meets in the wild, each with what its error must say."""
    t = np.arange(50) * 0.1
    cases = {}

    def save(name, **arrays):
        np.savez(folder / f"{name}.npz", **{"t": t, "F": np.sin(t), "d": np.cos(t), **arrays})

    (folder / "empty.npz").write_bytes(b"")
    cases["empty"] = "not a readable NPZ file"
    save("good")
    data = (folder / "good.npz").read_bytes()
    (folder / "cut.npz").write_bytes(data[: len(data) // 2])
    cases["cut"] = "not a readable NPZ file"
    save("complex", F=np.sin(t) + 1j)
    cases["complex"] = "holds complex values"
    save("dates", t=np.arange(50).astype("datetime64[s]"))
    cases["dates"] = "holds date-time values"
    save("cube", d=np.zeros((5, 5, 2)))
    cases["cube"] = "has shape (5, 5, 2)"
    save("text", F=np.array(["a"] * 50))
    cases["text"] = "holds text values"
    # headers that declare more samples than the file holds: 2^40 (refused for its size
    # before anything is allocated) and 1000 (truncated)
    _npz_declaring(folder / "huge.npz", 2**40)
    cases["huge"] = "declares 1099511627776 samples, more than"
    _npz_declaring(folder / "short.npz", 1000)
    cases["short"] = "is truncated"
    return cases


def _npz_declaring(path, samples):
    """An NPZ whose time array's header declares `samples` float64 values over 64 bytes."""
    import io
    import zipfile

    header = io.BytesIO()
    np.lib.format.write_array_header_1_0(
        header, {"descr": "<f8", "fortran_order": False, "shape": (samples,)}
    )
    with zipfile.ZipFile(path, "w") as z:
        z.writestr("t.npy", header.getvalue() + b"\0" * 64)
        for name in ("F", "d"):
            out = io.BytesIO()
            np.save(out, np.zeros(50))
            z.writestr(f"{name}.npy", out.getvalue())


def test_hostile_npz_files_fail_alone_with_one_sentence(tmp_path):
    """Each bad NPZ is a `DataError` naming the file and what is wrong, read no further than
    its headers (the 2^40-sample one allocates nothing); in a batch, each fails alone and the
    good file is identified."""
    cases = _hostile_npz(tmp_path)
    for name, message in cases.items():
        with pytest.raises(DataError, match=re.escape(message)) as info:
            load_records(tmp_path / f"{name}.npz", time="t", inputs=["F"], output="d")
        assert str(tmp_path / f"{name}.npz") in str(info.value) and "\n" not in str(info.value)
    files = sorted(p.name for p in tmp_path.glob("*.npz"))
    proc = _cli(
        "batch", *files, "--time", "t", "--input", "F", "--output", "d", "--method", "refit",
        "--out", "out", "--quiet", cwd=tmp_path,
    )
    assert proc.returncode == 2, proc.stderr
    with open(tmp_path / "out" / "failures.csv", newline="") as f:
        failed = {Path(r["file"]).stem for r in csv.DictReader(f)}
    assert failed == set(cases)
    assert (tmp_path / "out" / "good" / "summary.json").is_file()


def test_semicolons_decimal_commas_and_a_hint_for_them(tmp_path):
    """A file as a European spreadsheet writes it (';' between fields, a decimal comma) loads
    to the same numbers as the plain CSV; read with the defaults, the error says what to
    pass; a decimal comma with ',' between fields is refused."""
    _springpot_csv(tmp_path / "plain.csv", n=30)
    text = (tmp_path / "plain.csv").read_text()
    euro = "\n".join(
        ";".join(cell.replace(".", ",") for cell in line.split(",")) for line in text.splitlines()
    )
    (tmp_path / "euro.csv").write_text(euro + "\n")
    (tmp_path / "tabs.csv").write_text(text.replace(",", "\t"))
    cols = dict(time="time_s", inputs=["stress"], output="strain")
    (a,) = load_records(tmp_path / "plain.csv", **cols)
    (b,) = load_records(tmp_path / "euro.csv", **cols, delimiter=";", decimal=",")
    (c,) = load_records(tmp_path / "tabs.csv", **cols, delimiter="\t")
    for r in (b, c):
        np.testing.assert_array_equal(r.time, a.time)
        np.testing.assert_array_equal(r.inputs, a.inputs)
        np.testing.assert_array_equal(r.output, a.output)
    with pytest.raises(DataError, match="pass --delimiter ';'"):
        load_records(tmp_path / "euro.csv", **cols)
    with pytest.raises(DataError, match="pass --delimiter tab"):
        load_records(tmp_path / "tabs.csv", **cols)
    with pytest.raises(ValueError, match="a decimal comma needs another delimiter"):
        load_records(tmp_path / "plain.csv", **cols, decimal=",")
    proc = _cli("identify", "euro.csv", "--time", "time_s", "--input", "stress", "--output",
                "strain", "--delimiter", ";", "--decimal-comma", "--method", "refit",
                "--out", "o", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    summary = json.loads((tmp_path / "o" / "summary.json").read_text())
    assert abs(summary["refit"]["order"] - 0.35) < 1e-6


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
    proc = _cli("batch", "data", "--time", "time_s", "--input", "stress", "--output", "strain",
                "--method", "refit", "--out", "out", "--quiet", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    with open(tmp_path / "out" / "summary.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert [r["record"] for r in rows] == ["Spec 0", "Spec 1"]
    for r in rows:
        assert r["folder"] == record_folder(r["record"])
        assert (tmp_path / "out" / r["folder"] / "summary.json").is_file()
    (tmp_path / "empty").mkdir()
    proc = _cli("batch", "empty", "--time", "t", "--input", "u", "--output", "y",
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
    proc = _cli("batch", "clean.csv", "noise.csv", "--time", "time_s", "--input", "stress",
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
    proc = _cli("identify", "clean.csv", "--time", "time_s", "--input", "stress", "--output",
                "strain", "--out", "bounded", "--parameters", "0.2", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    summary = json.loads((tmp_path / "bounded" / "summary.json").read_text())
    assert summary["kalman"]["parameter_model"] == 0.2
    proc = _cli("identify", "clean.csv", "--time", "time_s", "--input", "stress", "--output",
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


def test_each_column_has_one_role_and_a_lone_input_may_be_a_string(tmp_path):
    """A single input given as a string is that column (it was read as its letters: "no
    column 's'"); a column given twice as an input, or as an input and the output (which fits
    itself perfectly), or the time as the output, is refused in one sentence, in Python and
    on the command line."""
    from vojax._data import load_records

    _springpot_csv(tmp_path / "r.csv", n=30)
    one, = load_records(tmp_path / "r.csv", time="time_s", inputs="stress", output="strain")
    two, = load_records(tmp_path / "r.csv", time="time_s", inputs=["stress"], output="strain")
    np.testing.assert_array_equal(one.inputs, two.inputs)
    assert one.input_names == ("stress",)
    cases = [
        (dict(inputs=["stress", "stress"]), "the column 'stress' is given twice as an input"),
        (dict(inputs=["strain"]), "the column 'strain' is both an input and the output"),
        (dict(inputs=["stress"], output="time_s"), "one column is given two roles"),
        (dict(inputs=[3]), "`inputs` must name a column"),
        (dict(inputs=[]), "`inputs` must name at least one column"),
    ]
    for change, words in cases:
        call = dict(time="time_s", inputs=["stress"], output="strain") | change
        with pytest.raises((ValueError, TypeError), match=words):
            load_records(tmp_path / "r.csv", **call)
    for args, words in [(["--input", "strain", "--output", "strain"], "both an input and"),
                        (["--input", "stress", "--input", "stress", "--output", "strain"],
                         "given twice as an input")]:
        done = _cli("identify", "r.csv", "--time", "time_s", *args, "--out", "o", cwd=tmp_path)
        assert done.returncode == 1 and words in done.stderr, done.stderr
        assert len(done.stderr.strip().splitlines()) == 1
        assert not (tmp_path / "o").exists()


def test_hostile_cells_clocks_and_silent_inputs_get_one_sentence(tmp_path):
    """A note holding U+2028 or a form feed is a text cell, not a line break (the reader
    split lines as str.splitlines does); a clock reaching 1e308 and a resampling step of
    1e-300 are refused in one sentence (OverflowError, exit 3 before; a 300-digit count);
    an input column that is 0 throughout is refused by the refit and the tracker alike (the
    refit exited 0 with q = 0.5 [0.01, 0.99])."""
    from vojax._data import load_records

    t = DT * np.arange(30)
    stress = np.minimum(t, 1.0)
    strain = np.asarray(vojax.simulate(stress, 0.4, 1.0, DT))
    notes = ["n"] * 30
    notes[5], notes[7] = "x\u2028y", "a\fb"
    with open(tmp_path / "notes.csv", "w", newline="", encoding="utf-8") as f:
        f.write("time_s,stress,strain,note\n")
        for row in zip(t, stress, strain, notes):
            f.write(",".join(map(str, row)) + "\n")
    rec, = load_records(tmp_path / "notes.csv", time="time_s", inputs="stress", output="strain")
    np.testing.assert_array_equal(rec.output, strain)
    far = tmp_path / "far.csv"
    far.write_text("time_s,stress,strain\n" + "".join(
        f"{a!r},1.0,{b!r}\n" for a, b in zip(np.linspace(0, 1e308, 30).tolist(), strain.tolist())
    ))
    zero = tmp_path / "zero.csv"
    zero.write_text("time_s,stress,strain\n" + "".join(
        f"{a!r},0.0,{b!r}\n" for a, b in zip(t.tolist(), strain.tolist())
    ))
    base = ["--time", "time_s", "--input", "stress", "--output", "strain"]
    for args, words in [
        (["far.csv"], f"line 3: the time {1e308 / 29:g} is beyond ±1e+100"),
        (["notes.csv", "--resample", "1e-300"], "makes 2.9e+300 samples"),
        (["zero.csv", "--method", "refit"], "the input column 'stress' is 0 at every sample"),
        (["zero.csv"], "the input column 'stress' is 0 at every sample"),
    ]:
        done = _cli("identify", args[0], *base, *args[1:], "--out", "o", cwd=tmp_path)
        lines = done.stderr.strip().splitlines()
        assert done.returncode == 1 and len(lines) == 1 and words in lines[0], done.stderr
    with pytest.raises(ValueError, match="input 1 of `u` is 0 at every sample"):
        vojax.refit(0 * stress, strain, DT)
    with pytest.raises(ValueError, match="input 2 of `u` is 0 at every sample"):
        vojax.identify(np.c_[stress, 0 * stress], strain, DT, warn=False)


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
    proc = _cli("identify", "test.csv", *common, "--method", "gradient+refit", "--out", "o",
                cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    batch = _cli("batch", "test.csv", *common, "--method", "gradient+refit", "--out", "b",
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
    bad = _cli("identify", "test.csv", *common[:-4], "--alpha-bounds", "0.9,0.5", "--out", "p",
               cwd=tmp_path)
    assert bad.returncode != 0 and "expected 0 < LO < HI < 1" in bad.stderr
    assert len(bad.stderr.strip().splitlines()) == 1 and not (tmp_path / "p").exists()


@pytest.mark.parametrize("n, words", [(1, "only 1 sample;"), (2, "only 2 samples;")])
def test_a_record_too_short_to_fit_says_how_many_samples_it_has(tmp_path, n, words):
    """A file of one or two rows is refused with its count, in the singular for one."""
    from vojax._data._records import load_records

    _springpot_csv(tmp_path / "short.csv", n=n)
    with pytest.raises(ValueError, match=f"{words} at least 3 are needed"):
        load_records(tmp_path / "short.csv", time="time_s", inputs=["stress"], output="strain")
