import jax

jax.config.update("jax_enable_x64", True)
jax.config.update("jax_numpy_dtype_promotion", "strict")

import os
from pathlib import Path

import vojax

# A persistent compilation cache for the processes that test this checkout: each xdist
# worker (gw0, gw1, …) keeps its own, reused by the same worker of the other tier and by the
# commands its tests run, so a program is compiled once per worker, checkout and versions of
# the dependencies, not once per process; about half of the tests' time is compilation. One
# cache shared by the workers saw a worker crash in two clean-clone CI runs, both times in
# the cache's compile-and-write path (a segfault writing an entry, an abort compiling one);
# with a cache of its own no two test processes write to the same place. It lives in the checkout's ignored .pytest_cache, never in
# the user's own cache. A cached program is the compiled program: results are the same.
# ``VOJAX_TEST_CACHE`` names another folder, or ``off``.
CHECKOUT = Path(__file__).resolve().parent.parent
BASE = os.environ.get("VOJAX_TEST_CACHE", str(CHECKOUT / ".pytest_cache" / "vojax-xla"))
WORKER = os.environ.get("PYTEST_XDIST_WORKER")
CACHE = BASE if BASE.lower() == "off" or not WORKER else f"{BASE}-{WORKER}"
os.environ["VOJAX_COMPILATION_CACHE"] = CACHE  # the commands the tests run use it too
if CACHE.lower() != "off":
    vojax.use_compilation_cache(CACHE)
