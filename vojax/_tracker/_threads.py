"""A pass's independent smoothings side by side in threads: one run at a time (a thread that is
done takes the next), or equal shares where each share's runs are batched into one program
(where that is faster)."""

import concurrent.futures
import contextlib
import os
import threading

import jax
import numpy as np

from .._xla import programs_dropped, to_device, x64_scope
from ._model import Hyper
from ._smoother import batch_pays, smoother_batch, smoother_modes

_warm: set = set()  # (drops, function, shapes) already run: their shares may run in threads
_warm_lock = threading.Lock()


def in_threads(problem, fn, count, call, key, batched=False):
    """``call(lo, hi)`` for shares ``[lo, hi)`` of the `count` runs, in threads (at most
    `settings.run_threads`, one per core) once `fn` has run for these shapes (`key`); the
    first time one share after another, so that two threads never compile the same
    program (again after `spare_mappings` has dropped the compiled programs). A share is
    one run, and a thread that is done takes the next: runs differ in their iterations (7
    to the budget), which no fixed split balances. Where `batched` (the share's runs are one
    vmapped program) the shares are equal, one per thread; with one thread, one share.
    Returns the shares' outputs in order, with their ``(lo, hi)``."""
    workers = max(1, min(count, os.cpu_count() or 1,
                         thread_limit(problem.settings, problem.schedule)))
    size = 1 if workers > 1 and not batched else -(-count // workers)
    shares = [(lo, min(lo + size, count)) for lo in range(0, count, size)]
    key = (programs_dropped(), id(fn), size, *key)

    def side_by_side():
        scoped = callers_scope(call)
        with concurrent.futures.ThreadPoolExecutor(workers) as pool:
            return list(pool.map(lambda share: scoped(*share), shares))

    return list(zip(shares, once_warm(key, lambda: [call(lo, hi) for lo, hi in shares],
                                      side_by_side if workers > 1 else None)))


def once_warm(key, in_turn, side_by_side=None):
    """``side_by_side()`` where `key`'s programs have run before (so that two threads never
    compile the same program) and it is given; else ``in_turn()``, after which `key` counts
    as run."""
    with _warm_lock:
        warm = key in _warm
    if warm and side_by_side is not None:
        return side_by_side()
    out = in_turn()
    with _warm_lock:
        _warm.add(key)
    return out


def callers_scope(fn):
    """`fn` for another thread, run there under the calling thread's JAX scopes, which a new
    thread does not inherit: float64 (``jax.enable_x64``, as a Dask task uses) and the
    default device (``jax.default_device``); where the thread's own differ."""
    x64 = bool(jax.config.jax_enable_x64)
    device = getattr(jax.config, "jax_default_device", None)

    def scoped(*args):
        with contextlib.ExitStack() as scopes:
            if bool(jax.config.jax_enable_x64) != x64:
                scopes.enter_context(x64_scope(x64))
            if getattr(jax.config, "jax_default_device", None) is not device:
                scopes.enter_context(jax.default_device(device))
            return fn(*args)

    return scoped


def thread_limit(settings, schedule) -> int:
    """The threads the tracker may run its smoothings in: `run_threads`, but one with a
    parallel-in-time `schedule` on a CPU (XLA:CPU's runtime was seen to deadlock running the
    prefix sums' programs from two threads at once: 1e6 samples, 1,000 block means)."""
    if schedule != "sequential" and jax.default_backend() == "cpu":
        return 1
    return settings.run_threads or 1


def two_at_once(settings, schedule, key, first, second=None):
    """``first()`` and ``second()`` (None: not run, its output None) side by side in two
    threads where two are allowed (`thread_limit`, two cores) and both have run for `key`
    before (so that two threads never compile the same program); else one after the other,
    the second not run where the first gives None (no answer to weigh it against). Returns
    both outputs."""
    if second is None:
        return first(), None

    def in_turn():
        out = first()
        return out, None if out is None else second()

    def side_by_side():
        with concurrent.futures.ThreadPoolExecutor(1) as pool:
            later = pool.submit(callers_scope(second))
            return first(), later.result()

    two = min(os.cpu_count() or 1, thread_limit(settings, schedule)) >= 2
    return once_warm((programs_dropped(), "two_at_once", *key), in_turn,
                     side_by_side if two else None)


def host_hyper(hyper):
    """``hyper.as_array()`` on the host."""
    return np.array([float(v) for v in jax.tree_util.tree_leaves(hyper)])


def stack_hypers(values):
    """A batched `Hyper` from rows of intensities in its order (``(q_order, q_params, r)``,
    and a coloured noise's ``(s, τ)``)."""
    arr = np.log(np.asarray(values, dtype=float))
    return Hyper(*(to_device(arr[:, i]) for i in range(arr.shape[1])))


def _run_shares(problem, fn, rows, firsts, budget):
    """`fn` (`smoother_batch` or `smoother_modes`) over the runs ``rows`` × ``firsts``, split
    into shares run in threads (`in_threads`), each share's runs batched where the problem
    asks for it and it pays (`batch_pays`); ``[((lo, hi), output)]``."""
    batched = problem.batched and batch_pays()

    def call(lo, hi):
        hyper, first = stack_hypers(rows[lo:hi]), np.asarray(firsts)[lo:hi]
        out = fn(*problem.record, hyper, problem.m0, problem.p0, first, problem.bounds, budget,
                 batched, problem.schedule)
        return jax.block_until_ready(out)

    return in_threads(problem, fn, len(rows), call, (problem.u.shape, budget, batched), batched)


def _joined(parts, k):
    """Output `k` of every share, its padding dropped, end to end."""
    return np.concatenate([np.asarray(o[k])[: hi - lo] for (lo, hi), o in parts])


def run_batch_shares(problem, rows, firsts, budget):
    """`smoother_batch` in shares (`_run_shares`); the same result as one call: the best run
    by score (the first of equal ones), its index, the index of the best by objective, the
    scores."""
    parts = _run_shares(problem, smoother_batch, rows, firsts, budget)
    scores, alts = _joined(parts, 3), _joined(parts, 5)
    i = int(np.argmax(scores)) if np.any(np.isfinite(scores)) else -1
    i_alt = int(np.argmax(alts)) if np.any(np.isfinite(alts)) else -1
    holder = next(o for (lo, hi), o in parts if lo <= max(i, 0) < hi)
    return holder[0], i, i_alt, scores


def run_mode_shares(problem, rows, firsts, budget):
    """`smoother_modes` in shares (`_run_shares`): each of its outputs, one row per run."""
    parts = _run_shares(problem, smoother_modes, rows, firsts, budget)
    return tuple(_joined(parts, k) for k in range(len(parts[0][1])))
