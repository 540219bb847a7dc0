"""The calibration suite's table from its progress lines, for a run stopped by a time limit.

`bench_calibration.py` prints one line per record and method as it goes (coverage of the ±2σ
band over the second half, the order's RMS there, identified, confidently wrong). Where a run
stopped before writing its table (a time limit on a borrowed machine), these lines still hold
the per-record scores; this script tabulates them in the suite's columns. Two columns the
lines do not carry are marked "—": the z RMS, and coverage pooled over samples (here the mean
of the records' coverages instead, which weighs every record alike).

    python scripts/calibration_logs.py LOG [LOG ...] [--out FILE] [--note TEXT]

Where two logs hold the same (family, index, method), the first one given wins.
"""

import argparse
import re
from pathlib import Path

import numpy as np

LINE = re.compile(r"^(\S+)\s+(\d+) (\S+)\s+(\S+)\s+(\d+) .* cov (\S+) rms (\S+) (ID|--)( WRONG)?")
FAMILIES = ("white", "noisy", "coloured", "drift", "drift-constant", "gain-drift",
            "gain-drift-constant", "irregular", "lengths", "long", "informative", "stated-drift")


def parse(paths):
    """{(family, index, method): dict(coverage, rms, identified, wrong)} from progress lines."""
    rows = {}
    for path in paths:
        for line in Path(path).read_text().splitlines():
            m = LINE.match(line)
            if m is None:
                continue
            key = (m.group(1), int(m.group(2)), m.group(3))
            rows.setdefault(key, dict(coverage=float(m.group(6)), rms=float(m.group(7)),
                                      identified=m.group(8) == "ID", wrong=bool(m.group(9))))
    return rows


def table(rows):
    methods = list(dict.fromkeys(method for _, _, method in rows))
    lines = ["| method | family | cases | identified | coverage (identified, mean) | "
             "coverage (all, mean) | z RMS | order RMS (median) | confidently wrong (of "
             "identified) |", "|---|---|---|---|---|---|---|---|---|"]
    for method in methods:
        pooled = []
        for family in [*FAMILIES, "pooled"]:
            sel = pooled if family == "pooled" else [
                r for (f, _, m), r in rows.items() if f == family and m == method]
            if family != "pooled":
                pooled += sel
            if not sel:
                continue
            ident = [r for r in sel if r["identified"]]
            cov_id = np.mean([r["coverage"] for r in ident]) if ident else float("nan")
            lines.append(
                f"| {method} | {family} | {len(sel)} | {len(ident)}/{len(sel)} "
                f"({len(ident) / len(sel):.2f}) | {cov_id:.2f} | "
                f"{np.mean([r['coverage'] for r in sel]):.2f} | — | "
                f"{np.median([r['rms'] for r in sel]):.4f} | "
                f"{sum(r['wrong'] for r in ident)}/{len(ident)} |")
    return lines


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("logs", nargs="+")
    parser.add_argument("--out", default=None)
    parser.add_argument("--note", default="")
    args = parser.parse_args(argv)
    rows = parse(args.logs)
    head = (f"# calibration_logs: {len(rows)} rows from {', '.join(Path(p).name for p in args.logs)}"
            + (f"; {args.note}" if args.note else ""))
    text = "\n".join([head, *table(rows)]) + "\n"
    print(text, end="")
    if args.out:
        Path(args.out).write_text(text)


if __name__ == "__main__":
    main()
