"""Records computed on Dask workers: the client (a local cluster or a scheduler's
address), the tasks and their results back in the batch's process."""


import contextlib
import os
import time

import jax
import numpy as np

from ._compute import _compute_group

DASK_TASKS_PER_WORKER = 2  # a bucket is cut into about this many tasks per Dask worker


def _x64():
    """float64 for the duration of a task on a Dask worker (a scope, not a setting of the
    worker process): ``jax.enable_x64`` where JAX has it, its experimental form before."""
    if hasattr(jax, "enable_x64"):
        return jax.enable_x64(True)
    from jax.experimental import enable_x64

    return enable_x64()


def _compute_chunk(chunk, num, dt, config):
    """`_compute_group` as a Dask task: ``[(index in chunk, state, result)]``, a failure as a
    `RuntimeError` holding its one-line reason (an exception of any class travels back)."""
    out = []
    index = {id(r): k for k, (r, _) in enumerate(chunk)}
    # one record per worker thread: the tracker's smoothings run one after another there
    config = dict(config, fit=dict(config["fit"], threads=1))
    with _x64():
        for r, state, result in _compute_group(chunk, num, dt, config):
            i = index[id(r)]
            if isinstance(result, Exception):
                text = str(result).splitlines()[0] if str(result) else type(result).__name__
                result = RuntimeError(text)
            else:
                columns, summary = result
                result = ({k: np.asarray(v) for k, v in columns.items()}, summary)
            out.append((i, state, result))
    return out


def _on_dask(client, groups, config, bar):
    """Submits every bucket to `client`'s workers, cut into chunks (about
    `DASK_TASKS_PER_WORKER` per worker: a bucket's programs compile once per worker that
    runs it), and yields ``(chunk, results)`` as tasks finish. A task lost with its worker
    (Dask's ``KilledWorker``) fails its own records, with the reason."""
    from distributed import as_completed

    workers = max(1, sum(client.nthreads().values()))
    futures = {}
    for (num, dt), group in groups.items():
        size = max(1, -(-len(group) // (DASK_TASKS_PER_WORKER * workers)))
        for k in range(0, len(group), size):
            chunk = group[k : k + size]
            futures[client.submit(_compute_chunk, chunk, num, dt, config, pure=False)] = chunk
    bar.note(
        f"{len(futures)} task(s) of {len(groups)} length bucket(s) on {workers} Dask worker "
        "thread(s)"
    )
    try:
        for future in as_completed(futures):
            chunk = futures[future]
            try:
                results = future.result()
            except Exception as e:  # noqa: BLE001 - a lost task fails its records only
                text = str(e).splitlines()[0] if str(e) else type(e).__name__
                results = [(i, state, RuntimeError(text)) for i, (_, state) in enumerate(chunk)]
            yield chunk, results
    finally:  # interrupted: nothing keeps computing for a run that is gone
        client.cancel(list(futures))


@contextlib.contextmanager
def dask_client(scheduler, workers=None):
    """A Dask client for `run_batch`: ``"local"`` starts a `LocalCluster` of `workers` worker
    processes (default: the cores, at most 8) with one thread each, which die with this
    process however it ends; any other string is the address of a running scheduler
    (``tcp://host:8786``), whose workers must have vojax installed and see the input files
    never (the records travel with the tasks) and the output folder never (this process
    writes it). Closed on exit."""
    try:
        from distributed import Client, LocalCluster
    except ImportError:
        raise ImportError(
            'the Dask scheduler needs the dask extra: pip install "vojax[dask]".'
        ) from None
    if scheduler == "local":
        if workers is None:
            workers = max(1, min(8, os.cpu_count() or 1))
        if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
            raise ValueError(f"`workers` must be a positive integer, got {workers!r}.")
        with LocalCluster(
            n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None
        ) as cluster, Client(cluster) as client:
            client.register_plugin(_dies_with_parent(os.getpid()))
            yield client
    else:
        if workers is not None:
            raise ValueError("`workers` applies to scheduler='local' only: a running "
                             "cluster has its own workers.")
        with Client(scheduler, timeout="30s") as client:
            yield client


def _dies_with_parent(parent):
    """A Dask worker plugin for the local cluster: the worker process exits when the process
    that started the cluster is gone, however it ended (as the figure workers do)."""
    from distributed import WorkerPlugin

    class DiesWithParent(WorkerPlugin):
        name = "vojax-dies-with-parent"
        idempotent = True

        def setup(self, worker):
            import threading

            try:
                import ctypes
                import signal

                ctypes.CDLL(None, use_errno=True).prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG
            except (OSError, AttributeError):
                pass

            def watch():
                while _alive(parent):
                    time.sleep(0.5)
                os._exit(0)

            threading.Thread(target=watch, daemon=True).start()

    return DiesWithParent()


def _alive(pid):
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True
