"""The calibration suite's draws: semi-synthetic records whose truth is known.

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

Every draw is seeded from its family and index (`draw_case`); `scripts/bench_calibration.py`
runs the estimators on them and scores their bands.
"""

import csv
import sys
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


def suite_signals(data: Path = DATA):
    """For a script on the suite's draws: float64 on, and the recorded signals under `data`,
    or the script's exit saying there are none."""
    import jax

    jax.config.update("jax_enable_x64", True)
    signals = real_signals(data)
    if not signals:
        sys.exit(f"no recorded signals under {data}")
    return signals


def within(ratios, factor) -> float:
    """The share of the `ratios` (realised over predicted) within a `factor` either way."""
    return float(np.mean(np.abs(np.log(ratios)) <= np.log(factor)))


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
