"""The tracker's noise intensities given on the command line (``--noise``), as Python's
``identify(noise=…)`` takes them: the measurement's level in the output column's unit."""

import csv
import json

import numpy as np
import pytest

import vojax

from .helpers import run_cli
from .test_offset import DT, _creep

NOISE = dict(order_drift=0.02, parameter_drift=1e-3)


def test_the_command_line_noise_is_in_the_files_unit(tmp_path):
    """``--noise order_drift=…,parameter_drift=…,noise_std=S`` with S in the output column's
    unit: with ``--length`` the tracker takes S/length on the strain, and its order is
    `vojax.identify(noise=…)`'s on the strain (to 1e-9); the provenance keeps what was
    given. Refused in one line, before anything is written: with a method that does not run
    the tracker, a missing or unknown key, a non-positive or non-finite value, and beside
    ``--parameters constant`` (which sets the parameters' drift itself)."""
    a, ell = 2.0, 5.0
    t, u, strain, _ = _creep(seed=4)
    force, d = a * u, ell * strain
    with open(tmp_path / "fd.csv", "w") as f:
        f.write("time_s,F,d\n" + "".join(f"{x!r},{y!r},{z!r}\n"
                                         for x, y, z in zip(t.tolist(), force.tolist(), d.tolist())))
    std = 0.01 * float(np.ptp(d))
    text = f"order_drift=0.02,parameter_drift=0.001,noise_std={std!r}"
    common = ("identify", "fd.csv", "--time", "time_s", "--input", "F", "--output", "d",
              "--area", str(a), "--length", str(ell))
    proc = run_cli(*common, "--noise", text, "--out", "o", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    summary = json.loads((tmp_path / "o" / "summary.json").read_text())
    assert summary["provenance"]["settings"]["noise"] == dict(NOISE, noise_std=std)
    with open(tmp_path / "o" / "identification.csv") as f:
        alpha = np.array([float(r["alpha"]) for r in csv.DictReader(f)])
    ref = vojax.identify(force / a, d / ell, DT, noise=dict(NOISE, noise_std=std / ell),
                         warn=False)
    np.testing.assert_allclose(alpha, np.asarray(ref.alpha), rtol=0, atol=1e-9)
    wrong = vojax.identify(force / a, d / ell, DT, noise=dict(NOISE, noise_std=std),
                           warn=False)
    assert np.max(np.abs(np.asarray(wrong.alpha) - alpha)) > 1e-6  # the unit does matter
    for extra, said in (
        (("--noise", text, "--method", "gradient"), "--noise sets the tracker"),
        (("--noise", "order_drift=0.02,noise_std=0.1"),
         "argument --noise: expected order_drift=…,parameter_drift=…,noise_std=…"),
        (("--noise", "order_drift=0.02,parameter_drift=0.001,noise=0.1"),
         "argument --noise: expected order_drift=…,parameter_drift=…,noise_std=…"),
        (("--noise", "order_drift=0.02,parameter_drift=-1,noise_std=0.1"),
         "argument --noise: parameter_drift must be a positive finite number, got '-1'"),
        (("--noise", "order_drift=nan,parameter_drift=1,noise_std=0.1"),
         "argument --noise: order_drift must be a positive finite number, got 'nan'"),
        (("--noise", text, "--parameters", "constant"),
         "--noise sets the parameters' drift itself (its 'parameter_drift'); give it, or "
         "--parameters constant, not both."),
        (("--noise", "order_drift=0.02,parameter_drift=0.001,noise_std=1e300"),
         "`noise['noise_std']` must be below 1e+150, got 1e+300."),
    ):
        bad = run_cli(*common, *extra, "--out", "p", cwd=tmp_path)
        assert bad.returncode != 0 and said in bad.stderr, bad.stderr
        assert len(bad.stderr.strip().splitlines()) == 1
        assert not (tmp_path / "p").exists()


def test_a_refusal_that_asks_for_the_noise_names_the_option_in_each_interface():
    from vojax._steps import Step, say

    assert "noise=" in say("a finding", [Step.NOISE], "python")
    assert say("a finding", [Step.NOISE], "cli").endswith("--noise")


@pytest.mark.parametrize("key", ["order_drift", "parameter_drift", "noise_std"])
def test_an_intensity_whose_square_overflows_is_refused(key):
    """Each intensity below 1e150, where its square stays finite (1e300 overflowed in the
    tracker with an OverflowError)."""
    t, u, y, _ = _creep(seed=2)
    noise = dict(NOISE, noise_std=0.01)
    with pytest.raises(ValueError, match=rf"`noise\['{key}'\]` must be below 1e\+150"):
        vojax.identify(u, y, DT, noise=dict(noise, **{key: 1e300}), warn=False)
