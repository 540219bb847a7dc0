import jax

jax.config.update("jax_enable_x64", True)
jax.config.update("jax_numpy_dtype_promotion", "strict")

import os
import tempfile

# the command's persistent compilation cache goes to a folder of this test session (shared by
# the commands the tests run, never the user's own cache)
os.environ.setdefault("VOJAX_COMPILATION_CACHE", tempfile.mkdtemp(prefix="vojax-xla-"))
