"""Batch re-identification: many records, equal lengths run together under `jax.vmap`, the
batch axis sharded over the available devices with `jax.sharding`.

Multi-host use: call `jax.distributed.initialize()` on every host before `run_batch`; the mesh
then spans `jax.devices()` of all hosts, and each host should be given its own share of the
files (the outputs are per record, so hosts do not collide).
"""

import collections
import concurrent.futures
import contextlib
import csv
import dataclasses
import io
import json
import os
import time
from pathlib import Path

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from .._adaptive._bands import law_covariance
from .._adaptive._build import (
    DEFAULT_BOUNDS,
    PAPER_LAM,
    assemble_law,
    auto_r0,
    law_identification,
    run_law,
)
from .._integral import make_memory
from .._io import atomic_path
from .._plotting import warm_record_figure
from .._progress import Bar, wanted
from .._stats import noise_variance
from ._paths import check_out_holds_no_input, claim_outputs, inside, record_folder
from ._pipeline import (
    adaptive_part,
    canonical_method,
    check_finite,
    check_parameters,
    compare_part,
    disagreement,
    estimator,
    finish_outputs,
    identify_record,
    make_provenance,
    plan_buckets,
    record_header,
    regressors,
    runs_refit,
    write_table,
)

LOCK_NAME = ".vojax-batch.lock"
TABLE_EVERY_S = 1.0  # summary.csv is rebuilt at most this often during a run, and at its end


def _sharded(x, mesh):
    """Places ``x`` with its leading (batch) axis split over the mesh's devices."""
    spec = jax.sharding.PartitionSpec("records", *([None] * (x.ndim - 1)))
    return jax.device_put(x, jax.sharding.NamedSharding(mesh, spec))


@eqx.filter_jit
def _law_batch(memory, us, ys, dt, gammas, lams, r0s, sigma2, alpha0):
    """The law and its band on a stack of records (one program per memory and shape)."""
    TRACES["law_batch"] += 1

    def one(u, y, gamma, lam, r0, s2):
        law = assemble_law(memory, dt, lam, gamma, alpha0, DEFAULT_BOUNDS, r0)
        out = run_law(law, u, y)
        var_alpha, var_p = law_covariance(law, u, y, s2)
        return out, var_alpha, var_p

    return jax.vmap(one)(us, ys, gammas, lams, r0s, sigma2)


TRACES = {"law_batch": 0}


def adaptive_batch(us, ys, dt, gammas, lams, r0s=None, *, alpha0=0.5, mesh=None, lengths=None):
    """The adaptive law on records of equal (padded) length at once: ``us`` (B, N, n), ``ys``
    (B, N), gains (B,), ``r0s`` (B, n, n) (default: each record's automatic ``R_0``, as
    `identify`). With `lengths` (B,), record b is its first ``lengths[b]`` samples, padded
    after its end (the law is causal: the padding does not reach the real samples' results;
    ``R_0`` and the noise level come from the real samples). Returns ``((law outputs, var α̂,
    var p̂), x0)`` with a leading batch axis, over all N samples; the variances are the law's
    band, as in `identify`. ``y − y[0]`` is identified (Remark 4), as `identify` does."""
    num = us.shape[1]
    lengths = np.full(us.shape[0], num) if lengths is None else np.asarray(lengths)
    memory = make_memory("exponential", dt, num, rule="trapezoid", order_range=DEFAULT_BOUNDS)
    if r0s is None:
        r0s = np.stack(
            [
                auto_r0(u, dt, alpha0, "exponential", "trapezoid", 1e-10, DEFAULT_BOUNDS, num=k,
                        mem=memory)
                for u, k in zip(us, lengths)
            ]
        )
    x0 = ys[:, :1]
    sigma2 = np.array([noise_variance(y[:k] - y[0]) for y, k in zip(ys, lengths)])
    args = [np.asarray(a) for a in (us, ys - x0, gammas, lams, r0s, sigma2)]
    # the stack grows to a power of two (and a multiple of the devices) by repeating its last
    # record, whose copies are dropped below: a few stack sizes, so a few compilations
    devices = 1 if mesh is None else mesh.devices.size
    size = 1 << max(len(us) - 1, 0).bit_length()
    size += (-size) % devices
    if size > len(us):
        args = [np.concatenate([a, np.repeat(a[-1:], size - len(us), axis=0)]) for a in args]
    args = [jnp.asarray(a) for a in args]
    if mesh is not None:
        args = [_sharded(a, mesh) for a in args]
    dtype = args[0].dtype
    out = _law_batch(memory, args[0], args[1], jnp.asarray(dt, dtype), *args[2:],
                     jnp.asarray(alpha0, dtype))
    return jax.tree_util.tree_map(lambda a: np.asarray(a)[: us.shape[0]], out), np.asarray(x0)


class BatchBusy(RuntimeError):
    """Another batch holds the output folder's lock."""


@contextlib.contextmanager
def _locked(out_dir: Path):
    """An exclusive, non-blocking lock on ``out_dir`` for the whole run (POSIX ``flock``;
    released by the OS if the process dies)."""
    path = out_dir / LOCK_NAME
    try:  # never through a link: the lock would create or touch a file elsewhere
        fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_APPEND | getattr(os, "O_NOFOLLOW", 0))
    except OSError:
        if path.is_symlink():
            raise BatchBusy(
                f"{path} is a symbolic link; vojax does not follow links in --out: remove it."
            ) from None
        raise
    f = os.fdopen(fd, "a")
    try:
        try:
            import fcntl

            fcntl.flock(f, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except ImportError:  # not POSIX: no lock
            pass
        except OSError:
            raise BatchBusy(
                f"another vojax batch is writing to {out_dir}; wait for it or use another --out."
            ) from None
        yield
    finally:
        f.close()


def _remove_orphans(out_dir: Path):
    """Temporary files left by a killed run (the lock is held: no one else writes here)."""
    for tmp in list(out_dir.glob(".*.tmp")) + list(out_dir.glob("*/.*.tmp")):
        with contextlib.suppress(OSError):
            tmp.unlink()


def strict_json(text):
    """`json.loads` refusing NaN and ±Infinity (vojax writes them as null): a summary that
    holds them was not written by this vojax, and is not taken as a result."""

    def refuse(constant):
        raise ValueError(f"a non-standard JSON number: {constant}")

    return json.loads(text, parse_constant=refuse)


def _state(folder: Path, provenance: dict, figure_format: str = "png", figure=True) -> str:
    """``"missing"``, ``"current"`` (complete, same provenance, with its figure when `figure`)
    or ``"stale"``."""
    summary = folder / "summary.json"
    if not summary.is_file():
        return "missing" if not folder.exists() else "stale"
    try:
        old = strict_json(summary.read_text())
        with open(folder / "identification.csv", newline="") as f:
            lines = sum(1 for _ in csv.reader(f))
    except (OSError, ValueError):
        return "stale"
    complete = lines == old.get("samples", -1) + 1 and (
        not figure or (folder / f"identification.{figure_format}").is_file()
    )
    same = old.get("provenance", {}).get("hash") == provenance["hash"]
    return "current" if complete and same else "stale"


def run_batch(
    records,
    out_dir,
    *,
    model,
    method,
    gamma,
    lam,
    area=None,
    length=None,
    failures=(),
    progress=None,
    loader=None,
    overwrite=True,
    buckets=True,
    figure_format="png",
    record_figures=True,
    figure_workers=None,
    origin=None,
    fit_from=None,
    fit_to=None,
    parameters=None,
    max_points=None,
    x0=None,
    client=None,
    compare=False,
):
    """Identifies every record into ``out_dir/<folder>/`` (`record_folder` of its name);
    returns a `BatchReport`.

    Each record's ``summary.json`` carries a provenance block (versions, input file and its
    SHA-256, record name, every setting that affects the numbers, and their hash). A record is
    skipped only when its outputs are complete and its provenance matches; otherwise it is
    redone (``overwrite=False``: it fails, saying why). A record that fails is listed in
    ``failures.csv`` with its reason and the rest go on. ``summary.csv`` is rebuilt from the
    records' own ``summary.json`` as records finish (at most once a second) and at the end,
    sorted by record, so a killed run loses nothing and a re-run gives exactly one row per
    record. The folder is locked for the run.
    Records are padded to the lengths of `plan_buckets` (for the records to be computed) and
    masked; their results equal the unpadded runs' within the solvers' tolerances, so they can
    differ at that level with the batch's other records (148 beef records in one bucket
    against three: tuned gains within 6e-6 relative, the law's final orders within 3e-6,
    the refit within 3e-9).
    ``buckets=False`` runs the tracker and the refit at each record's own length (one
    compilation per distinct length; for benchmarks). `figure_format`: ``png``, ``svg`` or
    ``pdf`` for each record's ``identification.<format>``; ``record_figures=False`` draws
    none (the overview figure is always drawn). The record figures are drawn in
    `figure_workers` worker processes (default: the cores but one, at least one, at most four;
    0 draws them in this process), off the computation's path; a record counts as done when its
    figure and summary are written. Records on irregular clocks run one at a time, on their own
    clock. `origin`, `fit_from`, `fit_to`: the refit's, `parameters`, `max_points` and `x0`:
    the tracker's, as in `identify_record`.

    `client`: a Dask ``distributed.Client`` (``pip install "vojax[dask]"``) to compute the
    records on its workers, in tasks of a few records of one length bucket each (see
    `dask_client`); this process keeps the lock, writes every record's folder and draws the
    figures, as without it. Results equal the single-process run's to rounding.
    """
    check_parameters(method, parameters, max_points, x0)
    method = canonical_method(method)
    out_dir = Path(out_dir)
    check_out_holds_no_input(out_dir, [r.source for r in records] + [f[0] for f in failures])
    out_dir.mkdir(parents=True, exist_ok=True)
    fit = {
        k: v
        for k, v in dict(
            origin=origin, fit_from=fit_from, fit_to=fit_to, parameters=parameters,
            max_points=max_points, x0=None if x0 is None else float(x0),
        ).items()
        if v is not None
    }
    settings = dict(
        model=model, method=method, gamma=gamma, lam=lam, area=area, length=length,
        figure_format=figure_format, **(loader or {}), **fit,
        **({"compare": True} if compare else {}),
    )
    for name in ("summary.csv", "failures.csv", f"overview.{figure_format}"):
        if (out_dir / name).is_dir() and not (out_dir / name).is_symlink():
            raise ValueError(
                f"{out_dir / name} is a folder, where the batch writes its {name}: rename it "
                "or choose another --out."
            )
    with _locked(out_dir), contextlib.ExitStack() as cleanup:
        _remove_orphans(out_dir)
        report = BatchReport()
        failed = list(failures)
        report.failed = len(failed)
        folders = {r.name: inside(out_dir, record_folder(r.name)) for r in records}
        tables = ["summary.csv", "failures.csv", f"overview.{figure_format}"]
        own = ("identification.csv", "summary.json", f"identification.{figure_format}")
        claim_outputs(
            out_dir, tables + [f"{record_folder(r.name)}/{name}" for r in records for name in own]
        )
        hashes = {}
        provenance = {r.name: make_provenance(r, settings, hashes) for r in records}
        todo = []
        for r in records:
            state = _state(folders[r.name], provenance[r.name], figure_format, record_figures)
            if state == "current":
                report.skipped += 1
            elif state == "stale" and not overwrite:
                failed.append((r.source, r.name, "outputs from other settings or inputs exist "
                               "(--no-overwrite)"))
                report.failed += 1
            else:
                todo.append((r, state))
        mesh = jax.sharding.Mesh(np.array(jax.devices()), ("records",))
        rows_cache = {}
        figures = _Figures(figure_workers if record_figures else 0, len(todo))
        cleanup.callback(figures.close)  # an interrupted run stops its workers too

        bar = cleanup.enter_context(Bar(len(todo), wanted(progress)))
        bar.update(0, failed=report.failed, skipped=report.skipped)
        last_table = [time.perf_counter()]

        def finished(r, state, ok):
            if ok:
                if state == "stale":
                    report.redone += 1
                else:
                    report.computed += 1
                # the table is rebuilt at most once a second (each rebuild writes every row) and
                # at the end; a killed run loses nothing: each record's summary.json is written
                # before it counts as done, and the next run rebuilds the table from them
                if time.perf_counter() - last_table[0] >= TABLE_EVERY_S:
                    _write_summary_table(
                        out_dir, records, folders, provenance, rows_cache, failed, overwrite
                    )
                    last_table[0] = time.perf_counter()
            else:
                report.failed += 1
            bar.update(failed=report.failed, skipped=report.skipped)

        def fail(r, e):
            failed.append((r.source, r.name, str(e).splitlines()[0] if str(e) else type(e).__name__))

        def settled():  # the records whose figure and summary are written, or failed to be
            for (r, state), error in figures.collect():
                if error is not None:  # a bad figure fails its record only
                    fail(r, error)
                finished(r, state, error is None)

        def write(r, state, columns, summary):  # a computed record's folder, then its figure
            try:
                summary["provenance"] = provenance[r.name]
                write_table(folders[r.name], columns, figure_format)
                inputs = r.inputs if record_figures else None
                figures.add((r, state), folders[r.name], columns, summary, inputs, figure_format)
            except Exception as e:  # noqa: BLE001
                fail(r, e)
                finished(r, state, False)

        config = dict(
            model=model, method=method, gamma=gamma, lam=lam, area=area, length=length, fit=fit,
            compare=bool(compare),
        )
        # records are padded to a few bucket lengths (m·2^k, neighbours merged where a compile
        # costs more than the padding: `plan_buckets`) and masked or cut back, so that a batch
        # compiles a few programs: the law runs a bucket's records together under vmap; the
        # gain tuning, the tracker and the refit run one record at a time. Steps equal to 12
        # digits share a bucket (a time column's rounding differs by file); a record on an
        # irregular clock is a bucket of its own, run at its length.
        def step(r):
            return float(f"{r.dt:.12g}")

        plans = {}
        for r, _ in todo:
            if r.uniform:
                plans.setdefault(step(r), []).append(r.time.size)
        plans = {
            dt: plan_buckets(sizes) if buckets else {n: n for n in sizes}
            for dt, sizes in plans.items()
        }

        def pad(r):
            return plans[step(r)][r.time.size]

        groups = {}
        for r, state in todo:
            key = (pad(r), step(r)) if r.uniform else (None, r.name)
            groups.setdefault(key, []).append((r, state))
        def settle(r, state, result):
            if isinstance(result, Exception):
                fail(r, result)
                finished(r, state, False)
            else:
                write(r, state, *result)
            settled()

        if client is None:
            for b, ((num, dt), group) in enumerate(groups.items()):
                # the first record of a bucket compiles its programs: say so
                what = (
                    f"{len(group)} record(s) padded to {num} samples" if num is not None
                    else f"record {dt!r} on its own irregular clock"
                )
                bar.note(f"length bucket {b + 1}/{len(groups)} ({what}): compiling")
                for r, state, result in _compute_group(group, num, dt, config, mesh):
                    settle(r, state, result)
        else:
            for chunk, results in _on_dask(client, groups, config, bar):
                for i, state, result in results:
                    settle(chunk[i][0], state, result)
        for _ in figures.drain():
            settled()
        settled()
        bar.close()
        rows = _write_summary_table(
            out_dir, records, folders, provenance, rows_cache, failed, overwrite
        )
        report.unidentified = sum(
            str(row.get("kalman_identified")) == "False" for row in rows
        )
        if rows:
            from .._plotting import overview_figure

            overview_figure(rows, out_dir / f"overview.{figure_format}", failed=len(failed))
        path = out_dir / "failures.csv"
        if failed:
            rows = [dict(file=f, record=n, reason=m) for f, n, m in sorted(failed, key=lambda x: (x[1], x[0]))]
            _write_table(path, rows)
        else:
            with contextlib.suppress(FileNotFoundError):
                path.unlink()  # a clean run leaves no stale failures
    return report


def _compute_group(group, num, dt, config, mesh=None):
    """Computes the records of one bucket (``num`` samples, step ``dt``; ``num=None``: one
    record on its own irregular clock), yielding ``(record, state, (columns, summary))`` per
    record as it is done, or ``(record, state, exception)`` for a record that failed. Writes
    nothing: the batch writes each record's folder where it runs (this process, or the
    process that holds a Dask client), so that the lock, the manifest and the atomic writes
    stay with it."""
    from .._tune import tune_gains

    model, method, gamma, lam = (config[k] for k in ("model", "method", "gamma", "lam"))
    area, length, fit = config["area"], config["length"], config["fit"]
    law = estimator(method) == "gradient"
    if mesh is None:
        mesh = jax.sharding.Mesh(np.array(jax.devices()), ("records",))
    prepared = []
    for r, state in group:
        try:
            u, y, names, physical = regressors(r, model, area, length)
            prepared.append((r, state, u, y, names, physical))
        except Exception as e:  # noqa: BLE001 - a bad record is reported, not fatal
            yield r, state, e
    if num is None or not law:
        gains = [(np.nan, np.nan)] * len(prepared)  # not run here
    elif gamma == "auto":
        # one record at a time, one compiled program per bucket (a vmapped search over the
        # bucket compiles for longer than it saves: 5.4 s against 2.8 s for 64 records of
        # 192 samples, cold)
        kept, gains = [], []
        for p in prepared:
            try:
                g = tune_gains(p[2], p[3], dt, lam=lam, pad_to=num)
            except Exception as e:  # noqa: BLE001
                yield p[0], p[1], e
            else:
                kept.append(p)
                gains.append((g.gamma, g.lam))
        prepared = kept
    else:
        gains = [(float(gamma), PAPER_LAM if lam is None else float(lam))] * len(prepared)
    if not prepared:
        return
    if num is not None and law:
        # padded after each record's end (inputs 0, output held): causal, so unseen
        us = np.stack([_pad_to(p[2], num, 0.0) for p in prepared])
        ys = np.stack([_pad_to(p[3], num, p[3][-1]) for p in prepared])
        lengths = [p[3].shape[0] for p in prepared]
        g = np.array(gains)
        try:
            out, x0 = adaptive_batch(us, ys, dt, g[:, 0], g[:, 1], mesh=mesh, lengths=lengths)
        except Exception as e:  # noqa: BLE001
            for r, state, *_ in prepared:
                yield r, state, e
            return
    for i, (r, state, u, y, names, physical) in enumerate(prepared):
        try:
            if num is None:  # an irregular clock: everything on it, one record
                columns, summary = identify_record(
                    r, model=model, method=method, gamma=gamma, lam=lam, area=area,
                    length=length, **fit,
                )
            elif law:
                columns, summary = _columns_from_batch(
                    r, y, names, physical, out, x0, i, g[i], model, method, area, length
                )
                if runs_refit(method):
                    refit_cols, refit_summary = identify_record(
                        r, model=model, method="refit", area=area, length=length,
                        pad_to=num, **fit,
                    )
                    for k in ("refit_alpha", "refit_alpha_lower", "refit_alpha_upper", "refit_y_hat"):
                        columns[k] = refit_cols[k]
                    summary["refit"] = refit_summary["refit"]
                    summary["disagreement"] = disagreement(columns, summary)
            else:  # the tracker and/or the refit: one record at a time
                columns, summary = identify_record(
                    r, model=model, method=method, area=area, length=length, pad_to=num, **fit,
                )
            if config.get("compare"):
                summary["compare"] = compare_part(r, area, length)
            check_finite(summary, columns)
        except Exception as e:  # noqa: BLE001
            yield r, state, e
        else:
            yield r, state, (columns, summary)


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


MIN_RECORDS_FOR_WORKERS = 4  # fewer records are drawn here: a worker takes ~2 s to start


class _Figures:
    """Each record's figure, then its ``summary.json`` (`finish_outputs`), written by worker
    processes while this process computes the next records, and by this process as well once
    it has none left (`drain`). Workers are started by spawn (forking a process that runs JAX's
    threads is unsafe) with `workers` processes (None: the cores but one, at least one, at most
    four; 0, or fewer than `MIN_RECORDS_FOR_WORKERS` records: none, all drawn here); each
    builds its figure at once, while the batch compiles. At most two records per worker are
    handed over at a time, so that the rest can still be drawn here."""

    def __init__(self, workers, count):
        import os

        if workers is None:
            workers = max(1, min(4, (os.cpu_count() or 2) - 1))
        if workers < 0:
            raise ValueError(f"`figure_workers` must be ≥ 0, got {workers}.")
        self.pool = None
        self.waiting = collections.deque()  # (key, arguments) not handed over yet
        self.running = []  # (key, future)
        self.ready = []  # (key, error or None)
        if workers and count >= MIN_RECORDS_FOR_WORKERS:
            import concurrent.futures
            import multiprocessing

            self.pool = concurrent.futures.ProcessPoolExecutor(
                max_workers=workers, mp_context=multiprocessing.get_context("spawn"),
                initializer=_figure_worker_init, initargs=(os.getpid(),),
            )
            self.limit = 2 * workers
            for _ in range(workers):
                self.running.append((None, self.pool.submit(warm_record_figure), None))

    def add(self, key, *arguments):
        """Queues `finish_outputs(*arguments)` for the record `key`."""
        if self.pool is None:
            self._here(key, arguments)
        else:
            self.waiting.append((key, arguments))
            self._hand_over()

    def _here(self, key, arguments):
        try:
            finish_outputs(*arguments)
        except Exception as e:  # noqa: BLE001
            self.ready.append((key, e))
        else:
            self.ready.append((key, None))

    def _hand_over(self):
        self._poll()
        while self.pool is not None and self.waiting and len(self.running) < self.limit:
            key, arguments = self.waiting.popleft()
            try:
                future = self.pool.submit(finish_outputs, *arguments)
            except concurrent.futures.BrokenExecutor:  # a worker died: draw here from now on
                self.waiting.appendleft((key, arguments))
                self._lost()
                return
            self.running.append((key, future, arguments))

    def _poll(self, wait=False):
        for item in list(self.running):
            key, future, arguments = item
            if wait or future.done():
                self.running.remove(item)
                try:
                    future.result()
                except concurrent.futures.BrokenExecutor:
                    # a worker was killed (out of memory, a signal): the record loses nothing,
                    # its figure and summary are drawn here
                    if key is not None:
                        self.waiting.append((key, arguments))
                    self._lost()
                    return
                except Exception as e:  # noqa: BLE001 - a bad figure fails its record only
                    if key is not None:  # a failed warm-up only costs time
                        self.ready.append((key, e))
                else:
                    if key is not None:
                        self.ready.append((key, None))

    def _lost(self):
        """The pool is broken: every record it held goes back to the queue, drawn here."""
        if self.pool is None:
            return
        for key, _, arguments in self.running:
            if key is not None:
                self.waiting.append((key, arguments))
        self.running = []
        self.pool.shutdown(wait=False, cancel_futures=True)
        self.pool = None

    def collect(self):
        """``(key, error or None)`` of the records finished since the last call."""
        if self.pool is not None:
            self._hand_over()
        ready, self.ready = self.ready, []
        return ready

    def drain(self):
        """Draws the records not handed over here, alongside the workers, yielding after each
        (for `collect`); returns when all are written (a worker lost on the way: its records
        are drawn here too)."""
        while self.waiting or self.running:
            if self.waiting:
                self._here(*self.waiting.popleft())
                self._hand_over()
            elif self.pool is not None:
                self._poll(wait=True)
            yield

    def close(self):
        if self.pool is not None:
            self.pool.shutdown(wait=True, cancel_futures=True)


def _figure_worker_init(parent):
    """A figure worker: Ctrl-C is its parent's to handle (the terminal sends it to the whole
    group; the parent stops the pool), and it exits as soon as its parent is gone, however
    the parent ended (SIGKILL included), so that nothing keeps running or holds the
    terminal's output. Linux asks the kernel for a signal at the parent's death; elsewhere a
    thread watches the parent's id."""
    import signal
    import threading

    signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        import ctypes

        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG
    except (OSError, AttributeError):
        pass

    def watch():
        while os.getppid() == parent:
            time.sleep(0.5)
        os._exit(0)

    if os.getppid() != parent:  # the parent died before the request took effect
        os._exit(0)
    threading.Thread(target=watch, daemon=True).start()


@dataclasses.dataclass
class BatchReport:
    """What a batch did: records computed, skipped as up to date, redone, and failed."""

    computed: int = 0
    skipped: int = 0
    redone: int = 0
    failed: int = 0
    # records in summary.csv whose tracker did not identify the order (the law's never does:
    # it is not counted)
    unidentified: int = 0


def _pad_to(a, num, value):
    """``a`` (N, …) extended to ``num`` rows with ``value``."""
    a = np.asarray(a)
    tail = np.full((num - a.shape[0],) + a.shape[1:], value, dtype=a.dtype)
    return np.concatenate([a, tail])


def _columns_from_batch(r, y, names, physical, batch, x0, i, gains, model, method, area, length):
    num = r.time.size  # the record's own samples, not its bucket's padding
    out, var_alpha, var_p = jax.tree_util.tree_map(lambda a: a[i][:num], batch)
    res = law_identification(
        out, var_alpha, var_p, float(x0[i, 0]), gains[0], gains[1], 0.5, r.dt, DEFAULT_BOUNDS,
        "exponential", host=True, y=y,
    )
    cols, part = adaptive_part(res, y, physical)
    columns = {"time": r.time, **cols, "y": y, "y_hat": np.asarray(res.y_hat)}
    summary = record_header(r, model, method, area, length)
    summary["parameter_names"] = names
    summary["gradient"] = part
    return columns, summary


def _summary_row(summary):
    row = {
        "record": summary["record"],
        "folder": record_folder(summary["record"]),
        "source": summary["source"],
        "samples": summary["samples"],
    }
    if "disagreement" in summary:
        row["disagreement"] = summary["disagreement"]
    if "compare" in summary:
        block = summary["compare"]
        for k in ("best", "second", "bayes_factor"):
            row[f"compare_{k}"] = block.get(k)
        for name, w in (block.get("weight") or {}).items():
            row[f"compare_weight_{name}"] = w
    for part in ("kalman", "gradient", "refit"):
        if part not in summary:
            continue
        for k, v in summary[part].items():
            if isinstance(v, (int, float, bool, str)) or v is None:
                row[f"{part}_{k}"] = v
        for group in ("parameters_final", "parameters_final_stderr", "parameters", "parameters_stderr"):
            for name, v in (summary[part].get(group) or {}).items():
                row[f"{part}_{group}_{name}"] = v
    return row


def _write_summary_table(
    out_dir, records, folders, provenance, cache=None, failed=(), overwrite=True
):
    """``summary.csv``: one row per record of this run whose outputs are current and that
    has not failed in this run, by name. `cache` (a dict kept over a run) holds the rows of
    summaries already read, by path and modification time, so that rebuilding the table
    after every record reads only new files. ``overwrite=False`` keeps every row of the
    table already there that this run did not replace (it rewrites nothing it would not
    redo: a record it refused to redo keeps its row)."""
    rows = []
    cache = {} if cache is None else cache
    lost = {name for _, name, _ in failed}
    for r in sorted(records, key=lambda r: r.name):
        if r.name in lost:
            continue
        path = folders[r.name] / "summary.json"
        try:
            stamp = path.stat().st_mtime_ns
            if cache.get(path, (None,))[0] != stamp:
                summary = strict_json(path.read_text())
                current = summary.get("provenance", {}).get("hash") == provenance[r.name]["hash"]
                cache[path] = (stamp, _summary_row(summary) if current else None)
        except (OSError, ValueError):
            continue
        if cache[path][1] is not None:
            rows.append(cache[path][1])
    if not overwrite:  # a row of the table already there stays unless this run replaced it
        new = {row["record"] for row in rows}
        kept = [row for row in _read_table(out_dir / "summary.csv") if row["record"] not in new]
        rows = sorted(rows + kept, key=lambda row: row["record"])
    _write_table(out_dir / "summary.csv", rows)
    return rows


def _read_table(path):
    """The rows of a table `_write_table` wrote (text cells unquoted), or [] if none."""
    try:
        with open(path, newline="", encoding="utf-8") as f:
            rows = list(csv.DictReader(f))
    except (OSError, UnicodeDecodeError, csv.Error):
        return []

    def plain(value):
        if isinstance(value, str) and value.startswith("'") and value[1:].startswith(FORMULA_START):
            return value[1:]
        return value

    return [
        {plain(k): (None if v == "" else plain(v)) for k, v in row.items()}
        for row in rows
        if row.get("record")
    ]


# a text cell starting with one of these is a formula to a spreadsheet (a record named
# "=HYPERLINK(…)" would run as one when the table is opened): it is written after a "'"
FORMULA_START = ("=", "+", "-", "@", "\t", "\r")


def _text_cell(value):
    if isinstance(value, str) and value.startswith(FORMULA_START):
        return "'" + value
    return value


def _write_table(path, rows):
    """Writes a CSV table atomically (an empty table is written as its header only); text
    that a spreadsheet would run as a formula is written after a ``'``."""
    fields = list(dict.fromkeys(k for row in rows for k in row)) or ["record"]
    buffer = io.StringIO()
    writer = csv.DictWriter(buffer, fieldnames=[_text_cell(f) for f in fields])
    writer.writeheader()
    writer.writerows({_text_cell(k): _text_cell(v) for k, v in row.items()} for row in rows)
    with atomic_path(path) as tmp, open(tmp, "w", newline="") as f:
        f.write(buffer.getvalue())
