"""Simulation-based calibration of the order bands: are they honest on data like a user's?

Each draw is a semi-synthetic record: a segment of a real recorded signal (every dataset of
../shared/data: beef and silicone indentation force, AFM force and piezo height, adhesive
staircase and load–unload stress, myocardium stretch, PP/PVC creep strain, rheometer creep
stress, LAOS strain) drives a drawn order trajectory α(t) and parameter p(t) through eq. (12)
— p inside the integral, constant or drifting in units of the record's span (the tracker's
clock) — computed by `vojax.reference`'s direct sums on a grid twice as fine
(never the code under test; for the ``long`` family, whose direct sums would take hours,
by the reference's NumPy recursion of the exponential memory at a tolerance of 1e-10: within
2e-12 of the direct sums on 4,000 samples), plus a drawn measurement noise. Families vary one thing at a
time over a common base (white noise of 0.5–2 % of the output's range, p constant):

- ``white``: the base; ``noisy``: white noise of 5–10 % with 12-bit quantisation;
- ``coloured``: AR(1) noise, ρ in 0.5–0.95, of the base's marginal level;
- ``drift``: p drifting smoothly by ±10–40 % over the record inside the integral
  (``D^α x = p(t)·u``); ``drift-constant``: the same with a constant order (the trade-off a
  single input cannot resolve);
- ``gain-drift``, ``gain-drift-constant``: the same drifts as a gain on the memory term,
  ``y = p(t)·I^α u`` (a tissue stiffening: ``σ = η(t)·D^q ε``), the tracker's own model of a
  drifting parameter;
- ``irregular``: samples at irregular times (gaps of 1–7 fine steps), run with ``t=``;
- ``lengths``: 100–4,800 samples (the other families use 300–1,200);
- ``long``: 20,000–100,000 samples, which `identify` fits as block means of 21–101 samples
  (its default ``max_points``): much less noisy than the samples;
- ``informative``: the recorded input with a superposed oscillation (a sine or an
  exponential chirp, 5–25 % of the load's RMS, 10–40 cycles over the record), which a
  springpot answers with a phase lag set by its order alone: the parameter constant (a
  third of the draws) or drifting by ±10–40 % inside the integral or as a gain (a third
  each); white noise or AR(1) noise (ρ 0.5–0.95), half the draws each;
- ``clock``: the parameter constant in the data's own unit of time, not the span's: on the
  span's clock a gain ``width^(α(t) − mean α)`` (``width`` the record's span in the
  recording's unit); the oscillation superposed on odd draws. The tracker states its
  parameters on the span, so its estimate is the wrong account's, and its band must cover
  the truth through its second fit on the data's unit (`vojax._tracker._clock`);
- ``stated-drift``: the parameter drifting as a gain, the user stating a bound D on its
  drift (0.1, 0.2 or 0.3: ``parameters=D``), the true drift below it (0.3–0.9 D) on even
  draws and above it (1.5–3 D) on odd ones.

Orders are drawn from five shapes: constant, a smooth random curve (a Gaussian-process draw,
non-monotone), a step, a fast early decay, and an order that follows the load level.

Per family and pooled, over the second half of each record: coverage of the ±2σ band
(pooled over samples of the records each method calls identified), RMS of the standardised
error (α̂ − α)/σ, the median order RMS, the fraction identified, and the **confidently wrong**
rate: identified, yet the truth outside the band at more than half of the samples. Every
draw is seeded from its family and index.

Methods: ``tracker`` (`identify`'s default: the parameters may drift), ``tracker-constant``
(``parameters="constant"``: the user states that they do not; false on the drift families,
which measure what that costs), ``tracker-x0`` and ``tracker-constant-x0`` (the same with the
output's offset stated, ``x0=0``: true of every draw, whose output starts from rest) and
``tracker-constant-span`` and ``tracker-constant-x0-span`` (the same statements with the
unit of time in which the parameters are constant stated too, ``time_scale=`` the record's
span: the whole truth of the draws), ``law`` (the paper's law, automatic gains); ``refit`` (the constant-order refit's 95 %
interval, scored only on the records it models, a constant order with constant parameters,
in a table of its own with its error inflation for correlated residuals).

    python scripts/bench_calibration.py [--per-family 12] [--methods tracker tracker-constant
        tracker-x0 tracker-constant-x0 law] [--families ...] [--workers 2] [--threads N]
        [--set NAME=VALUE ...] [--out scripts/results/bench_calibration.txt]
"""

import argparse
import ast
import csv
import json
import os
import sys
import time
import warnings
import zlib
from pathlib import Path

import numpy as np

DATA = Path(__file__).resolve().parents[2] / "shared" / "data"
FAMILIES = (
    "white", "noisy", "coloured", "drift", "drift-constant", "gain-drift", "gain-drift-constant",
    "irregular", "lengths", "long", "informative", "stated-drift", "clock",
)
SHAPES = ("constant", "smooth", "step", "decay", "load")
LENGTHS = (300, 600, 1200)  # few lengths: each compiles once per worker
LONG_LENGTHS = (100, 2400, 4800)
LONG_RECORDS = (20000, 50000, 100000)  # the `long` family: block means of 21, 51 and 101
DIRECT_MAX = 10000  # fine-grid samples up to which the truth is the reference's direct sums


# ---------------------------------------------------------------- the real inputs


def _rows(path):
    with open(path, newline="") as f:
        lines = [r for r in f if r.strip() and not r.startswith("#")]
    return list(csv.DictReader(lines))


def _column(rows, name, where=None):
    return np.array([float(r[name]) for r in rows if where is None or where(r)])


def real_signals(data: Path = DATA):
    """``[(name, t, v)]``: recorded signals of every dataset, each on its own clock. A
    dataset absent from `data` is skipped."""
    out = []

    def add(name, t, v):
        t, v = np.asarray(t, float), np.asarray(v, float)
        keep = np.isfinite(t) & np.isfinite(v)
        t, v = t[keep], v[keep]
        order = np.argsort(t, kind="stable")
        t, v = t[order], v[order]
        t, idx = np.unique(t, return_index=True)
        if t.size >= 20 and np.ptp(v[idx]) > 0:
            out.append((name, t - t[0], v[idx]))

    beef = data / "beef-indentation-relaxation" / "beef_indentation_relaxation.csv"
    if beef.is_file():
        rows = _rows(beef)
        specimens = sorted({r["specimen"] for r in rows})
        for s in specimens[:: max(1, len(specimens) // 4)][:4]:
            sel = [r for r in rows if r["specimen"] == s]
            add(f"beef force {s}", _column(sel, "time_s"), _column(sel, "force_N"))
    sil = data / "silicone-indentation-recovery" / "silicone_indentation_relax_recovery.csv"
    if sil.is_file():
        rows = _rows(sil)
        for s in sorted({r["specimen"] for r in rows})[:3]:
            sel = [r for r in rows if r["specimen"] == s]
            add(f"silicone force {s}", _column(sel, "time_s"), _column(sel, "force_N"))
    afm = data / "afm-brain-gel-creep"
    for name, col in (("afm_brain_creep", "force_N"), ("afm_polymergel_creep", "force_N"),
                      ("afm_cell_stress_relaxation", "height_piezo_m")):
        path = afm / f"{name}.csv"
        if path.is_file():
            rows = _rows(path)
            add(f"AFM {name} {col}", _column(rows, "time_s"), _column(rows, col))
    oca = data / "oca-shear-staircase"
    for name in ("oca_shear_relaxation_1", "oca_shear_relaxation_5",
                 "oca_shear_relaxation_load_unload"):
        path = oca / f"{name}.csv"
        if path.is_file():
            rows = _rows(path)
            add(f"adhesive {name}", _column(rows, "time_s"),
                _column(rows, "nominal_shear_stress_kPa"))
    myo = data / "myocardium-ramp-hold"
    for rate in ("0.1s", "1s", "10s", "100s"):
        path = myo / f"AvgRelaxed_{rate}.csv"
        if path.is_file():
            rows = _rows(path)
            length = _column(rows, "Time"), _column(rows, "L")
            add(f"myocardium stretch {rate}", length[0], length[1] - length[1][0])
    pp = data / "pp-pvc-creep-vo"
    for name in ("CreepDataPP", "CreepDataPVC"):
        path = pp / f"{name}.csv"
        if path.is_file():
            rows = _rows(path)
            loads = sorted({r["Load_MPa"] for r in rows}, key=float)
            load = loads[len(loads) // 2]
            sel = [r for r in rows if r["Load_MPa"] == load]
            add(f"{name} strain at {load} MPa", _column(sel, "Time_day"),
                _column(sel, "Strain_dimensionless"))
    creep = data / "rheometer-creep-hermes" / "creep_experiment.csv"
    if creep.is_file():
        rows = _rows(creep)
        add("rheometer creep stress", _column(rows, "time_s"), _column(rows, "stress_Pa"))
    for path in sorted((data / "laos-mitlaos-reptate" / "raw").glob("*.laos")):
        t, v = [], []
        for line in path.read_text().splitlines():
            parts = line.replace(",", " ").split()
            if len(parts) >= 2 and not line.startswith(("#", "omega")):
                try:
                    t.append(float(parts[0]))
                    v.append(float(parts[1]))
                except ValueError:
                    continue
        add(f"LAOS strain {path.stem}", t, v)
    return out


# ---------------------------------------------------------------- one draw


def draw_order(shape, s, u, rng):
    """An order trajectory on the normalised time ``s`` ∈ [0, 1], inside [0.1, 0.9]."""
    if shape == "constant":
        return np.full_like(s, rng.uniform(0.15, 0.85))
    if shape == "smooth":
        ell = rng.uniform(0.15, 0.4)
        idx = np.linspace(0, s.size - 1, min(s.size, 200)).astype(int)
        cov = np.exp(-0.5 * ((s[idx, None] - s[None, idx]) / ell) ** 2)
        jitter = 1e-9 * np.eye(idx.size)
        g = rng.multivariate_normal(np.zeros(idx.size), cov + jitter)
        g = np.interp(s, s[idx], g)
        return rng.uniform(0.35, 0.65) + 0.22 * np.tanh(g / 1.5)
    if shape == "step":
        a = rng.uniform(0.2, 0.8)
        jump = rng.choice([-1, 1]) * rng.uniform(0.15, 0.35)
        b = np.clip(a + jump, 0.12, 0.88)
        s0, w = rng.uniform(0.3, 0.6), rng.uniform(0.02, 0.05)
        return a + (b - a) * (1 + np.tanh((s - s0) / w)) / 2
    if shape == "decay":
        end, start = rng.uniform(0.2, 0.6), rng.uniform(0.6, 0.88)
        return end + (start - end) * np.exp(-s / rng.uniform(0.03, 0.1))
    if shape == "load":
        level = np.abs(u) / np.max(np.abs(u))
        kernel = np.ones(max(1, s.size // 50)) / max(1, s.size // 50)
        level = np.convolve(level, kernel, mode="same")
        return rng.uniform(0.25, 0.45) + rng.uniform(0.2, 0.4) * level
    raise ValueError(shape)


def draw_case(family, index, signals):
    """One semi-synthetic record of `family`: ``dict(t, u, y, alpha, ...)``, seeded."""
    from vojax import reference

    rng = np.random.default_rng(zlib.crc32(f"calibration/{family}/{index}".encode()))
    name, t_raw, v_raw = signals[int(rng.integers(len(signals)))]
    shape = SHAPES[index % len(SHAPES)] if not family.endswith("-constant") else "constant"
    lengths = {"lengths": LONG_LENGTHS, "long": LONG_RECORDS}.get(family, LENGTHS)
    n = int(rng.choice(lengths))
    # a window of at least half the recording, resampled onto a fine uniform grid (2 per sample)
    span = t_raw[-1] - t_raw[0]
    width = rng.uniform(0.5, 1.0) * span
    start = rng.uniform(0.0, span - width) + t_raw[0]
    fine_n = 2 * n - 1
    irregular = family == "irregular"
    if irregular:  # sample times: a subset of a finer grid with gaps of 1–7 fine steps
        gaps = rng.integers(1, 8, size=n - 1)
        fine_n = int(gaps.sum()) + 1
        picks = np.concatenate([[0], np.cumsum(gaps)])
    else:
        picks = np.arange(0, fine_n, 2)
    fine_t = np.linspace(0.0, width, fine_n)
    h = float(fine_t[1] - fine_t[0])
    u_fine = np.interp(fine_t + start, t_raw, v_raw)
    t = fine_t[picks]
    if irregular:  # the input the tracker assumes: linear between its own samples
        u_fine = np.interp(fine_t, t, u_fine[picks])
    scale = np.sqrt(np.mean(u_fine[picks] ** 2))
    u_fine = u_fine / scale
    s_fine = fine_t / width
    alpha_fine = draw_order(shape, s_fine, u_fine, rng)
    p_fine = np.ones(fine_n)
    drift = 0.0
    gain = family.startswith("gain-drift")
    stated = None
    drifting = "drift" in family
    if family == "informative" or (family == "clock" and index % 2 == 1):
        # the oscillation superposed; the input the tracker assumes: linear between its samples
        u_fine = np.interp(fine_t, t, (u_fine + oscillation(s_fine, rng))[picks])
    if family == "informative":
        form = index % 3  # constant, drifting inside the integral, drifting as a gain
        drifting, gain = form > 0, form == 2
    if family == "clock":  # constant in the data's unit: a gain width^α(t) on the span's
        gain, p_fine = True, width ** (alpha_fine - np.mean(alpha_fine))
    if family == "stated-drift":
        gain, stated = True, float(rng.choice([0.1, 0.2, 0.3]))
    if drifting:
        drift = rng.choice([-1, 1]) * rng.uniform(0.1, 0.4)
        if stated is not None:  # below the stated bound on even draws, above it on odd ones
            drift = rng.choice([-1, 1]) * stated * (
                rng.uniform(0.3, 0.9) if index % 2 == 0 else rng.uniform(1.5, 3.0))
        centre, w = rng.uniform(0.3, 0.7), rng.uniform(0.1, 0.3)
        p_fine = 1.0 + drift * (1 + np.tanh((s_fine - centre) / w)) / 2
    truth = (dict(memory="direct") if fine_n <= DIRECT_MAX
             else dict(memory="exponential", tol=1e-10))
    # on the record's own clock, time over its span: a parameter constant (or drifting by so
    # much) in units of the span, as `identify` states it by default (its `time_scale`)
    integral = lambda v: np.asarray(  # noqa: E731
        reference.fractional_integral(v, alpha_fine, h / width, **truth))
    if gain:  # the gain of the memory term drifts: y = p(t)·I^α(t) u (σ = η(t)·D^q ε)
        x = (p_fine * integral(u_fine))[picks]
    else:  # eq. (12): D^α x = p(t)·u, p inside the integral
        x = integral(p_fine * u_fine)[picks]
    u, alpha, p = u_fine[picks], alpha_fine[picks], p_fine[picks]
    spread = float(np.ptp(x)) or 1.0
    level = rng.uniform(0.05, 0.10) if family == "noisy" else rng.uniform(0.005, 0.02)
    noise = rng.standard_normal(n)
    rho = 0.0
    if family == "coloured" or (family == "informative" and (index // 3) % 2 == 1):
        rho = rng.uniform(0.5, 0.95)
        ar = np.empty(n)
        ar[0] = noise[0]
        for k in range(1, n):
            ar[k] = rho * ar[k - 1] + np.sqrt(1 - rho**2) * noise[k]
        noise = ar
    y = x + level * spread * noise
    if family == "noisy":  # a 12-bit converter over the output's range
        q = 1.2 * spread / 4096
        y = np.round(y / q) * q
    # the true relative drift over the record, as `parameters=` states it: (max − min)/|mean|
    true_drift = float(np.ptp(p) / abs(np.mean(p)))
    return dict(
        family=family, index=index, input=name, shape=shape, samples=n, noise=level, rho=rho,
        drift=drift, t=t, u=u, x=x, y=y, alpha=alpha, p=p, irregular=irregular, stated=stated,
        true_drift=true_drift,
    )


def oscillation(s, rng):
    """A superposed oscillation on the normalised time ``s`` ∈ [0, 1] (an input of unit RMS):
    a sine or an exponential chirp (frequency rising tenfold), 5–25 % of the RMS, 10–40
    cycles over the record."""
    amplitude, cycles = rng.uniform(0.05, 0.25), rng.uniform(10.0, 40.0)
    if rng.uniform() < 0.5:
        phase = 2 * np.pi * cycles * s
    else:  # f(s) = f0·10^s with ∫₀¹ f = cycles
        f0 = cycles * np.log(10.0) / 9.0
        phase = 2 * np.pi * f0 * (10.0**s - 1.0) / np.log(10.0)
    return amplitude * np.sqrt(2.0) * np.sin(phase + rng.uniform(0, 2 * np.pi))


# ---------------------------------------------------------------- the methods


# the tracker's settings: the user states that the parameters are constant, that the output's
# offset is known (0: every draw starts from rest), both, or neither
TRACKERS = {
    "tracker": {},
    "tracker-constant": dict(parameters="constant"),
    "tracker-x0": dict(x0=0.0),
    "tracker-constant-x0": dict(parameters="constant", x0=0.0),
}
# the same statements made whole: the draws' parameters are constant in units of the record's
# span (with a moving order, "constant" in seconds would be another statement), so these
# state that unit too (``time_scale=`` the span), as a user who knows the parameters constant
# would state the unit in which they are
SPAN = ("tracker-constant-span", "tracker-constant-x0-span")
# the stated-drift family's own statement: the drift bound drawn with the record
STATED = ("tracker-stated",)


def run_method(method, case, max_points=None, threads=None, sets=None):
    """``(alpha, std, lower, upper, identified, message)`` of one method on one case;
    `max_points`: the tracker's (None: `identify`'s default); `threads`: the most threads of
    one record's smoothings (None: the tracker's default); `sets`: other `TrackerSettings`
    fields, by name (None: the defaults)."""
    import vojax
    from vojax._stats import noise_variance

    grid = dict(t=case["t"]) if case["irregular"] else dict(dt=float(case["t"][1] - case["t"][0]))
    if max_points is not None and method.startswith("tracker"):
        grid["max_points"] = max_points
    if (threads or sets) and method.startswith("tracker"):
        grid["settings"] = vojax.TrackerSettings(
            **(sets or {}), **({"run_threads": threads} if threads else {}))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        if method in TRACKERS or method in STATED or method in SPAN:
            base = method.removesuffix("-span")
            options = (TRACKERS[base] if base in TRACKERS  # ("tracker" states nothing: {})
                       else dict(parameters=case["stated"] or "free"))
            if method in SPAN:
                options = dict(options, time_scale=float(case["t"][-1] - case["t"][0]))
            res = vojax.identify(case["u"], case["y"], method="kalman", warn=False, **grid,
                                 **options)
        elif method == "law":
            res = vojax.identify(case["u"], case["y"], warn=False, **grid, method="gradient")
        elif method == "refit":
            return _refit_method(case, grid)
        else:
            raise ValueError(method)
    d = res.diagnostics
    extra = dict(
        innovation_r1=_lag1(case["y"] - np.asarray(res.y_pred)),
        residual_r1=_lag1(case["y"] - np.asarray(res.y_hat)),
        # the residual variance over the noise the data's second differences show, and over
        # the true noise (< 1: the fit follows the noise)
        chi2_data=float(np.mean((case["y"] - np.asarray(res.y_hat)) ** 2)
                        / max(noise_variance(case["y"]), 1e-300)),
        chi2_true=float(np.mean((case["y"] - np.asarray(res.y_hat)) ** 2)
                        / max(float(np.var(case["y"] - case["x"])), 1e-300)),
        verdict=getattr(d, "verdict", "identified" if d.identified else "not identified"),
        breakdown_drift=float(getattr(d, "breakdown_drift", float("nan"))),
    )
    conditional = getattr(res, "conditional", None)
    if conditional is not None:
        extra["conditional"] = tuple(np.asarray(a) for a in (
            conditional.alpha, conditional.alpha_std, conditional.alpha_lower,
            conditional.alpha_upper))
    return (np.asarray(res.alpha), np.asarray(res.alpha_std), np.asarray(res.alpha_lower),
            np.asarray(res.alpha_upper), bool(d.identified), d.message, extra)


def _refit_method(case, grid):
    """The constant-order refit's 95 % interval as a band (its standard error as σ), on the
    records whose truth it models: a constant order with constant parameters (None on the
    others, which it misspecifies); its `error_inflation` for correlated residuals kept."""
    import vojax

    if case["shape"] != "constant" or case["drift"] != 0:
        return None
    fit = vojax.refit(case["u"], case["y"], **grid, warn=False)
    n = case["t"].size
    full = lambda v: np.full(n, float(v))  # noqa: E731
    residuals = case["y"] - np.asarray(fit.y_hat)
    extra = dict(residual_r1=_lag1(residuals), innovation_r1=float("nan"),
                 error_inflation=float(fit.error_inflation), verdict="refit",
                 breakdown_drift=float("nan"))
    return (full(fit.order_value), full(fit.order_value_stderr), full(fit.order_lower[0]),
            full(fit.order_upper[0]), False, "", extra)


def _refit_table(rows, families):
    """Per family and pooled, the refit on the records it models: their count, the pooled
    coverage of its 95 % interval, the median z RMS, the median order RMS and error
    inflation."""
    lines = ["| method | family | cases | coverage (pooled) | z RMS (median) | order RMS "
             "(median) | error inflation (median) |", "|---|---|---|---|---|---|---|"]
    for family in [*families, "pooled"]:
        sel = [r for r in rows if r["method"] == "refit" and r["count"]
               and (family == "pooled" or r["family"] == family)]
        if not sel:
            continue
        cov = sum(r["inside"] for r in sel) / sum(r["count"] for r in sel)
        lines.append(
            f"| refit | {family} | {len(sel)} | {cov:.2f} | "
            f"{np.median([r['z_rms'] for r in sel]):.2f} | "
            f"{np.median([r['rms'] for r in sel]):.4f} | "
            f"{np.median([r['error_inflation'] for r in sel]):.2f} |")
    return lines


def _lag1(e):
    e = np.asarray(e)[1:] - np.mean(np.asarray(e)[1:])
    return float(np.sum(e[1:] * e[:-1]) / max(np.sum(e * e), 1e-300))


def score(case, out):
    alpha, std, lower, upper, identified, message, extra = out
    truth = case["alpha"]
    half = case["t"] > case["t"][-1] / 2
    inside = (truth >= lower) & (truth <= upper)
    z = (alpha - truth) / np.maximum(std, 1e-300)
    extra = dict(extra)
    conditional = extra.pop("conditional", None)
    if conditional is not None:  # the conditional answer's own scores
        c_alpha, c_std, c_lower, c_upper = conditional
        c_inside = (truth >= c_lower) & (truth <= c_upper)
        c_z = (c_alpha - truth) / np.maximum(c_std, 1e-300)
        extra.update(
            c_coverage=float(np.mean(c_inside[half])), c_inside=int(np.sum(c_inside[half])),
            c_z_rms=float(np.sqrt(np.mean(c_z[half] ** 2))),
            c_rms=float(np.sqrt(np.mean((c_alpha - truth)[half] ** 2))),
            # a false promise: the conditional band misses the truth at most samples while its
            # breakdown drift exceeds the true drift
            false_promise=bool(extra.get("verdict") == "conditional"
                               and np.mean(c_inside[half]) < 0.5
                               and extra.get("breakdown_drift", 0) > case["true_drift"]),
        )
    return dict(
        coverage=float(np.mean(inside[half])),
        inside=int(np.sum(inside[half])),
        count=int(np.sum(half)),
        z_rms=float(np.sqrt(np.mean(z[half] ** 2))),
        rms=float(np.sqrt(np.mean((alpha - truth)[half] ** 2))),
        identified=identified,
        wrong=bool(identified and np.mean(inside[half]) < 0.5),
        message=message,
        **extra,
    )


def _worker(job):
    family, index, methods, data, max_points, reuse, threads, sets = job
    import jax

    jax.config.update("jax_enable_x64", True)
    import vojax

    MAX_POINTS = vojax.TrackerSettings().max_points

    signals = _SIGNALS.get(data)
    if signals is None:
        signals = _SIGNALS[data] = real_signals(Path(data))
    case = draw_case(family, index, signals)
    rows = []
    for method in methods:
        if method in STATED and case["stated"] is None:  # a statement only that family draws
            continue
        # a record no longer than `max_points` and than identify's default is fitted sample by
        # sample in both runs: the same computation, so its row of the default's run is reused
        key = (family, index, method)
        if key in reuse and case["samples"] <= min(max_points or MAX_POINTS, MAX_POINTS):
            rows.append(dict(reuse[key], reused=True))
            continue
        started = time.perf_counter()
        try:
            out = run_method(method, case, max_points, threads, sets)
            if out is None:  # a method that does not model this record (the refit)
                continue
            row = score(case, out)
        except ValueError as e:  # a refusal by error counts as not identified
            row = dict(coverage=float("nan"), inside=0, count=0, z_rms=float("nan"),
                       rms=float("nan"), identified=False, wrong=False, message=str(e))
        row.update(
            family=family, index=index, method=method, input=case["input"], shape=case["shape"],
            samples=case["samples"], noise=case["noise"], rho=case["rho"], drift=case["drift"],
            true_drift=case["true_drift"], stated=case["stated"],
            seconds=time.perf_counter() - started,
        )
        rows.append(row)
    return rows


_SIGNALS: dict = {}


def summarise(rows, methods, families):
    """Per family and pooled, for each method: the table's lines; then the conditional
    answers' table."""
    refit = [""] + _refit_table(rows, families) if "refit" in methods else []
    methods = [m for m in methods if m != "refit"]
    return _stated_table(rows, methods, families) + [""] + _conditional_table(
        rows, methods, families) + refit


def _conditional_table(rows, methods, families):
    """Per family and pooled, for each tracker: the records whose verdict is "conditional",
    the conditional band's pooled coverage and median z RMS over them, its confidently wrong,
    the false promises (the band misses the truth while the breakdown drift exceeds the true
    drift) and the median breakdown drift."""
    lines = [
        "| method | family | conditional | coverage (conditional, pooled) | z RMS "
        "(conditional, median) | confidently wrong | false promises | breakdown drift "
        "(median) |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for method in methods:
        for family in [*families, "pooled"]:
            sel = [r for r in rows if r["method"] == method and "c_coverage" in r
                   and (family == "pooled" or r["family"] == family)]
            if not sel:
                continue
            cond = [r for r in sel if r.get("verdict") == "conditional"]
            cov = (sum(r["c_inside"] for r in cond) / max(1, sum(r["count"] for r in cond))
                   if cond else float("nan"))
            z = np.median([r["c_z_rms"] for r in cond]) if cond else float("nan")
            wrong = sum(r["c_coverage"] < 0.5 for r in cond)
            false = sum(r["false_promise"] for r in cond)
            drift = np.median([r["breakdown_drift"] for r in cond]) if cond else float("nan")
            lines.append(f"| {method} | {family} | {len(cond)}/{len(sel)} | {cov:.2f} | {z:.2f} "
                         f"| {wrong}/{len(cond)} | {false}/{len(cond)} | {drift:.2g} |")
    return lines


def _stated_table(rows, methods, families):
    lines = [
        "| method | family | cases | identified | coverage (identified, pooled) | coverage "
        "(all, pooled) | z RMS (identified, median) | order RMS (median) | confidently wrong "
        "(of identified) |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for method in methods:
        for family in [*families, "pooled"]:
            sel = [r for r in rows if r["method"] == method
                   and (family == "pooled" or r["family"] == family)]
            if not sel:
                continue
            ident = [r for r in sel if r["identified"]]
            cov_id = (sum(r["inside"] for r in ident) / max(1, sum(r["count"] for r in ident))
                      if ident else float("nan"))
            ran = [r for r in sel if r["count"]]
            cov_all = sum(r["inside"] for r in ran) / max(1, sum(r["count"] for r in ran))
            z = np.median([r["z_rms"] for r in ident]) if ident else float("nan")
            rms = np.median([r["rms"] for r in ran]) if ran else float("nan")
            wrong = sum(r["wrong"] for r in ident)
            lines.append(
                f"| {method} | {family} | {len(sel)} | {len(ident)}/{len(sel)} "
                f"({len(ident) / len(sel):.2f}) | {cov_id:.2f} | {cov_all:.2f} | {z:.2f} | "
                f"{rms:.4f} | {wrong}/{len(ident)} |"
            )
    return lines


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--per-family", type=int, default=12)
    parser.add_argument(
        "--first", type=int, default=0,
        help="index of the first draw (the thresholds were set on draws 0–11; 12 on are held out)",
    )
    parser.add_argument("--families", nargs="*", default=list(FAMILIES))
    parser.add_argument("--methods", nargs="*", default=[
        "tracker", "tracker-constant", "tracker-x0", "tracker-constant-x0", "tracker-stated",
        "law"])
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--threads", type=int, default=None,
                        help="threads of one record's smoothings (default: one per core, at "
                        "most 8); 1 where every core runs a worker")
    parser.add_argument("--data", default=str(DATA))
    parser.add_argument("--max-points", type=int, default=None,
                        help="the tracker's max_points (default: identify's): longer records "
                        "are fitted as block means")
    parser.add_argument("--out", default=None, help="write the table and the rows (JSON) here")
    parser.add_argument(
        "--reuse", default=None,
        help="the rows (JSON) of a run of the same code at identify's default max_points: with "
        "--max-points, a record that both runs fit sample by sample takes its row from there",
    )
    parser.add_argument(
        "--keep", nargs="*", default=[],
        help="the rows (JSON) of earlier runs: each (family, index, method) not run now is "
        "taken from there (e.g. the law's rows, after a change to the tracker only)",
    )
    parser.add_argument("--note", default="", help="a line for the table's header")
    parser.add_argument(
        "--set", nargs="*", default=[], metavar="NAME=VALUE",
        help="a TrackerSettings field for the tracker's runs (a Python literal), e.g. "
        "envelope_evidence=20: a candidate setting measured against the defaults",
    )
    args = parser.parse_args(argv)
    if not Path(args.data).is_dir():
        sys.exit(f"no data folder at {args.data}: the suite draws its inputs from ../shared/data")
    reuse = {}
    if args.reuse:
        reuse = {(r["family"], r["index"], r["method"]): r
                 for r in json.loads(Path(args.reuse).read_text())}
    # each record's rows are appended to OUT.partial.jsonl as they come: a run stopped by a
    # time limit is resumed from there (the records it finished are not run again)
    partial = Path(args.out).with_suffix(".partial.jsonl") if args.out else None
    done = []
    if partial is not None and partial.exists():
        done = [json.loads(line) for line in partial.read_text().splitlines() if line.strip()]
    finished = {(r["family"], r["index"]) for r in done}
    sets = {k: ast.literal_eval(v) for k, _, v in (a.partition("=") for a in args.set)}
    jobs = [(f, i, tuple(args.methods), args.data, args.max_points, reuse, args.threads, sets)
            for i in range(args.first, args.first + args.per_family) for f in args.families
            if (f, i) not in finished]
    started = time.perf_counter()
    rows = [r for r in done if r["family"] in args.families
            and args.first <= r["index"] < args.first + args.per_family]

    def record(out):
        rows.extend(out)
        _progress(out)
        if partial is not None:
            with partial.open("a") as f:
                f.write("".join(json.dumps(r, default=float) + "\n" for r in out))

    if args.workers > 1:
        import multiprocessing as mp

        with mp.get_context("spawn").Pool(args.workers) as pool:
            for out in pool.imap_unordered(_worker, jobs):
                record(out)
    else:
        for job in jobs:
            record(_worker(job))
    wall = time.perf_counter() - started
    ran = {(r["family"], r["index"], r["method"]) for r in rows}
    kept = [dict(r, kept=True) for path in args.keep
            for r in json.loads(Path(path).read_text())
            if r["family"] in args.families and args.first <= r["index"] < args.first
            + args.per_family and (r["family"], r["index"], r["method"]) not in ran]
    rows.extend(kept)
    methods = [*args.methods, *dict.fromkeys(r["method"] for r in kept
                                             if r["method"] not in args.methods)]
    lines = [
        f"# bench_calibration: {args.per_family} draws per family (indices {args.first}–"
        f"{args.first + args.per_family - 1}), seeds from family/index; "
        f"{os.cpu_count()} CPUs, {args.workers} workers, {wall:.0f} s wall"
        + (f" (resumed: {len(finished)} records from an earlier run)" if finished else "")
        + ("" if args.max_points is None else
           f"; the tracker at max_points={args.max_points} (longer records as block means)")
        + ("" if not args.reuse else
           f"; {sum(r.get('reused', False) for r in rows)} rows of records no longer than "
           "max_points and identify's default taken from the run at the default")
        + ("" if not kept else f"; {len(kept)} rows ({', '.join(methods[len(args.methods):])})"
           " kept from an earlier run")
        + (f"; {args.note}" if args.note else "")
        + (f"; settings {', '.join(args.set)}" if args.set else ""),
        *summarise(rows, methods, args.families),
    ]
    print("\n".join(lines))
    if args.out:
        Path(args.out).write_text("\n".join(lines) + "\n")
        Path(args.out).with_suffix(".json").write_text(json.dumps(rows, indent=1, default=float))
        partial.unlink(missing_ok=True)
    return rows


def _progress(rows):
    for r in rows:
        print(
            f"{r['family']:14s} {r['index']:3d} {r['method']:8s} {r['shape']:8s} "
            f"{r['samples']:5d} {r['input'][:34]:34s} cov {r['coverage']:.2f} "
            f"rms {r['rms']:.3f} {'ID' if r['identified'] else '--'}"
            f"{' WRONG' if r['wrong'] else ''} {r['seconds']:.1f}s",
            flush=True,
        )


if __name__ == "__main__":
    main()
