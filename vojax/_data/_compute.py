"""The computation of one bucket of records, here or on a Dask worker: the law batched
over the bucket, the tracker and the refit one record at a time."""


import jax
import numpy as np

from .._adaptive._build import (
    PAPER_LAM,
)
from ._law_batch import _columns_from_batch, _pad_to, adaptive_batch
from ._pipeline import (
    check_finite,
    compare_part,
    disagreement,
    estimator,
    identify_record,
    regressors,
    runs_refit,
)
from ._regressors import FIT_OPTIONS


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
    # the law runs vmapped at its default order range; with --alpha-bounds, as identify_record
    law = estimator(method) == "gradient" and "alpha_bounds" not in fit
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
            else:  # the tracker and/or the refit (or the law): one record at a time
                columns, summary = identify_record(
                    r, model=model, method=method, gamma=gamma, lam=lam, area=area,
                    length=length, pad_to=num, **fit,
                )
            if config.get("compare"):
                summary["compare"] = compare_part(
                    r, area, length, **{k: fit[k] for k in FIT_OPTIONS if k in fit})
            check_finite(summary, columns)
        except Exception as e:  # noqa: BLE001
            yield r, state, e
        else:
            yield r, state, (columns, summary)
