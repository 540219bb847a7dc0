"""Records computed on Dask workers: the client (a local cluster or a scheduler's
address), the tasks and their results back in the batch's process."""


import contextlib
import os
import subprocess
import sys
import time

import numpy as np

from .._xla import x64_scope
from ._compute import _compute_group

DASK_TASKS_PER_WORKER = 2  # a bucket is cut into about this many tasks per Dask worker
# and into tasks of at most this many records: a map's curve takes about a second, so its
# results land a minute apart at most, and a worker killed mid-task loses that much work
DASK_TASK_RECORDS = 64
CONNECT_S = 20  # seconds a scheduler's address has to answer as a Dask scheduler
WORKERS_S = 20  # seconds a reachable scheduler has for its first worker to join
PROBE_S = 50  # hard limit of the whole check, whatever the address does (a port that
# accepts and never answers, an HTTP server, a dashboard): the user never waits longer

# run in a child process so that no address can hang or exhaust this one: exit 0 with
# workers, 3 without, 2 with a one-line reason on stderr
_PROBE = """
import sys
from distributed import Client
try:
    client = Client(sys.argv[1], timeout=sys.argv[2] + "s")
except BaseException as e:
    print(str(e).splitlines()[0] if str(e) else type(e).__name__, file=sys.stderr)
    sys.exit(2)
try:
    client.wait_for_workers(1, timeout=float(sys.argv[3]))
except BaseException:
    sys.exit(3)
sys.exit(0)
"""


def _compute_chunk(chunk, num, dt, config):
    """`_compute_group` as a Dask task: ``[(index in chunk, state, result)]``, a failure as a
    `RuntimeError` holding its one-line reason (an exception of any class travels back)."""
    out = []
    index = {id(r): k for k, (r, _) in enumerate(chunk)}
    # one record per worker thread: the tracker's smoothings run one after another there
    config = dict(config, fit=dict(config["fit"], threads=1))
    with x64_scope(True):  # float64 for the task, not a setting of the worker process
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
    """Submits every bucket to `client`'s workers, cut into chunks (`_chunks`: a bucket's
    programs compile once per worker that runs it), and yields ``(chunk, results)`` as
    tasks finish. A task lost with its worker (Dask's ``KilledWorker``) fails its own
    records, with the reason."""
    from distributed import as_completed

    workers = max(1, sum(client.nthreads().values()))
    futures = {}
    for (num, dt), group in groups.items():
        for chunk in _chunks(group, workers):
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
                if _scheduler_lost(client, text):  # every task is lost, not this one's
                    raise SchedulerLost(
                        "the Dask scheduler went away mid-run: the records finished so far "
                        "are written; run the same command again to compute the rest."
                    ) from None
                results = [(i, state, RuntimeError(text)) for i, (_, state) in enumerate(chunk)]
            yield chunk, results
    finally:  # interrupted: nothing keeps computing for a run that is gone
        client.cancel(list(futures))


def _chunks(group, workers):
    """A bucket's records cut into tasks: about `DASK_TASKS_PER_WORKER` a worker, each of at
    most `DASK_TASK_RECORDS`, all of one size but the last (each size a task's vmapped
    programs compile for, once a worker)."""
    tasks = max(-(-len(group) // DASK_TASK_RECORDS), DASK_TASKS_PER_WORKER * workers)
    size = max(1, -(-len(group) // tasks))
    return [group[k : k + size] for k in range(0, len(group), size)]


class SchedulerLost(ConnectionError):
    """The scheduler of a Dask batch went away mid-run (the batch's folder stays resumable)."""


def _scheduler_lost(client, text) -> bool:
    return "scheduler-connection-lost" in text or getattr(client, "status", "running") in (
        "closing", "closed", "failed")


@contextlib.contextmanager
def dask_client(scheduler, workers=None, *, check=True):
    """A Dask client for `run_batch`: ``"local"`` starts a `LocalCluster` of `workers` worker
    processes (default: the cores, at most 8) with one thread each, which die with this
    process however it ends; any other string is the address of a running scheduler
    (``tcp://host:8786``), whose workers must have vojax installed and see the input files
    never (the records travel with the tasks) and the output folder never (this process
    writes it). Closed on exit. An address is first checked by `check_scheduler` (skipped
    with ``check=False`` where the caller has just checked it)."""
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
        cores = os.cpu_count() or 1
        if workers > cores:
            raise ValueError(
                f"`workers` is {workers}, more than this machine's {cores} cores: each worker "
                "is a process with its own compiled programs; use at most one per core."
            )
        with LocalCluster(
            n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None
        ) as cluster, Client(cluster) as client:
            client.register_plugin(_dies_with_parent(os.getpid()))
            yield client
    else:
        if workers is not None:
            raise ValueError("`workers` applies to scheduler='local' only: a running "
                             "cluster has its own workers.")
        if check:
            check_scheduler(scheduler)
        with Client(scheduler, timeout=f"{CONNECT_S}s") as client:
            yield client


def check_scheduler(address):
    """Raises `ConnectionError` with a one-line reason unless `address` answers as a Dask
    scheduler with at least one worker, within `PROBE_S` seconds whatever the address
    does (the check runs in a child process, which is killed at the limit)."""
    if not isinstance(address, str) or not address.strip():
        raise ValueError(
            f"a scheduler's address is a string like tcp://host:8786, got {address!r}."
        )
    import importlib.util

    if importlib.util.find_spec("distributed") is None:
        raise ImportError('the Dask scheduler needs the dask extra: pip install "vojax[dask]".')
    command = [sys.executable, "-c", _PROBE, address, str(CONNECT_S), str(WORKERS_S)]
    try:
        done = subprocess.run(command, capture_output=True, text=True, timeout=PROBE_S)
    except subprocess.TimeoutExpired:
        raise ConnectionError(
            f"{address} did not answer as a Dask scheduler within {PROBE_S} s (is it the "
            "scheduler's port, 8786 by default, and not its dashboard's?)."
        ) from None
    if done.returncode == 3:
        raise ConnectionError(
            f"the Dask scheduler at {address} has no worker (none joined within "
            f"{WORKERS_S} s): start one with `dask worker {address}`."
        )
    if done.returncode != 0:
        lines = done.stderr.strip().splitlines()
        reason = lines[-1] if lines else f"exit status {done.returncode}"
        raise ConnectionError(f"{address} is not a reachable Dask scheduler: {reason}")


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
