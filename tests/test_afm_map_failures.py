"""A force map whose curve cannot be analysed: that curve fails alone, with its reason, and the
map's other curves are read exactly as they are from a map without it (in Python, in the
error's `records`; in the batch, as records, the failed curve in failures.csv)."""

import csv
import dataclasses

import afmformats
import h5py
import numpy as np
import pytest

from vojax._data import DataError, load_records
from vojax.io import CurvesFailed

from .helpers import run_cli
from .test_afm_contact import TIPS, _curve

OPTIONS = dict(time="time_s", inputs=["force_rise_N"], output="contact_strain",
               tip=("sphere", 5e-6), segments=[1], units={"force_rise_N": "N"})
FLAT = "a flat curve: no contact, so nanite's Hertz fit does not converge"


def _write_map(path, kinds):
    """An afmformats HDF5 map of synthetic Hertz curves on a 2-wide grid; a ``"flat"`` kind
    is the baseline and noise alone (the tip never touches)."""
    with h5py.File(path, "w") as h5:
        for k, kind in enumerate(kinds):
            curve, z_tip = _curve(TIPS["sphere"], seed=k)
            data = {c: np.array(curve[c]) for c in curve.columns if c != "index"}
            if kind == "flat":
                data["force"] = 3e-11 + np.random.default_rng(9).normal(0, 2e-12, z_tip.size)
                data["height (measured)"] = data["height (piezo)"] = z_tip - data["force"] / 0.05
            meta = dict(curve.metadata, **{"grid index x": k % 2, "grid index y": k // 2,
                                           "grid shape x": 2, "grid shape y": 2, "enum": k})
            afmformats.AFMForceDistance(data, meta, diskcache=False).export_data(h5, fmt="hdf5")


def _same(a, b):
    for field in dataclasses.fields(a):
        x, y = getattr(a, field.name), getattr(b, field.name)
        if isinstance(x, np.ndarray):
            np.testing.assert_array_equal(x, y)
        elif field.name not in ("name", "source"):
            assert x == y, field.name


def test_a_curve_that_cannot_be_analysed_fails_alone(tmp_path):
    _write_map(tmp_path / "map.h5", ["hertz", "hertz", "flat", "hertz"])
    _write_map(tmp_path / "good.h5", ["hertz", "hertz", "hertz", "hertz"])
    with pytest.raises(CurvesFailed) as raised:
        load_records(tmp_path / "map.h5", **OPTIONS)
    e = raised.value
    assert isinstance(e, DataError) and "\n" not in str(e)
    assert str(e).startswith(f"{tmp_path / 'map.h5'}: 1 of its 4 curves could not be read")
    assert [r.name for r in e.records] == ["map-0", "map-1", "map-3"]
    assert [name for name, _ in e.failures] == ["map-2"]
    assert "curve 2: nanite's Hertz fit did not converge" in e.failures[0][1]
    # the others as read from a map of good curves alone: data, units, modulus and grid
    good = load_records(tmp_path / "good.h5", **OPTIONS)
    for record, want in zip(e.records, [good[0], good[1], good[3]]):
        _same(record, want)
        assert record.units == (("force_rise_N", "N"),)
    with pytest.raises(DataError, match=r"none of its 2 curves could be read; the first's "
                                        r"reason: .*curve 0: nanite's Hertz fit did not"):
        _write_map(tmp_path / "flat.h5", ["flat", "flat"])
        load_records(tmp_path / "flat.h5", **OPTIONS)


def test_the_batch_keeps_a_maps_other_curves_and_lists_the_failed_one(tmp_path):
    folder = tmp_path / "in"
    folder.mkdir()
    _write_map(folder / "map.h5", ["hertz", "flat", "hertz", "hertz"])
    done = run_cli("batch", "in", "--time", "time_s", "--input", "force_rise_N", "--output",
                   "contact_strain", "--tip", "sphere:5e-6", "--segments", "1", "--method",
                   "refit", "--quiet", "--out", "out", cwd=tmp_path)
    assert done.returncode == 2, done.stderr
    with open(tmp_path / "out" / "summary.csv", newline="") as f:
        rows = {r["record"]: r for r in csv.DictReader(f)}
    assert sorted(rows) == ["map-0", "map-2", "map-3"]
    assert {(rows[n]["afm_grid_index_x"], rows[n]["afm_grid_index_y"]) for n in rows} == {
        ("0", "0"), ("0", "1"), ("1", "1")}
    with open(tmp_path / "out" / "failures.csv", newline="") as f:
        (failed,) = list(csv.DictReader(f))
    assert failed["record"] == "map-1" and "curve 1: nanite's Hertz fit" in failed["reason"]
    assert (tmp_path / "out" / "maps.png").stat().st_size > 0


def test_identify_picks_a_maps_curve_and_says_which_others_failed(tmp_path):
    _write_map(tmp_path / "map.h5", ["hertz", "flat"])
    done = run_cli("identify", "map.h5", "--record", "map-0", "--time", "time_s", "--input",
                   "force_rise_N", "--output", "contact_strain", "--tip", "sphere:5e-6",
                   "--segments", "1", "--method", "refit", "--out", "out", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    warned = [line for line in done.stderr.splitlines()
              if line.startswith("vojax: warning: map.h5, curve")]
    assert len(warned) == 1 and "curve 1: nanite's Hertz fit did not converge" in warned[0]
    assert (tmp_path / "out" / "summary.json").is_file()


def test_a_csv_export_of_several_curves_keeps_the_curves_that_can_be_read(tmp_path):
    """A long-format export (one curve per value of its `curve` column) whose second curve
    is flat: the first is read as from an export of it alone."""
    lines = {}
    for name, kind in (("a", "hertz"), ("b", "flat")):
        curve, z_tip = _curve(TIPS["sphere"], seed=1)
        force = np.array(curve["force"])
        if kind == "flat":
            force = 3e-11 + np.random.default_rng(9).normal(0, 2e-12, z_tip.size)
        h = z_tip - force / 0.05
        lines[name] = [f"{name},{float(t)!r},{float(s)!r},{float(f)!r},{float(z)!r}" for t, s, f, z in
                       zip(curve["time"], curve["segment"], force, h)]
    head = "curve,time_s,segment,force_N,height_measured_m"
    (tmp_path / "both.csv").write_text("\n".join([head, *lines["a"], *lines["b"]]) + "\n")
    (tmp_path / "a.csv").write_text("\n".join([head, *lines["a"]]) + "\n")
    options = dict(OPTIONS, group_by="curve", spring_constant=0.05)
    with pytest.raises(CurvesFailed) as raised:
        load_records(tmp_path / "both.csv", **options)
    (record,), ((name, reason),) = raised.value.records, raised.value.failures
    assert name == "b" and "nanite's Hertz fit did not converge" in reason
    (alone,) = load_records(tmp_path / "a.csv", **options)
    _same(record, alone)
