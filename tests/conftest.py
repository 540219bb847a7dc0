import jax

jax.config.update("jax_enable_x64", True)
jax.config.update("jax_numpy_dtype_promotion", "strict")

import os

import pytest

import vojax
from vojax import _xla

# No persistent compilation cache unless ``VOJAX_TEST_CACHE`` names a folder (results are the
# same either way); the commands the tests run use the same setting.
CACHE = os.environ.get("VOJAX_TEST_CACHE", "off")
os.environ["VOJAX_COMPILATION_CACHE"] = CACHE
if CACHE.lower() != "off":
    vojax.use_compilation_cache(CACHE)


@pytest.fixture(autouse=True)
def _spare_mappings():
    """A worker compiles some 20,000 programs over the suite; XLA:CPU maps each, and past
    Linux's cap on a process's mappings (65,530) compiling aborts, which crashed a worker in
    four of twelve CI runs. Dropped before a test at a lower share than the library's own
    check (`vojax._xla.spare_mappings` on entry to `identify` and `refit`), so that check
    never drops the programs in the middle of a test that counts its traces."""
    _xla.spare_mappings(share=0.8 * _xla.MAPPINGS_SHARE, every_s=0)


@pytest.fixture(scope="session")
def ramp():
    """`helpers.ramp_case()`: a 1,500-sample record of two inputs and an order ramp."""
    from .helpers import ramp_case

    return ramp_case()


@pytest.fixture(scope="module")
def suite():
    """`scripts/bench_calibration.py` and the recorded inputs its families draw on, from
    ../shared/data (the calibration tests skip where that folder is absent)."""
    from .helpers import SHARED_DATA, load_script

    module = load_script("bench_calibration")
    return module, module.real_signals(SHARED_DATA)
