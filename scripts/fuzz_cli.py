"""Replays hostile files and options through the ``vojax`` command and counts clean outcomes.

A case is clean when:

- the exit status is 0 (done), 1 (bad input, said in one line: no traceback, no "internal
  error") or 2 (a batch with failed records, listed in ``failures.csv``);
- no error line and no reason in ``failures.csv`` is one of NumPy's or Python's own
  messages, which name nothing (``_bench.LEAKS``);
- nothing outside ``--out`` was created, changed or removed (the inputs are untouched);
- with status 0, every ``summary.json`` written is strict JSON (no NaN) and every number of
  ``identification.csv`` is finite or empty;
- a file of the user's in ``--out`` named like an output (``summary.csv``,
  ``identification.csv``) is left as it was.

The corpus is deterministic: bad files (empty, header only, short, text and NaN cells,
decreasing or repeated times, duplicate columns, a 200 kB field, binary bytes, Latin-1, a
folder named like a file, NPZ files with complex, date-time, 3-D, truncated or
2^40-sample arrays, formula-like record names), each with option sets that are valid or
not (non-finite and absurd numbers, unknown names, an --out that holds the input or files
of the user's), a file of a million rows with the default method (refused at once, with
how to resample), and the demo's and check's options. The command runs in this process (``vojax._cli.main``), so a
case that fails fast costs milliseconds.

    python scripts/fuzz_cli.py [--limit N] [--show-dirty] [--out results.txt]
"""

import argparse
import contextlib
import csv
import io
import json
import math
import os
import shutil
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from _bench import leaks, publish
from fuzz_cli_files import FOREIGN, csv_fast, make_files  # the corpus

COLUMNS = ["--time", "time_s", "--input", "stress", "--output", "strain"]
MILLION = 1_000_000  # rows of the long file, run with the default method

OPTION_SETS = [
    ["--method", "refit"],
    ["--method", "refit", "--area", "inf"],
    ["--method", "refit", "--area", "nan"],
    ["--method", "refit", "--area", "-1"],
    ["--method", "refit", "--length", "1e308"],
    ["--method", "refit", "--resample", "5e-324"],
    ["--method", "refit", "--resample", "1e-308"],
    ["--method", "refit", "--resample", "0.05"],
    ["--method", "refit", "--origin=-1e308"],
    ["--method", "refit", "--origin", "nan"],
    ["--method", "refit", "--origin", "-1"],
    ["--method", "refit", "--fit-from", "2", "--fit-to", "1"],
    ["--method", "refit", "--fit-from", "inf"],
    ["--fit-from", "1e300"],
    ["--fit-to", "-1"],
    ["--method", "gradient", "--fit-from", "0.5"],
    ["--method", "refit", "--trim-column", "stress", "--trim-below", "0.5"],
    ["--method", "refit", "--trim-column", "stress", "--trim-below", "1e300"],
    ["--method", "refit", "--trim-column", "stress"],
    ["--method", "bogus"],
    ["--method", "gradient", "--gamma", "0"],
    ["--method", "gradient", "--gamma", "nan"],
    ["--method", "gradient", "--lam", "-1"],
    ["--method", "gradient", "--gamma", "0.5", "--lam", "0.9"],
    ["--method", "refit", "--gamma", "0.5"],
    ["--method", "refit", "--model", "bogus"],
    ["--method", "refit", "--model", "kelvin-voigt"],
    ["--method", "refit", "--model", "maxwell", "--area", "2", "--length", "3"],
    ["--method", "gradient", "--model", "zener"],
    ["--method", "refit", "--group-by", "specimen"],
    ["--method", "refit", "--format", "gif"],
    ["--method", "refit", "--strict"],
    ["--method", "refit", "--bogus-option"],
]


def cases(files):
    out = []
    for name in files:
        for opts in OPTION_SETS:
            out.append(["identify", name, *COLUMNS, *opts, "--out", "out"])
            out.append(["batch", name, *COLUMNS, *opts, "--out", "out", "--quiet"])
    # --out at or around the inputs
    for out_dir in (".", "good.csv", "..", "folder.csv"):
        out.append(["identify", "good.csv", *COLUMNS, "--method", "refit", "--out", out_dir])
        out.append(["batch", "good.csv", "text_cell.csv", *COLUMNS, "--method", "refit",
                    "--out", out_dir, "--quiet"])
    # --out holding the user's own summary.csv and identification.csv: refused, kept
    for command in ("identify", "batch"):
        out.append([command, "good.csv", *COLUMNS, "--method", "refit", "--out", "foreign_out"])
    # one batch over every file: each bad one fails alone
    out.append(["batch", *files, *COLUMNS, "--method", "refit", "--out", "out", "--quiet"])
    for value in ("inf", "nan", "0", "-1", "1e-300", "abc", "1e308"):
        out.append(["demo", "--dt", value, "--out", "out"])
    for value in ("-1", "99999999999999999999999", "abc", "1.5"):
        out.append(["demo", "--seed", value, "--out", "out"])
    for value in ("1.5", "0", "nan", "-0.1"):
        out.append(["demo", "--alpha0", value, "--out", "out"])
    for opts in (["--rtol", "nan"], ["--rtol", "-1"], ["--rtol", "0"], ["--fd-rtol", "inf"],
                 ["--order", "1.5"], ["--order", "a,b"], ["--max-samples", "-5"],
                 ["--lam", "0"], ["--memory", "bogus"]):
        out.append(["check", "good.csv", *COLUMNS, *opts])
    # the newer surface: compare, AFM, the cluster options, the column roles, the CLI's
    # spelling
    for name in ("good.csv", "zero_stress.csv", "same_series.csv", "tiny_numbers.csv",
                 "constant_output.csv", "huge_numbers.csv", "far_clock.csv"):
        out.append(["compare", name, *COLUMNS, "--models", "springpot,maxwell", "--out", "out"])
    for opts in (["--models", "bogus"], ["--knots", "0"], ["--knots", "99"],
                 ["--model", "zener"], ["--fit-from", "nan"], ["--fit-from", "1e300"],
                 ["--fit-from", "3", "--fit-to", "1"], ["--origin", "0"], ["--origin", "-inf"],
                 ["--x0", "inf"], ["--relative"], ["--relative", "--fit-from", "0.2"],
                 ["--origin", "-1", "--x0", "0", "--relative", "--fit-to", "0.5"]):
        out.append(["compare", "good.csv", *COLUMNS, *opts, "--out", "out"])
    for opts in (["--noise", "x"], ["--noise", "order_drift=1"], ["--noise", ""],
                 ["--noise", "order_drift=1,parameter_drift=1,noise_std=1,extra=1"],
                 ["--noise", "order_drift=1,order_drift=1,noise_std=1"],
                 ["--noise", "order_drift=inf,parameter_drift=1,noise_std=1"],
                 ["--noise", "order_drift=1e-300,parameter_drift=1e-300,noise_std=1e-300"],
                 ["--noise", "order_drift=1,parameter_drift=1,noise_std=1e300"],
                 ["--noise", "order_drift=0.01,parameter_drift=0.001,noise_std=0.01",
                  "--method", "gradient"],
                 ["--noise", "order_drift=0.01,parameter_drift=0.001,noise_std=0.01",
                  "--parameters", "0.1"], ["--strain-from-length", "0"],
                 ["--strain-from-length", "nan"], ["--strain-from-length", "1e300"],
                 ["--strain-from-length", "1e-300"], ["--strain-from-length", "1"],
                 ["--strain-from-length", "1", "--length", "1"],
                 ["--length-column", "nope"], ["--length-column", "strain"],
                 ["--length-column", "stress"], ["--area-column", "stress"],
                 ["--area-column", "time_s"], ["--length-column", "stress", "--length", "2"],
                 ["--length-column", "stress", "--strain-from-length", "2"]):
        out.append(["identify", "good.csv", *COLUMNS, *opts, "--out", "out"])
    afm = ["--time", "time_s", "--input", "force_N", "--output", "indentation_m"]
    for name in ("good.jpk-force", "cut.jpk-force", "channel.jpk-force"):
        for opts in ([], ["--tip", "sphere:1e-320"], ["--tip", "sphere:5"],
                     ["--tip", "cone:95"], ["--tip", "cube:1"], ["--segments", "9"],
                     ["--tip", "pyramid:89.9"], ["--tip", "pyramid:0"], ["--contact", "fit"],
                     ["--contact", "nope"], ["--tip", "cone:20", "--contact",
                                             "frechet_direct_path"],
                     ["--spring-constant", "0.061"], ["--spring-constant", "nan"],
                     ["--poisson", "-0.99", "--tip", "sphere:5e-6"]):
            out.append(["identify", name, *afm, "--method", "refit", *opts, "--out", "out"])
        out.append(["batch", name, "good.csv", *afm, "--method", "refit", "--quiet",
                    "--out", "out"])
    for opts in ([], ["--spring-constant", "0.061"], ["--spring-constant", "1e300"],
                 ["--spring-constant", "0.061", "--tip", "sphere:5e-6"],
                 ["--spring-constant", "0.061", "--contact", "gradient_zero_crossing"]):
        out.append(["identify", "good.csv", *afm, "--method", "refit", *opts, "--out", "out"])
    for opts in (["--scheduler", "local", "--workers", "1000"],
                 ["--scheduler", "local", "--workers", "0"], ["--workers", "2"],
                 ["--scheduler", " "], ["--scheduler", "tcp://127.0.0.1:1"]):
        out.append(["batch", "good.csv", *COLUMNS, "--method", "refit", *opts, "--out", "out"])
    for columns in (["--time", "time_s", "--input", "strain", "--output", "strain"],
                    ["--time", "time_s", "--input", "stress", "--input", "stress", "--output",
                     "strain"],
                    ["--time", "time_s", "--input", "stress", "--output", "time_s"]):
        out.append(["identify", "good.csv", *columns, "--method", "refit", "--out", "out"])
    out.append(["check", "good.csv", *COLUMNS, "--out", "out"])  # check takes no --out
    out.append(["identify", "good.csv", "--tim", "time_s", "--input", "stress", "--output",
                "strain", "--out", "out"])  # options only as spelled in full
    out.append(["example", "bogus"])
    out.append(["bogus-command"])
    out.append([])
    return out


def _snapshot(root: Path, skip: Path):
    state = {}
    for path in sorted(root.rglob("*")):
        if skip in path.parents or path == skip:
            continue
        stat = path.lstat()
        # a folder's time changes when --out is created in it: folders count by existence
        key = str(path.relative_to(root))
        state[key] = ("dir",) if path.is_dir() else (stat.st_size, stat.st_mtime_ns)
    return state


def _strict(text):
    def refuse(constant):
        raise ValueError(constant)

    return json.loads(text, parse_constant=refuse)


def _reasons(out: Path) -> str:
    """The reasons in a batch's ``failures.csv`` ("" without one)."""
    path = out / "failures.csv"
    return path.read_text(errors="replace") if path.is_file() else ""


def _outputs_clean(out: Path) -> str:
    for path in out.rglob("summary.json"):
        try:
            _strict(path.read_text())
        except ValueError as e:
            return f"{path}: not strict JSON ({e})"
    for path in out.rglob("identification.csv"):
        with open(path, newline="") as f:
            rows = list(csv.reader(f))
        for row in rows[1:]:
            for cell in row:
                if cell and not math.isfinite(float(cell)):
                    return f"{path}: a non-finite value {cell!r}"
    return ""


def run_case(argv, files_dir: Path, main):
    """``(clean, why, status, first line of stderr)`` of one command in a fresh copy."""
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp) / "work"
        # a fresh copy of the inputs per case: a case that writes over one cannot hide
        shutil.copytree(files_dir, work, symlinks=True)
        named = argv[argv.index("--out") + 1] if "--out" in argv[:-1] else "out"
        out = (work / named).resolve()
        before = _snapshot(Path(tmp), out)
        err = io.StringIO()
        cwd = os.getcwd()
        os.chdir(work)
        try:
            with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
                try:
                    status = main(argv)
                except SystemExit as e:
                    status = e.code if isinstance(e.code, int) else 1
                except BaseException as e:  # noqa: BLE001 - anything escaping main is dirty
                    return False, f"escaped {type(e).__name__}: {e}", None, ""
        finally:
            os.chdir(cwd)
        text = err.getvalue()
        if named == "foreign_out" and any(
            (out / name).read_text() != "mine\n" for name in FOREIGN
        ):
            return False, "overwrote a file vojax did not write", None, ""
        lines = [ln for ln in text.splitlines() if ln.strip()]
        errors = [ln for ln in lines if not ln.startswith("vojax: warning:")
                  and not ln.startswith("vojax: note:")]
        first = errors[0] if errors else ""
        after = _snapshot(Path(tmp), out)
        if after != before:
            changed = sorted(set(after) ^ set(before)) or [
                k for k in after if after[k] != before.get(k)
            ]
            return False, f"wrote outside --out: {changed[:3]}", status, first
        if "Traceback" in text or "internal error" in text:
            return False, "traceback or internal error", status, first
        if status not in (0, 1, 2):
            return False, f"exit status {status}", status, first
        if status == 1 and len(errors) != 1:
            return False, f"{len(errors)} error lines", status, first
        if any(leaks(line) for line in errors) or leaks(_reasons(out)):
            return False, "NumPy's or Python's own message, naming nothing", status, first
        if status == 0 and out.exists():
            why = _outputs_clean(out)
            if why:
                return False, why, status, first
        return True, "", status, first


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--limit", type=int, default=None, help="run the first N cases only")
    parser.add_argument("--show-dirty", action="store_true", help="print every dirty case")
    parser.add_argument("--out", default=None, help="write the summary here too")
    args = parser.parse_args(argv)
    import jax

    jax.config.update("jax_enable_x64", True)
    from vojax._cli import main as vojax_main

    saved = os.environ.get("VOJAX_COMPILATION_CACHE")
    os.environ["VOJAX_COMPILATION_CACHE"] = "off"  # leave the user's cache alone
    try:
        return _run(args, vojax_main)
    finally:
        if saved is None:
            os.environ.pop("VOJAX_COMPILATION_CACHE", None)
        else:
            os.environ["VOJAX_COMPILATION_CACHE"] = saved


def _run(args, vojax_main):

    started = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        files_dir = Path(tmp) / "files"
        files_dir.mkdir()
        files = make_files(files_dir)
        corpus = [(argv, files_dir) for argv in cases(files)][: args.limit]
        # a file of a million rows with the default method (the tracker): its own folder,
        # so that the other cases do not copy it
        big_dir = Path(tmp) / "big"
        big_dir.mkdir()
        t = np.arange(MILLION) * 1e-3
        csv_fast(big_dir / "million.csv", t, np.sin(t), np.cos(t))
        if args.limit is None:
            for command in ("identify", "batch"):
                corpus.append(([command, "million.csv", *COLUMNS, "--out", "out"], big_dir))
        results = []
        statuses = {}
        for k, (argv_case, where) in enumerate(corpus):
            clean, why, status, first = run_case(argv_case, where, vojax_main)
            results.append((clean, why, argv_case, first))
            statuses[status] = statuses.get(status, 0) + 1
            if not clean and args.show_dirty:
                print(f"DIRTY {' '.join(argv_case)}\n      {why}; stderr: {first}", flush=True)
            if (k + 1) % 50 == 0:
                print(f"  {k + 1}/{len(corpus)} cases, {sum(not r[0] for r in results)} dirty",
                      file=sys.stderr, flush=True)
    dirty = [r for r in results if not r[0]]
    lines = [
        f"# fuzz_cli: {len(results)} cases ({len(files)} files x {len(OPTION_SETS)} option "
        "sets x (identify, batch), --out around the inputs or holding the user's files, one "
        f"batch of every file, a file of {MILLION:,} rows with the default method, demo, "
        f"check and others); {time.perf_counter() - started:.0f} s",
        f"clean: {len(results) - len(dirty)}/{len(results)} "
        f"({100 * (len(results) - len(dirty)) / max(len(results), 1):.1f} %)",
        "exit statuses: " + ", ".join(f"{k}: {v}" for k, v in sorted(statuses.items(), key=str)),
    ]
    for _, why, argv_case, first in dirty[:20]:
        lines.append(f"dirty: {' '.join(argv_case)} -- {why} -- {first}")
    publish(lines, args.out)
    return 1 if dirty else 0


if __name__ == "__main__":
    sys.exit(main())
