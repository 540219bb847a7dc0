"""The commands `identify`, `compare`, `batch`, `check` and `example`."""

import contextlib
import os
import sys
import time
from pathlib import Path

from .._steps import say_block
from ._args import _load, _loader, _select, _settings, check_fit_window
from ._options import _law_options
from ._types import CLIError


def _new_dir(out: str | None) -> Path:
    if out is None:
        stamp = time.strftime("%Y%m%d-%H%M%S")
        path = Path(f"vojax-demo-{stamp}")
        i = 1
        while path.exists():
            path = Path(f"vojax-demo-{stamp}-{i}")
            i += 1
    else:
        path = Path(out)
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise CLIError(f"cannot create output folder {str(path)!r}: {e.strerror}.") from None
    return path


def _expand(paths, pattern=None, out=None):
    """The batch's inputs as ``(file, prefix)``: a folder stands for its CSV, NPZ and AFM files
    (not those of its subfolders), or with `pattern` for the files that glob matches in it
    (``**/*.csv`` recurses); a path that does not exist and holds ``*``, ``?`` or ``[`` is a
    glob itself. A file found in a subfolder of a given folder has that subfolder as
    `prefix`, which heads its records' names (``specimen_2/test``): names stay apart. Files
    found inside `out` (vojax's own outputs, when --out lies in a folder searched) are left
    out; a file named explicitly is taken as it is."""
    import glob

    from .._data._afm import AFM_SUFFIXES

    kinds = (".csv", ".npz", *AFM_SUFFIXES)
    inside_out = (lambda p: False) if out is None else (
        lambda p, o=Path(out).resolve(): Path(p).resolve().is_relative_to(o)
    )
    files = []
    for path in paths:
        folder = Path(path)
        if folder.is_dir():
            if pattern is None:
                found = [p for p in folder.iterdir() if p.is_file() and p.suffix.lower() in kinds]
            else:
                found = [p for p in folder.glob(pattern) if p.is_file()]
            if found and inside_out(folder):  # --out is this folder or holds it: said so
                _out_apart(out, [str(found[0])])
            found = [p for p in found if not inside_out(p)]
            if not found:
                what = f"files matching {pattern!r}" if pattern else "CSV, NPZ or AFM files"
                raise CLIError(f"{path} is a folder without {what}.")
            for p in sorted(found):
                prefix = p.parent.relative_to(folder).as_posix()
                files.append((str(p), "" if prefix == "." else prefix))
        elif not folder.exists() and any(c in str(path) for c in "*?["):
            found = sorted(
                p for p in glob.glob(str(path), recursive=True)
                if Path(p).is_file() and not inside_out(p)
            )
            if not found:
                raise CLIError(f"no file matches {path!r}.")
            files.extend((p, "") for p in found)
        else:
            files.append((str(path), ""))
    return files


def _out_apart(out, files):
    """--out must not be, or hold, an input file (see `check_out_holds_no_input`)."""
    from .._data._paths import check_out_holds_no_input

    try:
        check_out_holds_no_input(out, files)
    except ValueError as e:
        raise CLIError(str(e)) from None


def identify_command(args) -> int:
    from .._data._paths import claim_outputs
    from .._data._pipeline import check_finite, identify_record, make_provenance, write_outputs

    _law_options(args)
    _out_apart(args.out, [args.file])
    records = _select(_load(args.file, args), args)
    out = _new_dir(args.out)
    for record in records:
        target = out
        columns, summary = identify_record(record, **_settings(args))
        try:
            check_finite(summary, columns)
        except ValueError as e:
            raise CLIError(f"{record.name}: {e}") from None
        summary["provenance"] = make_provenance(
            record, {**_settings(args), "figure_format": args.format, **_loader(args)}
        )
        claim_outputs(
            target, ["identification.csv", "summary.json", f"identification.{args.format}"]
        )
        write_outputs(target, columns, summary, record.inputs, args.format)
        parts = [f"{record.name}: {record.time.size} samples"]
        afm = summary.get("afm") or {}
        if afm.get("youngs_modulus_Pa") is not None:
            parts.append(f"E = {afm['youngs_modulus_Pa']:.4g} ± "
                         f"{afm['youngs_modulus_stderr_Pa']:.2g} Pa (Hertz, {afm['tip']}, "
                         f"contact at {afm['contact_time']:.4g} s)")
        elif afm.get("fit_success") is False:
            print(f"vojax: warning: {record.name}: nanite's Hertz fit did not converge: no "
                  "Young's modulus.", file=sys.stderr)
        for key in ("kalman", "gradient"):
            if key not in summary:
                continue
            a = summary[key]
            parts.append(
                f"{a['method']} q ∈ [{a['alpha_min']:.3f}, {a['alpha_max']:.3f}] "
                f"(band ±{a['band_halfwidth']:.2g}), NRMSE {a['nrmse']:.3g}"
                + (f"; {a['answer']}" if "answer" in a else "")
            )
            if a["message"]:  # the verdict, why, and the next steps, a line each
                answer = a.get("answer") or ("identified" if a.get("identified")
                                             else "not identified")
                block = say_block(answer, a["finding"], a["next_steps"], "cli")
                print(f"vojax: warning: {record.name}: " + "\n".join(block), file=sys.stderr)
            if a.get("settling_test"):
                print(settling_line(record.name, a["settling_test"]), file=sys.stderr)
        if "refit" in summary:
            r = summary["refit"]
            flag = " (at a bound: the interval is not meaningful)" if r["at_bound"] else ""
            if not r["converged"]:
                print(f"vojax: warning: {record.name}: the refit did not converge; its "
                      "numbers are where it stopped.", file=sys.stderr)
            if r.get("residual_correlation", 0) > 0.5:
                print(f"vojax: warning: {record.name}: the refit's residuals are correlated "
                      f"(lag-1 {r['residual_correlation']:.2f}): the model misses part of the "
                      f"signal (vojax compare, --model); its errors are inflated "
                      f"×{r['error_inflation']:.2g} for it.", file=sys.stderr)
            parts.append(
                f"refit q = {r['order']:.4f} [{r['order_lower']:.4f}, {r['order_upper']:.4f}]"
                f"{flag}, NRMSE {r['nrmse']:.3g}"
            )
        if summary.get("disagreement"):
            print(f"vojax: warning: {record.name}: {summary['disagreement']}.", file=sys.stderr)
        print("; ".join(parts) + f" → {target}/")
    return 0


def settling_line(name, test) -> str:
    """The line that names a refused record's settling test (`summary.json`'s
    `settling_test`): the test that would settle the order where the tracker is expected to
    identify it with the oscillation (`expected` within ±`identified_halfwidth`) or where no
    expectation is known; else the test that would narrow it most, which alone would not."""
    from .._settings import TrackerSettings

    limit = TrackerSettings().identified_halfwidth
    expected = test.get("expected")
    if expected is None or expected <= limit:
        return (f"vojax: {name}: the test that would settle the order: {test['sentence']} "
                "(vojax.settling_test).")
    return (f"vojax: {name}: the test that would narrow the order most: {test['sentence']} "
            f"(vojax.settling_test); wider than ±{limit:g}, it would not settle the order "
            "alone with the parameters free.")


def compare_command(args) -> int:
    from .._compare import MODELS, compare
    from .._data._batch import _write_table
    from .._data._paths import claim_outputs
    from .._data._pipeline import refit_options, stress_strain

    if args.model is not None:
        raise CLIError("--model does not apply to compare: it fits every model (--models).")
    models = tuple(m.strip() for m in args.models.split(","))
    unknown = [m for m in models if m not in MODELS]
    if unknown or not models:
        raise CLIError(f"--models takes some of {','.join(MODELS)}, got {args.models!r}.")
    if not 2 <= args.knots <= 10:
        raise CLIError(f"--knots must be from 2 to 10 (a moving order), got {args.knots}.")
    check_fit_window(args)
    _out_apart(args.out, [args.file])
    records = _select(_load(args.file, args), args)
    for record in records:
        if len(record.input_names) != 1:
            raise CLIError("compare takes one input column, the stress: give one --input.")
    out = _new_dir(args.out)
    claim_outputs(out, ["comparison.csv"])
    rows = []
    for record in records:
        stress, strain = stress_strain(record, args.area, args.length)
        fitting = refit_options(record, None, args.area, args.length, args.origin,
                                args.fit_from, args.fit_to)  # in the record's own clock
        if args.x0 is not None:  # in the output column's unit: a strain through --length
            fitting["x0"] = args.x0 if args.length is None else args.x0 / args.length
        try:
            result = compare(stress, strain, **record.grid, models=models, knots=args.knots,
                             relative=args.relative, **fitting)
        except ValueError as e:
            raise CLIError(f"{record.name}: {e}") from None
        print(f"{record.name}:")
        print(result.table())
        for r in result.rows:
            rows.append({"record": record.name, **{k: v for k, v in r.items() if k != "refit"},
                         "verdict": result.verdict})
    _write_table(out / "comparison.csv", rows)
    print(f"→ {out / 'comparison.csv'}")
    return 0


def batch_command(args) -> int:
    from .._data._batch import BatchBusy, run_batch

    _law_options(args)
    _check_workers(args)
    if args.pattern is not None and not any(Path(f).is_dir() for f in args.files):
        raise CLIError("--pattern chooses the files of a folder: give a folder as input.")
    found = _expand(args.files, args.pattern, args.out)
    files = [path for path, _ in found]
    _out_apart(args.out, files)
    if args.scheduler not in (None, "local"):  # before anything is written
        from .._data._dask import check_scheduler

        try:
            check_scheduler(args.scheduler)
        except (ImportError, ConnectionError) as e:
            raise CLIError(str(e)) from None
    out = _new_dir(args.out)
    records, failures = _load_all(found, args)
    with contextlib.ExitStack() as stack:
        client = _dask(stack, args)
        try:
            report = run_batch(
                records,
                out,
                **_settings(args),
                failures=failures,
                progress=False if args.quiet else (True if args.progress else None),
                loader=_loader(args),
                overwrite=not args.no_overwrite,
                figure_format=args.format,
                record_figures=args.figures == "records",
                client=client,
            )
        except (BatchBusy, ConnectionError) as e:  # busy, or the scheduler went away
            raise CLIError(str(e)) from None
    return _said(report, out)


def _check_workers(args):
    """--workers and --scheduler, checked before anything is read."""
    if args.workers is not None and args.scheduler != "local":
        raise CLIError("--workers sets the worker processes of --scheduler local; use it with that.")
    if args.workers is not None and args.workers < 1:
        raise CLIError(f"--workers must be at least 1, got {args.workers}.")
    if args.workers is not None and args.workers > (os.cpu_count() or 1):
        raise CLIError(f"--workers is {args.workers}, more than this machine's "
                       f"{os.cpu_count() or 1} cores; use at most one worker per core.")
    if args.scheduler is not None and not args.scheduler.strip():
        raise CLIError("--scheduler needs 'local' or a scheduler's address (tcp://host:8786).")


def _load_all(found, args):
    """The records of every file found, named with their subfolder's prefix, and the files
    that could not be read (a failure each, the batch goes on); refuses two records of one
    name."""
    import dataclasses

    from .._data import DataError

    records, failures = [], []
    for path, prefix in found:
        try:
            loaded = _load(path, args, failures)
        except DataError as e:
            failures.append((str(path), "", str(e)))
            continue
        if prefix:
            loaded = [dataclasses.replace(r, name=f"{prefix}/{r.name}") for r in loaded]
        records.extend(loaded)
    names = [r.name for r in records]
    duplicated = sorted({n for n in names if names.count(n) > 1})
    if duplicated:
        raise CLIError(
            f"two records share the name {duplicated[0]!r}; rename a file or use --group-by."
        )
    return records, failures


def _dask(stack, args):
    """The Dask client of --scheduler, entered on `stack` (None without one)."""
    if args.scheduler is None:
        return None
    from .._data._batch import dask_client

    try:
        client = stack.enter_context(dask_client(args.scheduler, args.workers, check=False))
    except (ImportError, ConnectionError) as e:
        raise CLIError(str(e)) from None
    except (OSError, TimeoutError) as e:
        raise CLIError(f"could not reach the Dask scheduler {args.scheduler!r}: {e}") from None
    import logging

    # the command says a scheduler's loss in one line, not with distributed's own tracebacks
    # (its loggers have their own levels, set when it was imported)
    for name in list(logging.root.manager.loggerDict):
        if name == "distributed" or name.startswith("distributed."):
            logging.getLogger(name).setLevel(logging.CRITICAL)
    return client


def _said(report, out) -> int:
    """The batch's last line, the failures' file named on stderr; the exit code."""
    unidentified = (
        f", {report.unidentified} of them with the order not identified (see summary.csv)"
        if report.unidentified else ""
    )
    print(
        f"vojax batch: {report.computed} computed, {report.skipped} up to date (skipped), "
        f"{report.redone} redone, {report.failed} failed{unidentified} → {out}/"
    )
    if report.failed:
        print(
            f"vojax batch: the failures and their reasons are in {out / 'failures.csv'}",
            file=sys.stderr,
        )
        return 2
    return 0


def check_command(args) -> int:
    from .. import testing
    from .._data import DataError
    from .._data._pipeline import regressors

    if args.max_samples < 3:
        raise CLIError(f"--max-samples must be at least 3, got {args.max_samples}.")
    failed = 0
    for path in args.files:
        try:
            records = _load(path, args)
        except DataError as e:
            raise CLIError(str(e)) from None
        for record in records:
            if not record.uniform:
                raise CLIError(
                    f"{record.name}: its time steps are not uniform, and the closed forms (14) "
                    "and (26) that check compares with are written for a uniform step; add "
                    f"--resample STEP (its median step is {record.dt:g})."
                )
            u, y, _, _ = regressors(record, args.model, args.area, args.length)
            num = min(len(y), args.max_samples)
            note = f" (first {num} of {len(y)} samples)" if num < len(y) else ""
            print(f"{record.name}: {num} samples, step {record.dt:g}{note}")
            u, y = u[:num], y[:num]
            for order in args.order:
                for report in (
                    testing.check_gradients(
                        u, order, record.dt, memory=args.memory, rtol=args.rtol,
                        fd_rtol=args.fd_rtol, raise_on_failure=False,
                    ),
                    testing.check_parameter_sensitivity(
                        u, y - y[0], order, record.dt, lam=args.lam, memory=args.memory,
                        rtol=args.rtol, fd_rtol=args.fd_rtol, raise_on_failure=False,
                    ),
                ):
                    print(f"  order {order:g}: " + report.table().replace("\n", "\n    "))
                    failed += not report.passed
    if failed:
        print(f"vojax check: {failed} check(s) beyond tolerance.", file=sys.stderr)
        return 1
    print("vojax check: every comparison within tolerance.")
    return 0


def example_command(args) -> int:
    import shutil

    from ..io import example_file

    source = example_file(args.name)
    target = Path(args.out) if args.out else Path(source.name)
    if target.exists():
        raise CLIError(f"{target} exists; remove it or give another --out.")
    shutil.copyfile(source, target)
    licence = source.parent / f"LICENSE-{args.name}.txt"
    print(f"vojax example: wrote {target} (MIT licence: {licence})")
    return 0
