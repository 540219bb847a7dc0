"""The tracker's fit window (`identify(..., window=)`, ``--fit-from``/``--fit-to``): a record
whose first seconds are corrupted (a rheometer's inertial ringing) is identified over the
rest, with the whole input history still driving the memory; the diagnostics and the summary
speak of the window; bad windows are refused in one sentence."""

import json

import jax
import numpy as np
import pytest

import vojax
from vojax._cli import main
from vojax._tracker._band import second_half

jax.config.update("jax_enable_x64", True)

N, T, Q, P = 400, 20.0, 0.3, 0.5


@pytest.fixture(scope="module")
def ringing():
    """A springpot's creep under a unit step, ``x = P t^Q / Γ(1+Q)``, with a ringing of
    amplitude 0.3 decaying over 0.4 s added at the start and 0.2 % white noise."""
    t = np.linspace(0.0, T, N)
    u = np.ones(N)
    x = np.asarray(vojax.simulate(u, Q, np.array([P]), t=t))
    ring = 0.3 * np.exp(-t / 0.4) * np.sin(2 * np.pi * t / 0.3)
    y = x + ring + 0.002 * np.random.default_rng(0).standard_normal(N)
    return t, u, y


def test_second_half_of_the_fitted_range():
    """The second half starts half-way between the first fitted sample and the span."""
    assert second_half(None, 400) == 200
    mask = np.r_[np.zeros(40), np.ones(360)]
    assert second_half(mask, 400) == 40 + 180
    assert second_half(np.r_[np.zeros(300), np.ones(100)], 380) == 300 + 40


def test_window_recovers_the_order_the_ringing_hides(ringing):
    """With the parameters stated constant (true here), the whole record's band is wide (the
    ringing fits no constant order) and the order is not identified; fitted from 2 s on
    (the ringing below 0.2 % of the signal there) it is identified, the truth inside its band
    at every sample of the window's second half and the median error below its half-width."""
    t, u, y = ringing
    whole = vojax.identify(u, y, t=t, parameters="constant", warn=False)
    assert not whole.diagnostics.identified and whole.diagnostics.band_halfwidth > 0.05
    res = vojax.identify(u, y, t=t, parameters="constant", window=(2.0, None), warn=False)
    first = int(np.argmax(t >= 2.0))
    assert res.fitted == (first, N)
    assert res.diagnostics.identified
    half = first + (N - first) // 2
    alpha = np.asarray(res.alpha)[half:]
    lo, hi = np.asarray(res.alpha_lower)[half:], np.asarray(res.alpha_upper)[half:]
    assert np.all((lo <= Q) & (Q <= hi))
    assert np.median(np.abs(alpha - Q)) < res.diagnostics.band_halfwidth
    # the band is the window's: its half-width is the median over the window's second half
    width = np.median((np.asarray(res.alpha_upper) - np.asarray(res.alpha_lower))[half:]) / 2
    assert res.diagnostics.band_halfwidth == pytest.approx(width, rel=1e-12)


def test_window_is_a_mask_and_an_open_window_changes_nothing(ringing):
    """A window fits exactly the samples a mask of its samples fits, both ends included (the
    same states to the last bit); a window open at both ends is every sample, the same as
    none."""
    t, u, y = ringing
    # past the middle (the second half is the window's), both ends on samples: included
    late = (np.arange(N) >= 240) & (np.arange(N) <= 360)
    a = vojax.identify(u, y, t=t, window=(t[240], t[360]), warn=False)
    b = vojax.identify(u, y, t=t, mask=late.astype(float), warn=False)
    for k in ("alpha", "alpha_lower", "alpha_upper", "p", "y_hat"):
        np.testing.assert_array_equal(np.asarray(getattr(a, k)), np.asarray(getattr(b, k)))
    np.testing.assert_equal(vars(a.diagnostics), vars(b.diagnostics))  # NaN equals NaN
    first, stop = np.flatnonzero(late)[[0, -1]] + [0, 1]
    assert a.fitted == b.fitted == (first, stop)
    # the summary's final order is the window's last, not the record's (after the window the
    # states follow the random walk: the same mean, a slightly wider band)
    s = a.summary()
    std = np.asarray(a.alpha_std)
    assert std[-1] > (1 + 1e-6) * std[stop - 1]
    assert s["order (final)"]["stderr"] == pytest.approx(float(std[stop - 1]), rel=1e-12)
    width = np.median((np.asarray(a.alpha_upper) - np.asarray(a.alpha_lower))[
        first + (stop - first) // 2:stop]) / 2
    assert a.diagnostics.band_halfwidth == pytest.approx(width, rel=1e-12)
    full = vojax.identify(u[:200], y[:200], t=t[:200], warn=False)
    open_ = vojax.identify(u[:200], y[:200], t=t[:200], window=(None, None), warn=False)
    np.testing.assert_array_equal(np.asarray(full.alpha), np.asarray(open_.alpha))
    np.testing.assert_equal(vars(full.diagnostics), vars(open_.diagnostics))


@pytest.mark.parametrize(
    "kwargs, error, match",
    [
        (dict(window=(5.0, 1.0)), ValueError, "from < to"),
        (dict(window=(float("nan"), 1.0)), ValueError, "from < to"),
        (dict(window=(100.0, 200.0)), ValueError, "leaves 0 fitted samples"),
        (dict(window="ab"), TypeError, "pair of times"),
        (dict(window=(True, 3.0)), TypeError, "pair of times"),
        (dict(window=(1.0, 2.0, 3.0)), TypeError, "pair of times"),
        (dict(window=(1.0, None), method="gradient"), ValueError, "`window` sets the tracker"),
    ],
)
def test_bad_windows_are_refused(ringing, kwargs, error, match):
    t, u, y = ringing
    with pytest.raises(error, match=match):
        vojax.identify(u, y, t=t, warn=False, **kwargs)


def test_refit_window_takes_open_ends(ringing):
    """`refit`'s window takes None for an open end, the same as an infinite one."""
    t, u, y = ringing
    a = vojax.refit(u, y, t=t, window=(2.0, None))
    b = vojax.refit(u, y, t=t, window=(2.0, np.inf))
    assert a.order_value == b.order_value and abs(a.order_value - Q) < 0.01


def test_command_line_window_is_the_python_window(ringing, tmp_path, capsys):
    """``vojax identify --fit-from 102`` on a file whose clock starts at 100 s fits the record
    from 2 s on its own clock: the order equals ``identify(..., window=(2, None))``'s to the
    last digit written; the summary names the fitted samples; the paper's law refuses it."""
    t, u, y = ringing
    path = tmp_path / "creep.csv"
    np.savetxt(path, np.c_[t + 100.0, u, y], delimiter=",", header="time,stress,strain",
               comments="")
    cols = ["--time", "time", "--input", "stress", "--output", "strain"]
    out = tmp_path / "out"
    assert main(["identify", str(path), *cols, "--fit-from", "102", "--parameters",
                 "constant", "--out", str(out)]) == 0
    summary = json.loads((out / "summary.json").read_text())["kalman"]
    res = vojax.identify(u, y, t=t, parameters="constant", window=(2.0, None), warn=False)
    first = int(np.argmax(t >= 2.0))
    assert summary["fitted_samples"] == [first, N]
    assert summary["alpha_final"] == pytest.approx(float(np.asarray(res.alpha)[-1]), rel=1e-9)
    assert summary["alpha_min"] == pytest.approx(float(np.asarray(res.alpha)[first:].min()), rel=1e-9)
    assert summary["verdict"] == "identified"
    # the fit's error over the window (the ringing before it, 15 % of the range, left out)
    y_hat = np.asarray(res.y_hat)
    rms = np.sqrt(np.mean((y_hat[first:] - y[first:]) ** 2)) / np.ptp(y[first:])
    assert summary["nrmse"] == pytest.approx(rms, rel=1e-6)
    assert rms < 0.01
    capsys.readouterr()
    assert main(["identify", str(path), *cols, "--fit-from", "102", "--method", "gradient",
                 "--out", str(tmp_path / "o2")]) == 1
    assert "the paper's law (--method gradient) fits every sample" in capsys.readouterr().err
    # a window outside the record is refused in the file's times, before anything is fitted
    assert main(["identify", str(path), *cols, "--fit-from", "150", "--out",
                 str(tmp_path / "o3")]) == 1
    assert ("--fit-from 150 leaves 0 samples of the record, whose times run from 100 to 120 "
            "in the file") in capsys.readouterr().err
    assert not (tmp_path / "o3" / "summary.json").exists()
