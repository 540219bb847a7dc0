"""`compare` at parity with `refit`: a fit window, a given or estimated offset, the test's
start before the first sample, relative residuals; each checked against the closed form it
must equal or against `refit` called directly with the same options."""

import math

import numpy as np
import pytest

import vojax

from .helpers import run_cli


def _stress(n=240, dt=0.05):
    t = dt * np.arange(n)
    return np.minimum(t / 2.0, 1.0) + 0.5 * (t > 6.0), dt, t  # a ramp, a hold, a second step


def _springpot_fit(stress, y, dt, **options):
    law = vojax.Springpot()
    return vojax.refit(law.inputs(stress, y), y, dt, p_signs=law.p_signs, warn=False, **options)


def test_a_window_leaves_the_ringing_out_and_counts_only_its_samples():
    """Springpot data (q = 0.35, noise 0.5 %) whose first 2.8 s carry a decaying ringing (a
    rheometer's inertia, 50 % of the response, decay time 0.4 s): without a window the
    springpot's order is pulled away by more than 0.025; with the window after the ringing
    it is the order of `refit` over that window (to 1e-9) and within 0.005 of the truth. The likelihood counts the window's samples only (the Gaussian closed
    form from the in-window residuals), and the held-out end is the last quarter of the
    window, predicted by a refit over the window's first three quarters."""
    stress, dt, t = _stress()
    clean = np.asarray(vojax.simulate(stress, 0.35, np.array([0.5]), dt))
    ringing = 0.5 * np.ptp(clean) * np.exp(-t / 0.4) * np.sin(2 * np.pi * 3.0 * t)
    y = clean + ringing + 0.005 * np.ptp(clean) * np.random.default_rng(2).standard_normal(t.size)
    window = (t[56], np.inf)
    plain = vojax.compare(stress, y, dt, models=("springpot",)).rows[0]
    row = vojax.compare(stress, y, dt, models=("springpot",), window=window).rows[0]
    direct = _springpot_fit(stress, y, dt, window=window)
    assert abs(float(plain["refit"].order_value) - 0.35) > 0.025  # the ringing does matter
    assert float(row["refit"].order_value) == pytest.approx(float(direct.order_value), abs=1e-9)
    assert float(row["refit"].order_value) == pytest.approx(0.35, abs=0.005)
    inside = t >= window[0]
    res = (y - np.asarray(row["refit"].y_hat))[inside]
    n = int(inside.sum())
    ll = -0.5 * n * (math.log(2 * math.pi * float(res @ res) / n) + 1)
    assert row["log_likelihood"] == pytest.approx(ll, rel=1e-12)
    assert row["log_evidence"] == pytest.approx(ll - 0.5 * row["quantities"] * math.log(n), rel=1e-12)
    idx = np.flatnonzero(inside)
    split = t[idx[int(round(0.75 * (idx.size - 1)))]]
    early = _springpot_fit(stress, y, dt, window=(t[56], split))
    tail = inside & (t > split)
    want = np.sqrt(np.mean((y - np.asarray(early.y_hat))[tail] ** 2)) / np.ptp(y[inside])
    assert row["holdout_nrmse"] == pytest.approx(want, rel=1e-6)


def test_a_given_offset_is_held_and_not_counted():
    """``x0=0`` (a tared sensor): every law's refit holds its offset at exactly 0 and counts
    one free number fewer than with the offset estimated; ``x0=None`` takes the first
    sample."""
    stress, dt, _ = _stress(160)
    y = np.asarray(vojax.simulate(stress, 0.3, np.array([0.25]), dt))
    y = y + 0.01 * np.ptp(y) * np.random.default_rng(5).standard_normal(y.size)
    models = ("springpot", "maxwell")
    free = {r["model"]: r for r in vojax.compare(stress, y, dt, models=models).rows}
    held = {r["model"]: r for r in vojax.compare(stress, y, dt, models=models, x0=0.0).rows}
    for m in models:
        assert float(held[m]["refit"].x0) == 0.0
        assert held[m]["quantities"] == free[m]["quantities"] - 1
    first = vojax.compare(stress, y, dt, models=("springpot",), x0=None).rows[0]
    assert float(first["refit"].x0) == y[0]


def test_a_step_before_the_first_sample_is_found_with_origin():
    """A unit stress applied at T0 = −0.5 s, sampled from 0: the springpot's strain is
    ``p (t − T0)^q / Γ(1 + q)`` (closed form, q = 0.4, p = 0.5). With ``origin=T0`` the
    comparison's springpot finds q to 1e-4 and p to 1e-3; without it, the order is off by
    more than 0.01."""
    dt, n, t0, q, p = 0.05, 200, -0.5, 0.4, 0.5
    t = dt * np.arange(n)
    stress = np.ones(n)
    y = p * (t - t0) ** q / math.gamma(1 + q)
    row = vojax.compare(stress, y, dt, models=("springpot",), origin=t0).rows[0]
    assert float(row["refit"].order_value) == pytest.approx(q, abs=1e-4)
    assert float(row["refit"].p[0]) == pytest.approx(p, rel=1e-3)
    late = vojax.compare(stress, y, dt, models=("springpot",)).rows[0]
    assert abs(float(late["refit"].order_value) - q) > 0.01


def test_relative_residuals_have_the_likelihood_of_proportional_noise():
    """Creep after a step at T0 (strain over three decades, noise 2 % of each sample):
    ``relative=True`` gives each law the fit of ``refit(relative=True)`` and the likelihood of
    noise proportional to the data, ``−n/2 (ln(2π Σ(r/y)²/n) + 1) − Σ ln|y|`` (its last term
    makes it a density of the data, as the absolute rows'); the held-out error is the RMS
    relative error. A zero in the fitted samples is refused as `refit` refuses it."""
    t = np.geomspace(1e-3, 10.0, 300)
    stress = np.ones(t.size)
    y = 0.5 * (t + 1e-3) ** 0.3 / math.gamma(1.3)
    y = y * (1 + 0.02 * np.random.default_rng(6).standard_normal(t.size))
    row = vojax.compare(stress, y, t=t, models=("springpot",), origin=-1e-3,
                        relative=True).rows[0]
    law = vojax.Springpot()
    direct = vojax.refit(law.inputs(stress, y), y, t=t, origin=-1e-3, relative=True,
                         p_signs=law.p_signs, warn=False)
    assert float(row["refit"].order_value) == pytest.approx(float(direct.order_value), abs=1e-9)
    assert float(row["refit"].order_value) == pytest.approx(0.3, abs=0.01)
    r = (y - np.asarray(row["refit"].y_hat)) / y
    n = t.size
    ll = -0.5 * n * (math.log(2 * math.pi * float(r @ r) / n) + 1) - float(np.sum(np.log(y)))
    assert row["log_likelihood"] == pytest.approx(ll, rel=1e-12)
    split = t[int(round(0.75 * (n - 1)))]
    early = vojax.refit(law.inputs(stress, y), y, t=t, origin=-1e-3, relative=True,
                        window=(t[0], split), p_signs=law.p_signs, warn=False)
    tail = t > split
    want = np.sqrt(np.mean(((y - np.asarray(early.y_hat)) / y)[tail] ** 2))
    assert row["holdout_nrmse"] == pytest.approx(want, rel=1e-6)
    zero = y.copy()
    zero[10] = 0.0
    with pytest.raises(ValueError, match="relative residuals divide by y, which is 0"):
        vojax.compare(stress, zero, t=t, models=("springpot",), relative=True)


def test_a_window_too_short_to_compare_on_is_refused_in_one_sentence():
    stress, dt, t = _stress(120)
    y = np.asarray(vojax.simulate(stress, 0.3, np.array([0.25]), dt))
    with pytest.raises(ValueError, match=r"`window` \(5.0, 5.2\) holds 5 samples; compare needs"):
        vojax.compare(stress, y, dt, window=(5.0, 5.2))
    with pytest.raises(ValueError, match="`window` must satisfy from < to"):
        vojax.compare(stress, y, dt, window=(3.0, 1.0))
    with pytest.raises(ValueError, match="`x0` must be 'estimate', None"):
        vojax.compare(stress, y, dt, x0="zero")
    with pytest.raises(TypeError, match="`relative` must be True or False, got 'yes'"):
        vojax.compare(stress, y, dt, relative="yes")
    with pytest.raises(ValueError, match="`origin` must be a finite time before the first"):
        vojax.compare(stress, y, dt, origin=0.0, models=("springpot",))


def test_the_command_passes_the_window_offset_and_origin_in_the_files_time(tmp_path):
    """`vojax compare --fit-from --x0 --relative --origin` on a file whose clock starts at
    100 s (the window starting between samples, as a clock read from a file is exact only to
    rounding): the springpot's order in comparison.csv is the library's with the window and the
    origin shifted to the record's clock (the record starts at 0), and its free numbers
    count the offset as given."""
    import csv


    dt, n, q = 0.05, 160, 0.3
    t = dt * np.arange(n)
    stress = np.ones(n)
    y = 0.25 * (t + 0.5) ** q / math.gamma(1 + q)
    y = y * (1 + 0.01 * np.random.default_rng(7).standard_normal(n))
    with open(tmp_path / "r.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["time_s", "stress", "strain"])
        w.writerows(zip(100.0 + t, stress, y))
    done = run_cli("compare", "r.csv", "--time", "time_s", "--input", "stress", "--output",
                   "strain", "--models", "springpot", "--fit-from", "101.02", "--origin", "99.5",
                   "--x0", "0", "--relative", "--out", "out", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    with open(tmp_path / "out" / "comparison.csv", newline="") as f:
        (row,) = list(csv.DictReader(f))
    want = vojax.compare(stress, y, dt, models=("springpot",), window=(1.02, np.inf),
                         origin=-0.5, x0=0.0, relative=True).rows[0]
    assert float(row["order"]) == pytest.approx(float(want["refit"].order_value), abs=6e-4)  # 3 decimals
    assert int(row["quantities"]) == want["quantities"] == 3  # order, η, noise
    assert float(row["log_evidence"]) == pytest.approx(want["log_evidence"], rel=1e-6)


def test_the_batch_compares_over_the_refits_window_in_the_files_time(tmp_path):
    """``vojax batch --method refit --compare --fit-from``: the ``compare`` block of a
    record whose clock starts at 50 s is `vojax.compare` over the window shifted to the
    record's clock, and differs from the comparison over the whole record."""
    import json

    from vojax._cli import main
    from vojax._data import load_records

    from .test_data_cli import DT, _springpot_csv

    data = tmp_path / "data"
    data.mkdir()
    n = 80
    _springpot_csv(data / "a.csv", n=n, q=0.35, time=50.0 + DT * np.arange(n))
    start = 50.0 + 20.5 * DT  # between two samples
    assert main(["batch", str(data), "--time", "time_s", "--input", "stress", "--output",
                 "strain", "--method", "refit", "--figures", "overview", "--quiet",
                 "--compare", "--fit-from", repr(start), "--out", str(tmp_path / "o")]) == 0
    block = json.loads((tmp_path / "o" / "a" / "summary.json").read_text())["compare"]
    (rec,) = load_records(data / "a.csv", time="time_s", inputs=["stress"], output="strain")
    windowed = vojax.compare(rec.inputs, rec.output, **rec.grid, window=(start - 50.0, np.inf))
    whole = vojax.compare(rec.inputs, rec.output, **rec.grid)
    for r in windowed.rows:
        assert block["log_evidence"][r["model"]] == pytest.approx(r["log_evidence"], rel=1e-9)
    assert block["log_evidence"]["springpot"] != pytest.approx(
        next(r for r in whole.rows if r["model"] == "springpot")["log_evidence"], rel=1e-3)


def test_a_window_that_ends_before_it_starts_is_refused_by_both_commands(tmp_path):
    """``--fit-from 3 --fit-to 1``: the same one-line refusal from `vojax compare` and
    `vojax identify`, before anything is written."""
    from .test_data_cli import _springpot_csv

    _springpot_csv(tmp_path / "r.csv", n=60)
    common = ["r.csv", "--time", "time_s", "--input", "stress", "--output", "strain",
              "--fit-from", "3", "--fit-to", "1"]
    for command, extra in (("compare", []), ("identify", ["--method", "refit"])):
        done = run_cli(command, *common, *extra, "--out", "p", cwd=tmp_path)
        err = done.stderr.strip()
        assert done.returncode == 1, err
        assert err == "vojax: error: --fit-from must be before --fit-to, got 3.0 and 1.0.", err
        assert not (tmp_path / "p").exists()
