import jax

jax.config.update("jax_enable_x64", True)
jax.config.update("jax_numpy_dtype_promotion", "strict")

import os
from pathlib import Path

import vojax

# One persistent compilation cache for every process that tests this checkout: the test
# processes (the xdist workers, both tiers) and the commands the tests run. A program is then
# compiled once per checkout and versions of the dependencies, not once per process; about
# half of the tests' time is compilation. It lives in the checkout's ignored .pytest_cache,
# never in the user's own cache. A cached program is the compiled program: results are the
# same. An entry that another process is still writing is read as missing (the program is
# compiled again), with JAX's warning about it ignored in pyproject.toml.
CHECKOUT = Path(__file__).resolve().parent.parent
CACHE = os.environ.setdefault("VOJAX_COMPILATION_CACHE", str(CHECKOUT / ".pytest_cache" / "vojax-xla"))
if CACHE.lower() != "off":
    vojax.use_compilation_cache(CACHE)
