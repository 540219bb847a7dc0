"""Kills a Dask batch at random moments, then re-runs it once, and compares with a run that
was never interrupted.

A batch of the shipped beef records (or `--records` of them) runs with
``--scheduler local --workers 2``; it is killed (SIGKILL, SIGTERM or SIGINT, drawn) after a
random delay `--kills` times in a row in one output folder, then run once more to the end.
The table reports, for that folder against an uninterrupted run of the same records: the
rows per record in summary.csv (exactly one each), the largest difference of any number,
and the processes left behind (worker processes of a killed run that outlive it).

    python scripts/kill_dask.py [--kills 10] [--records 12] [--seed 0] [--out results.txt]
"""

import argparse
import csv
import os
import random
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from _bench import publish

ROOT = Path(__file__).resolve().parents[1]
DATA = (ROOT.parent / "shared" / "data" / "beef-indentation-relaxation"
        / "beef_indentation_relaxation.csv")


def _batch(source, out, extra=()):
    return [sys.executable, "-m", "vojax", "batch", str(source), "--time", "time_s",
            "--input", "force_N", "--output", "displacement_mm", "--group-by", "specimen",
            "--trim-column", "force_N", "--trim-below", "0.02",
            "--method", "refit", "--figures", "overview", "--quiet", "--out", str(out),
            "--scheduler", "local", "--workers", "2", *extra]


def _table(out):
    with open(Path(out) / "summary.csv", newline="") as f:
        return list(csv.DictReader(f))


def _workers():
    """Process ids of Dask workers (command lines naming distributed's worker)."""
    found = set()
    for pid in os.listdir("/proc"):
        if not pid.isdigit():
            continue
        try:
            cmd = (Path("/proc") / pid / "cmdline").read_bytes().replace(b"\0", b" ")
        except OSError:
            continue
        if b"distributed" in cmd and (b"spawn" in cmd or b"worker" in cmd):
            found.add(int(pid))
    return found


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--kills", type=int, default=10)
    parser.add_argument("--records", type=int, default=12)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--data", default=str(DATA))
    parser.add_argument("--out")
    args = parser.parse_args()
    rng = random.Random(args.seed)
    before = _workers()
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        # the first `--records` specimens of the shipped file
        lines = Path(args.data).read_text().splitlines()
        header = next(i for i, line in enumerate(lines) if not line.startswith("#"))
        column = lines[header].split(",").index("specimen")
        keep, rows = [], [lines[header]]
        for line in lines[header + 1:]:
            name = line.split(",")[column]
            if name not in keep:
                if len(keep) == args.records:
                    continue
                keep.append(name)
            rows.append(line)
        source = tmp / "beef.csv"
        source.write_text("\n".join(rows) + "\n")
        started = time.perf_counter()
        reference = subprocess.run(_batch(source, tmp / "reference"), capture_output=True,
                                   text=True)
        whole = time.perf_counter() - started
        assert reference.returncode in (0, 2), reference.stderr
        kills = []
        for _ in range(args.kills):
            how = rng.choice([signal.SIGKILL, signal.SIGTERM, signal.SIGINT])
            delay = rng.uniform(0.1, 0.6) * whole  # a resumed run has less left to do
            proc = subprocess.Popen(_batch(source, tmp / "killed"), stdout=subprocess.DEVNULL,
                                    stderr=subprocess.PIPE, text=True)
            time.sleep(delay)
            proc.send_signal(how)
            try:
                proc.wait(timeout=60)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()
            kills.append((how.name, delay, proc.returncode))
        time.sleep(3)  # workers watch their parent every 0.5 s
        left = _workers() - before
        again = subprocess.run(_batch(source, tmp / "killed"), capture_output=True, text=True)
        ref, got = _table(tmp / "reference"), _table(tmp / "killed")
    per_record = {}
    for row in got:
        per_record[row["record"]] = per_record.get(row["record"], 0) + 1
    worst = 0.0
    index = {row["record"]: row for row in got}
    for row in ref:
        for key, value in row.items():
            try:
                a, b = float(value), float(index.get(row["record"], {}).get(key, "nan"))
            except (TypeError, ValueError):
                continue
            if a == a:
                worst = max(worst, abs(a - b) / max(abs(a), 1e-300))
    lines = [
        f"# kill_dask: {args.records} records, {args.kills} kills (seed {args.seed}), "
        f"uninterrupted run {whole:.0f} s",
        "",
        "| kill | signal | after (s) | exit |",
        "|---|---|---|---|",
    ]
    lines += [f"| {k + 1} | {name} | {delay:.1f} | {code} |" for k, (name, delay, code)
              in enumerate(kills)]
    interrupted = sum(code != 0 for *_, code in kills)
    lines += [
        "",
        f"{interrupted} of {len(kills)} kills interrupted a run (the others came after it had "
        f"finished); re-run exit {again.returncode}; records {len(per_record)} of "
        f"{len(ref)}; rows per record {sorted(set(per_record.values()))}; largest relative "
        f"difference from the "
        f"uninterrupted run {worst:.1e}; worker processes left after the kills: {len(left)}",
    ]
    publish(lines, args.out)
    clean = (set(per_record.values()) == {1} and len(per_record) == len(ref) and worst < 1e-9
             and not left and again.returncode in (0, 2))
    return 0 if clean else 1


if __name__ == "__main__":
    sys.exit(main())
