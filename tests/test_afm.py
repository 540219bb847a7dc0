"""AFM force files: read through afmformats, the contact point (nanite's), the indentation and
the Hertz contact strain, against the instrument's CSV export and the contact mechanics by
hand (the modulus and nanite's estimators: test_afm_contact.py)."""

import csv
import math
from pathlib import Path

import numpy as np
import pytest

import vojax
from vojax._data import DataError, _afm, load_records

HERE = Path(__file__).parent / "data" / "afm"
RAW = HERE / "brain_creep.jpk-force"
SHARED = Path(__file__).resolve().parents[2] / "shared" / "data" / "afm-brain-gel-creep"

# afmformats is in the test extra: a missing or broken install fails here, loudly, rather
# than skipping every AFM test
import afmformats  # noqa: E402, F401


def _export(name):
    """A CSV export (afmformats 0.18.7, 10 significant digits) from the shared data folder."""
    path = SHARED / name
    if not path.is_file():
        pytest.skip(f"{path} is not here")
    with open(path) as f:
        rows = list(csv.reader(line for line in f if not line.startswith("#")))
    return {k: np.array([float(r[j]) for r in rows[1:]]) for j, k in enumerate(rows[0])}


@pytest.mark.parametrize(
    "raw, export",
    [
        (RAW, "afm_brain_creep.csv"),
        (SHARED / "raw" / "fmt-jpk-cc_pr14-polymergel-2021.06.30.jpk-force", "afm_polymergel_creep.csv"),
        (SHARED / "raw" / "fmt-jpk-sr_cell1-0008.jpk-force", "afm_cell_stress_relaxation.csv"),
    ],
)
def test_the_raw_file_gives_the_columns_of_its_csv_export(raw, export):
    """Time, segment, force and both heights as the export has them, to its 10 digits (a
    calibration step applied twice or skipped, or a segment's clock restarted, is off by far
    more); a JPK file of the older software (4.2, 16-bit channels, four segments) too."""
    want = _export(export)
    if not Path(raw).is_file():
        pytest.skip(f"{raw} is not here")
    ((cols, meta),), failed = _afm.read_afm(raw)
    assert failed == []
    for name in ("time_s", "segment", "force_N", "height_measured_m", "height_piezo_m"):
        np.testing.assert_allclose(cols[name], want[name], rtol=2e-9, atol=0, err_msg=name)
    assert meta["spring_constant"] == pytest.approx(0.061 if "cell" not in export else 1.0677)


def test_contact_indentation_and_hertz_strain():
    """The brain record: nanite's Hertz fit puts the contact during the approach (about
    1.71 s), the indentation is the tip position ``h + F/k`` below the fitted contact point
    (checked here from the file's columns: δ + h + F/k is one number, and δ turns
    non-negative at the contact), it creeps by about 1.6 µm during the 3 s hold at constant
    force (the recording's description), and the contact strains of a sphere and a cone
    against Hertz's forces written out by hand: an elastic half-space of shear modulus G
    under a sphere, F = 4/3 · E/(1 − ν²) · √R δ^{3/2} with E = 2G(1 + ν), is G times the
    strain."""
    ((cols, meta),), _ = _afm.read_afm(RAW, tip=("sphere", 5e-6), poisson=0.3)
    c = meta["contact_index"]
    assert 1.68 < meta["contact_time"] < 1.74
    assert meta["afm"]["contact_time"] == meta["contact_time"]
    t, f, h, seg = (cols[k] for k in ("time_s", "force_N", "height_measured_m", "segment"))
    delta = cols["indentation_m"]
    level = delta + h + f / 0.061
    np.testing.assert_allclose(level, level[0], rtol=0, atol=1e-15)
    assert delta[c] >= 0 > delta[c - 1]
    np.testing.assert_allclose(cols["force_rise_N"], f - f[0] - (f[c] - f[0]),
                               rtol=0, atol=0.02 * np.ptp(f))
    hold = seg == 1
    creep = delta[hold][-50:].mean() - delta[hold][:50].mean()
    assert 1.2e-6 < creep < 2.0e-6
    assert np.ptp(f[hold]) < 0.1 * np.ptp(f)  # the force is held during the hold
    g, nu, radius = 1234.0, 0.3, 5e-6
    d = np.clip(delta, 0, None)
    hertz = 4 / 3 * (2 * g * (1 + nu)) / (1 - nu**2) * math.sqrt(radius) * d**1.5
    np.testing.assert_allclose(g * cols["contact_strain"], hertz, rtol=1e-12, atol=0)
    ((cone, _),), _ = _afm.read_afm(RAW, tip=("cone", 20.0))  # F = 2/π · E/(1 − ν²) · tan θ · δ²
    d = np.clip(cone["indentation_m"], 0, None)
    hertz = 2 / math.pi * (2 * g * 1.5) / (1 - 0.25) * math.tan(math.radians(20)) * d**2
    np.testing.assert_allclose(g * cone["contact_strain"], hertz, rtol=1e-12, atol=0)
    assert np.any(delta < 0) and np.all(cols["contact_strain"][delta <= 0] == 0)


def test_records_from_contact_by_segment():
    """A record keeps the chosen segments from the contact point on, on the file's clock
    (the time restarts at 0 at contact), and a column that needs a tip says so."""
    rec, = load_records(RAW, time="time_s", inputs=["force_rise_N"], output="indentation_m",
                        segments=[0, 1])
    ((cols, meta),), _ = _afm.read_afm(RAW)
    c = meta["contact_index"]
    keep = np.flatnonzero(cols["segment"] <= 1)
    assert rec.output.size == keep[-1] + 1 - c
    np.testing.assert_array_equal(rec.output, cols["indentation_m"][c : keep[-1] + 1])
    assert rec.time[0] == 0 and rec.time_offset == pytest.approx(meta["contact_time"])
    assert rec.name == "brain_creep"
    with pytest.raises(DataError, match="contact_strain needs a tip"):
        load_records(RAW, time="time_s", inputs=["force_rise_N"], output="contact_strain")
    with pytest.raises(DataError, match="has no column 'force'"):
        load_records(RAW, time="time_s", inputs=["force"], output="indentation_m")
    with pytest.raises(ValueError, match="a cone's half-angle must lie in"):
        load_records(RAW, time="time_s", inputs=["force_N"], output="indentation_m", tip=("cone", 95))
    for radius in (1e-320, 5.0, float("nan")):  # subnormal, µm given as m, NaN: refused
        with pytest.raises(ValueError, match="a sphere's radius is in metres, from 1e-10 to"):
            load_records(RAW, time="time_s", inputs=["force_N"], output="contact_strain",
                         tip=("sphere", radius))
    with pytest.raises(ValueError, match="a sphere's radius is in metres"):
        load_records(RAW, time="time_s", inputs=["force_N"], output="contact_strain",
                     tip="sphere:1e-320")
    whole, = load_records(RAW, time="time_s", inputs=["force_N"], output="height_measured_m",
                          from_contact=False)
    assert whole.output.size == cols["time_s"].size


def test_raw_file_and_csv_export_give_the_same_identification():
    """The hold of the brain record, force in and measured height out, from the raw file
    and from its CSV export: the same refit (to the export's 10 digits)."""
    import jax

    jax.config.update("jax_enable_x64", True)
    _export("afm_brain_creep.csv")
    kw = dict(time="time_s", inputs=["force_N"], output="height_measured_m")
    raw, = load_records(RAW, segments=[1], from_contact=False, **kw)
    from_csv = [r for r in load_records(SHARED / "afm_brain_creep.csv", group_by="segment", **kw)
                if r.name == "1"][0]
    assert raw.output.size == from_csv.output.size == 3000
    a = vojax.refit(raw.inputs, raw.output, dt=raw.dt)
    b = vojax.refit(from_csv.inputs, from_csv.output, dt=from_csv.dt)
    assert a.order_value == pytest.approx(b.order_value, abs=1e-6)
    np.testing.assert_allclose(a.p, b.p, rtol=1e-5)


def test_bad_afm_files_fail_with_one_line(tmp_path):
    broken = tmp_path / "broken.jpk-force"
    broken.write_bytes(RAW.read_bytes()[:5000])
    with pytest.raises(DataError, match=r"not a readable AFM file"):
        load_records(broken, time="time_s", inputs=["force_N"], output="indentation_m")
    with pytest.raises(DataError, match="the AFM options are for AFM files and CSV exports"):
        csv_file = tmp_path / "a.csv"
        csv_file.write_text("t,u,y\n0,1,2\n1,1,2\n2,1,2\n")
        load_records(csv_file, time="t", inputs=["u"], output="y", segments=[1])


def _damaged(path, channel, change):
    """A copy of the shipped JPK file with one channel of segment 1 changed (None: left out)."""
    import zipfile

    with zipfile.ZipFile(RAW) as z, zipfile.ZipFile(path, "w") as out:
        for name in z.namelist():
            data = z.read(name)
            if name == f"segments/1/channels/{channel}.dat":
                data = change(data)
            if data is not None:
                out.writestr(name, data)
    return path


DAMAGE = [
    ("a channel cut at an odd byte", "vDeflection", lambda d: d[: len(d) // 2 + 1],
     "curve 0: a damaged channel (buffer size"),
    ("a channel cut at a whole sample", "vDeflection", lambda d: d[: len(d) // 2 // 8 * 8],
     "curve 0: its channels differ in length"),
    ("a channel left out", "height", lambda d: None, "curve 0: a damaged channel (No data"),
]


@pytest.mark.parametrize("case, channel, change, words", DAMAGE, ids=[d[0] for d in DAMAGE])
def test_a_damaged_jpk_channel_is_a_data_error_naming_file_and_curve(tmp_path, case, channel,
                                                                      change, words):
    """afmformats reads a channel when it is first used, and fails there with its own
    BaseException-derived error or NumPy's words, naming no file (a user's ``except
    Exception`` missed it): vojax says it as a DataError naming the file and the curve."""
    path = _damaged(tmp_path / "d.jpk-force", channel, change)
    with pytest.raises(DataError, match=f"d.jpk-force, {words}".replace("(", r"\(")):
        load_records(path, time="time_s", inputs=["force_N"], output="indentation_m")


def test_a_damaged_file_in_a_batch_fails_only_its_own_record(tmp_path):
    """Two damaged JPK files beside a good one: the good one is computed, each damaged one
    is in failures.csv with its one-line reason, exit 2 (a batch with failures); and `check`
    takes no --out (argparse read it as --output and ran)."""
    from .helpers import run_cli

    folder = tmp_path / "in"
    folder.mkdir()
    (folder / "good.jpk-force").write_bytes(RAW.read_bytes())
    for name, channel, change, _ in DAMAGE[:2]:
        _damaged(folder / f"{name.split()[-1]}.jpk-force", channel, change)
    base = ["--time", "time_s", "--input", "force_N", "--output", "indentation_m"]
    done = run_cli("batch", "in", *base, "--method", "refit", "--quiet", "--out", "out",
                   cwd=tmp_path)
    assert done.returncode == 2, done.stderr
    with open(tmp_path / "out" / "failures.csv", newline="") as f:
        failed = list(csv.DictReader(f))
    assert sorted(Path(r["file"]).name for r in failed) == ["byte.jpk-force", "sample.jpk-force"]
    assert all("curve 0:" in r["reason"] for r in failed)
    assert (tmp_path / "out" / "good" / "summary.json").is_file()
    check = run_cli("check", str(RAW), *base, "--out", "c", cwd=tmp_path)
    assert check.returncode == 1 and "unrecognized arguments: --out c" in check.stderr


def test_a_record_ends_where_the_tip_leaves_the_sample():
    """With every segment kept, the brain record runs from the contact point to the first
    sample after its deepest indentation at which the indentation is back to 0 or below: its
    retraction stays while the tip is in contact; with a tip, under 1 % of the contact
    strain (0 out of contact) is exactly 0. `released` on a closed case, where the
    indentation never comes back, and with nothing kept."""
    from vojax._data._afm_records import released

    ((cols, meta),), _ = _afm.read_afm(RAW)
    depth, c = cols["indentation_m"], meta["contact_index"]
    deepest = int(np.argmax(depth[c:])) + c
    end = deepest + int(np.flatnonzero(depth[deepest:] <= 0)[0])
    assert cols["segment"][end - 1] > 1  # the in-contact retraction is kept
    rec, = load_records(RAW, time="time_s", inputs=["force_rise_N"], output="indentation_m")
    assert rec.output.size == end - c
    np.testing.assert_array_equal(rec.output, depth[c:end])
    assert np.all(rec.output[deepest - c:] > 0) and depth[end] <= 0
    strain, = load_records(RAW, time="time_s", inputs=["force_rise_N"], output="contact_strain",
                           tip=("sphere", 5e-6))  # its own contact point (the Hertz fit's)
    assert np.mean(strain.output == 0) < 0.01
    keep = np.ones(10, bool)
    shape = np.array([-1, -0.5, 0.2, 0.8, 1.0, 0.6, 0.1, -0.1, -0.3, 0.05])
    assert released(shape, keep) == 7
    keep[:3] = False  # kept from the third sample on: the same
    assert released(shape, keep) == 7
    assert released(np.array([-1.0, 0.5, 1.0, 0.7]), np.ones(4, bool)) == 4
    assert released(shape, np.zeros(10, bool)) == 10
