"""Outputs a lab can trust: safe record folders, provenance and re-runs, crash-safe tables,
the lock, a failure never written as a result (strict JSON and the tables themselves:
`tests/test_tables.py`; the batch's folders: `tests/test_batch_folders.py`)."""

import csv
import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from vojax._data._paths import MAX_LEN, record_folder
from vojax._data._tables import natural_key

from .helpers import run_cli
from .test_data_cli import _springpot_csv

HOSTILE = [
    "..",
    ".",
    "../escaped",
    "/abs/path/x",
    "dup",
    "dup/",
    "x//y",
    "x/y",
    "summary.csv",
    "CON",
    "A",
    "a",
    "%2e%2e",
    "",
    "n" * 300,
    "#hash",
    " pad ",
    "pad",
]


def test_record_folder_is_injective_and_safe():
    folders = [record_folder(n) for n in HOSTILE]
    assert len(set(folders)) == len(HOSTILE)
    assert len({f.lower() for f in folders}) == len(HOSTILE)  # case-insensitive systems too
    for f in folders:
        assert f and f not in (".", "..") and "/" not in f and "\\\\" not in f
        assert not f.startswith(".") and len(f) <= MAX_LEN + 11
    assert record_folder("specimen_1-a.b") == "specimen_1-a.b"  # plain names stay readable


def _long_csv(path, names, n=40):
    rows = ["specimen,time_s,stress,strain"]
    t = np.arange(n) * 0.1
    for j, name in enumerate(names):
        quoted = '"' + name.replace('"', '""') + '"'
        stress = np.minimum(t, 1.0) + 0.1 * j
        strain = np.cumsum(stress) * 0.1 * (1 + 0.1 * j)
        rows += [f"{quoted},{float(a)!r},{float(b)!r},{float(c)!r}" for a, b, c in zip(t, stress, strain)]
    path.write_text("\n".join(rows) + "\n")


BASE = ["--time", "time_s", "--input", "stress", "--output", "strain", "--quiet"]


@pytest.mark.slow
def test_hostile_record_names_stay_inside_out(tmp_path):
    names = [n for n in HOSTILE if n.strip() and n != "#hash"]  # CSV cannot hold an empty key
    work = tmp_path / "work"
    work.mkdir()
    _long_csv(work / "long.csv", names)
    before = {p for p in tmp_path.rglob("*")}
    proc = run_cli(
        "batch", "long.csv", *BASE, "--group-by", "specimen", "--out", "out",
        "--method", "refit", cwd=work,
    )
    assert proc.returncode == 0, proc.stderr
    out = (work / "out").resolve()
    new = {p for p in tmp_path.rglob("*")} - before
    assert all(p.resolve() == out or out in p.resolve().parents for p in new if p != out)
    assert not (tmp_path / "escaped").exists() and not os.path.exists("/abs/path/x")
    with open(out / "summary.csv") as f:
        rows = list(csv.DictReader(f))
    # one row each, original names, in natural order
    assert [r["record"] for r in rows] == sorted(names, key=natural_key)
    for name in names:
        summary = json.loads((out / record_folder(name) / "summary.json").read_text())
        assert summary["record"] == name


def _strict(text):
    def refuse(c):
        raise ValueError(f"non-standard JSON constant {c}")

    return json.loads(text, parse_constant=refuse)


def _batch(work, *extra, method="gradient"):
    return run_cli(
        "batch", *sorted(p.name for p in work.glob("*.csv")), *BASE, "--out", "out",
        *(["--gamma", "0.5"] if method == "gradient" else []), "--method", method, *extra,
        cwd=work,
    )


@pytest.mark.slow
def test_reruns_redo_what_changed_and_only_that(tmp_path):
    work = tmp_path / "w"
    work.mkdir()
    for k, q in enumerate((0.3, 0.5, 0.4)):
        _springpot_csv(work / f"r{k}.csv", n=60, q=q)
    first = _batch(work)
    assert first.returncode == 0, first.stderr
    assert "3 computed, 0 up to date (skipped), 0 redone, 0 failed" in first.stdout
    out = work / "out"
    for p in out.rglob("summary.json"):
        prov = _strict(p.read_text())["provenance"]
        assert prov["settings"]["gamma"] == 0.5 and len(prov["source_sha256"]) == 64
    # a truncated output, a changed input file: those two records are redone
    ident = out / "r0" / "identification.csv"
    ident.write_text("\n".join(ident.read_text().splitlines()[:10]) + "\n")
    _springpot_csv(work / "r1.csv", n=60, q=0.45)
    again = _batch(work)
    assert "0 computed, 1 up to date (skipped), 2 redone, 0 failed" in again.stdout, again.stdout
    with open(out / "summary.csv") as f:
        rows = {r["record"]: r for r in csv.DictReader(f)}
    assert sorted(rows) == ["r0", "r1", "r2"]
    # another setting: every record is stale; --no-overwrite refuses and says why
    refused = _batch(work, "--no-overwrite", method="refit")
    assert refused.returncode == 2
    with open(out / "failures.csv") as f:
        reasons = [r["reason"] for r in csv.DictReader(f)]
    assert len(reasons) == 3 and all("--no-overwrite" in r for r in reasons)
    with open(out / "summary.csv") as f:  # and it rewrote no row it did not redo
        kept = {r["record"]: r for r in csv.DictReader(f)}
    assert kept == rows
    # a summary.json holding NaN (not vojax's: it writes null) is not a current result
    path = out / "r2" / "summary.json"
    path.write_text(path.read_text().replace('"nrmse": ', '"nrmse": NaN, "was": ', 1))
    nan = _batch(work)
    assert "2 up to date (skipped), 1 redone" in nan.stdout, nan.stdout
    _strict(path.read_text())
    redo = _batch(work, method="refit")
    assert redo.returncode == 0 and "3 redone" in redo.stdout
    assert not (out / "failures.csv").exists()  # a clean run leaves no stale failures
    with open(out / "summary.csv") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == 3 and all("refit_order" in r for r in rows)


@pytest.mark.slow
def test_killed_batches_lose_no_rows(tmp_path):
    """SIGKILL at five points, then a full run: one row per record, equal to a clean run's."""
    work = tmp_path / "w"
    work.mkdir()
    for k in range(8):
        _springpot_csv(work / f"r{k}.csv", n=48, q=0.3 + 0.05 * k)  # one length: one compile
    clean = tmp_path / "clean"
    clean.mkdir()
    for p in work.glob("*.csv"):
        (clean / p.name).write_bytes(p.read_bytes())
    assert _batch(clean, method="refit").returncode == 0
    rng = np.random.default_rng(0)
    args = [sys.executable, "-m", "vojax", "batch", *sorted(p.name for p in work.glob("*.csv")),
            *BASE, "--out", "out", "--method", "refit"]
    env = {k: v for k, v in os.environ.items() if k != "XLA_FLAGS"}
    done = lambda: len(list((work / "out").glob("*/summary.json")))  # noqa: E731
    kills = []
    for _ in range(5):
        before = done() if (work / "out").exists() else 0
        proc = subprocess.Popen(args, cwd=work, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        # kill while records are being written: just after one more finished (or at 60 s)
        deadline = time.monotonic() + 60
        while proc.poll() is None and time.monotonic() < deadline:
            if (work / "out").exists() and done() > before:
                time.sleep(float(rng.uniform(0.0, 0.3)))
                break
            time.sleep(0.02)
        proc.send_signal(signal.SIGKILL)
        proc.wait()
        kills.append(done())
    assert any(0 < k < 8 for k in kills), kills  # the kills interrupted a run part-way
    final = _batch(work, method="refit")
    assert final.returncode == 0, final.stderr
    def read(folder):
        with open(folder / "out" / "summary.csv", newline="") as f:
            return {r["record"]: r for r in csv.DictReader(f)}

    got, want = read(work), read(clean)
    assert sorted(got) == sorted(want) == [f"r{k}" for k in range(8)]
    for name in want:
        assert float(got[name]["refit_order"]) == pytest.approx(float(want[name]["refit_order"]), abs=1e-12)
    assert not list((work / "out").rglob("*.tmp"))


@pytest.mark.slow
@pytest.mark.skipif(not os.path.isdir("/proc"), reason="reads the process table from /proc")
@pytest.mark.parametrize("how", [signal.SIGKILL, signal.SIGTERM, signal.SIGINT])
def test_a_killed_batch_leaves_no_process_behind(tmp_path, how):
    """The batch's figure workers (and multiprocessing's helper) end with the batch however
    it ends: 10 s after SIGKILL, SIGTERM or SIGINT of the main process, none is running, and
    what it printed after the signal is at most one line."""
    from .helpers import load_script

    procs = load_script("kill_batch")  # its /proc helpers: children(pid), alive(pid)
    work = tmp_path / "w"
    work.mkdir()
    for k in range(6):
        _springpot_csv(work / f"r{k}.csv", n=40 + 8 * k, q=0.3 + 0.05 * k)
    args = [sys.executable, "-m", "vojax", "batch", *sorted(p.name for p in work.glob("*.csv")),
            *BASE, "--out", "out", "--method", "refit"]
    proc = subprocess.Popen(args, cwd=work, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True)
    # the kill comes once the workers have started: two children (the figure worker and
    # multiprocessing's helper) seen on two polls in a row. A SIGKILL within the millisecond in
    # which a spawned worker has not yet read its start-up data from its parent leaves that
    # worker a traceback (its EOFError) to print; it then exits. No code of the parent can run
    # under SIGKILL, so that window is not this test's subject.
    deadline, children, seen = time.monotonic() + 60, [], []
    while proc.poll() is None and time.monotonic() < deadline:
        time.sleep(0.2)
        children = procs.children(proc.pid)
        if len(children) >= 2 and sorted(children) == seen:
            break
        seen = sorted(children)
    assert proc.poll() is None and len(children) >= 2, "the batch ended before its workers started"
    proc.send_signal(how)
    _, err = proc.communicate(timeout=60)
    deadline = time.monotonic() + 10
    while any(procs.alive(c) for c in children) and time.monotonic() < deadline:
        time.sleep(0.2)
    assert not [c for c in children if procs.alive(c)]
    # Ctrl-C and SIGTERM: at most one line (SIGKILL: nothing, not even multiprocessing's
    # warning about the pool's semaphores)
    assert len(err.strip().splitlines()) <= 1 and "Traceback" not in err, err


def test_a_second_batch_on_the_same_out_is_refused(tmp_path):
    fcntl = pytest.importorskip("fcntl")
    work = tmp_path / "w"
    work.mkdir()
    _springpot_csv(work / "r.csv", n=40)
    (work / "out").mkdir()
    with open(work / "out" / ".vojax-batch.lock", "a") as held:
        fcntl.flock(held, fcntl.LOCK_EX | fcntl.LOCK_NB)
        proc = _batch(work)
    assert proc.returncode == 1
    assert "another vojax batch is writing to" in proc.stderr
    assert not (work / "out" / "r").exists()


def test_out_never_holds_the_inputs_and_follows_no_link(tmp_path):
    """--out equal to the input's folder (or above it, or the input itself) is refused before
    anything is written, and the input is left as it was; a lock file in --out that is a
    link is not followed (it would create a file elsewhere)."""
    work = tmp_path / "w"
    work.mkdir()
    _springpot_csv(work / "summary.csv", n=40)  # an input named like an output
    before = (work / "summary.csv").read_bytes()
    for command, out in (("identify", "."), ("batch", "."), ("identify", ".."),
                         ("batch", "summary.csv")):
        proc = run_cli(command, "summary.csv", *BASE[:-1], "--out", out, cwd=work)
        assert proc.returncode == 1, (command, out, proc.stderr)
        assert "choose a new folder for --out" in proc.stderr
        assert proc.stderr.count("\n") == 1
    assert (work / "summary.csv").read_bytes() == before
    assert sorted(p.name for p in work.iterdir()) == ["summary.csv"]
    from vojax._data._batch import run_batch
    from vojax._data._records import load_records

    records = load_records(work / "summary.csv", time="time_s", inputs=["stress"], output="strain")
    with pytest.raises(ValueError, match="holds the input"):
        run_batch(records, work, model="springpot", method="refit", gamma=None, lam=None)
    # a folder where the batch writes a table: refused by name before anything is computed
    (work / "o4" / "summary.csv").mkdir(parents=True)
    proc = _batch(work, "--out", "o4", method="refit")
    assert proc.returncode == 1 and "o4/summary.csv is a folder" in proc.stderr, proc.stderr
    assert sorted(p.name for p in (work / "o4").iterdir()) == ["summary.csv"]
    # the lock: a link to a file outside --out is refused, and nothing is created there
    (work / "out").mkdir()
    elsewhere = tmp_path / "elsewhere.txt"
    os.symlink(elsewhere, work / "out" / ".vojax-batch.lock")
    proc = _batch(work, method="refit")
    assert proc.returncode == 1 and "symbolic link" in proc.stderr
    assert not elsewhere.exists()


def test_vojax_overwrites_only_what_it_wrote(tmp_path):
    """A file in --out that vojax did not write (the user's own summary.csv, or a record's
    identification.csv) is refused by name before anything is written, and left as it was;
    what vojax wrote there itself, listed in the folder's manifest, it rewrites on a re-run."""
    from vojax._data._paths import MANIFEST

    work = tmp_path / "w"
    work.mkdir()
    _springpot_csv(work / "a.csv", n=40)
    for name in ("summary.csv", "a/identification.csv"):  # a table, and a record's file
        out = work / "out"
        shutil.rmtree(out, ignore_errors=True)
        (out / name).parent.mkdir(parents=True, exist_ok=True)
        (out / name).write_text("mine\n")
        proc = _batch(work, method="refit")
        assert proc.returncode == 1, proc.stderr
        assert f"{name}' exists and was not written by vojax" in proc.stderr
        assert proc.stderr.count("\n") == 1
        assert (out / name).read_text() == "mine\n"
        assert not (out / MANIFEST).exists()
        left = sorted(p.name for p in out.rglob("*") if p.is_file())
        assert left in ([Path(name).name], [".vojax-batch.lock", Path(name).name])
    shutil.rmtree(work / "out")
    # a fresh folder: written and listed; the re-run rewrites its own files
    for _ in range(2):
        proc = _batch(work, "--figures", "overview", method="refit")
        assert proc.returncode == 0, proc.stderr
    listed = (work / "out" / MANIFEST).read_text().split()
    assert {"summary.csv", "a/identification.csv", "a/summary.json"} <= set(listed)
    written = {str(p.relative_to(work / "out")) for p in (work / "out").rglob("*")
               if p.is_file() and p.name not in (MANIFEST, ".vojax-batch.lock")}
    assert written <= set(listed)
    (work / "out" / "notes.txt").write_text("mine\n")  # a file of the user's beside them
    (work / "single").mkdir()
    (work / "single" / "identification.csv").write_text("mine\n")
    proc = run_cli("identify", "a.csv", *BASE[:-1], "--method", "refit", "--out", "single",
                   cwd=work)
    assert proc.returncode == 1 and "was not written by vojax" in proc.stderr, proc.stderr
    assert (work / "single" / "identification.csv").read_text() == "mine\n"


@pytest.mark.slow
def test_failure_is_never_a_result(tmp_path):
    """A record whose estimates are not finite exits non-zero and writes no result."""
    t = np.arange(400) * 60.0
    path = tmp_path / "slow.csv"
    u = np.stack([np.sin(1e-4 * t) + 1.0, np.cos(2e-4 * t)], axis=1)
    y = u[:, 0] * 1e-3 + np.cumsum(u[:, 1]) * 1e-6
    with open(path, "w") as f:
        f.write("t,a,b,y\n" + "".join(f"{float(a)!r},{float(b)!r},{float(c)!r},{float(d)!r}\n" for a, b, c, d in zip(t, u[:, 0], u[:, 1], y)))
    proc = run_cli(
        "identify", "slow.csv", "--time", "t", "--input", "a", "--input", "b", "--output", "y",
        "--model", "linear", "--method", "gradient", "--gamma", "0.01", "--lam", "0.9",
        "--out", "o", cwd=tmp_path,
    )
    assert proc.returncode == 1, proc.stdout
    assert "diverged" in proc.stderr
    assert not (tmp_path / "o" / "summary.json").exists()
    # the batch: the record fails with its reason, exit 2, and no row in summary.csv
    proc = run_cli(
        "batch", "slow.csv", "--time", "t", "--input", "a", "--input", "b", "--output", "y",
        "--model", "linear", "--method", "gradient", "--gamma", "0.01", "--lam", "0.9",
        "--out", "b", "--quiet", cwd=tmp_path,
    )
    assert proc.returncode == 2
    with open(tmp_path / "b" / "failures.csv", newline="") as f:
        (row,) = list(csv.DictReader(f))
    assert row["record"] == "slow" and "diverged" in row["reason"] and "sample" in row["reason"]
    with open(tmp_path / "b" / "summary.csv", newline="") as f:
        assert list(csv.DictReader(f)) == []
    assert not (tmp_path / "b" / "slow" / "summary.json").exists()
