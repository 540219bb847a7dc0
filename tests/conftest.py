import jax

jax.config.update("jax_enable_x64", True)
jax.config.update("jax_numpy_dtype_promotion", "strict")

import os

import pytest

import vojax
from vojax import _xla

# No persistent compilation cache by default (``VOJAX_TEST_CACHE`` names a folder to use one;
# each xdist worker then keeps its own, suffixed with its name, which the commands its tests
# run inherit); results are the same either way.
BASE = os.environ.get("VOJAX_TEST_CACHE", "off")
WORKER = os.environ.get("PYTEST_XDIST_WORKER")
CACHE = BASE if BASE.lower() == "off" or not WORKER else f"{BASE}-{WORKER}"
os.environ["VOJAX_COMPILATION_CACHE"] = CACHE  # the commands the tests run use it too
if CACHE.lower() != "off":
    vojax.use_compilation_cache(CACHE)


@pytest.fixture(autouse=True)
def _spare_mappings():
    """A worker compiles some 20,000 programs over the suite; XLA:CPU maps each, and past
    Linux's cap on a process's mappings (65,530) compiling aborts, which crashed a worker in
    four of twelve CI runs. Dropped before a test at a lower share than the library's own
    check (`vojax._xla.spare_mappings` on entry to `identify` and `refit`), so that check
    never drops the programs in the middle of a test that counts its traces."""
    _xla.spare_mappings(share=0.8 * _xla.MAPPINGS_SHARE)
