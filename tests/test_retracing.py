"""Every public entry point traces its compiled programs once per shape and static setting:
new data, new numbers (gains, steps, tolerances, start orders) reuse them. Each program is
replaced by a fresh `eqx.debug.assert_max_traces(max_traces=1)` wrapper, so a second trace
raises; `get_num_traces` checks that the wrapper was really used."""

import subprocess
import sys

import equinox as eqx
import jax
import numpy as np
import pytest

import vojax
from vojax import _integral, _refit_active, _tune
from vojax._adaptive import _build, _estimator
from vojax._tracker import _start, _tuning

from .helpers import paper_inputs


def _once(monkeypatch, module, name):
    """Replaces the compiled function ``module.name`` by one that may trace only once."""
    limited = eqx.debug.assert_max_traces(getattr(module, name).__wrapped__, max_traces=1)
    monkeypatch.setattr(module, name, eqx.filter_jit(limited))
    return limited


def _record(n, order, seed, dt=0.1):
    _, u, _ = paper_inputs(n, dt)
    x = np.asarray(vojax.simulate(u, order, np.array([1.5, -0.7]), dt))
    return u, x + 0.01 * np.random.default_rng(seed).standard_normal(n)


def test_refit_traces_once(monkeypatch):
    fit = _once(monkeypatch, _refit_active, "_fit")
    u, y = _record(150, 0.4, 0)
    vojax.refit(u, y, 0.1)
    u2, y2 = _record(150, 0.6, 1)
    vojax.refit(u2, y2, 0.1 * 1.01, order0=0.3, rtol=1e-9, atol=1e-9)
    vojax.refit(u2, y2, 0.1, mask=np.r_[np.ones(140), np.zeros(10)])
    assert eqx.debug.get_num_traces(fit) == 1


@pytest.mark.slow
def test_tune_gains_traces_once(monkeypatch):
    grid = _once(monkeypatch, _tune, "_grid_losses")
    refine = _once(monkeypatch, _tune, "_refine")
    u, y = _record(120, 0.4, 2)
    vojax.tune_gains(u, y, 0.1)
    u2, y2 = _record(110, 0.6, 3)
    vojax.tune_gains(u2, y2, 0.1 * 1.01, alpha0=0.4, pad_to=120)
    assert eqx.debug.get_num_traces(grid) == 1 and eqx.debug.get_num_traces(refine) == 1


@pytest.mark.slow
def test_identify_with_given_gains_traces_once(monkeypatch):
    law = _once(monkeypatch, _estimator, "run_law")
    band = _once(monkeypatch, _estimator, "law_covariance")
    scan = _once(monkeypatch, _build, "scan_memory")  # the automatic R₀
    u, y = _record(130, 0.4, 4)
    vojax.identify(u, y, 0.1, gamma=0.5, warn=False, method="gradient")
    u2, y2 = _record(130, 0.6, 5)
    vojax.identify(u2, y2, 0.1 * 1.01, gamma=2.0, lam=0.3, alpha0=0.4, warn=False, method="gradient")
    assert [eqx.debug.get_num_traces(f) for f in (law, band, scan)] == [1, 1, 1]


def test_fractional_integral_traces_once(monkeypatch):
    scan = _once(monkeypatch, _integral, "scan_memory")
    _, u, alpha = paper_inputs(200, 0.05)
    vojax.fractional_integral(u, alpha, 0.05)
    vojax.fractional_integral(2 * u, 0.3, 0.07)
    assert eqx.debug.get_num_traces(scan) == 1


@pytest.mark.slow
def test_tracker_traces_once(monkeypatch):
    from vojax._tracker import _smoother

    # every smoothing (first pass, refinement, mixture, held order) runs one program
    limited = [_once(monkeypatch, _smoother, "smooth_compiled")]
    limited += [_once(monkeypatch, _tuning, "_refine_compiled"),
                _once(monkeypatch, _start, "_phi_constant")]
    u, y = _record(120, 0.4, 6)
    vojax.identify(u, y, 0.1, method="kalman", warn=False)
    u2, y2 = _record(120, 0.6, 7)
    vojax.identify(u2, y2, 0.1 * 1.01, method="kalman", warn=False)
    # a known offset is held by the prior: the same programs
    vojax.identify(u2, y2, 0.1, method="kalman", x0=0.0, warn=False)
    # given intensities (Python numbers) smooth with the tuned path's program
    vojax.identify(u2, y2, 0.1, method="kalman", warn=False,
                   noise=dict(order_drift=1e-3, parameter_drift=1e-4, noise_std=0.01))
    assert [eqx.debug.get_num_traces(f) for f in limited] == [1, 1, 1]


# a fresh process that records the name of every program XLA compiles once the record is
# made (`jax_log_compiles`), runs `identify` on it and prints its block size and the names
_FIRST_CALL = r"""
import logging, re, jax
jax.config.update("jax_enable_x64", True)
import numpy as np, vojax
names = []
class Keep(logging.Handler):
    def emit(self, record):
        m = re.search(r"Finished XLA compilation of jit\((\w+)\)", record.getMessage())
        if m:
            names.append(m.group(1))
logging.getLogger("jax").addHandler(Keep())
logging.getLogger("jax").setLevel(logging.WARNING)
{record}
jax.config.update("jax_log_compiles", True)
res = vojax.identify(u, y, dt, warn=False)
print(res.diagnostics.block)
print(",".join(names))
"""


def _first_call_programs(record: str, timeout: int):
    """``(block, names)`` of a fresh process's first `identify` on the record that the code
    `record` makes (``u``, ``y``, ``dt``)."""
    done = subprocess.run([sys.executable, "-c", _FIRST_CALL.format(record=record)],
                          capture_output=True, text=True, timeout=timeout)
    assert done.returncode == 0, done.stderr[-2000:]
    block, names = done.stdout.strip().splitlines()[-2:]
    return int(block), names.split(",")


def _assert_only(names, programs):
    """Each of `programs` compiled once, and besides them at most the log of the held order's
    two intensities (`held_order`: kept in JAX, whose log may differ from NumPy's in the last
    bit); JAX 0.4 also compiles an `add` and a `convert_element_type` while it traces the
    constant fit."""
    assert [names.count(n) for n in programs] == [1] * len(programs), names
    allowed = {"log"}
    if tuple(int(v) for v in jax.__version__.split(".")[:2]) < (0, 5):
        allowed |= {"add", "convert_element_type"}
    rest = [n for n in names if n not in programs]
    assert set(rest) <= allowed and len(rest) == len(set(rest)), names


def test_the_first_tracker_call_compiles_a_handful_of_programs():
    """A fresh process's first `identify` (the tracker) compiles one smoothing program for
    all its smoothings, the refinement, and one program of Φ at a constant order for the
    constant fit and the trade-off's profile, and next to nothing else: an eager JAX
    operation on the host side (each compiles a program of its own, ~0.01–0.05 s; newer JAX
    compiles one for every `jnp.asarray` of a host array of a new shape or dtype), a second
    way of running the smoother (~1 s) or a profile compiled for its own shapes (~0.3 s)
    shows up here."""
    block, names = _first_call_programs("""
dt = 0.1
t = np.arange(200) * dt
u = np.minimum(t, 5.0) + 0.2 * np.sin(t)
y = np.asarray(vojax.reference.fractional_integral(u, 0.3 + 0.3 * t / t[-1], dt))
y = y + 0.01 * np.ptp(y) * np.random.default_rng(0).standard_normal(t.size)
""", timeout=600)
    assert block == 1
    _assert_only(names, ["smooth_compiled", "_refine_compiled", "_phi_constant"])


@pytest.mark.slow
def test_a_blocked_first_call_compiles_only_its_programs():
    """A long record fitted as block means (20,000 samples, blocks of 21) compiles the
    batched smoothing, the single one (the climb), the refinement, Φ at a constant order and
    the two runs over every sample, and no program that moves host arrays (the batch's
    fields, the block clock's steps)."""
    block, names = _first_call_programs("""
dt, n = 0.05, 20000
t = np.arange(n) * dt
u = np.minimum(t / (0.2 * t[-1]), 1.0) + 0.05 * np.sin(t)
x = np.asarray(vojax.simulate(u, 0.35 + 0.2 * t / t[-1], np.array([2.0]), dt))
y = x + 0.01 * np.ptp(x) * np.random.default_rng(0).standard_normal(n)
""", timeout=900)
    assert block == 21
    _assert_only(names, ["smooth_batched", "smooth_compiled", "_refine_compiled",
                         "_phi_constant", "scan_memory_orders", "scan_memory"])


def test_import_leaves_the_solvers_and_plotting_for_when_they_are_used():
    """`import vojax` does not import optimistix (about 0.07 s of the import: only the refit,
    the law's gain tuning and the design use it), matplotlib or tqdm; the refit imports
    optimistix when it runs."""
    code = (
        "import sys, numpy as np, jax\n"
        "jax.config.update('jax_enable_x64', True)\n"
        "import vojax\n"
        "print(sorted(m for m in ('optimistix', 'matplotlib', 'tqdm') if m in sys.modules))\n"
        "u = np.ones(60)\n"
        "vojax.refit(u, np.asarray(vojax.reference.fractional_integral(u, 0.5, 0.1)), 0.1)\n"
        "print('optimistix' in sys.modules)\n"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=600)
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.split() == ["[]", "True"], done.stdout


def test_the_settling_test_padded_traces_once_for_records_of_two_lengths(monkeypatch):
    """The batch pads each record's settling test to a few lengths: two records of 150 and
    170 samples padded to 256 run one compiled Jacobian (unpadded they would run two)."""
    from vojax import _design

    jac = _once(monkeypatch, _design, "_jacobian")
    for n in (150, 170):
        times = 0.1 * np.arange(n) * (1 + 1e-3 * n)
        u = np.minimum(times / 3.0, 1.0)
        vojax.settling_test(u, 0.4, [2.0], t=times, noise_std=0.01, cycles=(5,), starts=(0.5,),
                            pad_to=256)
    assert eqx.debug.get_num_traces(jac) == 1
