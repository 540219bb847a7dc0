"""`vojax batch`: bad files reported while the rest go on, re-runs, and the sharded path."""

import csv
import json
import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest

import vojax

from .helpers import fresh_cli
from .test_data_cli import _springpot_csv


def _folder(tmp_path):
    data = tmp_path / "data"
    data.mkdir()
    _springpot_csv(data / "good1.csv", n=80, q=0.3)
    _springpot_csv(data / "good2.csv", n=80, q=0.5)
    _springpot_csv(data / "good3.csv", n=60, q=0.4)  # another length: another bucket
    _springpot_csv(data / "nan_row.csv", n=80, extra_rows=[["8.0", "nan", "0.1"]])
    (data / "bad_header.csv").write_text("tyme,stress,strain\n0,1,2\n0.1,1,2\n0.2,1,2\n")
    t = np.arange(80) * 0.1
    t[40] = t[38]
    _springpot_csv(data / "backwards.csv", n=80, time=t)
    return data


@pytest.mark.slow
def test_batch_survives_bad_files_and_reruns_do_nothing_new(tmp_path):
    data = _folder(tmp_path)
    files = sorted(str(p) for p in data.glob("*.csv"))
    args = [
        "batch",
        *files,
        "--time",
        "time_s",
        "--input",
        "stress",
        "--output",
        "strain",
        "--out",
        "out",
        "--gamma",
        "0.5",
        "--method",
        "gradient+refit",
        "--quiet",
    ]
    proc = fresh_cli(*args, cwd=tmp_path)
    assert proc.returncode == 2, proc.stderr
    out = tmp_path / "out"
    with open(out / "failures.csv") as f:
        failures = {os.path.basename(r["file"]): r["reason"] for r in csv.DictReader(f)}
    assert set(failures) == {"nan_row.csv", "bad_header.csv", "backwards.csv"}
    assert "value is NaN" in failures["nan_row.csv"]
    assert "no column 'time_s'" in failures["bad_header.csv"]
    assert "time does not increase" in failures["backwards.csv"]
    with open(out / "summary.csv") as f:
        rows = list(csv.DictReader(f))
    assert sorted(r["record"] for r in rows) == ["good1", "good2", "good3"]
    orders = {r["record"]: float(r["refit_order"]) for r in rows}
    assert abs(orders["good1"] - 0.3) < 1e-6 and abs(orders["good2"] - 0.5) < 1e-6
    # the overview figure a lab looks at first: one per batch, beside the tables
    assert (out / "overview.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    # the tables are rebuilt on every run; the records' own outputs are not touched again
    stamps = {
        p: p.stat().st_mtime_ns
        for p in out.rglob("*")
        if p.is_file() and p.parent != out
    }
    again = fresh_cli(*args, cwd=tmp_path)
    assert again.returncode == 2
    assert "0 computed, 3 up to date (skipped), 0 redone, 3 failed" in again.stdout
    assert {p: p.stat().st_mtime_ns for p in stamps} == stamps  # the complete records were skipped
    with open(out / "summary.csv") as f:
        assert [r["record"] for r in csv.DictReader(f)] == ["good1", "good2", "good3"]


@pytest.mark.slow
def test_sharded_batch_equals_single_device():
    script = textwrap.dedent(
        """
        import jax
        jax.config.update("jax_enable_x64", True)
        import numpy as np
        import vojax
        from vojax._data._batch import adaptive_batch
        assert len(jax.devices()) == 4
        dt, n = 0.05, 300
        t = np.arange(n) * dt
        us, ys = [], []
        for q in (0.3, 0.4, 0.5, 0.6, 0.7):  # five records on four devices: one padded
            u = np.stack([np.sin(0.7 * t + q), 1 + 0.5 * np.cos(0.25 * t)], 1)
            us.append(u)
            ys.append(np.asarray(vojax.simulate(u, q, np.array([2.0, -1.0]), dt)))
        us, ys = np.stack(us), np.stack(ys)
        g, lam = np.full(5, 0.05), np.full(5, 0.9)
        mesh = jax.sharding.Mesh(np.array(jax.devices()), ("records",))
        (a, va, _), _ = adaptive_batch(us, ys, dt, g, lam, mesh=mesh)
        (b, vb, _), _ = adaptive_batch(us, ys, dt, g, lam, mesh=None)
        single = vojax.identify(us[2], ys[2], dt, gamma=0.05, lam=0.9, warn=False, method="gradient")
        print(np.max(np.abs(a.alpha - b.alpha)), np.max(np.abs(a.p - b.p)),
              np.max(np.abs(b.alpha[2] - np.asarray(single.alpha))),
              np.max(np.abs(np.sqrt(vb[2]) - np.asarray(single.alpha_std))) / np.max(np.asarray(single.alpha_std)),
              np.max(np.abs(va - vb)) / np.max(vb))
        """
    )
    env = dict(os.environ, XLA_FLAGS="--xla_force_host_platform_device_count=4")
    proc = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, env=env)
    assert proc.returncode == 0, proc.stderr
    d_alpha, d_p, d_single, d_band, d_band_sharded = map(float, proc.stdout.split())
    assert d_alpha < 1e-12 and d_p < 1e-10 and d_single < 1e-12
    # the batch's band is identify's band, sharded or not
    assert d_band < 1e-9 and d_band_sharded < 1e-9


@pytest.mark.slow
def test_each_batch_record_equals_identify_on_that_record(tmp_path):
    """Records of one length with different true orders run together under vmap: each
    record's identification.csv is `identify` on that record (same gains), not a neighbour's."""
    import vojax

    data = tmp_path / "data"
    data.mkdir()
    series = {}
    for name, q in (("a", 0.3), ("b", 0.5), ("c", 0.7)):
        series[name] = _springpot_csv(data / f"{name}.csv", n=90, q=q)
    proc = fresh_cli(
        "batch", *sorted(str(p) for p in data.glob("*.csv")), "--time", "time_s", "--input",
        "stress", "--output", "strain", "--out", "out", "--method", "gradient", "--gamma", "0.5",
        "--lam", "0.9", "--quiet", cwd=tmp_path,
    )
    assert proc.returncode == 0, proc.stderr
    finals = []
    for name, (t, stress, strain) in series.items():
        with open(tmp_path / "out" / name / "identification.csv", newline="") as f:
            rows = list(csv.DictReader(f))
        alpha = np.array([float(r["alpha"]) for r in rows])
        ref = vojax.identify(stress, strain, 0.1, gamma=0.5, lam=0.9, warn=False, method="gradient")
        np.testing.assert_allclose(alpha, np.asarray(ref.alpha), rtol=0, atol=1e-12)
        finals.append(alpha[-1])
    assert len(set(np.round(finals, 6))) == 3  # three different records, three answers


@pytest.mark.slow
def test_records_of_different_lengths_share_a_bucket_and_equal_identify(tmp_path, capsys):
    """Three lengths (82, 90, 120 samples; buckets of 96 and 128 on their own) pad to one
    bucket (128, merged: padding is cheaper than another compilation): the gains are tuned and
    the law run on the padded records, yet each record's order equals `identify` on that
    record alone with automatic gains, and the law and the tuner compile once for the batch."""
    import vojax
    from vojax import _tune
    from vojax._cli import main
    from vojax._data import _law_batch as _batch

    data = tmp_path / "data"
    data.mkdir()
    series = {}
    for name, q, n in (("a", 0.3, 82), ("b", 0.5, 90), ("c", 0.7, 120)):
        series[name] = _springpot_csv(data / f"{name}.csv", n=n, q=q)
    law, tune = _batch.TRACES["law_batch"], _tune.TRACES["tune"]
    args = ["batch", *sorted(str(p) for p in data.glob("*.csv")), "--time", "time_s", "--input",
            "stress", "--output", "strain", "--method", "gradient", "--quiet"]
    assert main([*args, "--out", str(tmp_path / "out")]) == 0
    assert _batch.TRACES["law_batch"] - law == 1
    assert _tune.TRACES["tune"] - tune == 2  # the grid and the refinement, once each
    for name, (t, stress, strain) in series.items():
        with open(tmp_path / "out" / name / "identification.csv", newline="") as f:
            alpha = np.array([float(r["alpha"]) for r in csv.DictReader(f)])
        ref = vojax.identify(stress, strain, 0.1, warn=False, method="gradient")
        assert alpha.shape == (t.size,)
        np.testing.assert_allclose(alpha, np.asarray(ref.alpha), rtol=0, atol=1e-10)
    # the progress bar announces the bucket's compilation, then counts records and failures;
    # off by default where stderr is not a terminal (here), on with --progress
    capsys.readouterr()
    assert main([*args[:-1], "--out", str(tmp_path / "again")]) == 0
    assert capsys.readouterr().err == ""
    assert main([*args[:-1], "--progress", "--out", str(tmp_path / "third")]) == 0
    err = capsys.readouterr().err
    assert "length bucket 1/1 (3 record(s) padded to 128 samples): compiling" in err
    assert "vojax batch: 3/3 done" in err and "0 failed, 0 up to date; about 0 s left" in err


@pytest.mark.slow
def test_record_figures_in_worker_processes_or_none(tmp_path):
    """Five records: their figures are drawn by a worker process, each record complete (figure
    and summary) and counted once; without record figures only the overview is drawn, and a
    later run that wants them redoes exactly the records that lack one."""
    from vojax._data import load_records
    from vojax._data._batch import run_batch

    data = tmp_path / "data"
    data.mkdir()
    for i in range(5):
        _springpot_csv(data / f"r{i}.csv", n=40 + i, q=0.3 + 0.1 * i)
    records = [
        r for p in sorted(data.glob("*.csv"))
        for r in load_records(p, time="time_s", inputs=["stress"], output="strain")
    ]
    settings = dict(model="springpot", method="refit", gamma=None, lam=None, progress=False)
    with_figures = run_batch(records, tmp_path / "a", figure_workers=1, **settings)
    assert (with_figures.computed, with_figures.failed) == (5, 0)
    for i in range(5):
        folder = tmp_path / "a" / f"r{i}"
        assert (folder / "identification.png").read_bytes()[:4] == b"\x89PNG"
        assert (folder / "summary.json").is_file()
    without = run_batch(records, tmp_path / "b", record_figures=False, **settings)
    assert without.computed == 5
    assert not list((tmp_path / "b").rglob("identification.png"))
    assert (tmp_path / "b" / "overview.png").is_file()
    # outputs computed with figures are current for a run without them …
    assert run_batch(records, tmp_path / "a", record_figures=False, **settings).skipped == 5
    # … and a run with figures redoes only the record that lacks one
    (tmp_path / "a" / "r2" / "identification.png").unlink()
    again = run_batch(records, tmp_path / "a", figure_workers=1, **settings)
    assert (again.skipped, again.redone, again.failed) == (4, 1, 0)
    assert (tmp_path / "a" / "r2" / "identification.png").is_file()
    for i in range(5):
        a = (tmp_path / "a" / f"r{i}" / "identification.csv").read_text()
        assert a == (tmp_path / "b" / f"r{i}" / "identification.csv").read_text()


def test_plan_buckets_is_the_cheapest_cut_of_the_sorted_lengths():
    """Against brute force over every cut of the sorted candidate lengths (m·2^k) into runs,
    each run padded to its longest: the plan's cost, compile_cost·buckets + Σ padded samples,
    is the least; every record is padded to a bucket ≥ its length; no compile cost leaves each
    record at its own candidate length and a huge one makes a single bucket."""
    import itertools

    from vojax._data._pipeline import bucket_length, plan_buckets

    def cost(plan, lengths, k):
        return k * len(set(plan.values())) + sum(plan[n] for n in lengths)

    rng = np.random.default_rng(7)
    for trial in range(40):
        lengths = [int(n) for n in rng.integers(1, 3000, size=int(rng.integers(1, 30)))]
        k = float(rng.choice([0.0, 50.0, 1e3, 1e4, 1e6]))
        plan = plan_buckets(lengths, k)
        assert all(plan[n] >= n and plan[n] in {bucket_length(m) for m in lengths} for n in lengths)
        sizes = sorted({bucket_length(n) for n in lengths})
        best = np.inf
        for cuts in itertools.product([False, True], repeat=len(sizes) - 1):
            target, start = {}, 0
            for j in range(len(sizes)):
                if j == len(sizes) - 1 or cuts[j]:
                    target.update({s: sizes[j] for s in sizes[start : j + 1]})
                    start = j + 1
            best = min(best, cost({n: target[bucket_length(n)] for n in lengths}, lengths, k))
        assert cost(plan, lengths, k) == best, (trial, lengths, k)
    lengths = [120, 130, 150, 180, 200]
    assert plan_buckets(lengths, 0) == {n: bucket_length(n) for n in lengths}
    assert set(plan_buckets(lengths, 1e9).values()) == {256}
    # 1000 short records are not padded 3× to join ten long ones, at the default cost
    plan = plan_buckets([100] * 1000 + [300] * 10)
    assert (plan[100], plan[300]) == (128, 384)
    with pytest.raises(ValueError, match="compile_cost"):
        plan_buckets([10], -1.0)
    with pytest.raises(ValueError, match="≥ 1"):
        plan_buckets([10, 0])


def test_run_batch_in_python_checks_its_arguments_before_writing(tmp_path):
    import vojax.io

    _springpot_csv(tmp_path / "r.csv", n=20, q=0.3)
    rec, = vojax.io.load_records(tmp_path / "r.csv", time="time_s", inputs=["stress"], output="strain")
    out = tmp_path / "out"
    cases = [
        (dict(records=[rec, rec]), ValueError, "two records share the name 'r'"),
        (dict(records=[rec.output]), TypeError, "must be vojax.io.Record objects"),
        (dict(figure_format="jpg"), ValueError, "`figure_format` must be png, svg or pdf"),
        (dict(gamma=float("nan")), ValueError, "`gamma` must be a positive finite number"),
        (dict(lam=-1.0), ValueError, "`lam` must be a positive finite number"),
        (dict(method="kalmann"), ValueError, "`method` must be one of"),
        (dict(model="maxwell"), ValueError, "`model` must be springpot"),
        (dict(parameters="constant", method="refit"), ValueError, "--parameters sets the tracker"),
    ]
    for kwargs, error, text in cases:
        kwargs = {"records": [rec], **kwargs}
        with pytest.raises(error, match=text.replace("(", r"\(")):
            vojax.io.run_batch(kwargs.pop("records"), out, **kwargs)
        assert not out.exists()


def test_run_batch_lists_the_files_that_could_not_be_loaded(tmp_path):
    """`failures=` (file, record, reason) from a loader go into failures.csv and the report,
    with the records that fail here; anything but text triples is refused before writing."""
    from vojax._data import load_records
    from vojax.io import run_batch

    _springpot_csv(tmp_path / "r.csv", n=40, q=0.4)
    records = load_records(tmp_path / "r.csv", time="time_s", inputs=["stress"], output="strain")
    lost = [("bad.csv", "", "bad.csv, line 2: row has 2 fields")]
    report = run_batch(records, tmp_path / "o", method="refit", record_figures=False,
                       progress=False, failures=lost)
    assert (report.computed, report.failed) == (1, 1)
    with open(tmp_path / "o" / "failures.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert [(r["file"], r["record"], r["reason"]) for r in rows] == lost
    for bad in (["bad.csv"], [("a", "b")], [("a", "b", 3)], ["abc"]):
        with pytest.raises(ValueError, match="triples"):
            run_batch(records, tmp_path / "p", method="refit", failures=bad)
    assert not (tmp_path / "p").exists()


def test_batch_takes_folders_by_pattern_and_quoted_globs(tmp_path, capsys):
    """A folder stands for its own CSV files; ``--pattern '**/*.csv'`` recurses and names a
    record in a subfolder ``subfolder/name`` (two ``test.csv`` stay apart); a quoted glob is
    expanded; vojax's outputs inside a searched folder are not taken as inputs on a re-run;
    a pattern or a glob that finds nothing is one line, exit 1."""
    from vojax._cli import main

    data = tmp_path / "data"
    for sub, q in (("a", 0.3), ("b", 0.5)):
        (data / sub).mkdir(parents=True)
        _springpot_csv(data / sub / "test.csv", n=40, q=q)
    _springpot_csv(data / "top.csv", n=40, q=0.4)
    common = ["--time", "time_s", "--input", "stress", "--output", "strain", "--method",
              "refit", "--figures", "overview", "--quiet"]

    def names(out):
        with open(out / "summary.csv", newline="") as f:
            return sorted(r["record"] for r in csv.DictReader(f))

    assert main(["batch", str(data), *common, "--out", str(tmp_path / "flat")]) == 0
    assert names(tmp_path / "flat") == ["top"]
    out = data / "results"  # inside the folder searched
    args = ["batch", str(data), "--pattern", "**/*.csv", *common, "--out", str(out)]
    assert main(args) == 0
    assert names(out) == ["a/test", "b/test", "top"]
    assert main(args) == 0  # its own outputs are not inputs now
    assert names(out) == ["a/test", "b/test", "top"]
    assert main(["batch", str(data / "*" / "test.csv"), *common, "--out", str(tmp_path / "g")]) == 1
    assert "share the name 'test'" in capsys.readouterr().err  # a glob gives no prefix
    assert main(["batch", str(data / "a" / "*.csv"), *common, "--out", str(tmp_path / "g")]) == 0
    assert names(tmp_path / "g") == ["test"]
    for bad, message in (
        (["batch", str(data), "--pattern", "*.npz"], "without files matching '*.npz'"),
        (["batch", str(data / "*.npz")], "no file matches"),
        (["batch", str(data / "top.csv"), "--pattern", "*.csv"], "give a folder as input"),
    ):
        assert main([*bad, *common, "--out", str(tmp_path / "bad")]) == 1
        err = capsys.readouterr().err.strip()
        assert message in err and "\n" not in err, err


def test_batch_compare_ranks_the_laws_of_each_record_as_compare_does(tmp_path):
    """``--compare`` adds each record's ranking of the laws to its summary.json and to
    summary.csv, equal to `vojax.compare` on that record; it enters the provenance only
    when on (a run without it leaves the outputs of a run without it current); a record with
    two input columns fails alone, saying why."""
    from vojax._cli import main
    from vojax._data import load_records

    data = tmp_path / "data"
    data.mkdir()
    _springpot_csv(data / "a.csv", n=80, q=0.35)
    common = ["--time", "time_s", "--input", "stress", "--output", "strain", "--method",
              "refit", "--figures", "overview", "--quiet", "--out", str(tmp_path / "o")]
    assert main(["batch", str(data), *common]) == 0
    assert main(["batch", str(data), *common, "--compare"]) == 0  # redone: other settings
    summary = json.loads((tmp_path / "o" / "a" / "summary.json").read_text())
    (rec,) = load_records(data / "a.csv", time="time_s", inputs=["stress"], output="strain")
    c = vojax.compare(rec.inputs, rec.output, **rec.grid)
    block = summary["compare"]
    assert block["best"] == c.best and block["verdict"] == c.verdict
    for r in c.rows:
        assert block["log_evidence"][r["model"]] == pytest.approx(r["log_evidence"], rel=1e-9)
    with open(tmp_path / "o" / "summary.csv", newline="") as f:
        (row,) = list(csv.DictReader(f))
    assert row["compare_best"] == c.best
    assert float(row["compare_weight_" + c.best]) == pytest.approx(max(r["weight"] for r in c.rows))
    # two input columns: that record fails with the reason, the batch goes on
    two = data / "two.csv"
    two.write_text("time_s,stress,strain,temp\n" + "".join(
        f"{0.1 * k!r},{1.0 + 0.01 * k!r},{0.02 * k!r},{20 + 0.1 * k!r}\n" for k in range(40)))
    args = ["batch", str(two), "--time", "time_s", "--input", "stress", "--input", "temp",
            "--output", "strain", "--model", "linear", "--method", "refit", "--figures",
            "overview", "--quiet", "--compare", "--out", str(tmp_path / "p")]
    assert main(args) == 2  # a record failed (exit 2), written in failures.csv
    with open(tmp_path / "p" / "failures.csv", newline="") as f:
        (failure,) = list(csv.DictReader(f))
    assert "--compare takes one input column" in failure["reason"]
