import jax

jax.config.update("jax_enable_x64", True)
jax.config.update("jax_numpy_dtype_promotion", "strict")

import os

import vojax

# No persistent compilation cache by default: with one (JAX 0.10.2, each process writing
# every program it compiles) an xdist worker crashed in three of eleven clean-clone CI runs,
# always inside the cache's compile-and-write path (segfaults in `put_executable_and_time`,
# an abort compiling), with one cache shared by the workers and with one per worker alike.
# Each process still keeps its compiled programs in memory. ``VOJAX_TEST_CACHE`` names a
# folder to use one (each xdist worker then keeps its own, suffixed with its name, which
# the commands its tests run inherit); results are the same either way.
BASE = os.environ.get("VOJAX_TEST_CACHE", "off")
WORKER = os.environ.get("PYTEST_XDIST_WORKER")
CACHE = BASE if BASE.lower() == "off" or not WORKER else f"{BASE}-{WORKER}"
os.environ["VOJAX_COMPILATION_CACHE"] = CACHE  # the commands the tests run use it too
if CACHE.lower() != "off":
    vojax.use_compilation_cache(CACHE)
