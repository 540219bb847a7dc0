"""The parsed options turned into the library's calls: the records read, the settings of
the identification, the record chosen."""

import sys

from .._data._regressors import FIT_OPTIONS as FIT_OPTIONS  # the refit's own options
from ._types import CLIError


def _load(path, args, failures=None):
    """The records of the file `path` under the command's options. Where some curves of an
    AFM file cannot be read, the others are returned and each failed curve is appended to
    `failures` as ``(file, curve, reason)``, or, without that list, said on stderr."""
    from .._data import DataError, load_records
    from .._data._errors import CurvesFailed
    from .._data._records import check_units

    if (args.trim_column is None) != (args.trim_below is None):
        raise CLIError("--trim-column and --trim-below go together.")
    check_strain_options(args)
    if args.decimal_comma and args.delimiter == ",":
        raise CLIError("--decimal-comma needs another separator: add --delimiter ';' (or tab).")
    try:
        check_units(getattr(args, "units", None), [args.time, *args.inputs, args.output])
    except ValueError as e:
        raise CLIError(str(e).replace("`units`", "--units")) from None
    import warnings

    # the loader's warnings (resampled time steps) are shown as one line each, not as Python's
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            records = load_records(path, **_loader(args))
        except CurvesFailed as e:
            records = e.records
            for name, reason in e.failures:
                if failures is None:
                    print(f"vojax: warning: {reason}", file=sys.stderr)
                else:
                    failures.append((str(path), name, reason))
        except DataError:
            raise
        except (ValueError, TypeError) as e:  # an option's check, in the command's words
            text = str(e)
            for name in ("strain_from_length", "length_column", "area_column"):
                text = text.replace(f"`{name}`", "--" + name.replace("_", "-"))
            raise CLIError(text) from None
    for w in caught:
        print(f"vojax: warning: {w.message}", file=sys.stderr)
    return records


def check_fit_window(args) -> None:
    """``--fit-from`` must come before ``--fit-to`` where both are given."""
    if args.fit_from is not None and args.fit_to is not None and not args.fit_from < args.fit_to:
        raise CLIError(f"--fit-from must be before --fit-to, got {args.fit_from} and {args.fit_to}.")


def check_strain_options(args) -> None:
    """``--strain-from-length`` and ``--length-column`` give the strain themselves, and
    ``--area-column`` the stress: refused beside ``--length``, ``--area`` or each other."""
    length_column = getattr(args, "length_column", None)
    if getattr(args, "strain_from_length", None) is not None:
        if args.length is not None or length_column is not None:
            raise CLIError("--strain-from-length already gives a strain; leave out "
                           f"{'--length' if args.length is not None else '--length-column'}.")
    if length_column is not None and args.length is not None:
        raise CLIError("--length-column already gives each record's length; leave out --length.")
    if getattr(args, "area_column", None) is not None and args.area is not None:
        raise CLIError("--area-column already gives each record's area; leave out --area.")


def _settings(args) -> dict:
    """The options that set the identification."""
    return dict(
        model=args.model,
        method=args.method,
        gamma=args.gamma,
        lam=args.lam,
        area=args.area,
        length=args.length,
        **{k: getattr(args, k) for k in FIT_OPTIONS if getattr(args, k) is not None},
        **({"parameters": args.parameters} if getattr(args, "parameters", None) else {}),
        **({"max_points": args.max_points} if getattr(args, "max_points", None) else {}),
        **({"x0": args.x0} if getattr(args, "x0", None) is not None else {}),
        **({"noise": args.noise} if getattr(args, "noise", None) is not None else {}),
        **({"time_scale": args.time_scale}
           if getattr(args, "time_scale", None) is not None else {}),
        **({"alpha_bounds": list(args.alpha_bounds)}
           if getattr(args, "alpha_bounds", None) is not None else {}),
        **({"compare": True} if getattr(args, "compare", False) else {}),
    )


def _loader(args) -> dict:
    """The options that set how records are read."""
    return dict(
        time=args.time,
        inputs=list(args.inputs),
        output=args.output,
        group_by=args.group_by,
        strict=args.strict,
        resample=args.resample,
        trim_column=args.trim_column,
        trim_below=args.trim_below,
        delimiter=args.delimiter,
        decimal="," if args.decimal_comma else ".",
        **_afm_loader(args),
        **({"units": args.units} if getattr(args, "units", None) else {}),
        **{k: getattr(args, k) for k in ("strain_from_length", "length_column", "area_column")
           if getattr(args, k, None) is not None},
    )


def _afm_loader(args) -> dict:
    """The AFM options, only where given (a CSV's provenance is unchanged by them)."""
    from .._data._afm_records import AfmOptions

    try:
        AfmOptions.checked(tip=args.tip, poisson=args.poisson, contact=args.contact,
                           spring_constant=args.spring_constant, baseline=args.baseline)
    except ValueError as e:
        raise CLIError(str(e)) from None
    out = {}
    if args.segments is not None:
        out["segments"] = list(args.segments)
    if args.no_contact:
        out["from_contact"] = False
    if args.tip is not None:
        out["tip"] = args.tip
    if args.poisson != 0.5:
        out["poisson"] = args.poisson
    if args.contact is not None:
        out["contact"] = args.contact
    if args.spring_constant is not None:
        out["spring_constant"] = args.spring_constant
    if args.baseline is not None:
        out["baseline"] = args.baseline
    return out


def _select(records, args):
    """`identify` works on one record: of a file holding several (a long-format file read
    with --group-by, an AFM map's curves), --record names it."""
    names = [r.name for r in records]
    if args.record is not None:
        chosen = [r for r in records if r.name == args.record]
        if not chosen:
            shown = ", ".join(repr(n) for n in names[:5]) + (", …" if len(names) > 5 else "")
            raise CLIError(f"no record {args.record!r} in {args.file} (records: {shown}).")
        return chosen
    if len(records) > 1:
        raise CLIError(
            f"{args.file} holds {len(records)} records"
            f"{'' if args.group_by is None else f' (--group-by {args.group_by})'}; identify "
            f"takes one: add --record NAME (e.g. --record {names[0]!r}), or use vojax batch."
        )
    return records
