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
                   limit=0.1, block=10, block_error=1.0, unstable_from=5, clock=0.6,
               span_order=0.3)
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


def test_the_calibration_report_holds_the_benchmarks_tables():
    """Every table of docs/calibration.md is the rows of its method in the results file it
    names (scripts/calibration_report.py writes them), and the README's and the
    identifiability page's headline numbers are the held-out default's pooled row."""
    import importlib.util

    spec = importlib.util.spec_from_file_location(
        "calibration_report", ROOT / "scripts" / "calibration_report.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    page = (ROOT / "docs" / "calibration.md").read_text()
    # one table per method the held-out run scored
    assert len(module.MARKER.findall(page)) >= 5
    assert module.render(page) == page
    pooled = next(line for line in module.rows("bench_calibration_held_out.txt", "tracker",
                                                 "stated") if "| pooled |" in line)
    cells = [c.strip() for c in pooled.strip().strip("|").split("|")]
    identified, wrong = cells[3].split()[0], cells[8]
    for name in ("README.md", "docs/identifiability.md"):
        text = " ".join((ROOT / name).read_text().split())
        assert f"identified {identified} held-out records, {wrong.split('/')[0]} of them " \
               "confidently wrong" in text, name


def test_the_readmes_two_commands_are_what_ci_runs():
    """The README's two commands (the indented lines under "Install and run") are lines of
    `.ci/run`, literally, and the times the README states are those its script measures:
    the demo's within 1.5× of `scripts/results/bench_readme.txt`."""
    text = (ROOT / "README.md").read_text()
    section = text.split("## Install and run", 1)[1].split("\n## ", 1)[0]
    commands = [line.strip() for line in section.splitlines() if line.startswith("    ")]
    assert commands == ['pip install -e . && vojax demo',
                        'pip install -e ".[test]" && python -m pytest']
    # each as a line of its own, followed at most by `|| exit 1` (a failed install stops CI)
    ci = {line.strip().removesuffix(" || exit 1")
          for line in (ROOT / ".ci" / "run").read_text().splitlines()}
    assert set(commands) <= ci
    measured = (ROOT / "scripts" / "results" / "bench_readme.txt").read_text()
    cold = float(re.search(r"\| vojax demo, compilation cache empty \| ([\d.]+) \|",
                           measured).group(1))
    stated = float(re.search(r"the demo takes about (\d+) s", " ".join(section.split())).group(1))
    assert cold / 1.5 <= stated <= cold * 1.5
