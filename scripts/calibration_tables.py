"""The calibration suite's scores of one record and its tables per family
(`scripts/bench_calibration.py` runs the records; this module scores and tabulates them).

Per record, over the second half of its samples: the coverage of the ±2σ band, the RMS of
the standardised error (α̂ − α)/σ (z RMS), the order RMS and whether it is **confidently
wrong** (identified, yet the truth outside the band at more than half of the samples). Per
family and pooled: those pooled or as medians, and the identified records whose own
coverage falls short of `SHORT_OF`: a band narrower than its error that the confidently
wrong count (coverage below one half) does not see.

    python scripts/calibration_tables.py scripts/results/FILE.txt
        (its tables written again from FILE.json, the rows of the run: after a change to
        what the tables report)
"""

import argparse
import json
import os
import sys
from pathlib import Path

import numpy as np
from calibration_suite import FAMILIES

# an identified record whose band holds the truth at fewer of its second half's samples
# than this is reported (the coverage the demo's test asks of the paper's simulation study)
SHORT_OF = 0.85


def score(case, out):
    """The scores of one record: `case` (the suite's draw: its times ``t`` and true order
    ``alpha``) and `out`, a method's ``(alpha, std, lower, upper, identified, message,
    extra)``; `extra`'s ``conditional`` ``(alpha, std, lower, upper)``, where given, is
    scored as well (its coverage, z RMS, order RMS and whether its promise is false)."""
    alpha, std, lower, upper, identified, message, extra = out
    truth = case["alpha"]
    half = case["t"] > case["t"][-1] / 2
    inside = (truth >= lower) & (truth <= upper)
    z = (alpha - truth) / np.maximum(std, 1e-300)
    extra = dict(extra)
    conditional = extra.pop("conditional", None)
    if conditional is not None:  # the conditional answer's own scores
        c_alpha, c_std, c_lower, c_upper = conditional
        c_inside = (truth >= c_lower) & (truth <= c_upper)
        c_z = (c_alpha - truth) / np.maximum(c_std, 1e-300)
        extra.update(
            c_coverage=float(np.mean(c_inside[half])), c_inside=int(np.sum(c_inside[half])),
            c_z_rms=float(np.sqrt(np.mean(c_z[half] ** 2))),
            c_rms=float(np.sqrt(np.mean((c_alpha - truth)[half] ** 2))),
            # a false promise: the conditional band misses the truth at most samples while its
            # breakdown drift exceeds the true drift
            false_promise=bool(extra.get("verdict") == "conditional"
                               and np.mean(c_inside[half]) < 0.5
                               and extra.get("breakdown_drift", 0) > case["true_drift"]),
        )
    return dict(
        coverage=float(np.mean(inside[half])),
        inside=int(np.sum(inside[half])),
        count=int(np.sum(half)),
        z_rms=float(np.sqrt(np.mean(z[half] ** 2))),
        rms=float(np.sqrt(np.mean((alpha - truth)[half] ** 2))),
        identified=identified,
        wrong=bool(identified and np.mean(inside[half]) < 0.5),
        message=message,
        **extra,
    )


def summarise(rows, methods, families):
    """Per family and pooled, for each method: the table's lines; then the conditional
    answers' table."""
    refit = [""] + _refit_table(rows, families) if "refit" in methods else []
    methods = [m for m in methods if m != "refit"]
    stating = [m for m in methods if "constant" in m or "stated" in m]
    reach = [""] + _reach_table(rows, stating, families) if stating else []
    return _stated_table(rows, methods, families) + [""] + _conditional_table(
        rows, methods, families) + refit + reach


def _reach(row):
    """Whether an answer states its reach: a finite breakdown drift beyond what its method
    states (0 for constant; ``tracker-stated``'s drift bound), as the verdict line does."""
    bound = (row.get("stated") or 0.0) if row["method"].startswith("tracker-stated") else 0.0
    return bool(bound < row["breakdown_drift"] < np.inf)


def _reach_table(rows, methods, families):
    """Per family and pooled, for each tracker that states the parameters (constant or a
    drift bound): the identified records, those whose answer states its reach (`_reach`:
    "with a drift of X % an order outside the band fits as well") and its median, and the
    confidently wrong split by whether their reach warned of the drift that misled them
    (stated, at or below the true drift) or not (above it, or none stated)."""
    lines = [
        "| method | family | identified | reach stated (of identified) | reach (median) | "
        "confidently wrong | wrong, warned by the reach | wrong, not warned |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for method, family, sel in _groups(rows, methods, families):
        ident = [r for r in sel if r["identified"]]
        stated = [r["breakdown_drift"] for r in ident if _reach(r)]
        wrong = [r for r in ident if r["wrong"]]
        warned = sum(_reach(r) and r["breakdown_drift"] <= r["true_drift"] for r in wrong)
        reach = np.median(stated) if stated else float("nan")
        lines.append(
            f"| {method} | {family} | {len(ident)}/{len(sel)} | {len(stated)}/{len(ident)} "
            f"| {reach:.2g} | {len(wrong)}/{len(ident)} | {warned}/{len(wrong)} | "
            f"{len(wrong) - warned}/{len(wrong)} |")
    return lines


def _groups(rows, methods, families):
    """Each method's rows per family and pooled over `families`: ``(method, family, rows)``,
    none where a group is empty."""
    for method in methods:
        for family in [*families, "pooled"]:
            sel = [r for r in rows if r["method"] == method
                   and (family == "pooled" or r["family"] == family)]
            if sel:
                yield method, family, sel


def _conditional_table(rows, methods, families):
    """Per family and pooled, for each tracker: the records whose verdict is "conditional",
    the conditional band's pooled coverage and median z RMS over them, its confidently wrong,
    the false promises (the band misses the truth while the breakdown drift exceeds the true
    drift) and the median breakdown drift."""
    lines = [
        "| method | family | conditional | coverage (conditional, pooled) | z RMS "
        "(conditional, median) | confidently wrong | false promises | breakdown drift "
        "(median) |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for method, family, sel in _groups([r for r in rows if "c_coverage" in r], methods,
                                       families):
        cond = [r for r in sel if r.get("verdict") == "conditional"]
        cov = (sum(r["c_inside"] for r in cond) / max(1, sum(r["count"] for r in cond))
               if cond else float("nan"))
        z = np.median([r["c_z_rms"] for r in cond]) if cond else float("nan")
        wrong = sum(r["c_coverage"] < 0.5 for r in cond)
        false = sum(r["false_promise"] for r in cond)
        drift = np.median([r["breakdown_drift"] for r in cond]) if cond else float("nan")
        lines.append(f"| {method} | {family} | {len(cond)}/{len(sel)} | {cov:.2f} | {z:.2f} "
                     f"| {wrong}/{len(cond)} | {false}/{len(cond)} | {drift:.2g} |")
    return lines


def _stated_table(rows, methods, families):
    """Per family and pooled, for each method: the records, those identified, the pooled
    coverage over the identified and over all, the identified's median z RMS, the median
    order RMS, the confidently wrong and those short of `SHORT_OF` among the identified."""
    lines = [
        "| method | family | cases | identified | coverage (identified, pooled) | coverage "
        "(all, pooled) | z RMS (identified, median) | order RMS (median) | confidently wrong "
        f"(of identified) | coverage short of {SHORT_OF} (of identified) |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for method, family, sel in _groups(rows, methods, families):
        ident = [r for r in sel if r["identified"]]
        cov_id = (sum(r["inside"] for r in ident) / max(1, sum(r["count"] for r in ident))
                  if ident else float("nan"))
        ran = [r for r in sel if r["count"]]
        cov_all = sum(r["inside"] for r in ran) / max(1, sum(r["count"] for r in ran))
        z = np.median([r["z_rms"] for r in ident]) if ident else float("nan")
        rms = np.median([r["rms"] for r in ran]) if ran else float("nan")
        wrong = sum(r["wrong"] for r in ident)
        short = sum(r["coverage"] < SHORT_OF for r in ident)
        lines.append(
            f"| {method} | {family} | {len(sel)} | {len(ident)}/{len(sel)} "
            f"({len(ident) / len(sel):.2f}) | {cov_id:.2f} | {cov_all:.2f} | {z:.2f} | "
            f"{rms:.4f} | {wrong}/{len(ident)} | {short}/{len(ident)} |"
        )
    return lines


def _refit_table(rows, families):
    """Per family and pooled, the refit on the records it models: their count, the pooled
    coverage of its 95 % interval, the median z RMS, the median order RMS and error
    inflation."""
    lines = ["| method | family | cases | coverage (pooled) | z RMS (median) | order RMS "
             "(median) | error inflation (median) |", "|---|---|---|---|---|---|---|"]
    for family in [*families, "pooled"]:
        sel = [r for r in rows if r["method"] == "refit" and r["count"]
               and (family == "pooled" or r["family"] == family)]
        if not sel:
            continue
        cov = sum(r["inside"] for r in sel) / sum(r["count"] for r in sel)
        lines.append(
            f"| refit | {family} | {len(sel)} | {cov:.2f} | "
            f"{np.median([r['z_rms'] for r in sel]):.2f} | "
            f"{np.median([r['rms'] for r in sel]):.4f} | "
            f"{np.median([r['error_inflation'] for r in sel]):.2f} |")
    return lines


def retable(path):
    """Writes the tables of a results file `path` (``--out``'s FILE.txt) again from its rows
    (FILE.json), in the order of its methods and of `FAMILIES`, its lines outside the tables
    kept; returns the new text. The file is replaced at once (written beside it, then
    renamed): a run stopped halfway leaves the old one."""
    path = Path(path)
    rows = json.loads(path.with_suffix(".json").read_text())
    lines = path.read_text().splitlines()
    at = [i for i, line in enumerate(lines) if line.startswith("|")]
    if not at:
        raise ValueError(f"{path} holds no table to write again")
    body = [line.split("|")[1].strip() for line in lines[at[0]:at[-1] + 1]
            if line.startswith("| ") and not line.startswith("| method")]
    methods = list(dict.fromkeys(body))
    families = [f for f in FAMILIES if any(r["family"] == f for r in rows)]
    text = "\n".join([*lines[:at[0]], *summarise(rows, methods, families),
                      *lines[at[-1] + 1:]]) + "\n"
    fresh = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    fresh.write_text(text)
    os.replace(fresh, path)
    return text


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description="a results file's tables written again "
                                     "from its rows")
    parser.add_argument("files", nargs="+", help="scripts/results/FILE.txt (FILE.json beside)")
    for name in parser.parse_args().files:
        try:
            retable(name)
        except (OSError, ValueError) as e:
            sys.exit(f"{name}: {e}")
