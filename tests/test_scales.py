"""The signals a file's columns stand for: a strain from a recorded length, ``ε = (L − L₀)/L₀``
(`load_records(strain_from_length=L₀)`, ``--strain-from-length``: the subtraction ``--length``
cannot do), and a strain and a stress from a length and an area given per record in columns
(``length_column=``, ``area_column=``; ``--length-column``, ``--area-column``), the same from
Python and the command line."""

import csv
import json

import numpy as np
import pytest

import vojax
from vojax._data import DataError, load_records

from .helpers import run_cli
from .test_offset import DT, N, _creep

L0 = 12.5  # mm, the specimen's rest length


def _length_csv(path):
    t, u, strain, _ = _creep(seed=5)
    length = L0 * (1.0 + strain)  # a specimen stretched from its rest length
    with open(path, "w") as f:
        f.write("time_s,stress_kPa,length_mm\n" + "".join(
            f"{a!r},{b!r},{c!r}\n" for a, b, c in zip(t.tolist(), u.tolist(), length.tolist())))
    return t, u, length


def test_the_output_is_the_strain_of_the_length_over_its_rest_length(tmp_path):
    """The output is ``(L − L₀)/L₀`` of the file's column (to rounding), named ``strain``
    with unit 1 (the figures' label); the inputs and the clock are as without it."""
    t, u, length = _length_csv(tmp_path / "l.csv")
    kw = dict(time="time_s", inputs=["stress_kPa"], output="length_mm")
    (plain,) = load_records(tmp_path / "l.csv", **kw)
    (rec,) = load_records(tmp_path / "l.csv", **kw, strain_from_length=L0)
    np.testing.assert_array_equal(rec.output, (plain.output - L0) / L0)
    np.testing.assert_array_equal(rec.inputs, plain.inputs)
    np.testing.assert_array_equal(rec.time, plain.time)
    assert rec.output_name == "strain" and dict(rec.units)["strain"] == "1"
    for bad, said in ((0.0, "`strain_from_length` must be a positive finite length"),
                      (-1.0, "`strain_from_length` must be a positive finite length"),
                      (np.nan, "`strain_from_length` must be a positive finite length"),
                      ("12", "`strain_from_length` must be a number")):
        with pytest.raises((ValueError, TypeError), match=said):
            load_records(tmp_path / "l.csv", **kw, strain_from_length=bad)


def test_the_command_identifies_the_strain_of_a_length_column(tmp_path):
    """``vojax identify --strain-from-length L0`` on the length column gives the order
    `vojax.identify` gives on ``(L − L₀)/L₀`` (to 1e-9), and the provenance keeps L₀;
    beside ``--length`` (which would divide the strain again) it is refused in one line,
    before anything is written."""
    t, u, length = _length_csv(tmp_path / "l.csv")
    common = ("identify", "l.csv", "--time", "time_s", "--input", "stress_kPa", "--output",
              "length_mm", "--parameters", "constant")
    proc = run_cli(*common, "--strain-from-length", str(L0), "--out", "o", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    summary = json.loads((tmp_path / "o" / "summary.json").read_text())
    assert summary["provenance"]["settings"]["strain_from_length"] == L0
    assert summary["output_column"] == "strain"
    with open(tmp_path / "o" / "identification.csv") as f:
        alpha = np.array([float(r["alpha"]) for r in csv.DictReader(f)])
    ref = vojax.identify(u, (length - L0) / L0, DT, parameters="constant", warn=False)
    np.testing.assert_allclose(alpha, np.asarray(ref.alpha), rtol=0, atol=1e-9)
    bad = run_cli(*common, "--strain-from-length", str(L0), "--length", str(L0), "--out", "p",
                  cwd=tmp_path)
    assert bad.returncode == 1 and len(bad.stderr.strip().splitlines()) == 1
    assert "--strain-from-length already gives a strain; leave out --length" in bad.stderr
    assert not (tmp_path / "p").exists()
    batch = run_cli("batch", *common[1:], "--strain-from-length", str(L0), "--length", "2",
                    "--out", "p", cwd=tmp_path)
    assert batch.returncode == 1 and "leave out --length" in batch.stderr
    assert not (tmp_path / "p").exists()  # refused before the batch makes its folder
    zero = run_cli(*common, "--strain-from-length", "0", "--out", "p", cwd=tmp_path)
    assert zero.returncode != 0 and "--strain-from-length" in zero.stderr
    assert not (tmp_path / "p").exists()


def test_a_record_that_is_not_a_length_is_refused_not_divided_by_zero(tmp_path):
    """The output's column must be a length: one that reaches 0 or below is refused."""
    with open(tmp_path / "bad.csv", "w") as f:
        f.write("time_s,stress_kPa,length_mm\n" + "".join(
            f"{0.1 * k!r},1.0,{1.0 - 0.2 * k!r}\n" for k in range(10)))
    with pytest.raises(DataError, match="length_mm reaches -0.8 at"):
        load_records(tmp_path / "bad.csv", time="time_s", inputs=["stress_kPa"],
                     output="length_mm", strain_from_length=1.0)


SPECIMENS = (("A", 10.0, 2.0, 1.0), ("B", 12.5, 3.0, 1.3))  # name, gap, area, load factor


def _gaps_csv(path):
    """Two specimens in long format, each with its own tool gap (which shrinks by the
    displacement as the tool moves in, as a testing machine records it) and area."""
    t, u, strain, _ = (np.asarray(a).tolist() for a in _creep(seed=6))
    with open(path, "w") as f:
        f.write("specimen,time_s,force_N,displacement_mm,gap_mm,area_mm2\n")
        for name, gap, area, load in SPECIMENS:
            for k in range(N):
                g = gap - (load * gap * strain[k] if k else 0.0)  # the initial gap exact
                f.write(f"{name},{t[k]!r},{load * area * u[k]!r},{load * gap * strain[k]!r},"
                        f"{g!r},{area!r}\n")


def test_a_length_and_an_area_per_record_from_columns(tmp_path):
    """Each record's output is its displacement over its own initial gap (the column's value
    at its first sample, not the shrinking gap of each sample) and its input its force over
    its own area (exactly as divided here), named ``strain`` and ``stress``; a zero area, a
    column in two roles, an area with two inputs and two ways of making the strain are
    refused, each in one sentence."""
    _gaps_csv(tmp_path / "g.csv")
    kw = dict(time="time_s", inputs=["force_N"], output="displacement_mm", group_by="specimen")
    plain = {r.name: r for r in load_records(tmp_path / "g.csv", **kw)}
    scaled = {r.name: r for r in load_records(tmp_path / "g.csv", **kw, length_column="gap_mm",
                                              area_column="area_mm2")}
    for name, gap, area, _ in SPECIMENS:
        np.testing.assert_array_equal(scaled[name].output, plain[name].output / gap)
        np.testing.assert_array_equal(scaled[name].inputs, plain[name].inputs / area)
        assert scaled[name].input_names == ("stress",) and scaled[name].output_name == "strain"
    for extra, error, said in (
        (dict(length_column="displacement_mm"), ValueError, "is already the time, the output"),
        (dict(length_column="gap_mm", area_column="gap_mm"), ValueError, "both the length and"),
        (dict(length_column="gap_mm", strain_from_length=1.0), ValueError, "give one"),
        (dict(length_column=3), TypeError, "`length_column` must name a column"),
        (dict(area_column="area_mm2", inputs=["force_N", "gap_mm"]), ValueError,
         "`area_column` divides the one input"),
        (dict(length_column="nope"), DataError, "nope"),
    ):
        with pytest.raises(error, match=said):
            load_records(tmp_path / "g.csv", **{**kw, **extra})
    with open(tmp_path / "zero.csv", "w") as f:
        f.write("time_s,force_N,displacement_mm,area_mm2\n" + "".join(
            f"{0.1 * k!r},{1.0 + k!r},{0.01 * k!r},0.0\n" for k in range(10)))
    with pytest.raises(DataError, match="area_mm2 is 0 at its first sample; a length or an area"):
        load_records(tmp_path / "zero.csv", time="time_s", inputs=["force_N"],
                     output="displacement_mm", area_column="area_mm2")


def test_the_batch_takes_each_specimens_gap_and_area_from_its_columns(tmp_path):
    """``vojax batch --length-column --area-column`` on the long file gives each record the
    refit of a file where the stress and the strain were divided by hand (the same order to
    the last bit); beside ``--length`` or ``--area`` it is refused before anything is
    written."""
    _gaps_csv(tmp_path / "g.csv")
    kw = dict(time="time_s", inputs=["force_N"], output="displacement_mm", group_by="specimen")
    with open(tmp_path / "by_hand.csv", "w") as f:
        f.write("specimen,time_s,stress,strain\n")
        for r in load_records(tmp_path / "g.csv", **kw):
            gap, area = next((g, a) for n, g, a, _ in SPECIMENS if n == r.name)
            f.write("".join(f"{r.name},{t!r},{s / area!r},{e / gap!r}\n" for t, s, e in
                            zip(r.time.tolist(), r.inputs[:, 0].tolist(), r.output.tolist())))
    common = ("--time", "time_s", "--group-by", "specimen", "--method", "refit", "--figures",
              "overview", "--quiet")
    done = run_cli("batch", "g.csv", *common, "--input", "force_N", "--output", "displacement_mm",
                   "--length-column", "gap_mm", "--area-column", "area_mm2", "--out", "o",
                   cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    hand = run_cli("batch", "by_hand.csv", *common, "--input", "stress", "--output", "strain",
                   "--out", "h", cwd=tmp_path)
    assert hand.returncode == 0, hand.stderr
    from vojax._data._paths import record_folder

    for name, *_ in SPECIMENS:
        a = json.loads((tmp_path / "o" / record_folder(name) / "summary.json").read_text())["refit"]
        b = json.loads((tmp_path / "h" / record_folder(name) / "summary.json").read_text())["refit"]
        assert a["order"] == b["order"] and a["p"] == b["p"], (a, b)
    for extra, said in ((("--length", "2"), "--length-column already gives each record's length"),
                        (("--area", "2"), "--area-column already gives each record's area")):
        bad = run_cli("batch", "g.csv", *common, "--input", "force_N", "--output",
                      "displacement_mm", "--length-column", "gap_mm", "--area-column", "area_mm2",
                      *extra, "--out", "p", cwd=tmp_path)
        assert bad.returncode == 1 and said in bad.stderr, bad.stderr
        assert not (tmp_path / "p").exists()
