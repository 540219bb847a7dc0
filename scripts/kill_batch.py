"""Interrupts a batch at random and checks that nothing is lost, duplicated or left running.

A 20-record batch (synthetic springpot records of two lengths, 1 % noise, the tracker and
the refit, the figures drawn by worker processes) is started and sent SIGKILL, SIGTERM or
SIGINT once one or two more of its records have finished, at a random moment up to 0.3 s
later, ten times (on the same --out; a finished --out is removed first, so that every kill
interrupts a batch in progress), then run to the end once. The final
``summary.csv`` must have exactly one row per record, each equal to an uninterrupted run's to 1e-12, no process
of a killed run may be alive 10 s after its kill, and no input file may have changed.

    python scripts/kill_batch.py [--kills 10] [--records 20] [--seed 0] [--out FILE]
"""

import argparse
import csv
import hashlib
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from _bench import publish

COLUMNS = ["--time", "time_s", "--input", "stress", "--output", "strain", "--quiet"]


def write_records(folder: Path, count: int):
    import jax

    jax.config.update("jax_enable_x64", True)
    import vojax

    for k in range(count):
        n = 160 if k % 2 else 200
        t = np.arange(n) * 0.1
        stress = np.minimum(t, 3.0) + 0.1 * np.sin(3 * t)
        strain = np.asarray(vojax.simulate(stress, 0.3 + 0.02 * k, np.array([0.25]), 0.1))
        strain = strain + 0.01 * np.ptp(strain) * np.random.default_rng(k).standard_normal(n)
        rows = ["time_s,stress,strain"] + [
            f"{a!r},{b!r},{c!r}" for a, b, c in zip(t.tolist(), stress.tolist(), strain.tolist())
        ]
        (folder / f"r{k:02d}.csv").write_text("\n".join(rows) + "\n")


def children(pid):
    out = []
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            try:
                with open(f"/proc/{entry}/stat") as f:
                    fields = f.read().rsplit(")", 1)[1].split()
            except OSError:
                continue
            if int(fields[1]) == pid:
                out.append(int(entry))
    return out


def alive(pid):
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().rsplit(")", 1)[1].split()[0] != "Z"
    except OSError:
        return False


def done(folder: Path):
    """Records whose outputs are complete (their summary.json, written last, exists)."""
    return len(list((folder / "out").glob("*/summary.json")))


def table(folder: Path):
    with open(folder / "out" / "summary.csv", newline="") as f:
        return list(csv.DictReader(f))


def digest(folder: Path):
    return {p.name: hashlib.sha256(p.read_bytes()).hexdigest() for p in sorted(folder.glob("*.csv"))}


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--kills", type=int, default=10)
    parser.add_argument("--records", type=int, default=20)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", default=None)
    args = parser.parse_args(argv)
    rng = np.random.default_rng(args.seed)
    env = {k: v for k, v in os.environ.items() if k != "XLA_FLAGS"}
    with tempfile.TemporaryDirectory() as tmp:
        work, clean = Path(tmp) / "work", Path(tmp) / "clean"
        work.mkdir()
        clean.mkdir()
        write_records(work, args.records)
        for p in work.glob("*.csv"):
            (clean / p.name).write_bytes(p.read_bytes())
        inputs = digest(work)
        files = sorted(p.name for p in work.glob("*.csv"))
        command = [sys.executable, "-m", "vojax", "batch", *files, *COLUMNS, "--method",
                   "kalman+refit", "--out", "out"]
        started = time.perf_counter()
        reference = subprocess.run(command, cwd=clean, env=env, capture_output=True, text=True)
        if reference.returncode != 0:
            raise SystemExit(f"the uninterrupted run failed: {reference.stderr}")
        uninterrupted = time.perf_counter() - started
        left, log = [], []
        for k in range(args.kills):
            how = [signal.SIGKILL, signal.SIGTERM, signal.SIGINT][int(rng.integers(3))]
            # while records are being written: once one or two more have finished (or at
            # 60 s), then a random moment up to 0.3 s later
            if done(work) == args.records:  # a finished folder: start a fresh batch, so that
                shutil.rmtree(work / "out")  # every kill interrupts one in progress
            before = done(work)
            wanted = before + int(rng.integers(1, 3))
            proc = subprocess.Popen(command, cwd=work, env=env, stdout=subprocess.DEVNULL,
                                    stderr=subprocess.PIPE, text=True)
            started = time.monotonic()
            kids = []
            while proc.poll() is None and time.monotonic() < started + 60:
                kids = children(proc.pid) or kids
                if done(work) >= wanted:
                    time.sleep(float(rng.uniform(0.0, 0.3)))
                    break
                time.sleep(0.02)
            delay = time.monotonic() - started
            finished = proc.poll() is not None
            if not finished:
                proc.send_signal(how)
            _, err = proc.communicate(timeout=120)
            stop = time.monotonic() + 10
            while any(alive(c) for c in kids) and time.monotonic() < stop:
                time.sleep(0.1)
            left += [c for c in kids if alive(c)]
            rows = len(table(work)) if (work / "out" / "summary.csv").exists() else 0
            log.append(f"kill {k + 1}: {how.name} after {delay:.1f} s"
                       f"{' (had finished)' if finished else ''}; {rows} rows; stderr: "
                       f"{' | '.join(err.strip().splitlines()[-2:]) or '(none)'}")
        final = subprocess.run(command, cwd=work, env=env, capture_output=True, text=True)
        got, want = table(work), table(clean)
        equal = sorted(r["record"] for r in got) == sorted(r["record"] for r in want)
        worst = 0.0
        if equal:
            by = {r["record"]: r for r in want}
            for r in got:
                for key in ("refit_order", "kalman_alpha_final"):
                    worst = max(worst, abs(float(r[key]) - float(by[r["record"]][key])))
        same_inputs = digest(work) == inputs
    ok = final.returncode == 0 and equal and len(got) == args.records and worst <= 1e-12 \
        and not left and same_inputs
    lines = [
        f"# kill_batch: {args.records} records, {args.kills} random kills (seed {args.seed}), "
        f"uninterrupted run {uninterrupted:.1f} s",
        *log,
        f"final run: exit {final.returncode}; rows {len(got)} (of {args.records}); "
        f"largest difference from the uninterrupted run {worst:.2g}; processes left {len(left)}; "
        f"inputs unchanged: {same_inputs}",
        "PASS" if ok else "FAIL",
    ]
    publish(lines, args.out)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
