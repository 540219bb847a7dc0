"""Recorded datasets in: the loader (groups, trimming, resampling, units, columns and their
roles), and hostile files and cells, each failing alone with one sentence."""

import csv
import json
import re
from pathlib import Path

import numpy as np
import pytest

import vojax
from vojax._data import DataError, load_records

from .helpers import run_cli

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
    proc = run_cli(
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
    proc = run_cli(
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
    proc = run_cli("identify", "euro.csv", "--time", "time_s", "--input", "stress", "--output",
                   "strain", "--delimiter", ";", "--decimal-comma", "--method", "refit",
                   "--out", "o", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    summary = json.loads((tmp_path / "o" / "summary.json").read_text())
    assert abs(summary["refit"]["order"] - 0.35) < 1e-6


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
        done = run_cli("identify", "r.csv", "--time", "time_s", *args, "--out", "o", cwd=tmp_path)
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
        done = run_cli("identify", args[0], *base, *args[1:], "--out", "o", cwd=tmp_path)
        lines = done.stderr.strip().splitlines()
        assert done.returncode == 1 and len(lines) == 1 and words in lines[0], done.stderr
    with pytest.raises(ValueError, match="input 1 of `u` is 0 at every sample"):
        vojax.refit(0 * stress, strain, DT)
    with pytest.raises(ValueError, match="input 2 of `u` is 0 at every sample"):
        vojax.identify(np.c_[stress, 0 * stress], strain, DT, warn=False)


@pytest.mark.parametrize("n, words", [(1, "only 1 sample;"), (2, "only 2 samples;")])
def test_a_record_too_short_to_fit_says_how_many_samples_it_has(tmp_path, n, words):
    """A file of one or two rows is refused with its count, in the singular for one."""
    from vojax._data._records import load_records

    _springpot_csv(tmp_path / "short.csv", n=n)
    with pytest.raises(ValueError, match=f"{words} at least 3 are needed"):
        load_records(tmp_path / "short.csv", time="time_s", inputs=["stress"], output="strain")
