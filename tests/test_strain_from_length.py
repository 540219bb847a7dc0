"""A strain from a recorded length, ``ε = (L − L₀)/L₀`` (`load_records(strain_from_length=L₀)`,
``--strain-from-length``): the subtraction ``--length`` cannot do, the same from Python and
the command line."""

import csv
import json

import numpy as np
import pytest

import vojax
from vojax._data import DataError, load_records

from .test_offset import DT, _cli, _creep

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
    proc = _cli(*common, "--strain-from-length", str(L0), "--out", "o", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    summary = json.loads((tmp_path / "o" / "summary.json").read_text())
    assert summary["provenance"]["settings"]["strain_from_length"] == L0
    assert summary["output_column"] == "strain"
    with open(tmp_path / "o" / "identification.csv") as f:
        alpha = np.array([float(r["alpha"]) for r in csv.DictReader(f)])
    ref = vojax.identify(u, (length - L0) / L0, DT, parameters="constant", warn=False)
    np.testing.assert_allclose(alpha, np.asarray(ref.alpha), rtol=0, atol=1e-9)
    bad = _cli(*common, "--strain-from-length", str(L0), "--length", str(L0), "--out", "p",
               cwd=tmp_path)
    assert bad.returncode == 1 and len(bad.stderr.strip().splitlines()) == 1
    assert "--strain-from-length already gives a strain; leave out --length" in bad.stderr
    assert not (tmp_path / "p").exists()
    batch = _cli("batch", *common[1:], "--strain-from-length", str(L0), "--length", "2",
                 "--out", "p", cwd=tmp_path)
    assert batch.returncode == 1 and "leave out --length" in batch.stderr
    assert not (tmp_path / "p").exists()  # refused before the batch makes its folder
    zero = _cli(*common, "--strain-from-length", "0", "--out", "p", cwd=tmp_path)
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
