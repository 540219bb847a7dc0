"""Batch re-identification: many records, equal lengths run together under `jax.vmap`, the
batch axis sharded over the available devices with `jax.sharding`.

Multi-host use: call `jax.distributed.initialize()` on every host before `run_batch`; the mesh
then spans `jax.devices()` of all hosts, and each host should be given its own share of the
files (the outputs are per record, so hosts do not collide).
"""

import contextlib
import csv
import dataclasses
import time
from pathlib import Path

import jax
import numpy as np

from .._progress import Bar, wanted
from ._compute import _compute_group
from ._dask import (
    SchedulerLost,
    _on_dask,
    dask_client,  # noqa: F401
)
from ._figures import _Figures  # noqa: F401
from ._law_batch import adaptive_batch  # noqa: F401
from ._lock import (
    BatchBusy,  # noqa: F401
    _locked,
    _remove_orphans,
)
from ._paths import check_out_holds_no_input, claim_outputs, inside, record_folder
from ._pipeline import (
    canonical_method,
    check_parameters,
    make_provenance,
    plan_buckets,
    write_table,
)
from ._tables import (
    _write_summary_table,
    _write_table,
    natural_key,
    strict_json,
)

TABLE_EVERY_S = 1.0  # summary.csv is rebuilt at most this often during a run, and at its end
TABLE_SHARE = 0.05  # and taking at most this share of the run: a rebuild writes every row
# (0.27 s for a map of 3,200 curves, 2.4 kB a row), so it waits 20 times its own duration


class Throttle:
    """When a periodic task is due: at most once every `every_s` seconds, and so that it
    takes at most `share` of the time (after a run of d seconds it waits d / share)."""

    def __init__(self, every_s: float, share: float, now: float):
        self.every_s, self.share = every_s, share
        self.last, self.wait = now, every_s

    def due(self, now: float) -> bool:
        return now - self.last >= self.wait

    def ran(self, started: float, ended: float):
        self.last, self.wait = ended, max(self.every_s, (ended - started) / self.share)


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
    time_scale=None,
    alpha_bounds=None,
    noise=None,
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
    clock. `origin`: the refit's, `fit_from`, `fit_to`: the tracker's and the refit's fit
    window, `parameters`, `max_points`, `x0`,
    `time_scale` and `noise`: the tracker's, `alpha_bounds`: every estimator's, as in `identify_record`.

    `client`: a Dask ``distributed.Client`` (``pip install "vojax[dask]"``) to compute the
    records on its workers, in tasks of a few records of one length bucket each (see
    `dask_client`); this process keeps the lock, writes every record's folder and draws the
    figures, as without it. Results equal the single-process run's to rounding.
    """
    check_parameters(method, parameters, max_points, x0, time_scale, noise)
    if client is not None and not all(hasattr(client, a) for a in ("submit", "nthreads")):
        raise TypeError(
            f"`client` must be a distributed.Client, got {type(client).__name__}: start one "
            "with vojax.io.dask_client('local') (a context manager) and pass what it gives."
        )
    method = canonical_method(method)
    out_dir = Path(out_dir)
    check_out_holds_no_input(out_dir, [r.source for r in records] + [f[0] for f in failures])
    out_dir.mkdir(parents=True, exist_ok=True)
    fit = {
        k: v
        for k, v in dict(
            origin=origin, fit_from=fit_from, fit_to=fit_to, parameters=parameters,
            max_points=max_points, x0=None if x0 is None else float(x0),
            time_scale=None if time_scale is None else float(time_scale),
            alpha_bounds=None if alpha_bounds is None else [float(b) for b in alpha_bounds],
            noise=None if noise is None else {k: float(v) for k, v in dict(noise).items()},
        ).items()
        if v is not None
    }
    settings = dict(
        model=model, method=method, gamma=gamma, lam=lam, area=area, length=length,
        figure_format=figure_format, **(loader or {}), **fit,
        **({"compare": True} if compare else {}),
    )
    config = dict(
        model=model, method=method, gamma=gamma, lam=lam, area=area, length=length, fit=fit,
        compare=bool(compare),
    )
    _check_table_paths(out_dir, figure_format)
    with _locked(out_dir), contextlib.ExitStack() as cleanup:
        _remove_orphans(out_dir)
        run = _Run(out_dir, records, failures, settings, figure_format, overwrite)
        todo = run.plan(record_figures)
        run.figures = _Figures(figure_workers if record_figures else 0, len(todo))
        cleanup.callback(run.figures.close)  # an interrupted run stops its workers too
        run.bar = cleanup.enter_context(Bar(len(todo), wanted(progress)))
        run.bar.update(0, failed=run.report.failed, skipped=run.report.skipped)
        groups = _groups(todo, buckets)
        if client is None:
            run.compute_here(groups, config)
        else:
            run.compute_on_dask(client, groups, config)
        for _ in run.figures.drain():
            run.settled()
        run.settled()
        run.bar.close()
        run.tabulate()
    return run.report


def _check_table_paths(out_dir, figure_format):
    for name in ("summary.csv", "failures.csv", f"overview.{figure_format}",
                 f"maps.{figure_format}"):
        if (out_dir / name).is_dir() and not (out_dir / name).is_symlink():
            raise ValueError(
                f"{out_dir / name} is a folder, where the batch writes its {name}: rename it "
                "or choose another --out."
            )


def _step(r):
    """A uniform record's step to 12 digits: a time column's rounding differs by file."""
    return float(f"{r.dt:.12g}")


def _groups(todo, buckets):
    """The records to compute, grouped by (padded length, step); a record on an irregular
    clock is a group of its own, keyed (None, its name), run at its length.

    Records are padded to a few bucket lengths (m·2^k, neighbours merged where a compile costs
    more than the padding: `plan_buckets`) and masked or cut back, so that a batch compiles a
    few programs: the law runs a bucket's records together under vmap; the gain tuning, the
    tracker and the refit run one record at a time."""
    sizes = {}
    for r, _ in todo:
        if r.uniform:
            sizes.setdefault(_step(r), []).append(r.time.size)
    plans = {
        dt: plan_buckets(n) if buckets else {k: k for k in n} for dt, n in sizes.items()
    }
    groups = {}
    for r, state in todo:
        key = (plans[_step(r)][r.time.size], _step(r)) if r.uniform else (None, r.name)
        groups.setdefault(key, []).append((r, state))
    return groups


class _Run:
    """One batch while it runs: its records' folders and provenance, the failures, the report,
    the progress bar and the figure pool. Its methods are the stages: plan, compute (here or
    on Dask), write each record (folder, then figure), tabulate."""

    def __init__(self, out_dir, records, failures, settings, figure_format, overwrite):
        self.out_dir, self.records = out_dir, records
        self.figure_format, self.overwrite = figure_format, overwrite
        self.failed = list(failures)
        self.report = BatchReport(failed=len(self.failed))
        self.folders = {r.name: inside(out_dir, record_folder(r.name)) for r in records}
        tables = ["summary.csv", "failures.csv", f"overview.{figure_format}"]
        if any(dict(r.afm).get("grid_index_x") is not None for r in records):
            tables.append(f"maps.{figure_format}")  # a force map's curves: maps of them
        own = ("identification.csv", "summary.json", f"identification.{figure_format}")
        claim_outputs(
            out_dir, tables + [f"{record_folder(r.name)}/{name}" for r in records for name in own]
        )
        hashes = {}
        self.provenance = {r.name: make_provenance(r, settings, hashes) for r in records}
        self.rows_cache = {}
        self.table_due = Throttle(TABLE_EVERY_S, TABLE_SHARE, time.perf_counter())
        self.figures = self.bar = None
        self.record_figures = True

    def plan(self, record_figures):
        """The records to compute, with their state ("missing" or "stale"); up-to-date records
        are counted as skipped, stale ones under ``overwrite=False`` as failed."""
        self.record_figures = record_figures
        todo = []
        for r in self.records:
            state = _state(
                self.folders[r.name], self.provenance[r.name], self.figure_format,
                record_figures,
            )
            if state == "current":
                self.report.skipped += 1
            elif state == "stale" and not self.overwrite:
                self.failed.append((r.source, r.name, "outputs from other settings or inputs "
                                    "exist (--no-overwrite)"))
                self.report.failed += 1
            else:
                todo.append((r, state))
        return todo

    def table(self):
        return _write_summary_table(
            self.out_dir, self.records, self.folders, self.provenance, self.rows_cache,
            self.failed, self.overwrite,
        )

    def finished(self, r, state, ok):
        if ok:
            if state == "stale":
                self.report.redone += 1
            else:
                self.report.computed += 1
            # the table is rebuilt at most once a second and 5 % of the time (each rebuild
            # writes every row) and at the end; a killed run loses nothing: each record's
            # summary.json is written before it counts as done, and the next run rebuilds
            # the table from them
            if self.table_due.due(time.perf_counter()):
                started = time.perf_counter()
                self.table()
                self.table_due.ran(started, time.perf_counter())
        else:
            self.report.failed += 1
        self.bar.update(failed=self.report.failed, skipped=self.report.skipped)

    def fail(self, r, e):
        reason = str(e).splitlines()[0] if str(e) else type(e).__name__
        self.failed.append((r.source, r.name, reason))

    def settled(self):
        """Counts the records whose figure and summary are written, or failed to be."""
        for (r, state), error in self.figures.collect():
            if error is not None:  # a bad figure fails its record only
                self.fail(r, error)
            self.finished(r, state, error is None)

    def settle(self, r, state, result):
        """A computed record (or its exception): its folder is written, its figure queued."""
        if isinstance(result, Exception):
            self.fail(r, result)
            self.finished(r, state, False)
        else:
            columns, summary = result
            try:
                summary["provenance"] = self.provenance[r.name]
                write_table(self.folders[r.name], columns, self.figure_format)
                inputs = r.inputs if self.record_figures else None
                self.figures.add(
                    (r, state), self.folders[r.name], columns, summary, inputs,
                    self.figure_format,
                )
            except Exception as e:  # noqa: BLE001
                self.fail(r, e)
                self.finished(r, state, False)
        self.settled()

    def compute_here(self, groups, config):
        mesh = jax.sharding.Mesh(np.array(jax.devices()), ("records",))
        for b, ((num, dt), group) in enumerate(groups.items()):
            # the first record of a bucket compiles its programs: say so
            what = (
                f"{len(group)} record(s) padded to {num} samples" if num is not None
                else f"record {dt!r} on its own irregular clock"
            )
            self.bar.note(f"length bucket {b + 1}/{len(groups)} ({what}): compiling")
            for r, state, result in _compute_group(group, num, dt, config, mesh):
                self.settle(r, state, result)

    def compute_on_dask(self, client, groups, config):
        try:
            for chunk, results in _on_dask(client, groups, config, self.bar):
                for i, state, result in results:
                    self.settle(chunk[i][0], state, result)
        except SchedulerLost:  # the table holds what was finished; a re-run resumes
            self.bar.close()
            self.table()
            raise

    def tabulate(self):
        """summary.csv, the overview figure and failures.csv (removed after a clean run)."""
        rows = self.table()
        self.report.unidentified = sum(
            str(row.get("kalman_identified")) == "False" for row in rows
        )
        if rows:
            from .._plotting import overview_figure

            overview_figure(
                rows, self.out_dir / f"overview.{self.figure_format}", failed=len(self.failed)
            )
            from .._plotting_maps import map_figure

            map_figure(rows, self.out_dir / f"maps.{self.figure_format}")
        path = self.out_dir / "failures.csv"
        if self.failed:
            order = sorted(self.failed, key=lambda x: (natural_key(x[1]), x[0]))
            _write_table(path, [dict(file=f, record=n, reason=m) for f, n, m in order])
        else:
            with contextlib.suppress(FileNotFoundError):
                path.unlink()  # a clean run leaves no stale failures
