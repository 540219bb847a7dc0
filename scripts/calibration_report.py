"""Writes the tables of `docs/calibration.md` from the calibration suite's results.

The page's prose stays as written; each table between a pair of markers
``<!-- table: FILE METHOD KIND -->`` … ``<!-- end -->`` is replaced by the rows of METHOD in
`scripts/results/FILE` (KIND: ``stated``, the band under what the method states, or
``conditional``, the conditional answers; ``reach``, how far the answers under stated
parameters carry). `tests/test_docs.py` checks that the page holds
exactly these tables.

    python scripts/calibration_report.py [--check]
"""

import argparse
import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PAGE = ROOT / "docs" / "calibration.md"
MARKER = re.compile(r"<!-- table: (\S+) (\S+) (\S+) -->\n.*?<!-- end -->", re.S)


def tables(text):
    """The markdown tables of a results file, as lists of lines (header first)."""
    out, current = [], []
    for line in text.splitlines() + [""]:
        if line.startswith("|"):
            current.append(line)
        elif current:
            out.append(current)
            current = []
    return out


def rows(file, method, kind):
    """The table of METHOD's rows (the header and its rule kept) from a results file: the
    first table (the stated band), the second (the conditional answers) or the reach
    table (the answers under stated parameters)."""
    found = tables((ROOT / "scripts" / "results" / file).read_text())
    if kind == "reach":  # the answers under stated parameters: how far each carries
        table = next(t for t in found if "| reach stated" in t[0])
    else:
        table = found[0 if kind == "stated" else 1]
    head, rule, *body = table
    return [head, rule, *(line for line in body if line.split("|")[1].strip() == method)]


def render(page_text):
    def replace(match):
        file, method, kind = match.groups()
        body = "\n".join(rows(file, method, kind))
        return f"<!-- table: {file} {method} {kind} -->\n{body}\n<!-- end -->"

    return MARKER.sub(replace, page_text)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--check", action="store_true",
                        help="exit 1 where the page's tables differ from the results")
    args = parser.parse_args(argv)
    text = PAGE.read_text()
    new = render(text)
    if args.check:
        sys.exit(0 if new == text else 1)
    PAGE.write_text(new)


if __name__ == "__main__":
    main()
