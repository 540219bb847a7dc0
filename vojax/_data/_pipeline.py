"""Identify one recorded test and write its outputs (CSV, JSON, PNG), atomically."""

import csv
import dataclasses
import io
from pathlib import Path

import numpy as np

from .._io import atomic_path, write_json
from .._models import FractionalMaxwell, FractionalZener, KelvinVoigt, Springpot
from .._stats import delta_stderr

MODELS = {
    "springpot": Springpot(),
    "kelvin-voigt": KelvinVoigt(),
    "maxwell": FractionalMaxwell(),
    "zener": FractionalZener(),
}
# models with an order-0 regressor: the refit takes them, the adaptive law and the tracker not
REFIT_ONLY = ("maxwell", "zener")

# the estimators by one name each, as `vojax.identify`'s `method` and `summary.json`'s keys:
# "kalman" the tracker, "gradient" the paper's law, "refit" the constant-order refit; a
# record runs one of them or one of the first two with the refit
METHODS = ("kalman", "gradient", "refit", "kalman+refit", "gradient+refit")
# earlier names, still accepted: "adaptive" was the law, "both" the law with the refit
ALIASES = {"adaptive": "gradient", "both": "gradient+refit"}


def canonical_method(method) -> str:
    """The method's name in `METHODS` (an alias replaced); `ValueError` naming the choices."""
    method = ALIASES.get(method, method)
    if method not in METHODS:
        raise ValueError(f"`method` must be one of {', '.join(METHODS)}, got {method!r}.")
    return method


def estimator(method) -> str | None:
    """The order tracker a method runs, "kalman" or "gradient", or None (the refit alone)."""
    first = method.split("+")[0]
    return first if first in ("kalman", "gradient") else None


def check_parameters(method, parameters, max_points=None, x0=None) -> None:
    """`parameters`, `max_points` and `x0` (the tracker's) are refused with a method that does
    not run the tracker; `x0` must be a finite number."""
    if x0 is not None:
        from .._validate import known_offset

        known_offset(x0)
    if estimator(canonical_method(method)) == "kalman":
        return
    for name, value in (("--parameters", parameters), ("--max-points", max_points),
                        ("--x0", x0)):
        if value is not None:
            raise ValueError(
                f"{name} sets the tracker; use --method kalman or kalman+refit, not {method}."
            )


def runs_refit(method) -> bool:
    return method.endswith("refit")


class _Columns:
    """``p ↦ {name: p[..., i]}``: the linear model's parameters, named by their columns;
    hashable, so that derived standard errors compile once per batch."""

    def __init__(self, names):
        self.names = names

    def __call__(self, p):
        return {n: p[..., i] for i, n in enumerate(self.names)}

    def __eq__(self, other):
        return isinstance(other, _Columns) and other.names == self.names

    def __hash__(self):
        return hash(self.names)


def regressors(record, model: str, area=None, length=None):
    """``(u, y, parameter names, to_physical)`` for `model` (``linear`` keeps the columns)."""
    if model == "linear":
        names = [f"p_{c}" for c in record.input_names]
        return record.inputs, record.output, names, _Columns(tuple(names))
    stress, strain = _stress_strain(record, model, area, length)
    law = MODELS[model]
    return np.asarray(law.inputs(stress, strain)), strain, list(law.names), law.parameters


def output_scale(model, length) -> float:
    """What the file's output column is divided by to give the model's output: the strain
    ``d/length`` of a law (1 when `length` is not given), the column itself for ``linear``."""
    return 1.0 if model == "linear" else (length or 1.0)


def _stress_strain(record, model, area, length):
    """Eq. (35) on a record: ``σ = F/area``, ``ε = d/length`` (either 1 when not given)."""
    if record.inputs.shape[1] != 1:
        raise ValueError(
            f"--model {model} takes one --input (the stress or force), got {record.inputs.shape[1]}; "
            "use --model linear for several inputs."
        )
    with np.errstate(over="ignore", under="ignore"):
        stress = record.inputs[:, 0] / (area or 1.0)
        strain = record.output / output_scale(model, length)
    for option, value, signal in (("--area", area, stress), ("--length", length, strain)):
        big = float(np.max(np.abs(signal))) if signal.size else 0.0
        if value is not None and not big < 1e150:  # squares must stay finite
            raise ValueError(
                f"{option} {value:g} makes the {'stress' if option == '--area' else 'strain'} "
                f"reach {big:.3g}, beyond what float64 arithmetic can square; give {option} "
                "in the units of the data's columns."
            )
    return stress, strain


def refit_options(record, model, area=None, length=None, origin=None, fit_from=None, fit_to=None):
    """The `refit` keywords for a record: the model's order-0 regressors and signs, and the
    test's origin and fit window given in the file's time unit (the record's clock starts at 0
    at its first sample, ``time_offset`` in the file)."""
    options = {}
    if model in MODELS:
        law = MODELS[model]
        options["p_signs"] = law.p_signs
        direct = law.direct(*_stress_strain(record, model, area, length))
        if direct is not None:
            options["direct"] = np.asarray(direct)
    shift = record.time_offset
    if origin is not None:
        options["origin"] = float(origin) - shift
    if fit_from is not None or fit_to is not None:
        options["window"] = (
            -np.inf if fit_from is None else float(fit_from) - shift,
            np.inf if fit_to is None else float(fit_to) - shift,
        )
    return options


def diagnostics_dict(d):
    """The `Diagnostics` of an identification as JSON-ready values."""
    out = dataclasses.asdict(d)
    out["at_edge"] = list(out["at_edge"])
    return out


ESTIMATES = ("alpha", "alpha_lower", "alpha_upper", "y_hat", "refit_alpha", "refit_y_hat")


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
            and k not in ("innovation_correlation", "block_error", "noise_correlation")
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

    from .. import __version__

    return {"vojax": __version__, "jax": jax.__version__, "python": platform.python_version()}


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
    }


def adaptive_part(res, y, physical):
    """Per-sample columns and the summary block of an `Identification` (either method)."""
    alpha = np.asarray(res.alpha)
    p = np.asarray(res.p)
    params = {k: np.asarray(v) for k, v in physical(p).items()}
    columns = {
        "alpha": alpha,
        "alpha_lower": np.asarray(res.alpha_lower),
        "alpha_upper": np.asarray(res.alpha_upper),
        **params,
    }
    part = {
        "method": res.method,
        "nrmse": nrmse(y, res.y_hat),
        "alpha_min": float(alpha.min()),
        "alpha_max": float(alpha.max()),
        "alpha_mean": float(alpha.mean()),
        "alpha_final": float(alpha[-1]),
        "alpha_final_std": float(res.alpha_std[-1]),
        "parameters_final": {k: float(v[-1]) for k, v in params.items()},
        "parameters_final_stderr": delta_stderr(
            physical, p[-1], np.diag(np.asarray(res.p_std)[-1] ** 2)
        ),
        "x0": float(res.x0),
        "x0_std": float(res.x0_std),
        **diagnostics_dict(res.diagnostics),
    }
    if res.method == "gradient":
        part.update(gamma=float(res.gamma), lam=float(res.lam))
    else:
        part.update(tuning=dataclasses.asdict(res.tuning))
    return columns, part


def nrmse(y, y_hat):
    """Root-mean-square error normalised by the range of ``y``."""
    span = float(np.ptp(y))
    return (
        float(np.sqrt(np.mean((np.asarray(y_hat) - y) ** 2)) / span) if span > 0 else float("nan")
    )


def bucket_length(num: int) -> int:
    """The padded length of a record of `num` samples: the smallest ``m·2^k ≥ num`` with
    m ∈ {4, 6}. At most 50 % padding, and two lengths per octave, so that a batch compiles a
    few programs (each costs seconds; a padded sample costs a microsecond)."""
    k = 0
    while 6 * 2**k < num:
        k += 1
    return min(m * 2**k for m in (4, 6) if m * 2**k >= num)


# One more compiled length costs about as much wall time as this many padded samples: on the
# 2-core CPU a bucket compiles in ~7 s (the tuner, the law, the refit), and a padded sample
# costs ~5e-5 s of tuning and refitting per record (scripts/bench_batch.py, docs/benchmarks.md).
COMPILE_COST_SAMPLES = 100_000


def plan_buckets(lengths, compile_cost: float = COMPILE_COST_SAMPLES) -> dict:
    """``{length: padded length}`` for the records of one batch: the padded lengths are
    `bucket_length`'s (``m·2^k``), and neighbouring ones are merged (the shorter records padded
    to the longer length) where that saves more compilation than the padding costs, counting
    one compiled length as `compile_cost` samples. Dynamic programming over the sorted lengths
    gives the least total ``compile_cost · buckets + Σ padded samples``."""
    lengths = [int(n) for n in lengths]
    if compile_cost < 0 or not np.isfinite(compile_cost):
        raise ValueError(f"`compile_cost` must be a finite number ≥ 0, got {compile_cost}.")
    if any(n < 1 for n in lengths):
        raise ValueError(f"record lengths must be ≥ 1, got {min(lengths)}.")
    sizes = sorted({bucket_length(n) for n in lengths})
    counts = [sum(bucket_length(n) == s for n in lengths) for s in sizes]
    # best[j]: the least cost of the first j sizes; the last bucket of that plan is sizes[j-1]
    best, cut = [0.0], [0]
    for j in range(1, len(sizes) + 1):
        options = [
            (best[i] + compile_cost + sizes[j - 1] * sum(counts[i:j]), i) for i in range(j)
        ]
        cost, i = min(options)
        best.append(cost)
        cut.append(i)
    padded, j = {}, len(sizes)
    while j > 0:
        i = cut[j]
        for s in sizes[i:j]:
            padded[s] = sizes[j - 1]
        j = i
    return {n: padded[bucket_length(n)] for n in lengths}


def _padded(fn, u, y, pad_to, **kwargs):
    """``fn(u, y, …)`` on the record padded to `pad_to` samples and masked, its per-sample
    outputs cut back: one compiled program serves every record of a bucket. Padding comes
    after the end, so the causal memory of the real samples does not see it."""
    import jax

    num = y.shape[0]
    if pad_to is None or pad_to <= num:
        return fn(u, y, **kwargs)
    extra = pad_to - num
    up = np.concatenate([u, np.zeros((extra, u.shape[1]))])
    yp = np.concatenate([y, np.full(extra, y[-1])])
    mask = np.r_[np.ones(num), np.zeros(extra)]
    if kwargs.get("direct") is not None:  # order-0 regressors are padded like the inputs
        d = kwargs["direct"]
        kwargs = {**kwargs, "direct": np.concatenate([d, np.zeros((extra, d.shape[1]))])}
    res = fn(up, yp, mask=mask, **kwargs)
    return jax.tree_util.tree_map(
        lambda a: np.asarray(a)[:num] if getattr(a, "ndim", 0) >= 1 and a.shape[0] == pad_to else a,
        res,
    )


def stress_strain(record, area=None, length=None):
    """A one-input record's stress σ = F/a and strain ε = d/l (eq. 35; a and l 1 if None)."""
    stress, strain = record.inputs[:, 0], record.output
    return (stress if area is None else stress / area), (strain if length is None else strain / length)


def compare_part(record, area=None, length=None):
    """`vojax.compare` of one record (its one input as the stress, its output as the strain,
    through `area` and `length` as eq. (35)) as the ``compare`` block of its summary: the
    best law, the next one and the Bayes factor between them, the verdict, and each law's
    log evidence, weight and held-out NRMSE."""
    from .._compare import compare

    if record.inputs.shape[1] != 1:
        raise ValueError(
            f"--compare takes one input column (the stress); this record has "
            f"{record.inputs.shape[1]}."
        )
    c = compare(*stress_strain(record, area, length), **record.grid)
    rows = c.rows
    out = {
        "best": rows[0]["model"],
        "second": rows[1]["model"] if len(rows) > 1 else None,
        "bayes_factor": c.bayes_factor(rows[0]["model"], rows[1]["model"]) if len(rows) > 1 else None,
        "verdict": c.verdict,
    }
    for key in ("log_evidence", "weight", "holdout_nrmse"):
        out[key] = {r["model"]: float(r[key]) for r in rows}
    return out


def identify_record(
    record, *, model="springpot", method="kalman", gamma="auto", lam=None, area=None,
    length=None, pad_to=None, origin=None, fit_from=None, fit_to=None, parameters=None,
    max_points=None, x0=None, threads=None,
):
    """Runs the tracker or the law and/or the refit on one record (`method`: one of
    `METHODS`); returns ``(columns, summary)``.
    With `pad_to`, the tracker and the refit of a record on a uniform clock run on it padded
    to that length and masked (results equal to the unpadded run within the solvers'
    tolerances). `origin` (the test's start, before the first sample) and the fit window
    `fit_from`, `fit_to` are in the file's time unit and apply to the refit; the refit keeps
    the model's coefficients physical (`p_signs`). `parameters`, `max_points`: the
    tracker's, as in `vojax.identify` (its defaults when None); `x0`: the tracker's known
    offset of the output, in the unit of the file's output column (None: estimated);
    `threads`: the most threads the tracker's smoothings run in (None: its settings')."""
    from .._identify import identify
    from .._refit import refit

    method = canonical_method(method)
    if model in REFIT_ONLY and estimator(method) is not None:
        raise ValueError(
            f"--model {model} has a spring (an order-0 term) that the adaptive law and the "
            "tracker do not take; use --method refit."
        )
    if not runs_refit(method) and not (origin is None and fit_from is None and fit_to is None):
        raise ValueError(
            "--origin, --fit-from and --fit-to set the refit; use --method refit or "
            f"{method}+refit."
        )
    check_parameters(method, parameters, max_points, x0)
    u, y, names, physical = regressors(record, model, area, length)
    grid = record.grid
    pad_to = pad_to if record.uniform else None  # a bucket pads a uniform clock only
    columns = {"time": record.time}
    summary = record_header(record, model, method, area, length)
    tracker = estimator(method)
    if tracker == "kalman":
        extra = {} if max_points is None else {"max_points": max_points}
        if x0 is not None:  # in the model's output, as the output column is
            extra["x0"] = float(x0) / output_scale(model, length)
        if threads is not None:
            from .._settings import TrackerSettings

            extra["settings"] = TrackerSettings(run_threads=threads)
        res = _padded(
            identify, u, y, pad_to, **grid, method="kalman", parameters=parameters, warn=False,
            **extra,
        )
    elif tracker == "gradient":
        res = identify(u, y, **grid, method="gradient", gamma=gamma, lam=lam, warn=False)
    if tracker is not None:
        cols, summary[tracker] = adaptive_part(res, y, physical)
        columns.update(cols)
    if tracker == "kalman":
        summary["kalman"]["parameter_model"] = parameters or "drifting"
        summary["kalman"]["offset_model"] = "estimated" if x0 is None else "known"
    columns["y"] = y
    if "alpha" in columns:
        columns["y_hat"] = np.asarray(res.y_hat)
    if runs_refit(method):
        import optimistix as optx  # imported where it is used: 0.07 s of `import vojax`

        options = refit_options(record, model, area, length, origin, fit_from, fit_to)
        fit = _padded(refit, u, y, pad_to, **grid, **options)
        p = np.asarray(fit.p)
        with np.errstate(divide="ignore", invalid="ignore"):
            phys = {k: float(v) for k, v in physical(p).items()}
        # η = 1/p with p = 0 (held at its sign's bound, or 0 to rounding): the data bound the
        # coefficient, not the parameter; written as null and named, not a failure
        undetermined = [k for k, v in phys.items() if not np.isfinite(v)]
        columns["refit_alpha"] = np.asarray(fit.order)
        columns["refit_alpha_lower"] = np.asarray(fit.order_lower)
        columns["refit_alpha_upper"] = np.asarray(fit.order_upper)
        columns["refit_y_hat"] = np.asarray(fit.y_hat)
        summary["refit"] = {
            "order": float(fit.order[0]),
            "order_stderr": float(fit.order_stderr[0]),
            "order_lower": float(fit.order_lower[0]),
            "order_upper": float(fit.order_upper[0]),
            "at_bound": bool(fit.at_bound),
            "p": p.tolist(),
            "p_stderr": np.asarray(fit.p_stderr).tolist(),
            "p_at_bound": list(fit.p_at_bound),
            "parameters": phys,
            "parameters_stderr": {
                k: (float("inf") if k in undetermined else v)
                for k, v in delta_stderr(physical, p, np.asarray(fit.p_cov)).items()
            },
            "parameters_undetermined": undetermined,
            "x0": float(fit.x0),
            "x0_stderr": float(fit.x0_stderr),
            "nrmse": nrmse(y, fit.y_hat),
            "converged": bool(fit.result == optx.RESULTS.successful),
        }
    summary["parameter_names"] = names
    if tracker is not None and "refit" in summary:
        summary["disagreement"] = disagreement(columns, summary)
    return columns, summary


def disagreement(columns, summary) -> str:
    """One sentence when the two estimators run on a record give disjoint order bands over
    the second half of the fitted samples (median of each bound), else ``""``: at most one of
    them can be right, and neither band says so alone."""
    half = len(columns["alpha"]) // 2
    lo_a = float(np.median(columns["alpha_lower"][half:]))
    hi_a = float(np.median(columns["alpha_upper"][half:]))
    lo_r, hi_r = summary["refit"]["order_lower"], summary["refit"]["order_upper"]
    if hi_a < lo_r or hi_r < lo_a:
        name = "the tracker" if "kalman" in summary else "the paper's law"
        return (
            f"{name} ([{lo_a:.3g}, {hi_a:.3g}] over the second half) and the constant-order "
            f"refit ([{lo_r:.3g}, {hi_r:.3g}]) disagree: their bands are disjoint, so at least one "
            "model is wrong for these data; compare both fits in the figure"
        )
    return ""


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
        from .._plotting import record_figure

        record_figure(columns, summary, inputs, out_dir / f"identification.{figure_format}")
    write_json(out_dir / "summary.json", summary)
