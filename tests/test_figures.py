"""The record figure drawn again on one reused figure equals a fresh one, pixel for pixel; the
figures leave pyplot alone; the batch's figure queue reports every record once."""

import numpy as np
import pytest

matplotlib = pytest.importorskip("matplotlib")


def _records():
    """Three records of different shapes: the law and the refit on one input; a refit of two
    parameters, one undetermined (inf error); two inputs with a narrow output range."""
    t1 = np.linspace(0.0, 12.0, 150)
    a = (
        {
            "time": t1, "y": 1 - np.exp(-t1), "y_hat": 1 - np.exp(-1.02 * t1),
            "refit_y_hat": 1 - np.exp(-0.98 * t1), "alpha": 0.4 + 0.01 * np.sin(t1),
            "alpha_lower": 0.35 + 0.0 * t1, "alpha_upper": 0.45 + 0.0 * t1,
            "refit_alpha": np.full(150, 0.41), "refit_alpha_lower": np.full(150, 0.39),
            "refit_alpha_upper": np.full(150, 0.43), "eta": 2.0 + 0.1 * np.cos(t1),
        },
        {
            "record": "a", "model": "springpot", "output_column": "displacement_mm",
            "input_columns": ["force_N"], "parameter_names": ["eta"], "time_column": "time_s",
            "gradient": {"method": "gradient"},
            "refit": {"parameters": {"eta": 2.05}, "parameters_stderr": {"eta": 0.02}},
        },
        np.tanh(t1)[:, None],
    )
    t2 = np.linspace(0.0, 3.0, 60)
    b = (
        {
            "time": t2, "y": 5e3 * t2, "refit_y_hat": 4.9e3 * t2,
            "refit_alpha": np.full(60, 0.5), "refit_alpha_lower": np.full(60, 0.01),
            "refit_alpha_upper": np.full(60, 0.99),
        },
        {
            "record": "b", "model": "kelvin-voigt", "output_column": "strain",
            "input_columns": ["stress"], "parameter_names": ["eta", "k"], "length": 2.0,
            "refit": {"parameters": {"eta": 40.0, "k": 20.0},
                      "parameters_stderr": {"eta": float("inf"), "k": 3.0}},
        },
        (1e4 * t2)[:, None],
    )
    t3 = np.linspace(-1.0, 1.0, 90)
    c = (
        {
            "time": t3, "y": 1e-3 + 1e-6 * t3, "y_hat": 1e-3 + 1.1e-6 * t3,
            "alpha": np.full(90, 0.7), "alpha_lower": np.full(90, 0.6),
            "alpha_upper": np.full(90, 0.8), "p_u1": 0.2 + 0 * t3, "p_u2": -0.1 + 0 * t3,
        },
        {
            "record": "c", "model": "linear", "output_column": "x", "input_columns": ["u1", "u2"],
            "parameter_names": ["p_u1", "p_u2"], "kalman": {"method": "kalman"},
        },
        np.c_[np.sin(3 * t3), np.cos(3 * t3)],
    )
    t4 = np.geomspace(10.0, 1e6, 150) - 10.0  # a creep record's log-spaced clock
    d = (
        {"time": t4, "y": t4**0.2, "refit_y_hat": 1.01 * t4**0.2, "refit_alpha": np.full(150, 0.2),
         "refit_alpha_lower": np.full(150, 0.19), "refit_alpha_upper": np.full(150, 0.21)},
        {"record": "d", "model": "springpot", "output_column": "strain",
         "input_columns": ["stress_Pa"], "parameter_names": ["eta"], "time_column": "time_s",
         "refit": {"parameters": {"eta": 3.0}, "parameters_stderr": {"eta": 0.1}}},
        np.full((150, 1), 3.0),
    )
    return {"a": a, "b": b, "c": c, "d": d}


def test_a_reused_record_figure_equals_a_fresh_one_pixel_for_pixel(tmp_path):
    """Each record drawn on a new figure, then all drawn in turn on the one reused figure
    (after records of other shapes): the PNGs decode to the same pixels. A reset that forgot
    the last record's lines, bands, legend, colour cycle or fixed y-limits shows here."""
    from matplotlib.image import imread

    from vojax import _plotting_record as _record

    records = _records()
    for name, (columns, summary, inputs) in records.items():
        _record._RECORD_FIGURE.clear()
        _record.record_figure(columns, summary, inputs, tmp_path / f"fresh_{name}.png")
    _record._RECORD_FIGURE.clear()
    # a record drawn after a log-spaced one ("d") starts from a linear axis (matplotlib 3.7
    # warned of a refit's constant drawn under the last record's symmetric-log scale)
    for step, name in enumerate(["a", "b", "c", "d", "a", "c", "d", "b"]):
        columns, summary, inputs = records[name]
        _record.record_figure(columns, summary, inputs, tmp_path / f"reused_{step}.png")
        fresh = imread(tmp_path / f"fresh_{name}.png")
        reused = imread(tmp_path / f"reused_{step}.png")
        assert fresh.shape == reused.shape
        np.testing.assert_array_equal(reused, fresh, err_msg=f"record {name} at step {step}")
    # the records differ, so equality above is not that of blank images
    assert not np.array_equal(imread(tmp_path / "fresh_a.png"), imread(tmp_path / "fresh_b.png"))


def test_figures_leave_pyplot_alone(tmp_path):
    """Drawing record, overview and study figures opens no pyplot figure and keeps the
    backend: a notebook shows none of them and keeps its own."""
    import types

    plt = pytest.importorskip("matplotlib.pyplot")
    from vojax import _plotting, _plotting_record

    before, backend = plt.get_fignums(), matplotlib.get_backend()
    columns, summary, inputs = _records()["a"]
    _plotting_record.record_figure(columns, summary, inputs, tmp_path / "r.png")
    row = {"record": "a", "kalman_alpha_final": 0.4, "kalman_alpha_final_std": 0.01,
           "refit_order": 0.41, "refit_order_lower": 0.39, "refit_order_upper": 0.43,
           "kalman_nrmse": 0.01, "refit_nrmse": 0.02}
    _plotting.overview_figure([row, dict(row, record="b")], tmp_path / "o.png")
    t = np.linspace(0.0, 1.0, 20)
    result = types.SimpleNamespace(alpha=t, alpha_lower=t - 0.1, alpha_upper=t + 0.1, y_hat=t,
                                   p=np.c_[t, t], p_std=np.full((20, 2), 0.1))
    _plotting.study_figures(t, t, np.c_[t, t], t, t, result, tmp_path, tracker=result)
    assert plt.get_fignums() == before
    assert matplotlib.get_backend() == backend
    for name in ("r.png", "o.png", "fig2_order.png", "fig3_output.png", "fig4_parameters.png"):
        assert (tmp_path / name).read_bytes()[:4] == b"\x89PNG"


def _finish(figures):
    """Every ``(key, error)`` the queue reports until all its records are written."""
    got = list(figures.collect())
    for _ in figures.drain():
        got += figures.collect()
    return got + figures.collect()


@pytest.mark.slow
def test_the_figure_queue_reports_every_record_once_with_its_error(tmp_path):
    """Eight records handed to one worker (at most two at a time) while this process queues
    the rest and draws them on `drain`: each key comes back exactly once, the record whose
    summary lacks a field with its error, and every other record has its figure and summary."""
    from vojax._data._batch import _Figures

    columns, summary, inputs = _records()["a"]
    figures = _Figures(1, 8)
    try:
        keys = [f"r{i}" for i in range(8)]
        for key in keys:
            (tmp_path / key).mkdir()
            bad = key == "r5"
            s = {k: v for k, v in summary.items() if not (bad and k == "output_column")}
            figures.add(key, tmp_path / key, columns, s, inputs, "png")
        assert len(figures.waiting) > 0  # some left for this process to draw
        got = _finish(figures)
    finally:
        figures.close()
    assert sorted(k for k, _ in got) == keys
    errors = {k: e for k, e in got if e is not None}
    assert list(errors) == ["r5"] and "output_column" in str(errors["r5"])
    for key in keys:
        has = (tmp_path / key / "identification.png").is_file(), (tmp_path / key / "summary.json").is_file()
        assert has == ((False, False) if key == "r5" else (True, True))


@pytest.mark.slow
def test_a_killed_figure_worker_costs_no_record(tmp_path):
    """Two workers, one killed (SIGKILL, as the out-of-memory killer does) while it holds
    records: the pool breaks, and every record it held or would have held is drawn in this
    process instead; each key comes back once, with no error. Before, every record then
    failed with BrokenProcessPool."""
    import os
    import signal
    import time

    from vojax._data._batch import _Figures

    columns, summary, inputs = _records()["a"]
    figures = _Figures(2, 8)
    try:
        for _, future, _ in list(figures.running):  # the workers are up
            future.result(timeout=60)
        keys = [f"r{i}" for i in range(8)]
        for key in keys[:4]:
            (tmp_path / key).mkdir()
            figures.add(key, tmp_path / key, columns, summary, inputs, "png")
        victim = next(iter(figures.pool._processes))
        os.kill(victim, signal.SIGKILL)
        time.sleep(0.5)
        for key in keys[4:]:
            (tmp_path / key).mkdir()
            figures.add(key, tmp_path / key, columns, summary, inputs, "png")
        got = _finish(figures)
    finally:
        figures.close()
    assert sorted(k for k, _ in got) == keys
    assert all(e is None for _, e in got), got
    for key in keys:
        assert (tmp_path / key / "identification.png").is_file()
        assert (tmp_path / key / "summary.json").is_file()


def test_the_overview_marks_what_was_not_identified_and_what_failed(tmp_path, monkeypatch):
    """Records the tracker did not identify are drawn hollow under their own legend entry,
    and the title counts them and the failed records; the record axis has whole ticks."""
    from vojax import _plotting

    saved = []
    monkeypatch.setattr(_plotting, "_save", lambda fig, path, **kw: saved.append(fig))
    rows = [
        {"record": name, "kalman_alpha_final": q, "kalman_alpha_final_std": 0.01,
         "kalman_identified": ident, "kalman_nrmse": 0.01}
        for name, q, ident in (("a", 0.4, True), ("b", 0.45, False), ("c", 0.5, "True"))
    ]
    _plotting.overview_figure(rows, tmp_path / "o.png", failed=2)
    ax = saved[0].axes[0]
    assert ax.get_title() == "3 records, 1 not identified, 2 failed (failures.csv)"
    labels = ax.get_legend_handles_labels()[1]
    assert labels == ["final order ±2σ", "not identified"]
    ticks = ax.get_xticks()
    assert np.all(ticks == np.round(ticks))
    # the histogram's bins span the orders found, not 0–1
    counts, edges = np.histogram([0.4, 0.45, 0.5], bins=20, range=(0.38, 0.52))
    heights = [p.get_height() for p in saved[0].axes[1].patches]
    assert heights == list(counts)
