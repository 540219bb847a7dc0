"""Every fenced ``python`` and ``bash`` block of the README, the docs and the public modules'
docstrings runs as written: the blocks of one page in order, in one fresh process (python)
or shell (bash) per page, in an empty folder, with this environment's `vojax` on the PATH.
No page may point outside the repository."""

import ast
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
MODULES = [ROOT / "vojax" / "io.py", ROOT / "vojax" / "testing.py"]
FENCE = re.compile(r"^```(\w+)\n(.*?)^```", re.S | re.M)


def _blocks(text, lang):
    return [body for kind, body in FENCE.findall(text) if kind == lang]


def _docstring(path):
    return ast.get_docstring(ast.parse(path.read_text())) or ""


def _sources():
    for page in PAGES:
        yield page.relative_to(ROOT).as_posix(), page.read_text()
    for module in MODULES:
        yield module.relative_to(ROOT).as_posix(), _docstring(module)


CASES = [(name, lang) for name, text in _sources() for lang in ("python", "bash") if _blocks(text, lang)]


def _env():
    env = dict(os.environ)
    env["PATH"] = str(Path(sys.executable).parent) + os.pathsep + env.get("PATH", "")
    env["MPLBACKEND"] = "Agg"
    env.pop("XLA_FLAGS", None)
    return env


@pytest.mark.slow
@pytest.mark.parametrize("name, lang", CASES, ids=[f"{n}:{lang}" for n, lang in CASES])
def test_code_blocks_run(name, lang, tmp_path):
    text = dict(_sources())[name]
    code = "\n".join(_blocks(text, lang))
    if lang == "python":
        cmd = [sys.executable, "-c", code]
    else:
        cmd = ["bash", "-euo", "pipefail", "-c", code]
    done = subprocess.run(cmd, cwd=tmp_path, env=_env(), capture_output=True, text=True, timeout=900)
    assert done.returncode == 0, f"{name} ({lang}) failed:\n{done.stdout[-3000:]}\n{done.stderr[-3000:]}"
    # what a reader sees is short: no printed array of more than 10 values (or cut by NumPy)
    for group in re.findall(r"\[[^\[\]]*\]", done.stdout):
        numbers = re.findall(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?", group)
        assert len(numbers) <= 10 and "..." not in group, f"{name} prints {group[:200]}"


def test_the_runner_finds_the_blocks_it_must_run():
    names = {n for n, _ in CASES}
    assert {"README.md", "docs/index.md", "docs/cli.md", "docs/checks.md", "vojax/io.py"} <= names
    assert ("README.md", "python") in CASES and ("README.md", "bash") in CASES


def test_no_page_points_outside_the_repository():
    texts = [p.read_text() for p in PAGES]
    texts += [p.read_text() for p in (ROOT / "vojax").rglob("*.py")]
    texts += [p.read_text() for p in (ROOT / "notebooks").glob("*.ipynb")]
    for text in texts:
        assert "../shared" not in text and "NOTES.md" not in text and "NOTES §" not in text


def test_every_diagnostic_message_has_a_troubleshooting_section():
    """Each reason that `identify` can give (`vojax.Reason`) opens exactly one section of the
    troubleshooting page: a heading whose quoted text (… standing for any words) begins its
    message, and which names the reason."""
    import vojax

    context = dict(width=0.2, trade=(0.1, 0.3), bounds=(0.01, 0.99), at_bound=0.1,
                   held_shift=0.3, drifts=["order_drift"], others=["gamma"], correlation=0.5,
                   limit=0.1, block=10, block_error=1.0, unstable_from=5)
    headings = {}
    for line in (ROOT / "docs" / "troubleshooting.md").read_text().splitlines():
        quoted = re.match(r'## "(.*)"', line)
        if quoted:
            # (re.escape escapes the spaces too: a space before … goes with it)
            pattern = re.escape(quoted.group(1)).replace("\\ …", "…").replace("…", ".*?")
            headings[line] = re.compile(pattern)
    assert len(vojax.Reason) >= 12
    for reason in vojax.Reason:
        text = reason.render(**context)
        found = [h for h, pattern in headings.items() if pattern.match(text)]
        assert len(found) == 1, f"{len(found)} sections for {reason.value}: {text!r}"
        assert f"`{reason.value}`" in found[0], f"the section {found[0]!r} names no reason"


def _markdown_tables(text):
    """The rows of every table of a page, as lists of cells, table by table."""
    tables, current = [], []
    for line in text.splitlines() + [""]:
        if line.startswith("|"):
            cells = [c.strip() for c in line.strip().strip("|").split("|")]
            if not set("".join(cells)) <= set("-: "):
                current.append(cells)
        elif current:
            tables.append(current)
            current = []
    return tables


def _calibration_rows(path, method):
    """A results table of scripts/bench_calibration.py, in the docs' columns."""
    rows = []
    for line in path.read_text().splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) == 9 and cells[0] == method:
            _, family, _, identified, coverage, _, z, order, wrong = cells
            rows.append([family, identified.split()[0], *(
                "–" if v == "nan" else v for v in (coverage, z)
            ), order, wrong])
    return rows


def test_the_docs_band_components_tables_are_the_scripts_summaries():
    """The identifiability page's two tables of what sets the band's width (draws 0–11, and
    the held-out draws) are the summaries that scripts/band_components.py computes from its
    per-record results (recomputed here)."""
    import importlib.util

    spec = importlib.util.spec_from_file_location(
        "band_components", ROOT / "scripts" / "band_components.py"
    )
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    expected = []
    for name in ("band_components.txt", "band_components_held_out.txt"):
        lines = (ROOT / "scripts" / "results" / name).read_text().splitlines()
        table = lines[: next(i for i, x in enumerate(lines) if x.startswith("| parameters"))]
        expected += _markdown_tables("\n".join(module.summarise(table)) + "\n")
    docs = [
        t for t in _markdown_tables((ROOT / "docs" / "identifiability.md").read_text())
        if t[0][:2] == ["parameters", "records"]
    ]
    assert len(expected) == 2 and all(len(t) == 3 for t in expected)  # header, two groups
    assert docs == expected


def test_the_docs_calibration_tables_are_the_benchmarks_results():
    """The eight calibration tables of the identifiability page (the offset estimated, then
    known), and the README's summary of the held-out draws, are those of scripts/results/
    (the benchmark's own output)."""
    results = ROOT / "scripts" / "results"
    tables = [
        t for t in _markdown_tables((ROOT / "docs" / "identifiability.md").read_text())
        if t[0][:2] == ["family", "identified"]
    ]
    expected = [
        _calibration_rows(results / name, method)
        for offset in ("", "-x0")  # the offset estimated, then known
        for name in ("bench_calibration.txt", "bench_calibration_held_out.txt")
        for method in ("tracker" + offset, "tracker-constant" + offset)
    ]
    assert len(tables) == 8 and all(len(rows) == 11 for rows in expected)
    assert [t[1:] for t in tables] == expected
    pooled = dict(zip(["family", "identified", "coverage", "z", "order", "wrong"],
                      expected[2][-1]))
    done, total = map(int, pooled["identified"].split("/"))
    wrong = pooled["wrong"].split("/")[0]
    readme = " ".join((ROOT / "README.md").read_text().split())
    assert (f"{wrong} of the {done} records it calls identified is confidently wrong" in readme
            and f"pooled coverage {pooled['coverage']}" in readme
            and f"it identifies {round(100 * done / total)} % of the {total} records" in readme)


def test_the_docs_band_rules_table_is_the_scripts_summary():
    """The identifiability page's table of band rules is the summary at the head of
    scripts/results/band_rules.txt, and its first rule of each setting (the band as reported)
    counts what the calibration suite's results count for that setting."""
    lines = (ROOT / "scripts" / "results" / "band_rules.txt").read_text()
    expected = _markdown_tables(lines)[0]
    docs = [
        t for t in _markdown_tables((ROOT / "docs" / "identifiability.md").read_text())
        if t[0][:2] == ["parameters", "band"]
    ]
    assert docs == [expected]
    results = ROOT / "scripts" / "results"
    for setting, method in (("drifting", "tracker"), ("constant", "tracker-constant")):
        row = next(r for r in expected if r[0] == setting and r[1].startswith("reported"))
        pooled = [_calibration_rows(results / name, method)[-1]
                  for name in ("bench_calibration.txt", "bench_calibration_held_out.txt")]
        assert row[2:] == [c for r in pooled for c in (r[1], r[5].split("/")[0])]
