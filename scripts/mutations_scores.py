"""Planted bugs of `mutation_check.py`: the calibration suite's scores and tables, and the band
rules scored offline on saved explanations (`band_scores.py`)."""

# name: (file, [(old, new), ...], tests that should fail)
MUTATIONS = {
    "the suite counts a record at exactly 0.85 coverage as short of it": (
        "scripts/calibration_tables.py",
        [('short = sum(r["coverage"] < SHORT_OF for r in ident)',
          'short = sum(r["coverage"] <= SHORT_OF for r in ident)')],
        ["tests/test_calibration_tables.py"],
    ),
    "the suite counts records short of 0.85 among the refused too": (
        "scripts/calibration_tables.py",
        [('short = sum(r["coverage"] < SHORT_OF for r in ident)',
          'short = sum(r["coverage"] < SHORT_OF for r in sel)')],
        ["tests/test_calibration_tables.py"],
    ),
    "the suite's z RMS is the mean square": (
        "scripts/calibration_tables.py",
        [("z_rms=float(np.sqrt(np.mean(z[half] ** 2)))", "z_rms=float(np.mean(z[half] ** 2))")],
        ["tests/test_calibration_tables.py"],
    ),
    "the offline far-alternative rule takes the faster order drifts for the slower": (
        "scripts/band_scores.py",
        [('"slower": [i for i, m in zip(drifts, factors) if m < 1],',
          '"slower": [i for i, m in zip(drifts, factors) if m > 1],')],
        ["tests/test_band_scores.py"],
    ),
    "the offline far-alternative rule leaves out alternatives near the tuned evidence too": (
        "scripts/band_scores.py",
        [('if e["evidence"] < ref["evidence"] - limit', 'if e["evidence"] < ref["evidence"] + limit')],
        ["tests/test_band_scores.py"],
    ),
    "the offline far-alternative rule's fastest takes every faster order drift": (
        "scripts/band_scores.py",
        [('"fastest": [i for i, m in zip(drifts, factors) if m == max(factors)]}[which]',
          '"fastest": [i for i, m in zip(drifts, factors) if m > 1]}[which]')],
        ["tests/test_band_scores.py"],
    ),
    "the clock replay covers a statement's excluded account where the span's fit is ahead": (
        "scripts/band_library.py",
        [("    if not (excluded and (apart > 0.0 or wide)):",
          "    if not (excluded and wide):")],
        ["tests/test_band_scores.py::test_the_second_clocks_replay_widens_exactly_where_the_tracker_does"],
    ),
    "the clock replay covers an account the evidence excludes": (
        "scripts/band_library.py",
        [('    if r["setting"] != "stated" and apart > s.clock_evidence:\n        return band',
          '    if False:\n        return band')],
        ["tests/test_band_scores.py::test_the_second_clocks_replay_widens_exactly_where_the_tracker_does"],
    ),
}
