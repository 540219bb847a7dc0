"""The AFM contact point and Young's modulus through nanite: a synthetic Hertz curve whose
modulus, contact point and baseline are known, the contact strains against nanite's own
model functions, nanite's contact estimators wired to the right samples, and the modulus in
the command's summary, table and line."""

import csv
import json
import math
import sys
from pathlib import Path

# nanite and afmformats are in the test extra: a missing install fails here, loudly
import afmformats
import nanite
import numpy as np
import pytest

from vojax._data import DataError, _afm, _contact, load_records

RAW = Path(__file__).parent / "data" / "afm" / "brain_creep.jpk-force"
K, E, NU, ZC, BASE, NOISE = 0.05, 2000.0, 0.4, 1e-6, 3e-11, 2e-12
TIPS = {"sphere": ("sphere", 5e-6), "cone": ("cone", 20.0), "pyramid": ("pyramid", 35.0)}


def _hertz_force(tip, delta, e=E, nu=NU):
    """Hertz's force for an indentation `delta` (m), written out by hand (Bilodeau's
    three-sided pyramid with nanite's coefficient 0.8887)."""
    shape, size = tip
    d = np.clip(delta, 0, None)
    if shape == "sphere":
        return 4 / 3 * e / (1 - nu**2) * math.sqrt(size) * d**1.5
    if shape == "cone":
        return 2 / math.pi * e / (1 - nu**2) * math.tan(math.radians(size)) * d**2
    return 0.8887 * e / (1 - nu**2) * math.tan(math.radians(size)) * d**2


def _curve(tip, seed=0, pause=400, loading=1600):
    """A force curve: a pause (segment 0) then a loading (segment 1) in which the tip moves
    from 3 µm above the surface at ``ZC`` to 1 µm below it; the force is Hertz's plus a
    baseline and white noise, and the cantilever height is the tip position less F/k."""
    t = np.arange(pause + loading) * 1e-3
    segment = np.r_[np.zeros(pause), np.ones(loading)]
    z_tip = np.r_[np.full(pause, 3e-6), np.linspace(3e-6, -1e-6, loading)]
    rng = np.random.default_rng(seed)
    force = _hertz_force(tip, ZC - z_tip) + BASE + rng.normal(0, NOISE, t.size)
    h = z_tip - force / K
    data = {"time": t, "segment": segment, "force": force, "height (measured)": h,
            "height (piezo)": h}
    meta = {"spring constant": K, "imaging mode": "force-distance", "path": "synthetic",
            "enum": 0}
    return afmformats.AFMForceDistance(data, meta), z_tip


@pytest.mark.parametrize("shape", list(TIPS))
def test_the_hertz_fit_recovers_the_modulus_the_contact_and_the_strain(shape):
    """nanite's fit through vojax: E within 4 standard errors of the truth (the error below
    1 % of E), the contact at the first sample at or below the surface (±1 sample), the
    loading found after the pause, and G·x (G = E/(2(1 + ν)), x the contact strain) equal to
    the force rise to the noise: the strain and the modulus share their units."""
    tip = TIPS[shape]
    curve, z_tip = _curve(tip)
    rise, delta, c, block = _contact.analyse(curve, "synthetic", tip, NU, "fit")
    assert block["fit_success"] and block["segment_fitted"] == 1
    e, se = block["youngs_modulus_Pa"], block["youngs_modulus_stderr_Pa"]
    assert abs(e - E) < 4 * se < 0.01 * E
    truth = int(np.flatnonzero(z_tip <= ZC)[0])
    assert abs(c - truth) <= 1
    # the indentation is the truth's to the contact point's error (a few nm of 1 µm)
    assert np.max(np.abs(delta - (ZC - z_tip))) < 0.01 * 1e-6
    g = E / (2 * (1 + NU))
    x = _afm.contact_strain(delta, tip, NU)
    after = slice(c + 10, None)
    rms = np.sqrt(np.mean((g * x[after] - rise[after]) ** 2))
    assert rms < 1.5 * NOISE


@pytest.mark.parametrize("shape, key", [("sphere", "hertz_para"), ("cone", "hertz_cone"),
                                        ("pyramid", "hertz_pyr3s")])
def test_contact_strain_times_g_is_nanites_model_force(shape, key):
    """nanite's own model function (its tip position below the contact point is the
    indentation) with E = 2G(1 + ν) is G times vojax's contact strain, for ν = 0.5 and 0.3."""
    tip = TIPS[shape]
    delta = np.linspace(-2e-7, 1e-6, 101)
    model = nanite.model.models_available[key]
    g = 1234.0
    for nu in (0.5, 0.3):
        force = model.module.model_func(-delta, 2 * g * (1 + nu), tip[1], nu, contact_point=0.0,
                                 baseline=0.0)
        np.testing.assert_allclose(g * _afm.contact_strain(delta, tip, nu), force,
                                   rtol=1e-12, atol=0)


@pytest.mark.parametrize("method", _contact.POC_METHODS)
def test_a_named_estimator_is_nanites_on_the_loading(method):
    """Without a tip, the contact is nanite's estimator run on the loading segment (through
    nanite's own dispatcher here), offset to the curve's samples; the force rise is taken
    from the mean force of the loading before it, and the indentation is 0 there."""
    curve, _ = _curve(TIPS["sphere"], seed=1)
    rise, delta, c, block = _contact.analyse(curve, "synthetic", None, NU, method)
    idnt = nanite.Indentation({k: curve[k] for k in curve.columns}, curve.metadata)
    idnt.apply_preprocessing(_contact.PREPROCESSING)
    force = np.asarray(idnt["force"])
    start = 400
    assert c == start + int(nanite.poc.compute_poc(force[start:], method=method))
    np.testing.assert_allclose(rise, force - force[start : c + 1].mean(), rtol=0, atol=1e-20)
    assert delta[c] == 0.0 and block["contact_method"] == method
    assert "youngs_modulus_Pa" not in block
    # with a tip, the modulus is the fit's, whose own contact point is kept beside
    _, _, c2, both = _contact.analyse(curve, "synthetic", TIPS["sphere"], NU, method)
    fitted, *_ = _contact.analyse(curve, "synthetic", TIPS["sphere"], NU, "fit")[3:]
    assert c2 == c and both["contact_point_m"] == block["contact_point_m"]
    assert both["fit_contact_point_m"] == fitted["contact_point_m"]
    assert both["youngs_modulus_Pa"] == fitted["youngs_modulus_Pa"]


def test_contact_options_are_checked():
    with pytest.raises(ValueError, match="'fit' fits a Hertz contact and needs a tip"):
        _contact.check_contact("fit", None)
    with pytest.raises(ValueError, match="the contact method must be one of fit, deviation"):
        _contact.check_contact("threshold", None)
    assert _contact.check_contact(None, None) == "deviation_from_baseline"
    assert _contact.check_contact(None, ("cone", 20.0)) == "fit"
    with pytest.raises(TypeError, match="`from_contact` must be True or False, got 'yes'"):
        load_records(RAW, time="time_s", inputs=["force_N"], output="indentation_m",
                     from_contact="yes")
    for bad in ("0", [0.5], [True], 3):
        with pytest.raises(TypeError, match="`segments` must be a list of segment numbers"):
            load_records(RAW, time="time_s", inputs=["force_N"], output="indentation_m",
                         segments=bad)
    rec, = load_records(RAW, time="time_s", inputs=["force_N"], output="indentation_m",
                        segments=(k for k in (0, 1)))  # any iterable of numbers, once
    assert rec.output.size > 3000
    with pytest.raises(ValueError, match="a pyramid's face angle must lie in"):
        _afm.check_tip("pyramid:95")
    with pytest.raises(ValueError, match="the tip must be a sphere, a cone or a pyramid"):
        _afm.check_tip(("cube", 1.0))


def test_a_flat_curve_and_a_missing_nanite_fail_in_one_line(monkeypatch):
    curve, _ = _curve(TIPS["sphere"])
    flat = afmformats.AFMForceDistance(
        {k: (np.full(curve["force"].size, 1e-9) if k == "force" else curve[k])
         for k in curve.columns}, {"spring constant": K, "path": "flat", "enum": 0})
    with pytest.raises(DataError, match="flat: the force is constant"):
        _contact.analyse(flat, "flat", None, NU, "deviation_from_baseline")
    monkeypatch.setitem(sys.modules, "nanite", None)  # as if not installed
    with pytest.raises(DataError, match=r'found with nanite: pip install "vojax\[afm\]"'):
        load_records(RAW, time="time_s", inputs=["force_rise_N"], output="indentation_m")
    # the file's own columns need no contact, hence no nanite
    rec, = load_records(RAW, time="time_s", inputs=["force_N"], output="height_measured_m",
                        from_contact=False)
    assert "youngs_modulus_Pa" not in dict(rec.afm) and "contact_index" not in dict(rec.afm)


def test_the_modulus_reaches_the_summary_the_table_and_the_line(tmp_path):
    """`vojax identify` and `vojax batch` with --tip: the summary's ``afm`` block holds the
    modulus of nanite's fit done here directly on the same curve (same R, ν, segment), the
    batch's summary.csv has it as a column, the line prints it, and --contact on a CSV is
    refused."""
    from .helpers import run_cli

    curve = afmformats.load_data(RAW)[0]
    idnt = nanite.Indentation({k: curve[k] for k in curve.columns}, curve.metadata)
    idnt.apply_preprocessing(["compute_tip_position", "correct_force_offset",
                              "correct_tip_offset"])
    params = idnt.get_initial_fit_parameters(model_key="hertz_para")
    params["R"].set(value=5e-6)
    idnt.fit_model(model_key="hertz_para", params_initial=params, segment=0,
                   x_axis="tip position", y_axis="force")
    e = idnt.fit_properties["params_fitted"]["E"].value
    base = ["--time", "time_s", "--input", "force_rise_N", "--output", "contact_strain",
            "--tip", "sphere:5e-6", "--segments", "0,1", "--model", "springpot",
            "--method", "refit"]
    done = run_cli("identify", str(RAW), *base, "--out", "one", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    afm = json.loads((tmp_path / "one" / "summary.json").read_text())["afm"]
    assert afm["youngs_modulus_Pa"] == pytest.approx(e, rel=1e-9)
    assert afm["model"] == "hertz_para" and afm["contact_method"] == "fit"
    assert f"E = {e:.4g} ±" in done.stdout
    folder = tmp_path / "in"
    folder.mkdir()
    (folder / "a.jpk-force").write_bytes(RAW.read_bytes())
    done = run_cli("batch", "in", *base, "--quiet", "--out", "out", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    with open(tmp_path / "out" / "summary.csv", newline="") as f:
        row, = list(csv.DictReader(f))
    assert float(row["afm_youngs_modulus_Pa"]) == pytest.approx(e, rel=1e-9)
    assert float(row["afm_contact_time"]) == pytest.approx(afm["contact_time"])
    (tmp_path / "a.csv").write_text("t,u,y\n0,1,2\n1,1,2\n2,1,2\n")
    done = run_cli("identify", "a.csv", "--time", "t", "--input", "u", "--output", "y",
                   "--contact", "gradient_zero_crossing", "--out", "c", cwd=tmp_path)
    assert done.returncode != 0 and "the AFM options are for AFM files and CSV" in done.stderr


SHARED = Path(__file__).resolve().parents[2] / "shared" / "data" / "afm-brain-gel-creep"


def test_a_csv_export_is_read_as_its_raw_file(tmp_path):
    """The brain curve's CSV export (afmformats, 10 significant digits) with its spring
    constant: the same contact sample, modulus and contact strain as the raw JPK file (to the
    export's digits), and as two curves of a long-format file with a curve column; the
    export's own refusals in one line."""
    export = SHARED / "afm_brain_creep.csv"
    if not export.is_file():
        pytest.skip(f"{export} is not here")
    kw = dict(time="time_s", inputs=["force_rise_N"], output="contact_strain",
              tip=("sphere", 5e-6), segments=[0, 1])
    raw, = load_records(RAW, **kw)
    csv_rec, = load_records(export, spring_constant=0.061, **kw)
    a, b = dict(raw.afm), dict(csv_rec.afm)
    assert a["contact_index"] == b["contact_index"]
    assert b["youngs_modulus_Pa"] == pytest.approx(a["youngs_modulus_Pa"], rel=1e-6)
    np.testing.assert_allclose(csv_rec.output, raw.output, rtol=0,
                               atol=1e-6 * np.ptp(raw.output))
    np.testing.assert_allclose(csv_rec.inputs, raw.inputs, rtol=0,
                               atol=1e-6 * np.ptp(raw.inputs))
    # a long-format file: the same curve twice, the second with its force doubled
    lines = [line for line in export.read_text().splitlines() if not line.startswith("#")]
    head, body = lines[0], lines[1:]
    doubled = []
    for line in body:
        cells = line.split(",")
        cells[2] = repr(2 * float(cells[2]))
        doubled.append(",".join(cells))
    long = tmp_path / "long.csv"
    long.write_text("\n".join([f"curve,{head}"] + [f"a,{x}" for x in body]
                              + [f"b,{x}" for x in doubled]) + "\n")
    first, second = load_records(long, group_by="curve", spring_constant=0.061, **kw)
    assert (first.name, second.name) == ("a", "b")
    assert dict(first.afm)["youngs_modulus_Pa"] == pytest.approx(a["youngs_modulus_Pa"],
                                                                 rel=1e-6)
    assert dict(second.afm)["youngs_modulus_Pa"] > 1.5 * a["youngs_modulus_Pa"]
    with pytest.raises(DataError, match="needs its cantilever's spring constant"):
        load_records(export, **kw)
    with pytest.raises(ValueError, match="the spring constant is in N/m, from 1e-06"):
        load_records(export, spring_constant=61.0e9, **kw)
    with pytest.raises(DataError, match="an AFM file gives its own spring constant"):
        load_records(RAW, spring_constant=0.061, **kw)
    bare = tmp_path / "bare.csv"
    bare.write_text("time_s,force_N,height_measured_m\n0,0,1\n1,1,0\n2,2,-1\n")
    with pytest.raises(DataError, match="have the columns time_s, segment, force_N .*'segment'"):
        load_records(bare, spring_constant=0.061, **kw)


QI = Path(__file__).parent / "data" / "afm" / "qi_map.jpk-qi-data"


def test_a_force_map_gives_a_record_per_curve_and_maps_over_its_grid(tmp_path):
    """The four curves of a QI map: one row each in summary.csv with the grid indices and
    positions of afmformats' metadata, and maps.png whose images hold each curve's modulus
    and refit order at its grid index (NaN elsewhere)."""
    from vojax._plotting_maps import map_figure

    from .helpers import run_cli

    curves = afmformats.load_data(QI)
    want = {f"qi_map-{k}": (c.metadata["grid index x"], c.metadata["grid index y"],
                            c.metadata["position x"]) for k, c in enumerate(curves)}
    folder = tmp_path / "in"
    folder.mkdir()
    (folder / QI.name).write_bytes(QI.read_bytes())
    done = run_cli("batch", "in", "--time", "time_s", "--input", "force_rise_N", "--output",
                   "contact_strain", "--tip", "sphere:5e-6", "--segments", "0", "--model",
                   "springpot", "--method", "refit", "--quiet", "--out", "out", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert (tmp_path / "out" / "maps.png").stat().st_size > 0
    with open(tmp_path / "out" / "summary.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert sorted(r["record"] for r in rows) == sorted(want)
    for r in rows:
        gx, gy, px = want[r["record"]]
        assert (int(r["afm_grid_index_x"]), int(r["afm_grid_index_y"])) == (gx, gy)
        assert float(r["afm_position_x_m"]) == pytest.approx(px, rel=1e-12)
        assert int(r["afm_grid_shape_x"]) == 128
    drawn = map_figure(rows, tmp_path / "again.png")  # the rows as read back: text cells
    images = {title: (image, origin) for _, title, image, origin in drawn}
    for key, title in (("afm_youngs_modulus_Pa", "Young's modulus E (Pa)"),
                       ("refit_order", "refit order q")):
        image, (x0, y0) = images[title]
        assert image.shape == (1, 4) and (x0, y0) == (0, 0)
        for r in rows:
            gx, gy = int(r["afm_grid_index_x"]), int(r["afm_grid_index_y"])
            assert image[gy - y0, gx - x0] == pytest.approx(float(r[key]), rel=1e-12)
    # a sparse map: NaN where no curve was measured, and a file without grid draws nothing
    sparse = [dict(rows[0], afm_grid_index_x="5", afm_grid_index_y="3"),
              dict(rows[1], afm_grid_index_x="7", afm_grid_index_y="4")]
    (_, _, image, origin), *_ = map_figure(sparse, tmp_path / "sparse.png")
    assert origin == (5, 3) and image.shape == (2, 3)
    assert np.isnan(image).sum() == 4 and np.isfinite(image[1, 2])
    assert map_figure([{"source": "a.csv", "record": "a"}], tmp_path / "none.png") == []
    assert not (tmp_path / "none.png").exists()


def _tilted_curve(tip, tilt=1.5e-9):
    """`_curve` with a force baseline that rises by `tilt` (N) linearly with the tip's travel
    over the whole approach (an optical lever's virtual deflection), the measured height
    consistent with the measured force."""
    curve, z_tip = _curve(tip)
    data = {k: np.asarray(curve[k], float) for k in curve.columns}
    data["force"] = data["force"] + tilt * (z_tip[0] - z_tip) / (z_tip[0] - z_tip[-1])
    data["height (measured)"] = data["height (piezo)"] = z_tip - data["force"] / K
    return afmformats.AFMForceDistance(data, curve.metadata), z_tip


def test_a_tilted_baseline_is_corrected_with_baseline_tilt():
    """A baseline sloping with the tip position moves the contact point by tens of samples
    and the modulus by several standard errors where only its offset is corrected; with
    ``baseline="tilt"`` (nanite's slope correction) the contact is the truth's to a sample
    and E is within 4 standard errors of the truth, as on an untilted curve."""
    tip = TIPS["sphere"]
    curve, z_tip = _tilted_curve(tip)
    truth = int(np.flatnonzero(z_tip <= ZC)[0])
    plain_rise, _, c, plain = _contact.analyse(curve, "tilted", tip, NU, "fit", "offset")
    assert abs(c - truth) > 20 and abs(plain["youngs_modulus_Pa"] - E) > 3 * plain[
        "youngs_modulus_stderr_Pa"]
    hertz = _hertz_force(tip, ZC - z_tip)
    late = slice(truth + 10, None)
    plain_error = np.sqrt(np.mean((plain_rise[late] - hertz[late]) ** 2))
    curve, _ = _tilted_curve(tip)
    rise, delta, c, block = _contact.analyse(curve, "tilted", tip, NU, "fit", "tilt")
    assert block["baseline"] == "tilt" and abs(c - truth) <= 1
    assert abs(block["youngs_modulus_Pa"] - E) < 4 * block["youngs_modulus_stderr_Pa"] < 0.01 * E
    # after contact the corrected force rise is Hertz's to 0.2 % of its range, a tenth of the
    # offset-only error
    error = np.sqrt(np.mean((rise[late] - hertz[late]) ** 2))
    assert error < 0.002 * hertz.max() and error < 0.1 * plain_error


def test_the_baseline_option_from_python_and_the_command_line(tmp_path):
    """``load_records(..., baseline="tilt")`` and ``--baseline tilt`` give the same record and
    the same modulus; an unknown correction is refused in one line by both."""
    from vojax._cli import main

    rows = [load_records(RAW, time="time_s", inputs=["force_rise_N"], output="indentation_m",
                         tip=TIPS["sphere"], baseline=b)[0] for b in ("offset", "tilt")]
    afm = [dict(r.afm) for r in rows]
    assert afm[1]["baseline"] == "tilt" and afm[0]["baseline"] == "offset"
    args = ["identify", str(RAW), "--time", "time_s", "--input", "force_rise_N", "--output",
            "indentation_m", "--tip", "sphere:5e-6", "--method", "refit", "--baseline", "tilt",
            "--out", str(tmp_path / "o")]
    assert main(args) == 0
    summary = json.loads((tmp_path / "o" / "summary.json").read_text())["afm"]
    assert summary["baseline"] == "tilt"
    assert summary["youngs_modulus_Pa"] == pytest.approx(dict(rows[1].afm)["youngs_modulus_Pa"],
                                                     rel=1e-12)
    with pytest.raises(ValueError, match="the baseline correction must be one of offset, tilt"):
        load_records(RAW, time="time_s", inputs=["force_rise_N"], output="indentation_m",
                     baseline="drift")
    with pytest.raises(SystemExit):
        main([*args[:-4], "--baseline", "drift", "--out", str(tmp_path / "p")])
