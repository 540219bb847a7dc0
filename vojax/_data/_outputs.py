"""What a record's pipeline writes: its summary's checks (no non-finite estimate),
its provenance, `identification.csv`, `summary.json`, the figure and the tables."""


import csv
import dataclasses
import io
from pathlib import Path

import numpy as np

from .._io import atomic_path, write_json


def diagnostics_dict(d):
    """The `Diagnostics` of an identification as JSON-ready values."""
    out = dataclasses.asdict(d)
    out["at_edge"] = list(out["at_edge"])
    out["reasons"] = list(out["reasons"])
    out["next_steps"] = list(out["next_steps"])
    return out


ESTIMATES = ("alpha", "alpha_lower", "alpha_upper", "alpha_conditional", "y_hat", "refit_alpha",
             "refit_y_hat")


def _non_finite(data, where=""):
    """The key path of the first non-finite number in a JSON-like structure, or None."""
    if isinstance(data, float):
        return where if not np.isfinite(data) else None
    if isinstance(data, dict):
        items = data.items()
    elif isinstance(data, (list, tuple)):
        items = enumerate(data)
    else:
        return None
    for k, v in items:
        bad = _non_finite(v, f"{where}.{k}" if where else str(k))
        if bad is not None:
            return bad
    return None


def _without_errors(data):
    if isinstance(data, dict):
        # errors and diagnostic statistics may be undefined (null in JSON); estimates not
        return {
            k: _without_errors(v) for k, v in data.items()
            if "stderr" not in k
            and k not in ("innovation_correlation", "block_error", "noise_correlation",
                          "breakdown_drift", "conditional_halfwidth", "reference_drift",
                          "clock_order", "settling_test", "residual_correlation")
        }
    return data


def check_finite(summary, columns):
    """Raises `ValueError` naming the first non-finite estimate: a failure is never a result."""
    for name in ESTIMATES:
        if name in columns:
            values = np.asarray(columns[name], dtype=float)
            if not np.all(np.isfinite(values)):
                k = int(np.argmax(~np.isfinite(values)))
                raise ValueError(f"the identification diverged: {name} is not finite at sample {k}.")
    # an infinite standard error is a result (the data do not determine that quantity; JSON
    # writes null), a non-finite estimate is not; nor is a parameter the refit names as
    # undetermined (1/p of a coefficient fitted as 0)
    parts = {
        k: _without_errors(v) for k, v in summary.items() if k in ("kalman", "gradient", "refit")
    }
    if "refit" in parts:
        loose = set(parts["refit"].get("parameters_undetermined", ()))
        parts["refit"] = {
            **parts["refit"],
            "parameters": {
                k: v for k, v in parts["refit"].get("parameters", {}).items() if k not in loose
            },
        }
    bad = _non_finite(parts)
    if bad is not None:
        raise ValueError(f"the identification diverged: {bad} is not finite.")


def file_sha256(path) -> str:
    import hashlib

    digest = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def versions() -> dict:
    """The versions that produced a result: vojax, JAX and Python."""
    import platform

    import jax

    from .._version import version

    return {"vojax": version(), "jax": jax.__version__, "python": platform.python_version()}


def make_provenance(record, settings, cache=None) -> dict:
    """Versions, the input file and its SHA-256, the record and every setting that affects the
    numbers, with the SHA-256 of all of it (`hash`) for deciding whether outputs are current."""
    import hashlib
    import json

    source = str(Path(record.source).resolve())
    cache = {} if cache is None else cache
    if source not in cache:
        cache[source] = file_sha256(source) if Path(source).is_file() else None
    block = {
        **versions(),
        "source": source,
        "source_sha256": cache[source],
        "record": record.name,
        "settings": {k: settings[k] for k in sorted(settings)},
    }
    text = json.dumps(block, sort_keys=True, default=str)
    return {**block, "hash": hashlib.sha256(text.encode()).hexdigest()}


def record_header(record, model, method, area, length):
    """The part of a record's summary that describes the data and the settings."""
    return {
        "record": record.name,
        "source": record.source,
        "samples": int(record.time.size),
        # the file's time at the first sample: each record's clock (`time`, the knots, the
        # fit window's samples) starts at 0 there; `file_time` in identification.csv is both
        "time_offset": float(record.time_offset),
        "dt": record.dt,
        "uniform_clock": record.uniform,
        "resampled_step_spread": record.resampled,
        "model": model,
        "method": method,
        "time_column": record.time_name,
        "input_columns": list(record.input_names),
        "output_column": record.output_name,
        "area": area,
        "length": length,
        **({"units": dict(record.units)} if record.units else {}),
        **({"afm": dict(record.afm)} if record.afm else {}),
    }


def nrmse(y, y_hat):
    """Root-mean-square error normalised by the range of ``y``."""
    span = float(np.ptp(y))
    return (
        float(np.sqrt(np.mean((np.asarray(y_hat) - y) ** 2)) / span) if span > 0 else float("nan")
    )


def write_outputs(out_dir, columns, summary, inputs=None, figure_format="png"):
    """``identification.csv``, ``summary.json`` and ``identification.<figure_format>`` (when
    `inputs` are given) in ``out_dir``, each written atomically, the summary last."""
    write_table(out_dir, columns, figure_format)
    finish_outputs(out_dir, columns, summary, inputs, figure_format)


def write_table(out_dir, columns, figure_format="png"):
    """``identification.csv`` in ``out_dir``, atomically: the per-sample columns. An older
    ``summary.json`` there is removed first (it is written last, by `finish_outputs`)."""
    if figure_format not in ("png", "svg", "pdf"):
        raise ValueError(f"`figure_format` must be png, svg or pdf, got {figure_format!r}.")
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    buffer = io.StringIO()
    writer = csv.writer(buffer)
    names = list(columns)
    writer.writerow(names)
    # a quantity undefined at a sample (η = 1/p while p̂ = 0 at sample 0) is left empty;
    # repr of a Python float is the shortest string that reads back to the same number
    data = np.column_stack([np.asarray(columns[n], dtype=float) for n in names])
    finite = np.isfinite(data).tolist()
    writer.writerows(
        [repr(v) if ok else "" for v, ok in zip(row, oks)]
        for row, oks in zip(data.tolist(), finite)
    )
    # summary.json is written last and certifies the folder: the old one goes first, so that
    # a run killed between this table and its summary never leaves this table under the
    # summary of another run (which the same settings as that run would take as current)
    summary = out_dir / "summary.json"
    if summary.is_file() or summary.is_symlink():
        summary.unlink()
    with atomic_path(out_dir / "identification.csv") as tmp, open(tmp, "w") as f:
        f.write(buffer.getvalue())


def finish_outputs(out_dir, columns, summary, inputs=None, figure_format="png"):
    """The figure (when `inputs` are given), then ``summary.json``, whose presence marks the
    record's outputs as complete. Runs in a worker process in a batch."""
    out_dir = Path(out_dir)
    if inputs is not None:
        from .._plotting_record import record_figure

        record_figure(columns, summary, inputs, out_dir / f"identification.{figure_format}")
    write_json(out_dir / "summary.json", summary)
