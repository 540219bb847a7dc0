"""The `vojax` command keeps XLA's own C++ log lines off stderr; the library leaves them alone.

XLA prints a paragraph to stderr when constant folding takes over a second
(``slow_operation_alarm``). A product of two 700 × 700 constants in a compiled function is
folded by XLA's evaluator, which takes several seconds on any CPU: the alarm fires. Each
case runs in a fresh process, because the level is read when jaxlib loads (older versions:
at its first log line)."""

import os
import subprocess
import sys

import pytest

ALARM = "Constant folding an instruction is taking"

PROGRAM = """
import sys
import numpy as np
import jax
import jax.numpy as jnp

jax.config.update("jax_enable_x64", True)
if sys.argv[1] == "cli":  # the command's own path: main() runs a command, then the program
    from vojax._cli import main

    assert main(["example", "myocardium", "--out", sys.argv[2]]) == 0
elif sys.argv[1] == "library":
    import vojax  # noqa: F401

c = np.random.default_rng(0).random((700, 700))
print(float(jax.jit(lambda y: y + (jnp.asarray(c) @ jnp.asarray(c)).sum())(1.0)))
"""


def _run(tmp_path, how, env_level=None):
    env = {k: v for k, v in os.environ.items() if k != "TF_CPP_MIN_LOG_LEVEL"}
    env["VOJAX_COMPILATION_CACHE"] = "off"  # a cached program would not be folded again
    if env_level is not None:
        env["TF_CPP_MIN_LOG_LEVEL"] = env_level
    return subprocess.Popen(
        [sys.executable, "-c", PROGRAM, how, str(tmp_path / f"{how}-{env_level}.csv")],
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


def test_the_command_silences_xla_and_the_library_does_not(tmp_path):
    runs = {
        "library": _run(tmp_path, "library"),
        "cli": _run(tmp_path, "cli"),
        "cli, the user's level kept": _run(tmp_path, "cli", env_level="0"),
    }
    out = {}
    for name, proc in runs.items():
        stdout, stderr = proc.communicate(timeout=600)
        assert proc.returncode == 0, (name, stderr[-2000:])
        out[name] = (float(stdout.split()[-1]), stderr)
    # the same number each way: silencing changes no result
    values = {v for v, _ in out.values()}
    assert len(values) == 1, out
    # importing vojax leaves XLA's logging as it is: the alarm shows (which also shows that
    # this program does fire it on this machine)
    if ALARM not in out["library"][1]:
        pytest.skip("XLA folded the constants in under a second here: no alarm to silence")
    assert ALARM not in out["cli"][1], out["cli"][1][-2000:]
    # a level the user set is theirs: TF_CPP_MIN_LOG_LEVEL=0 shows every line
    assert ALARM in out["cli, the user's level kept"][1]


def test_the_level_set_is_fatal_only_and_a_users_level_wins(monkeypatch):
    from vojax import _xla

    for users in ("0", "2"):
        monkeypatch.setenv("TF_CPP_MIN_LOG_LEVEL", users)
        assert _xla.quiet_xla_logs() is False
        assert os.environ["TF_CPP_MIN_LOG_LEVEL"] == users
    # JAX's own default, which `import jax` writes where the variable is unset, is not a choice
    monkeypatch.setenv("TF_CPP_MIN_LOG_LEVEL", "1")
    levels = []
    try:
        from jax._src.lib import utils
    except ImportError:
        utils = None
    setter = utils is not None and hasattr(utils, "absl_set_min_log_level")
    if setter:  # newer jaxlib: the level is also set at run time
        monkeypatch.setattr(utils, "absl_set_min_log_level", levels.append)
    assert _xla.quiet_xla_logs() is True
    assert os.environ["TF_CPP_MIN_LOG_LEVEL"] == "3"
    assert levels == ([3] if setter else [])
