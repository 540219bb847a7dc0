import dataclasses
import math
from pathlib import Path

import jax.numpy as jnp
import numpy as np

import vojax

# the recorded inputs beside the project (``../shared/data``); tests that need them skip where
# the folder is absent
SHARED_DATA = Path(__file__).resolve().parents[2] / "shared" / "data"


def paper_inputs(n: int, dt: float):
    """The inputs and order of the simulation study (34) on ``n`` samples."""
    t = np.arange(n) * dt
    u = np.stack([np.sin(0.5 * t), np.cos(0.2 * t)], axis=1)
    alpha = 0.15 * np.exp(-0.02 * t) * (np.cos(0.2 * t) + 2) + 0.4
    return t, u, alpha


def power_law(t, mu, b):
    """Φ and ∂Φ/∂b for u = t^μ (NOTES §1)."""
    from vojax._kernels._special import digamma

    b = np.broadcast_to(np.asarray(b, float), t.shape)
    lg = np.vectorize(math.lgamma)
    safe = np.where(t > 0, t, 1.0)
    phi = np.where(t > 0, np.exp(lg(mu + 1) - lg(mu + 1 + b) + (mu + b) * np.log(safe)), 0.0)
    return phi, phi * (np.log(safe) - digamma(mu + 1 + b))


def slope(hs, errors):
    """Least-squares slope of log(error) against log(h): the measured convergence order."""
    return float(np.polyfit(np.log(hs), np.log(errors), 1)[0])


def rel_max(a, b):
    a, b = np.asarray(a), np.asarray(b)
    return float(np.max(np.abs(a - b)) / np.max(np.abs(b)))


def load_script(name):
    """The module of ``scripts/<name>.py`` (scripts are not a package), with the scripts'
    folder on ``sys.path`` as when the script runs (its shared ``_bench`` helpers)."""
    import importlib.util
    import sys
    from pathlib import Path

    folder = Path(__file__).resolve().parents[1] / "scripts"
    if str(folder) not in sys.path:
        sys.path.append(str(folder))
    path = folder / f"{name}.py"
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def fresh_cli(*args, cwd):
    """``vojax ARGS`` in a fresh Python process in the folder `cwd` (its own loops: the
    command's default, fast ones), as ``subprocess.run`` reports it."""
    import os
    import subprocess
    import sys

    env = {k: v for k, v in os.environ.items() if k != "XLA_FLAGS"}
    return subprocess.run([sys.executable, "-m", "vojax", *args], cwd=cwd,
                          capture_output=True, text=True, env=env)


def run_cli(*args, cwd):
    """``vojax ARGS`` run by this process in the folder `cwd`, reported as
    ``subprocess.run(..., capture_output=True, text=True)`` reports a command: its exit
    status (an argument refused by argparse included), its standard output and error. With
    XLA's default loops (this process has computed already), so its numbers equal
    `identify`'s here; the environment the command sets for itself (its log level, its
    warnings filter) is restored after it. `fresh_cli` runs it in a fresh process."""
    import contextlib
    import io
    import os
    import subprocess

    from vojax._cli import main

    out, err = io.StringIO(), io.StringIO()
    environ = dict(os.environ)
    os.environ["VOJAX_FAST_CPU_LOOPS"] = "0"
    try:
        with contextlib.chdir(cwd), contextlib.redirect_stdout(out), \
                contextlib.redirect_stderr(err):
            try:
                code = main([str(a) for a in args])
            except SystemExit as e:  # argparse's refusal
                code = e.code if isinstance(e.code, int) else int(e.code is not None)
    finally:
        os.environ.clear()
        os.environ.update(environ)
    return subprocess.CompletedProcess(["vojax", *args], code, out.getvalue(), err.getvalue())


def make_problem(memory, u, y, *, dt=None, times=None, mask=None, bounds=(0.01, 0.99),
                 settings=None, offset_known=False, batched=False):
    """A tracker `Problem` on arrays given as they are (no normalisation): `u` (N, n), `y`
    (N,), on the step `dt` or at the sample `times`, every sample fitted unless `mask`."""
    import jax.numpy as jnp

    from vojax import TrackerSettings
    from vojax._tracker._problem import Problem, prior

    settings = TrackerSettings() if settings is None else settings
    u, y = jnp.asarray(u), jnp.asarray(y)
    num = y.shape[0]
    mask = jnp.ones(num) if mask is None else jnp.asarray(mask, float)
    times = dt * np.arange(num) if times is None else np.asarray(times, float)
    steps = np.diff(times)
    steps = jnp.asarray(np.concatenate([steps, steps[-1:]]))
    last = int(np.flatnonzero(np.asarray(mask) > 0)[-1])
    horizon = jnp.asarray(times[last] - times[0])
    m0, p0 = prior(u.shape[1], u.dtype, settings, offset_known=offset_known)
    return Problem(memory, u, y, mask, steps, horizon, m0, p0, bounds, times, last, settings,
                   batched=batched)


def mittag_leffler_series(alpha, x, offset=1, plus_alpha=False):
    """E_{α,β}(−x), β = `offset` (+ α where `plus_alpha`), by mpmath's power series at enough
    digits to absorb its cancellation (the largest term is about e^{x^{1/α}}; α·k and β are
    formed in mpmath, since a double's rounding of them, amplified by the cancellation,
    would cost the reference 1e-9). Needs mpmath."""
    import mpmath

    digits = 30 + int(x ** (1 / alpha) / 2.3)
    with mpmath.workdps(digits):
        xs, a = mpmath.mpf(float(x)), mpmath.mpf(alpha)
        b = offset + (a if plus_alpha else 0)
        total, k = mpmath.mpf(0), 0
        while True:
            term = (-xs) ** k / mpmath.gamma(a * k + b)
            total += term
            if k > 10 and abs(term) < mpmath.mpf(10) ** (-digits):
                return float(total)
            k += 1


def ramp_case(n=1500, dt=0.1, noise=0.02, seed=0):
    t = np.arange(n) * dt
    u = np.stack([np.sin(0.5 * t) + 0.3, np.cos(0.2 * t)], axis=1)
    alpha = 0.3 + 0.4 * t / t[-1]
    p = np.array([2.0, -1.5])
    x = np.asarray(vojax.simulate(u, alpha, p, dt)) + 0.7
    y = x + noise * np.std(x) * np.random.default_rng(seed).standard_normal(n)
    return t, u, y, alpha, p, dt


def normalised_problem(case, num, columns=None, settings=None):
    """The tracker's problem for the first `num` samples of a `ramp_case` (its first
    `columns` inputs, or all), its input and output normalised (the constant fit's rescaling
    left out) and the constant starts: ``(Problem, starts)``."""
    from vojax._integral import make_memory
    from vojax._tracker._problem import data_scales
    from vojax._tracker._start import starting_trajectories

    t, u, y, *_, dt = case
    u, y = jnp.asarray(u[:num, :columns]), jnp.asarray(y[:num])
    memory = make_memory("exponential", dt, num, order_range=(0.01, 0.99))
    scales = data_scales(u, y, jnp.ones(num))
    un = u / jnp.asarray(scales.u_scale)
    yn = (y - scales.y_ref) / scales.y_scale
    problem = make_problem(memory, un, yn, dt=dt, settings=settings)
    return problem, np.asarray(starting_trajectories(problem, 0.5))


def gain_drift_case(n=300, alpha=0.45, noise=0.01, seed=3, width=0.15, centre=0.5):
    """One input, an order (constant, or `alpha` of each sample), and a gain that rises by
    30 % about `centre` of the record over about ±`width` of it: ``y = p(t)·I^α u + c`` (a
    tissue stiffening during a test)."""
    from vojax import reference

    dt = 0.05
    t = np.arange(n) * dt
    u = 1.0 - np.exp(-t / 3.0) + 0.2 * np.sin(0.7 * t)
    s = t / t[-1]
    p = 1.0 + 0.3 * (1.0 + np.tanh((s - centre) / width)) / 2.0
    orders = np.broadcast_to(np.asarray(alpha, float), (n,))
    x = p * np.asarray(reference.fractional_integral(u[:, None], orders, dt))[:, 0]
    sd = noise * np.ptp(x)
    y = x + 0.2 + sd * np.random.default_rng(seed).standard_normal(n)
    return t, u, y, dt, sd


def band_calls(monkeypatch, **options):
    """The calls the tracker makes to its band (`vojax._tracker._fit.bands`) while
    `identify` fits `ramp_case(n=300)`'s first input with `options`: a list of
    ``(explanations, args, kwargs)``."""
    from vojax._tracker import _band, _fit

    seen = []

    def spy(explanations, *args, **kwargs):
        seen.append((explanations, args, kwargs))
        return _band.bands(explanations, *args, **kwargs)

    monkeypatch.setattr(_fit, "bands", spy)
    _, u, y, _, _, dt = ramp_case(n=300)
    vojax.identify(u[:, :1], y, dt, method="kalman", warn=False, **options)
    return seen


@dataclasses.dataclass(frozen=True)
class ClockResult:
    """A stand-in for the tracker's result: the fields `weigh_clock` reads and writes."""

    alpha: np.ndarray
    alpha_lower: np.ndarray
    alpha_upper: np.ndarray
    alpha_std: np.ndarray
    converged: bool = True
    tuning: object = None  # `log_likelihood` only


def clock_fit(alpha, half_width, converged=True, log_likelihood=0.0):
    """A stand-in result with the band ``alpha ± half_width`` (σ a quarter of its width) and
    a tuning of that log-likelihood, and its fitted points (every sample fitted), as
    `vojax._tracker._clock.weigh_clock` reads them."""
    alpha = np.asarray(alpha, float)
    lo, hi = alpha - half_width, alpha + half_width
    tuning = type("Tuning", (), dict(log_likelihood=float(log_likelihood)))()
    res = ClockResult(alpha, lo, hi, np.full(alpha.size, half_width / 2), converged, tuning)
    return res, dict(alpha=alpha, lower=lo, upper=hi, span=alpha.size)
