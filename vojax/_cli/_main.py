"""The `vojax` command's parser and its entry point. Errors are one sentence on stderr and a
non-zero exit code."""

import argparse
import os
import sys

from ._commands import (
    batch_command,
    check_command,
    compare_command,
    example_command,
    identify_command,
)
from ._demo import demo
from ._options import _column_options, _data_options, _refit_options
from ._types import (
    CLIError,
    _count,
    _finite,
    _fraction,
    _gain,
    _order,
    _order_list,
    _Parser,
    _positive,
)


def build_parser() -> argparse.ArgumentParser:
    from .._version import version

    __version__ = version()

    parser = _Parser(
        prog="vojax",
        description="Identify the variable order q(t) and the parameters of recorded tests "
        "(D^q(t) x = p·u), with bands and a verdict; simulate the paper's study; cross-check "
        "the order sensitivities on your data. Each command's --help says its options, with "
        "their defaults and units.",
    )
    parser.add_argument("--version", action="version", version=f"vojax {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)
    _demo_parser(sub)
    _identify_parser(sub)
    _check_parser(sub)
    _compare_parser(sub)
    _example_parser(sub)
    _batch_parser(sub)
    return parser


def _demo_parser(sub) -> None:
    """The ``demo`` command: the paper's simulation study."""
    d = sub.add_parser(
        "demo", help="simulate the paper's study (34), identify it with the paper's law and with "
        "vojax's tracker; write Figs. 2–4 with their bands and a summary"
    )
    d.add_argument("--out", help="output folder (default: a new vojax-demo-<time> folder here)")
    d.add_argument("--dt", type=_positive, default=0.05, help="sampling step h in s (default 0.05)")
    d.add_argument("--seed", type=_count, default=0, help="noise seed (default 0)")
    d.add_argument(
        "--gamma", type=_gain, default=0.01, help="order gain γ or 'auto' (default 0.01)"
    )
    d.add_argument(
        "--lam", type=_gain, default=0.9, help="forgetting factor λ (default 0.9, the paper's)"
    )
    d.add_argument("--alpha0", type=_order, default=0.5, help="initial order estimate (default 0.5)")
    d.add_argument(
        "--tracker",
        action=argparse.BooleanOptionalAction,
        default=True,
        help="also run vojax's tracker (identify's default) on the same record and draw its "
        "band (default; about 10 s on 2 cores); --no-tracker: the paper's law alone",
    )
    d.add_argument(
        "--memory",
        choices=("exponential", "direct"),
        default="exponential",
        help="memory kernel: exponential (O(1) per sample, default) or direct (whole history)",
    )
    d.add_argument(
        "--rule",
        choices=("trapezoid", "rectangle"),
        default="trapezoid",
        help="quadrature of the input between samples: trapezoid (O(h²), default) or rectangle",
    )
    d.set_defaults(run=demo)


def _identify_parser(sub) -> None:
    """The ``identify`` command: one recorded test."""
    i = sub.add_parser("identify", help="identify q(t) and the parameters of one recorded test")
    i.add_argument("file", help="CSV (header row, '#' comments) or NPZ file")
    _data_options(i, many=False)
    i.add_argument(
        "--record",
        help="of a file of several records (--group-by, an AFM map's curves): the record to "
        "identify (identify takes one; batch takes all)",
    )
    i.set_defaults(run=identify_command)


def _check_parser(sub) -> None:
    """The ``check`` command: the order sensitivities on the user's data."""
    c = sub.add_parser(
        "check",
        help="cross-check the order sensitivities on your data: autodiff vs the closed forms "
        "(14) and (26) vs finite differences; exit 1 beyond tolerance",
    )
    c.add_argument("files", nargs="+", help="CSV or NPZ files; each is a record unless --group-by")
    _column_options(c)
    c.add_argument(
        "--order",
        type=_order_list,
        default=(0.25, 0.5, 0.75),
        help="constant orders to check at, comma-separated, each in (0, 1) (default 0.25,0.5,0.75)",
    )
    c.add_argument(
        "--lam",
        type=_gain,
        default=0.9,
        help="forgetting factor λ in 1/(time unit) for ∂p/∂β (default 0.9)",
    )
    c.add_argument(
        "--memory",
        choices=("direct", "exponential"),
        default="direct",
        help="the memory kernel checked (default direct)",
    )
    c.add_argument(
        "--max-samples",
        type=_count,
        default=2000,
        help="check the first this many samples of each record: the closed forms are O(N²) "
        "(default 2000)",
    )
    c.add_argument(
        "--rtol",
        type=_fraction,
        default=1e-8,
        help="tolerance of autodiff vs closed form, relative to the largest value (default 1e-8)",
    )
    c.add_argument(
        "--fd-rtol",
        type=_fraction,
        default=1e-6,
        help="tolerance of central finite differences (order step 1e-5), relative (default 1e-6)",
    )
    c.set_defaults(run=check_command)


def _compare_parser(sub) -> None:
    """The ``compare`` command: the laws one record supports."""
    m = sub.add_parser(
        "compare",
        help="which law do the data of one recorded test support: springpot, Kelvin-Voigt, "
        "Maxwell, Zener and a variable order, ranked by evidence",
    )
    m.add_argument("file", help="CSV, NPZ or AFM file")
    _column_options(m)
    m.set_defaults(model=None)
    m.add_argument("--out", required=True, help="output folder for comparison.csv")
    m.add_argument(
        "--record", help="of a file of several records (--group-by, an AFM map's curves): the "
        "record to compare (default: the only one)"
    )
    m.add_argument(
        "--models", default="springpot,kelvin-voigt,maxwell,zener,variable",
        help="comma-separated laws to fit (default: all five)",
    )
    m.add_argument("--knots", type=int, default=3,
                   help="knots of the variable order, 2 to 10 (default 3)")
    _refit_options(m)
    m.add_argument(
        "--x0", type=_finite, default=None, metavar="VALUE",
        help="the output's offset where it is known (the output column's reading at rest, in "
        "its unit; a tared sensor reads 0): every law holds it there instead of estimating it "
        "(default: estimated, one free number more)",
    )
    m.add_argument(
        "--relative", action="store_true",
        help="residuals relative to the strain, for data over decades (no fitted sample may "
        "be 0: leave the start out with --fit-from or give --origin)",
    )
    m.set_defaults(run=compare_command)


def _example_parser(sub) -> None:
    """The ``example`` command: a shipped recording copied here."""
    e = sub.add_parser(
        "example", help="copy a real recording shipped with vojax into the current folder"
    )
    e.add_argument("name", choices=("adhesive", "myocardium"), help="which recording")
    e.add_argument("--out", help="file to write (default: the example's own name, here)")
    e.set_defaults(run=example_command)


def _batch_parser(sub) -> None:
    """The ``batch`` command: many recorded tests into one folder."""
    b = sub.add_parser(
        "batch", help="identify many recorded tests (files, or groups of a long file)"
    )
    b.add_argument(
        "files", nargs="+",
        help="CSV, NPZ or AFM files, folders of them (their files, not their subfolders'; "
        "see --pattern) or quoted globs ('runs/*/test_*.csv'); each file is a record "
        "unless --group-by or an AFM map",
    )
    b.add_argument(
        "--compare",
        action="store_true",
        help="also rank the laws each record supports (as vojax compare: springpot, "
        "Kelvin-Voigt, Maxwell, Zener, a variable order), in summary.json and the compare_* "
        "columns of summary.csv (one input column; about 2 s a record)",
    )
    b.add_argument(
        "--pattern",
        metavar="GLOB",
        help="the files to take from each folder given, as a glob inside it: '*.txt.csv', or "
        "'**/*.csv' to recurse (a record in a subfolder is named subfolder/name) (default: "
        "the folder's .csv, .npz and AFM files)",
    )
    _data_options(b, many=True)
    shown = b.add_mutually_exclusive_group()
    shown.add_argument(
        "--progress", action="store_true",
        help="a progress bar on stderr even when it is not a terminal (default: only on a "
        "terminal)",
    )
    shown.add_argument("--quiet", action="store_true", help="no progress bar")
    b.add_argument(
        "--no-overwrite",
        action="store_true",
        help="fail a record whose outputs exist from other settings or inputs instead of redoing "
        "it (default: redo it)",
    )
    b.add_argument(
        "--figures",
        choices=("records", "overview"),
        default="records",
        help="records (default): each record's figure, drawn in worker processes, and the "
        "overview; overview: only overview.<format> of all records (faster: a record's figure "
        "costs about 0.14 s of one core)",
    )
    b.add_argument(
        "--scheduler",
        help="compute the records on Dask (pip install \"vojax[dask]\"): 'local' for worker "
        "processes on this machine, or a running scheduler's address (tcp://host:8786); this "
        "process writes every output (default: compute here)",
    )
    b.add_argument(
        "--workers", type=int,
        help="worker processes of --scheduler local (default: the cores, at most 8)",
    )
    b.set_defaults(run=batch_command)


def main(argv=None) -> int:
    import jax

    from .._xla import CACHE_ENV, quiet_xla_logs, use_compilation_cache, use_fast_cpu_loops

    quiet_xla_logs()
    if os.environ.get("VOJAX_FAST_CPU_LOOPS", "1") != "0":
        try:
            use_fast_cpu_loops()
        except RuntimeError:  # main() run inside a process that has already computed
            pass
    jax.config.update("jax_enable_x64", True)
    # after a SIGKILL of this process, multiprocessing's helper would print a warning about
    # the figure pool's semaphores into the user's terminal: it inherits this setting
    os.environ.setdefault(
        "PYTHONWARNINGS", "ignore::UserWarning:multiprocessing.resource_tracker"
    )
    cache = os.environ.get(CACHE_ENV, "")
    if cache.lower() != "off":
        use_compilation_cache(cache or None)
    parser = build_parser()
    args = parser.parse_args(argv)
    import signal

    def stop(signum, frame):
        # Ctrl-C or SIGTERM: one line, then out at once. Raising an exception here could land
        # in a garbage-collector callback, where Python prints it and goes on; exiting is
        # safe: every output is written atomically, a re-run removes the temporaries and
        # redoes what is incomplete, the lock dies with the process and so do the workers
        interrupted = signum == signal.SIGINT
        sys.stdout.flush()
        print(f"vojax: {'interrupted' if interrupted else 'terminated'}.", file=sys.stderr,
              flush=True)
        os._exit(130 if interrupted else 143)

    previous = {}
    try:
        for sig in (signal.SIGINT, signal.SIGTERM):
            previous[sig] = signal.signal(sig, stop)
    except ValueError:  # not the main thread (main() called from a thread): leave them
        pass
    try:
        return args.run(args)
    except CLIError as e:
        print(f"vojax: error: {e}", file=sys.stderr)
        return 1
    except OSError as e:
        print(f"vojax: error: {e.strerror or e}: {e.filename}.", file=sys.stderr)
        return 1
    except (ValueError, TypeError) as e:
        print(f"vojax: error: {str(e).splitlines()[0]}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print("vojax: interrupted.", file=sys.stderr)
        return 130
    except Exception as e:  # a bug, not the user's fault: still one line, the trace on request
        if os.environ.get("VOJAX_DEBUG"):
            raise
        first = str(e).splitlines()[0] if str(e) else ""
        print(
            f"vojax: internal error ({type(e).__name__}: {first}); set VOJAX_DEBUG=1 for the traceback.",
            file=sys.stderr,
        )
        return 3
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)
