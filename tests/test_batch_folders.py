"""The batch's folders: a record folder current only with the summary of its own run, the
manifest of what vojax wrote, and an output folder that holds the input refused."""

import os

import numpy as np
import pytest

from .helpers import fresh_cli
from .test_data_cli import _springpot_csv
from .test_outputs import BASE


def test_a_folder_is_current_only_with_the_summary_of_its_own_run(tmp_path):
    """A run killed between a record's new table and its new summary: the folder must not
    pair the new table with the old summary (the old run's settings would then take it as
    current). Writing the table removes the old summary first, so the folder is stale until
    its summary is written; and a complete folder is current again."""
    from vojax._data._batch import _state
    from vojax._data._pipeline import finish_outputs, write_table

    folder = tmp_path / "r"
    columns = {"time": np.arange(5.0), "y": np.ones(5)}
    provenance = {"hash": "old"}
    summary = {"samples": 5, "provenance": provenance}
    write_table(folder, columns)
    finish_outputs(folder, columns, summary, None, "png")
    assert _state(folder, provenance, figure=False) == "current"
    write_table(folder, {"time": np.arange(5.0), "y": np.zeros(5)})  # the new run, then killed
    assert not (folder / "summary.json").exists()
    assert _state(folder, provenance, figure=False) == "stale"


def test_the_manifest_keeps_what_every_run_wrote(tmp_path):
    """`claim_outputs` adds this run's names to the folder's manifest and keeps every name an
    earlier run put there: a file vojax wrote in an earlier run may be rewritten, and one it
    never wrote may not."""
    from vojax._data._paths import MANIFEST, claim_outputs

    claim_outputs(tmp_path, ["a/summary.json"])
    (tmp_path / "a").mkdir()
    (tmp_path / "a" / "summary.json").write_text("{}")
    claim_outputs(tmp_path, ["b/summary.json"])
    written = (tmp_path / MANIFEST).read_text().split()
    assert written == ["a/summary.json", "b/summary.json"]
    claim_outputs(tmp_path, ["a/summary.json"])  # written by vojax before: may be redone
    (tmp_path / "mine.csv").write_text("x")
    with pytest.raises(ValueError, match="was not written by vojax"):
        claim_outputs(tmp_path, ["mine.csv"])


def test_a_batch_whose_out_is_its_input_folder_says_so(tmp_path):
    """`batch in --out in`, `--out` a link to `in`, and `--out` a folder above `in`: the
    documented refusal (it said "in is a folder without CSV, NPZ or AFM files", which held
    CSVs), and nothing written."""
    work = tmp_path / "w"
    (work / "in").mkdir(parents=True)
    _springpot_csv(work / "in" / "a.csv", n=30)
    os.symlink("in", work / "link")
    for out in ("in", "link", "."):
        proc = fresh_cli("batch", "in", *BASE, "--out", out, cwd=work)
        assert proc.returncode == 1, proc.stderr
        assert f"the output folder '{out}' holds the input 'in/a.csv'" in proc.stderr
        assert proc.stderr.count("\n") == 1
    assert sorted(p.name for p in work.rglob("*")) == ["a.csv", "in", "link"]
