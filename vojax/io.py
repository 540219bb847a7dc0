"""Files in and out: recorded tests, the per-record identification, and the shipped examples.

```python
import jax
import vojax.io

jax.config.update("jax_enable_x64", True)
path = vojax.io.example_file("adhesive")
record, = vojax.io.load_records(
    path, time="time_s", inputs=["nominal_shear_stress_kPa"], output="shear_strain"
)
columns, summary = vojax.io.identify_record(record, model="springpot", method="refit")
print(summary["refit"]["order"], summary["refit"]["parameters"])   # q and η (kPa·s^q)
```

`vojax.io.write_results(folder, columns, summary, record)` then writes what `vojax identify`
writes: ``identification.csv``, ``summary.json`` and the figure, each atomically.
"""

import math
from pathlib import Path

from ._data._batch import BatchReport, dask_client
from ._data._batch import run_batch as _run_batch
from ._data._contact import POC_METHODS
from ._data._errors import CurvesFailed
from ._data._pipeline import canonical_method, make_provenance, write_outputs
from ._data._pipeline import identify_record as _identify_record
from ._data._records import DataError, Record, load_records
from ._progress import wanted
from ._values import flag

__all__ = [
    "BatchReport",
    "CurvesFailed",
    "DataError",
    "POC_METHODS",
    "Record",
    "dask_client",
    "example_file",
    "identify_record",
    "load_records",
    "run_batch",
    "write_results",
]

_EXAMPLES = {
    "adhesive": "adhesive_shear_staircase.csv",
    "myocardium": "myocardium_ramp_hold_10s.csv",
}


def example_file(name: str) -> Path:
    """The path of a recording shipped with vojax (MIT-licensed; see ``vojax/examples/README.md``):

    - ``"adhesive"``: an optically clear adhesive in simple shear, a staircase of ramps and
      holds (columns ``time_s``, ``force_N``, ``displacement_mm``, ``nominal_shear_stress_kPa``,
      ``shear_strain``);
    - ``"myocardium"``: passive myocardium stretched in a 10 s ramp and held (columns ``Time``
      in s, ``L`` = L/L₀, ``F`` tension in kPa, ``SD``).
    """
    if name not in _EXAMPLES:
        raise ValueError(f"no example {name!r}; the examples are {', '.join(map(repr, _EXAMPLES))}.")
    return Path(__file__).parent / "examples" / _EXAMPLES[name]


def _check_model(model, area, length):
    """The model's name, and eq. (35)'s area and length where given, as the command checks them."""
    if model not in ("springpot", "kelvin-voigt", "linear"):
        raise ValueError(f"`model` must be springpot, kelvin-voigt or linear, got {model!r}.")
    for key, value in (("area", area), ("length", length)):
        if value is not None and not float(value) > 0:
            raise ValueError(f"`{key}` must be positive, got {value}.")


def identify_record(
    record: Record,
    *,
    model: str = "springpot",
    method: str = "kalman",
    gamma="auto",
    lam=None,
    area=None,
    length=None,
    parameters=None,
):
    """Identifies one `Record` as ``vojax identify`` does; returns ``(columns, summary)``.

    - `model`: ``"springpot"`` (σ = η D^q ε: u = σ, p = 1/η), ``"kelvin-voigt"``
      (σ = kε + η D^q ε: u = [σ, ε], p = [1/η, −k/η]) or ``"linear"`` (the input columns as
      given).
    - `method`: ``"kalman"`` (the tracker, default), ``"gradient"`` (the paper's law, with
      `gamma` and `lam`), ``"refit"`` (constant-order least squares), or ``"kalman+refit"``
      / ``"gradient+refit"`` (one of the first two and the refit). The same names as
      `vojax.identify`'s `method` and the keys of the summary.
    - `area`, `length`: eq. (35): σ = F/a and ε = d/l.
    - `parameters`: the tracker's, as in `vojax.identify` (``"free"`` when None).

    `columns` holds the per-sample series (``time``, ``alpha`` and its band, the physical
    parameters, ``y``, ``y_hat``, the refit's columns), `summary` the estimates with their
    standard errors and the diagnostics (the contents of ``summary.json``).
    """
    _check_model(model, area, length)
    method = canonical_method(method)
    return _identify_record(
        record, model=model, method=method, gamma=gamma, lam=lam, area=area, length=length,
        parameters=parameters,
    )


def write_results(folder, columns, summary, record: Record | None = None, *, figure_format="png"):
    """Writes ``identification.csv``, ``summary.json`` (with a provenance block: versions, the
    input file's SHA-256, the settings) and, when `record` is given,
    ``identification.<figure_format>`` (png, svg or pdf) into `folder`, each atomically.
    Returns the folder as a `Path`.

    **Raises:** `TypeError` or `ValueError`, before anything is written, for a `folder` that
    is not a path, `columns` that are not named columns (N,) of numbers of one length, a
    `summary` that is not a mapping JSON can hold, or a `record` that is not a `Record`."""
    _check_results(folder, columns, summary, record)
    folder = Path(folder)
    summary = dict(summary)
    if record is not None:
        settings = {k: summary.get(k) for k in ("model", "method", "area", "length")}
        summary["provenance"] = make_provenance(record, {**settings, "figure_format": figure_format})
    write_outputs(folder, columns, summary, None if record is None else record.inputs, figure_format)
    return folder


def _check_results(folder, columns, summary, record):
    """`write_results`'s arguments checked, so that a bad one writes nothing (an older
    ``summary.json`` there would go first)."""
    import os
    from collections.abc import Mapping

    from ._io import json_text
    from ._values import reals

    if isinstance(folder, bool) or not isinstance(folder, (str, os.PathLike)) or not str(folder):
        raise TypeError(f"`folder` must be a path, got {folder!r}.")
    if Path(folder).exists() and not Path(folder).is_dir():
        raise ValueError(f"`folder` {str(folder)!r} is a file, not a folder.")
    if not isinstance(columns, Mapping):
        raise TypeError("`columns` must be a mapping of column names to samples, got "
                        f"{type(columns).__name__}.")
    if not columns:
        raise ValueError("`columns` is empty: give at least one column of samples.")
    lengths = set()
    for name, values in columns.items():
        if not isinstance(name, str) or not name:
            raise TypeError(f"`columns`' names must be non-empty text, got {name!r}.")
        shape = reals(values, f"columns[{name!r}]").shape
        if len(shape) != 1 or not shape[0]:
            raise ValueError(f"`columns[{name!r}]` must be one column of samples (N,), got shape "
                             f"{shape}.")
        lengths.add(shape[0])
    if len(lengths) > 1:
        raise ValueError(f"`columns` must all have one length, got lengths {sorted(lengths)}.")
    if not isinstance(summary, Mapping):
        raise TypeError(f"`summary` must be a mapping (a dict), got {type(summary).__name__}.")
    try:
        json_text(dict(summary))  # as `write_json` will write it
    except (TypeError, ValueError):
        raise TypeError("`summary` must hold what JSON can: text keys, and numbers, text, "
                        "True/False, None, and lists and mappings of these.") from None
    if record is not None and not isinstance(record, Record):
        raise TypeError(f"`record` must be a vojax.io.Record or None, got {type(record).__name__}.")


def run_batch(
    records,
    out,
    *,
    model: str = "springpot",
    method: str = "kalman",
    gamma="auto",
    lam=None,
    area=None,
    length=None,
    parameters=None,
    overwrite: bool = True,
    figure_format: str = "png",
    record_figures: bool = True,
    progress: bool | None = None,
    client=None,
    failures=(),
    compare: bool = False,
) -> BatchReport:
    """Identifies every `Record` into ``out/<folder>/`` as ``vojax batch`` does (the same
    defaults, outputs, lock, provenance and re-run rules; see the command line's docs) and
    returns a `BatchReport` (records computed, skipped as up to date, redone, failed, and not
    identified). A record that fails is listed in ``out/failures.csv`` and the rest go on.

    `failures`: ``(file, record, reason)`` triples of what could not be loaded (a
    `DataError` from `load_records`), listed in ``out/failures.csv`` with the records that
    fail here and counted in the report.

    `compare`: also rank the laws each record supports (`vojax.compare`: springpot,
    Kelvin–Voigt, Maxwell, Zener and a variable order, by evidence), as the ``compare``
    block of its ``summary.json`` and the ``compare_*`` columns of ``summary.csv`` (the best
    law, the next, the Bayes factor between them, each law's weight). Records with one
    input column only.

    `progress`: a progress bar (tqdm) on stderr with the records done, failed and up to date
    and the time left; ``None`` (the default) shows it when stderr is a terminal, not in a log
    file or a pipe.

    `client`: a Dask ``distributed.Client`` to compute the records on its workers
    (``pip install "vojax[dask]"``); `dask_client` makes one (``"local"``: worker processes on
    this machine; an address: a running cluster). This process writes every output either
    way, and the results equal the single-process run's to rounding::

        with vojax.io.dask_client("local", workers=4) as client:
            report = vojax.io.run_batch(records, "out", client=client)
    """
    _check_model(model, area, length)
    wanted(progress)  # True, False or None
    flag(compare, "compare")
    failures = list(failures)
    if not all(
        isinstance(f, (tuple, list)) and len(f) == 3 and all(isinstance(x, str) for x in f)
        for f in failures
    ):
        raise ValueError("`failures` must be (file, record, reason) triples of text.")
    records = list(records)
    if not all(isinstance(r, Record) for r in records):
        raise TypeError("`records` must be vojax.io.Record objects (see load_records).")
    names = [r.name for r in records]
    duplicated = sorted({n for n in names if names.count(n) > 1})
    if duplicated:
        raise ValueError(f"two records share the name {duplicated[0]!r}; each needs its own.")
    if figure_format not in ("png", "svg", "pdf"):
        raise ValueError(f"`figure_format` must be png, svg or pdf, got {figure_format!r}.")
    for key, value in (("gamma", gamma), ("lam", lam)):
        if value is None or (key == "gamma" and isinstance(value, str) and value == "auto"):
            continue
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not 0 < value < math.inf:
            raise ValueError(f"`{key}` must be a positive finite number, got {value!r}.")
    return _run_batch(
        records, out, model=model, method=canonical_method(method), gamma=gamma, lam=lam,
        area=area, length=length, parameters=parameters, overwrite=overwrite,
        figure_format=figure_format, record_figures=record_figures, progress=progress,
        client=client, failures=[tuple(f) for f in failures], compare=compare,
    )
