"""The real-records table's independent check (`scripts/real_records_table.py`): a springpot's
strain lags its stress by qπ/2 in a steady oscillation, so the first harmonic's phase gives
the order without the model's memory; on the recorded LAOS tests the estimators must agree
with it or say they do not know."""

import math

import numpy as np
import pytest

import vojax

from .helpers import SHARED_DATA, load_script

LAOS = SHARED_DATA / "laos-mitlaos-reptate" / "raw"


@pytest.fixture(scope="module")
def table():
    return load_script("real_records_table")


@pytest.mark.parametrize("q", [0.05, 0.37, 0.9, 1.4])
def test_phase_order_reads_the_lag_of_two_sinusoids(table, q):
    """Two sinusoids a lag qπ/2 apart, with offsets, on an irregular clock over a
    non-whole number of cycles: the first harmonic's phase gives q back to rounding."""
    rng = np.random.default_rng(3)
    omega = 2.7
    t = np.sort(rng.uniform(0.0, 31.3, 900))
    stress = 4.0 * np.sin(omega * t + 0.8) + 1.5
    strain = 0.3 * np.sin(omega * t + 0.8 - q * math.pi / 2) - 2.0
    assert table.phase_order(t, stress, strain, omega) == pytest.approx(q, abs=1e-12)


def test_phase_order_of_the_library_springpot_in_steady_oscillation(table):
    """The library's memory (`vojax.simulate`, a constant order 0.4) driven by a sine for 60
    cycles: over the last 30 the strain lags the stress by qπ/2 up to the start's decaying
    transient, a slowly varying term that the fitted offset absorbs (4e-5 off here, 1e-3
    allowed); an order read wrong by the memory (another q, or a lead in place of a lag)
    is off by far more."""
    q, omega, dt = 0.4, 2 * math.pi, 0.01
    t = np.arange(6000) * dt
    stress = np.sin(omega * t)
    strain = np.asarray(vojax.simulate(stress[:, None], q, np.array([1.0]), dt))
    late = t >= 30.0
    assert table.phase_order(t[late], stress[late], strain[late], omega) == pytest.approx(
        q, abs=1e-3)


@pytest.mark.slow
@pytest.mark.skipif(not LAOS.is_dir(), reason="no LAOS recordings in ../shared/data")
@pytest.mark.parametrize("name", ["CPyCL-omega00p30-gam03p1600", "SlugSlime-omega03p00-Run31"])
def test_laos_records_agree_with_their_phase_or_refuse(table, name, tmp_path):
    """On each recorded LAOS test (a wormlike-micelle solution near q 0.9, a slug's mucus
    near 0.1 by the phase), the constant-order refit's 95 % interval holds the phase order,
    and the tracker is never identified with the phase order outside its band (where the
    large amplitude's nonlinearity leaves correlated residuals it refuses instead)."""
    from vojax._data import load_records
    from vojax._data._pipeline import identify_record

    path, phase = table._laos(LAOS / f"{name}.laos", tmp_path)
    (record,) = load_records(path, time="time_s", inputs=["stress"], output="strain")
    columns, summary = identify_record(record, method="kalman+refit", threads=1)
    refit = summary["refit"]
    assert refit["order_lower"] <= phase <= refit["order_upper"]
    half = len(columns["alpha"]) // 2
    inside = ((columns["alpha_lower"][half:] <= phase)
              & (phase <= columns["alpha_upper"][half:]))
    assert summary["kalman"]["verdict"] != "identified" or np.mean(inside) >= 0.5
