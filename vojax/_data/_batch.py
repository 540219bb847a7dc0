"""Batch re-identification: many records, equal lengths run together under `jax.vmap`, the
batch axis sharded over the available devices with `jax.sharding`.

Multi-host use: call `jax.distributed.initialize()` on every host before `run_batch`; the mesh
then spans `jax.devices()` of all hosts, and each host should be given its own share of the
files (the outputs are per record, so hosts do not collide).
"""

import csv
import io
import sys

import jax
import jax.numpy as jnp
import numpy as np

from .._adaptive._bands import law_covariance
from .._identify import DEFAULT_BOUNDS, PAPER_LAM, auto_r0, build_law, law_identification, run_law
from .._io import atomic_path
from .._stats import noise_variance
from ._pipeline import adaptive_part, identify_record, record_header, regressors, write_outputs


def _sharded(x, mesh):
    """Places ``x`` with its leading (batch) axis split over the mesh's devices."""
    spec = jax.sharding.PartitionSpec("records", *([None] * (x.ndim - 1)))
    return jax.device_put(x, jax.sharding.NamedSharding(mesh, spec))


def adaptive_batch(us, ys, dt, gammas, lams, r0s=None, *, alpha0=0.5, mesh=None):
    """The adaptive law on records of equal length at once: ``us`` (B, N, n), ``ys`` (B, N),
    gains (B,), ``r0s`` (B, n, n) (default: each record's automatic ``R_0``, as `identify`).
    Returns ``((law outputs, var α̂, var p̂), x0)`` with a leading batch axis; the variances
    are the law's band, as in `identify`. ``y − y[0]`` is identified
    (Remark 4), as `identify` does by default."""
    if r0s is None:
        r0s = np.stack(
            [auto_r0(jnp.asarray(u), dt, alpha0, "exponential", "trapezoid", 1e-10, DEFAULT_BOUNDS) for u in us]
        )
    num = us.shape[1]
    x0 = ys[:, :1]

    sigma2 = np.array([noise_variance(y - y[0]) for y in ys])

    def one(u, y, gamma, lam, r0, s2):
        law = build_law(
            dt,
            num,
            lam=lam,
            gamma=gamma,
            alpha0=alpha0,
            alpha_bounds=DEFAULT_BOUNDS,
            memory="exponential",
            rule="trapezoid",
            r0=r0,
        )
        out = run_law(law, u, y)
        var_alpha, var_p = law_covariance(law, u, y, s2)
        return out, var_alpha, var_p

    args = [jnp.asarray(a) for a in (us, ys - x0, gammas, lams, r0s, sigma2)]
    if mesh is not None:
        size = mesh.devices.size
        pad = (-args[0].shape[0]) % size
        if pad:  # repeat the last record: its results are dropped below
            args = [jnp.concatenate([a, jnp.repeat(a[-1:], pad, axis=0)]) for a in args]
        args = [_sharded(a, mesh) for a in args]
    out = jax.jit(jax.vmap(one))(*args)
    return jax.tree_util.tree_map(lambda a: np.asarray(a)[: us.shape[0]], out), np.asarray(x0)


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
    progress=True,
):
    """Identifies every record into ``out_dir/<record>/``; returns the number that failed.

    A record whose ``summary.json`` exists is skipped (complete). A record that fails is listed
    in ``failures.csv`` with its reason and the rest go on. ``summary.csv`` gets a row per record.
    """
    from .._tune import tune_gains

    out_dir.mkdir(parents=True, exist_ok=True)
    failed = list(failures)
    rows = []
    todo = [r for r in records if not (out_dir / r.name / "summary.json").is_file()]
    done = len(records) - len(todo)
    mesh = jax.sharding.Mesh(np.array(jax.devices()), ("records",))

    def report():
        if progress:
            print(
                f"\rvojax batch: {done}/{len(records)} records done",
                end="",
                file=sys.stderr,
                flush=True,
            )

    report()
    # equal lengths (and steps) run together under vmap
    buckets = {}
    for r in todo:
        buckets.setdefault((r.time.size, r.dt), []).append(r)
    for (num, dt), group in buckets.items():
        prepared, gains = [], []
        for r in group:
            try:
                u, y, names, physical = regressors(r, model, area, length)
                if gamma == "auto" and method in ("adaptive", "both"):
                    g = tune_gains(u, y, dt, lam=lam)
                    gains.append((g.gamma, g.lam))
                else:
                    gains.append((float(gamma), PAPER_LAM if lam is None else float(lam)))
                prepared.append((r, u, y, names, physical))
            except Exception as e:  # noqa: BLE001 - a bad record is reported, not fatal
                failed.append((r.source, r.name, str(e).splitlines()[0]))
                done += 1
                report()
        if not prepared:
            continue
        if method in ("adaptive", "both"):
            us = np.stack([p[1] for p in prepared])
            ys = np.stack([p[2] for p in prepared])
            g = np.array(gains)
            out, x0 = adaptive_batch(us, ys, dt, g[:, 0], g[:, 1], mesh=mesh)
        for i, (r, u, y, names, physical) in enumerate(prepared):
            try:
                if method in ("adaptive", "both"):
                    columns, summary = _columns_from_batch(
                        r, y, names, physical, out, x0, i, g[i], model, method, area, length
                    )
                    if method == "both":
                        refit_cols, refit_summary = identify_record(
                            r, model=model, method="refit", area=area, length=length
                        )
                        for k in ("refit_alpha", "refit_alpha_lower", "refit_alpha_upper", "refit_y_hat"):
                            columns[k] = refit_cols[k]
                        summary["refit"] = refit_summary["refit"]
                else:  # "refit" or "kalman": one record at a time
                    columns, summary = identify_record(
                        r, model=model, method=method, area=area, length=length
                    )
                if not np.all(
                    np.isfinite(columns["y_hat" if "y_hat" in columns else "refit_y_hat"])
                ):
                    raise ValueError("the identification diverged (non-finite output)")
                write_outputs(out_dir / r.name, columns, summary, r.inputs)
                rows.append(_summary_row(summary))
            except Exception as e:  # noqa: BLE001
                failed.append((r.source, r.name, str(e).splitlines()[0]))
            done += 1
            report()
    if progress:
        print(file=sys.stderr)
    _write_table(out_dir / "summary.csv", rows, append=True)
    if failed:
        _write_table(
            out_dir / "failures.csv", [dict(file=f, record=n, reason=m) for f, n, m in failed]
        )
    return len(failed)


def _columns_from_batch(r, y, names, physical, batch, x0, i, gains, model, method, area, length):
    out, var_alpha, var_p = jax.tree_util.tree_map(lambda a: a[i], batch)
    res = law_identification(
        out, var_alpha, var_p, float(x0[i, 0]), gains[0], gains[1], 0.5, r.dt, DEFAULT_BOUNDS,
        "exponential",
    )
    cols, part = adaptive_part(res, y, physical)
    columns = {"time": r.time, **cols, "y": y, "y_hat": np.asarray(res.y_hat)}
    summary = record_header(r, model, method, area, length)
    summary["parameter_names"] = names
    summary["adaptive"] = part
    return columns, summary


def _summary_row(summary):
    row = {"record": summary["record"], "source": summary["source"], "samples": summary["samples"]}
    for part in ("adaptive", "refit"):
        if part in summary:
            for k, v in summary[part].items():
                if isinstance(v, (int, float, bool)):
                    row[f"{part}_{k}"] = v
    return row


def _write_table(path, rows, append=False):
    """Writes (or extends) a CSV table atomically, keeping earlier rows of an interrupted run."""
    old = []
    if append and not rows:
        return  # nothing new: leave the table as it is
    if append and path.is_file():
        with open(path, newline="") as f:
            old = list(csv.DictReader(f))
    rows = old + rows
    if not rows:
        return
    fields = list(dict.fromkeys(k for row in rows for k in row))
    buffer = io.StringIO()
    writer = csv.DictWriter(buffer, fieldnames=fields)
    writer.writeheader()
    writer.writerows(rows)
    with atomic_path(path) as tmp, open(tmp, "w") as f:
        f.write(buffer.getvalue())
