"""`use_fast_cpu_loops`: the XLA_FLAGS it writes, its errors, and that it changes speed only."""

import json
import os
import subprocess
import sys

import jax
import numpy as np
import pytest

import vojax
from vojax import _xla

KEY = _xla.THRESHOLD_KEY


@pytest.mark.parametrize(
    "flags, expected",
    [
        ("", None),
        ("--xla_force_host_platform_device_count=4", None),
        (f"--xla_backend_extra_options={KEY}=2048", 2048),
        (f"--a=1 --xla_backend_extra_options=foo=1,{KEY}=77,bar", 77),
        ("--xla_backend_extra_options=foo=1", None),
    ],
)
def test_threshold_is_read_from_flags(flags, expected):
    assert _xla.fast_cpu_loops_threshold(flags) == expected


def test_flags_are_written_and_merged(monkeypatch):
    monkeypatch.setattr(_xla, "_backend_started", lambda: False)
    monkeypatch.setenv("XLA_FLAGS", "--xla_force_host_platform_device_count=4")
    assert vojax.use_fast_cpu_loops(4096) is True
    assert os.environ["XLA_FLAGS"] == (
        f"--xla_force_host_platform_device_count=4 --xla_backend_extra_options={KEY}=4096"
    )
    assert _xla.fast_cpu_loops_threshold() == 4096
    # a second call leaves the first threshold alone
    assert vojax.use_fast_cpu_loops(1) is False
    assert _xla.fast_cpu_loops_threshold() == 4096

    monkeypatch.setenv("XLA_FLAGS", "--xla_backend_extra_options=foo=1 --x=2")
    assert vojax.use_fast_cpu_loops() is True
    assert os.environ["XLA_FLAGS"] == (
        f"--xla_backend_extra_options=foo=1,{KEY}={_xla.DEFAULT_THRESHOLD} --x=2"
    )

    monkeypatch.delenv("XLA_FLAGS")
    assert vojax.use_fast_cpu_loops() is True
    assert os.environ["XLA_FLAGS"] == f"--xla_backend_extra_options={KEY}={_xla.DEFAULT_THRESHOLD}"


def test_errors(monkeypatch):
    monkeypatch.delenv("XLA_FLAGS", raising=False)
    jax.numpy.zeros(1).block_until_ready()
    # this process has computed already: the flag would be ignored, so it is an error
    with pytest.raises(RuntimeError, match="before the first JAX computation"):
        vojax.use_fast_cpu_loops()
    assert "XLA_FLAGS" not in os.environ
    for bad in (0, -5, 1.5, True, "1024"):
        with pytest.raises(ValueError, match="threshold_bytes"):
            vojax.use_fast_cpu_loops(bad)


_SCRIPT = """
import json, sys
import vojax
if sys.argv[1] == "fast":
    vojax.use_fast_cpu_loops()
import jax
jax.config.update("jax_enable_x64", True)
import jax.numpy as jnp
from vojax._adaptive._build import build_law, run_law

s = vojax.simulate_study(0.1, seed=3)
u, y = jnp.asarray(s["u"]), jnp.asarray(s["y"] - s["y"][0])
law = build_law(0.1, u.shape[0], lam=0.9, gamma=0.01, alpha0=0.5, alpha_bounds=(0.05, 0.95),
                memory="exponential", rule="trapezoid")
compiled = jax.jit(lambda u, y: run_law(law, u, y)).lower(u, y).compile()
out = compiled(u, y)
phi = vojax.order_sensitivity(s["u"], s["alpha"], 0.1, memory="exponential")
tracker = vojax.identify(s["u"][:200], s["y"][:200], 0.1, warn=False)  # the default
print(json.dumps(dict(alpha=out.alpha.tolist(), p=out.p.tolist(), dphi=phi.tolist(),
                      tracker=tracker.alpha.tolist(), band=tracker.alpha_upper.tolist(),
                      one_kernel="xla_cpu_small_call" in compiled.as_text())))
"""


def _run(mode):
    env = {k: v for k, v in os.environ.items() if k != "XLA_FLAGS"}
    proc = subprocess.run(
        [sys.executable, "-c", _SCRIPT, mode], capture_output=True, text=True, env=env, check=True
    )
    return json.loads(proc.stdout)


@pytest.mark.slow
def test_fast_loops_take_effect_and_change_nothing_but_speed():
    default, fast = _run("default"), _run("fast")
    # the scan of the law is compiled as one kernel only under the setting
    assert not default["one_kernel"]
    assert fast["one_kernel"]
    for key in ("alpha", "p", "dphi"):
        a, b = np.asarray(default[key]), np.asarray(fast[key])
        assert np.max(np.abs(a - b)) <= 1e-12 * np.max(np.abs(a))
    # the tracker (iterative: its smoothings stop at a relative decrease of 1e-9) agrees far
    # inside its band
    for key in ("tracker", "band"):
        a, b = np.asarray(default[key]), np.asarray(fast[key])
        assert np.max(np.abs(a - b)) <= 1e-6, (key, np.max(np.abs(a - b)))
