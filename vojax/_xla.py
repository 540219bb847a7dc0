"""Opt-in XLA:CPU setting under which vojax's scans run as one compiled kernel each.

XLA:CPU's thunk runtime launches one kernel per fused operation; a step of the adaptive law is
dozens of them, so on a CPU the launch cost, not arithmetic, sets the time per sample. XLA
compiles a *small* while loop (bytes touched per iteration below a threshold, default 1 KiB)
as a single kernel instead. Raising the threshold to cover vojax's loops makes the tracker,
the paper's law's recursion and the exponential memory several times faster on a CPU, with
results equal to rounding (`docs/benchmarks.md`, "Should I call `use_fast_cpu_loops`?";
``scripts/bench_first_call.py``, ``scripts/bench_loop_threshold.py``).

The threshold is read from ``XLA_FLAGS`` when JAX creates its CPU backend, so it is a setting
of the whole process, made before the first computation. vojax never sets it on import; the
``vojax`` command sets it for itself (``VOJAX_FAST_CPU_LOOPS=0`` turns that off), and a
notebook or script opts in with `use_fast_cpu_loops` before its first JAX computation.

Also here: `quiet_xla_logs` (the command's stderr without XLA's own log lines), for the
first call's cost `use_compilation_cache` (compiled programs kept on disk) and `to_device`
(host arrays moved to the device by a transfer, not by a compiled program), and for a long
process `spare_mappings` (compiled programs dropped before they exhaust the memory mappings
Linux allows a process).
"""

import math
import os
import re
import time

THRESHOLD_KEY = "xla_cpu_small_while_loop_byte_threshold"
DEFAULT_THRESHOLD = 1 << 20  # 1 MiB per iteration: every vojax loop except a long direct memory
_EXTRA = re.compile(r"--xla_backend_extra_options=(\S*)")


def _backend_started() -> bool:
    try:
        from jax._src import xla_bridge

        return bool(xla_bridge.backends_are_initialized())
    except (ImportError, AttributeError):  # a JAX without the query: assume not started
        return False


def fast_cpu_loops_threshold(flags: str | None = None) -> int | None:
    """The small-loop threshold in ``XLA_FLAGS`` (or in `flags`), or None where unset."""
    flags = os.environ.get("XLA_FLAGS", "") if flags is None else flags
    for match in _EXTRA.finditer(flags):
        for item in match.group(1).split(","):
            key, _, value = item.partition("=")
            if key == THRESHOLD_KEY and value.isdigit():
                return int(value)
    return None


def use_fast_cpu_loops(threshold_bytes: int = DEFAULT_THRESHOLD) -> bool:
    """Asks XLA:CPU to compile every while loop touching fewer than `threshold_bytes` bytes per
    iteration as one kernel. Call it before the process's first JAX computation.

    It appends ``--xla_backend_extra_options=xla_cpu_small_while_loop_byte_threshold=N`` to the
    ``XLA_FLAGS`` environment variable (merging with extra options already there). GPUs and TPUs
    ignore it. Results are unchanged to rounding.

    **Returns:** True if the setting was added, False if ``XLA_FLAGS`` already had a threshold
    (which is left as it is).

    **Raises:** `RuntimeError` if JAX's backends already exist (the flag would be ignored);
    `ValueError` for a threshold that is not a positive integer.
    """
    if isinstance(threshold_bytes, bool) or not isinstance(threshold_bytes, int):
        raise ValueError(f"`threshold_bytes` must be a positive integer, got {threshold_bytes!r}.")
    if threshold_bytes <= 0:
        raise ValueError(f"`threshold_bytes` must be a positive integer, got {threshold_bytes}.")
    flags = os.environ.get("XLA_FLAGS", "")
    if fast_cpu_loops_threshold(flags) is not None:
        return False
    if _backend_started():
        raise RuntimeError(
            "use_fast_cpu_loops() must run before the first JAX computation of the process "
            "(JAX has already created its backends, which read XLA_FLAGS only once)."
        )
    item = f"{THRESHOLD_KEY}={threshold_bytes}"
    match = _EXTRA.search(flags)
    if match:  # one extra-options flag: add to its list
        flags = (
            flags[: match.end(1)] + ("," if match.group(1) else "") + item + flags[match.end(1) :]
        )
    else:
        flags = f"{flags} --xla_backend_extra_options={item}".strip()
    os.environ["XLA_FLAGS"] = flags
    return True


LOG_ENV = "TF_CPP_MIN_LOG_LEVEL"


def quiet_xla_logs() -> bool:
    """Keeps XLA's own C++ log lines off stderr: a slow constant folding or a slow compile
    (``slow_operation_alarm``) prints a paragraph there, past Python's logging. The ``vojax``
    command calls it for itself; the library never does (a notebook's logging is its own).

    It sets ``TF_CPP_MIN_LOG_LEVEL=3`` (only fatal lines) for this process and the processes it
    starts, and, where jaxlib reads that variable only once when it loads (newer versions,
    through absl), sets the same level at run time.

    **Returns:** True if the level was set, False if ``TF_CPP_MIN_LOG_LEVEL`` was set to
    another level than JAX's own default (1, which ``import jax`` sets where it is unset): the
    user's choice is left as it is, so ``TF_CPP_MIN_LOG_LEVEL=0 vojax ...`` shows every line.
    """
    if os.environ.get(LOG_ENV, "") not in ("", "1"):
        return False
    os.environ[LOG_ENV] = "3"
    try:
        from jax._src.lib import utils
    except ImportError:  # a jaxlib without it: the variable alone, read at its first log line
        return True
    set_level = getattr(utils, "absl_set_min_log_level", None)
    if set_level is not None:
        set_level(3)
    return True


CACHE_ENV = "VOJAX_COMPILATION_CACHE"


def default_cache_dir() -> str:
    """``$XDG_CACHE_HOME/vojax/xla`` (``~/.cache/vojax/xla`` by default)."""
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return os.path.join(base, "vojax", "xla")


def use_compilation_cache(path: str | None = None) -> str | None:
    """Keeps JAX's compiled programs on disk in `path` (default `default_cache_dir`), so that a
    later process with the same shapes and settings loads them instead of compiling: a batch's
    seconds of compilation per length bucket are paid once per machine, not once per run.

    A process-wide JAX setting (``jax_compilation_cache_dir``); vojax never makes it on import.
    The ``vojax`` command makes it for itself, in the directory named by the environment
    variable ``VOJAX_COMPILATION_CACHE`` if set (``off`` turns it off). Results are unchanged:
    a cached program is the compiled program.

    **Returns:** the directory in use, or None when it could not be created (then nothing is
    cached and nothing else changes).
    """
    import jax

    path = default_cache_dir() if path is None else os.fspath(path)
    try:
        os.makedirs(path, exist_ok=True)
    except OSError:
        return None
    jax.config.update("jax_compilation_cache_dir", path)
    # every program of a batch is worth keeping: the small ones compile in ~0.1 s each
    jax.config.update("jax_persistent_cache_min_compile_time_secs", 0.0)
    jax.config.update("jax_persistent_cache_min_entry_size_bytes", 0)
    return path


def to_device(value):
    """A host value (NumPy array, NumPy or Python scalar) as a JAX array of its NumPy dtype,
    by a transfer. Newer JAX turns ``jnp.asarray`` of a host array into a small compiled
    program (``stage``), one per shape and dtype, each compiled on a first call (a dozen in
    the tracker's)."""
    import jax
    import numpy as np

    return jax.device_put(np.asarray(value))


def cut_padding(tree, num: int, padded: int, device: bool = False):
    """`tree` (a result) with every array leaf whose first axis is `padded` long cut to its
    first `num` rows, on the host (an eager slice of a device array compiles a program for
    every length); as JAX arrays where `device`, else NumPy. `tree` itself where nothing
    was padded."""
    import jax
    import numpy as np

    if padded <= num:
        return tree
    back = to_device if device else (lambda a: a)

    def cut(a):
        if getattr(a, "ndim", 0) >= 1 and a.shape[0] == padded:
            return back(np.asarray(a)[:num])
        return a

    return jax.tree_util.tree_map(cut, tree)


# XLA:CPU keeps every compiled program in memory mappings of its own (3 to 20 each; a tracker
# run on a record of a new length adds about 800), and Linux caps the mappings of a process
# (``vm.max_map_count``, 65,530 by default). A process past the cap cannot map a new program
# and dies inside the compiler (a segfault or an abort): records of about 80 distinct lengths
# identified one after another in one process, or the test suite in one worker.
MAPPINGS_SHARE = 0.5  # share of the cap past which `spare_mappings` drops the compiled programs
CHECK_EVERY_S = 1.0  # seconds between two counts on entry (a count reads /proc/self/maps: about
# 0.5 ms at 1,300 mappings, 18 ms at 30,000; a new record length adds some 800 mappings)
_dropped = 0  # how many times `spare_mappings` has dropped them (`programs_dropped`)
_counted_at = -math.inf  # `time.monotonic()` of the last count


def _mapping_count_and_limit() -> tuple[int, int] | None:
    """This process's memory mappings and the most Linux allows it; None elsewhere."""
    try:
        with open("/proc/sys/vm/max_map_count", "rb") as f:
            limit = int(f.read())
        with open("/proc/self/maps", "rb") as f:
            return f.read().count(b"\n"), limit
    except (OSError, ValueError):
        return None


def spare_mappings(share: float | None = None, every_s: float | None = None) -> bool:
    """Drops JAX's compiled programs held in memory (`jax.clear_caches`) once this process
    holds more than `share` (default `MAPPINGS_SHARE`) of the memory mappings Linux allows
    it, so that a long process (a batch, a notebook) never reaches the cap, where compiling
    aborts. A program dropped is compiled again when next needed (or loaded from
    `use_compilation_cache`'s folder); results are unchanged. `identify` and `refit` (so
    `compare`, once per model) call it on entry. It counts at most once every `every_s`
    seconds (default `CHECK_EVERY_S`; 0 counts on every call) and returns False in between.
    Elsewhere than Linux it does nothing.

    **Returns:** whether the programs were dropped.
    """
    global _dropped, _counted_at
    share = MAPPINGS_SHARE if share is None else share
    every_s = CHECK_EVERY_S if every_s is None else every_s
    if isinstance(share, bool) or not isinstance(share, (int, float)) or not 0 <= share <= 1:
        raise ValueError(f"`share` must be a number in [0, 1], got {share!r}.")
    if isinstance(every_s, bool) or not isinstance(every_s, (int, float)) or not every_s >= 0:
        raise ValueError(f"`every_s` must be a number of seconds ≥ 0, got {every_s!r}.")
    now = time.monotonic()
    if now - _counted_at < every_s:
        return False
    _counted_at = now
    counted = _mapping_count_and_limit()
    if counted is None or counted[0] <= share * counted[1]:
        return False
    import jax

    jax.clear_caches()
    _dropped += 1
    return True


def programs_dropped() -> int:
    """How many times `spare_mappings` has dropped the compiled programs in this process (a
    program known to have run may have to compile again since)."""
    return _dropped


def x64_scope(on: bool = True):
    """A scope with float64 on (or off) in this thread only: ``jax.enable_x64`` where JAX has
    it, its experimental form before."""
    import jax

    if hasattr(jax, "enable_x64"):
        return jax.enable_x64(on)
    from jax.experimental import enable_x64

    return enable_x64(on)
