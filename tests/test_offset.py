"""The tracker with the output's offset known (`identify(..., x0=…)`): held exactly, the same
as a shift of the output, narrower bands where the offset traded off with the order."""

import csv
import json

import numpy as np
import pytest

import vojax
from vojax._tracker._start import least_squares

from .helpers import run_cli

DT, N = 0.1, 300


def _creep(seed, x0=0.0):
    """A creep test from rest: a unit step of the input, the order rising 0.35 → 0.65, the
    output offset `x0`, white noise of 1 % of the output's range."""
    t = DT * np.arange(N)
    u = np.ones(N)
    alpha = 0.35 + 0.3 * t / t[-1]
    x = np.asarray(vojax.simulate(u, alpha, np.ones(1), DT))
    y = x0 + x + 0.01 * np.ptp(x) * np.random.default_rng(seed).standard_normal(N)
    return t, u, y, alpha


@pytest.fixture(scope="module")
def creep_fits():
    # the parameter is constant in seconds (the record's unit): stated so with time_scale=1
    t, u, y, alpha = _creep(seed=1, x0=0.4)
    known = vojax.identify(u, y, DT, parameters="constant", time_scale=1.0, x0=0.4, warn=False)
    free = vojax.identify(u, y, DT, parameters="constant", time_scale=1.0, warn=False)
    return t, u, y, alpha, known, free


def test_least_squares_without_an_offset_is_lstsq_without_its_column():
    rng = np.random.default_rng(0)
    x, y, mask = rng.standard_normal((40, 3)), rng.standard_normal(40), np.ones(40)
    mask[[3, 17]] = 0.0
    rss, coef = least_squares(x, y, mask, offset=False)
    keep = mask > 0
    ref, res, *_ = np.linalg.lstsq(x[keep], y[keep], rcond=None)
    np.testing.assert_allclose(coef[:3], ref, rtol=1e-12)
    assert coef[3] == 0.0 and coef.shape == (4,)  # the offset's place, held at 0
    assert rss == pytest.approx(float(res[0]), rel=1e-12)
    # with the column, the fit can only be better, and its offset is the lstsq one
    rss1, coef1 = least_squares(x, y, mask)
    ref1 = np.linalg.lstsq(np.c_[x, np.ones(40)][keep], y[keep], rcond=None)[0]
    np.testing.assert_allclose(coef1, ref1, rtol=1e-12)
    assert rss1 < rss


def test_a_known_offset_is_held_and_reported_as_given(creep_fits):
    *_, known, free = creep_fits
    assert float(known.x0) == 0.4 and float(known.x0_std) == 0.0
    # estimated, the offset has a band of its own
    assert float(free.x0_std) > 0.0 and float(free.x0) != 0.4


def test_a_known_offset_narrows_the_band_where_it_traded_off_with_the_order(creep_fits):
    """A creep test: the order's level, the parameter's scale and the offset trade off; the
    offset known (as from rest) removes one of them, and the band holds the truth. The
    scale still trades off with the order, which the band covers: the band narrows by more
    than 3× (±0.013 known, ±0.049 estimated) and both hold the truth."""
    t, u, y, alpha, known, free = creep_fits
    half = t > t[-1] / 2
    width = {k: float(np.median(np.asarray(r.alpha_upper - r.alpha_lower)[half]) / 2)
             for k, r in (("known", known), ("free", free))}
    assert width["known"] < 0.1 and width["free"] > 3 * width["known"]
    inside = (alpha >= np.asarray(known.alpha_lower)) & (alpha <= np.asarray(known.alpha_upper))
    assert np.mean(inside[half]) >= 0.9
    assert known.diagnostics.identified
    err = np.asarray(known.alpha)[half] - alpha[half]
    assert np.sqrt(np.mean(err**2)) < 0.02
    # with the offset estimated the order is still answered (the band calibrated, ±0.05 here),
    # and that wider band holds the truth too
    inside = (alpha >= np.asarray(free.alpha_lower)) & (alpha <= np.asarray(free.alpha_upper))
    assert np.mean(inside[half]) >= 0.9


def test_a_known_offset_is_the_same_as_subtracting_it(creep_fits):
    """The offset is in the output's units: shifting the output and the offset together
    changes nothing (the output is normalised about the offset); a wrong offset does."""
    t, u, y, alpha, known, _ = creep_fits
    shifted = vojax.identify(u, y - 0.4, DT, parameters="constant", time_scale=1.0, x0=0.0,
                             warn=False)
    np.testing.assert_allclose(shifted.alpha, known.alpha, rtol=0, atol=1e-8)
    np.testing.assert_allclose(shifted.alpha_std, known.alpha_std, rtol=1e-6, atol=1e-10)
    np.testing.assert_allclose(np.asarray(shifted.y_hat) + 0.4, known.y_hat, rtol=0, atol=1e-8)
    # an offset wrong by 5 % of the output's range moves the order by more than its band
    wrong = vojax.identify(u, y, DT, parameters="constant", time_scale=1.0,
                           x0=0.4 + 0.05 * np.ptp(y), warn=False)
    half = t > t[-1] / 2
    shift = np.median(np.abs(np.asarray(wrong.alpha) - np.asarray(known.alpha))[half])
    assert shift > 2 * np.median(np.asarray(known.alpha_std)[half])


@pytest.mark.parametrize(
    "x0, said",
    [(np.nan, "`x0` must be finite, got nan"), (-np.inf, "`x0` must be finite, got -inf"),
     ("zero", "`x0` must be a number, got 'zero'"),
     ([0.0, 1.0], r"`x0` must be a scalar, got shape \(2,\)")],
)
def test_a_known_offset_must_be_a_finite_number(x0, said):
    t, u, y, _ = _creep(seed=2)
    for method in ("kalman", "gradient"):  # one check of x0 for both estimators
        with pytest.raises(ValueError, match=said):
            vojax.identify(u, y, DT, method=method, x0=x0)


def test_the_command_line_offset_is_in_the_files_unit(tmp_path):
    """``--x0`` is the output column's reading at rest: with ``--length`` the tracker holds
    the strain's offset at x0/length, as `vojax.identify(x0=…)` on the strain does."""
    a, ell, d0 = 2.0, 5.0, 0.3
    t, u, strain, _ = _creep(seed=3)
    force, d = a * u, d0 + ell * strain
    with open(tmp_path / "fd.csv", "w") as f:
        f.write("time_s,F,d\n" + "".join(f"{x!r},{y!r},{z!r}\n"
                                         for x, y, z in zip(t.tolist(), force.tolist(), d.tolist())))
    common = ("identify", "fd.csv", "--time", "time_s", "--input", "F", "--output", "d",
              "--area", str(a), "--length", str(ell), "--parameters", "constant")
    proc = run_cli(*common, "--x0", str(d0), "--out", "o", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    summary = json.loads((tmp_path / "o" / "summary.json").read_text())
    assert summary["kalman"]["offset_model"] == "known"
    assert summary["kalman"]["x0"] == pytest.approx(d0 / ell, rel=1e-12)
    assert summary["kalman"]["x0_std"] == 0.0
    assert summary["provenance"]["settings"]["x0"] == d0
    with open(tmp_path / "o" / "identification.csv") as f:
        alpha = np.array([float(r["alpha"]) for r in csv.DictReader(f)])
    ref = vojax.identify(force / a, d / ell, DT, parameters="constant", x0=d0 / ell,
                         warn=False)
    np.testing.assert_allclose(alpha, np.asarray(ref.alpha), rtol=0, atol=1e-9)
    # the offset is the tracker's: refused with the law, and a non-number is refused
    for extra, said in ((("--method", "gradient"), "--x0 sets the tracker"),
                        ((), "argument --x0: expected a finite number")):
        bad = run_cli(*common[:-2], "--x0", "inf" if not extra else "0", *extra, "--out", "p",
                      cwd=tmp_path)
        assert bad.returncode != 0 and said in bad.stderr
        assert len(bad.stderr.strip().splitlines()) == 1
        assert not (tmp_path / "p").exists()
