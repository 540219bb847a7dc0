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


def test_parameters_panel_shows_a_constant_plainly_and_names_the_parameters(tmp_path):
    """A constant η (31.9185851, with wiggles of 1e-9) is drawn within ±1 % of its level with
    plain tick labels, not zoomed on its last digits with an offset; a start-up transient
    (η = 1/p̂ while p̂ is near 0, the first 5 % of samples) does not set the limits, but the
    whole record after it does (a step in the first half stays in view); the y-label names
    the parameter with its unit (a strain: dimensionless)."""
    from vojax import _plotting_record as _plotting

    t = np.linspace(0.0, 10.0, 200)
    eta = 31.9185851 + 1e-9 * np.sin(t)
    eta[:10] = 1e6  # the transient
    eta[40:60] = 34.0  # a step in the first half
    columns = {"time": t, "y": np.sin(t), "eta": eta}
    summary = {
        "record": "r", "model": "springpot", "output_column": "strain",
        "input_columns": ["stress_kPa"], "parameter_names": ["eta"], "time_column": "time_s",
    }
    seen = {}
    real = _plotting._save

    def keep(fig, path, **kw):
        ax = fig.axes[4]
        fig.canvas.draw()
        seen.update(ylim=ax.get_ylim(), label=ax.get_ylabel(),
                    offset=ax.yaxis.get_major_formatter().get_offset(),
                    time=fig.axes[1].get_xlabel(), input=fig.axes[2].get_ylabel())
        real(fig, path, **kw)

    _plotting._save = keep
    try:
        _plotting.record_figure(columns, summary, np.sin(t)[:, None], tmp_path / "f.png")
    finally:
        _plotting._save = real
    lo, hi = seen["ylim"]
    assert lo <= 31.9185851 * 0.99 + 1e-12 and hi >= 34.0 and hi < 1e3
    assert seen["offset"] == "" and seen["label"] == "η (kPa·s$^{\\alpha}$)"
    assert seen["time"] == "time (s, from the first sample)" and seen["input"] == "stress (kPa)"
    # a record whose first sample is at 100 s in its file says so on its time axes
    _plotting._save = keep
    try:
        _plotting.record_figure(columns, dict(summary, time_offset=100.0), np.sin(t)[:, None],
                                tmp_path / "g.png")
    finally:
        _plotting._save = real
    assert seen["time"] == "time (s, from the first sample, at 100 in the file)"


def test_axis_labels_carry_the_units_of_the_column_names():
    from vojax._plotting import axis_label

    cases = {
        "nominal_shear_stress_kPa": "nominal shear stress (kPa)",
        "time_s": "time (s)",
        "force_rise_N": "force rise (N)",
        "indentation_um": "indentation (µm)",
        "temperature_C": "temperature (°C)",
        "contact_strain": "contact_strain",  # no unit: as it is
        "F": "F",
        "_s": "_s",
        "mass_kg_total": "mass_kg_total",
    }
    assert {k: axis_label(k) for k in cases} == cases




def _drawn(monkeypatch, module):
    """Figures `module._save` would write, drawn and kept instead."""
    kept = []

    def keep(fig, path, **kw):
        fig.canvas.draw()
        kept.append(fig)

    monkeypatch.setattr(module, "_save", keep)
    return kept


def _captions(fig):
    """The figure's texts other than its title."""
    return [t for t in fig.texts if t is not fig._suptitle]


def _inside_and_apart(fig):
    """Every panel with its drawn ticks, labels, title and legend, and the figure's title and
    caption, inside the canvas; the figure's title overlapping no panel's title."""
    renderer = fig.canvas.get_renderer()
    box = fig.bbox
    boxes = [(ax.get_title() or "a panel", ax.get_tightbbox(renderer)) for ax in fig.axes]
    boxes += [(t.get_text()[:40], t.get_window_extent(renderer)) for t in fig.texts]
    for name, b in boxes:
        assert b.x0 >= box.x0 - 1 and b.x1 <= box.x1 + 1 and b.y0 >= box.y0 - 1 and b.y1 <= box.y1 + 1, (
            f"{name!r} leaves the figure")
    top = fig._suptitle.get_window_extent(renderer)
    for ax in fig.axes:
        if ax.get_title():
            assert not top.overlaps(ax.title.get_window_extent(renderer)), ax.get_title()


def test_the_record_figure_shows_the_fit_its_residuals_and_the_verdict_uncut(tmp_path, monkeypatch):
    """The residual panel draws y − ŷ of each estimator; the title is one line with the
    verdict; the caption holds the answer, what it assumes and the whole reason (no "…"),
    wrapped inside the figure; no text leaves the canvas or overlaps the title."""
    from vojax import _plotting_record

    columns, summary, inputs = _records()["c"]
    kept = _drawn(monkeypatch, _plotting_record)
    reason = ("the order band is ±0.47 wide because a drifting parameter explains the data as "
              "well with any constant order from 0.01 to 0.99: " + "an order and a parameter "
              "trade off, " * 12 + "and the band covers both")
    part = {"method": "kalman", "identified": False, "verdict": "not identified",
            "answer": "not identified: α 0.70 → 0.70 ± 0.47", "finding": reason,
            "parameter_model": "constant", "offset_model": "known"}
    _plotting_record.record_figure(columns, {**summary, "kalman": part}, inputs, tmp_path / "f.png")
    (fig,) = kept
    out, resid = fig.axes[0], fig.axes[1]
    assert out.get_title() == "output and fit" and resid.get_title() == "residuals (measured − fit)"
    (line,) = [ln for ln in resid.get_lines() if ln.get_label().startswith("tracker")]
    np.testing.assert_array_equal(line.get_ydata(), columns["y"] - columns["y_hat"])
    rms = np.sqrt(np.mean((columns["y"] - columns["y_hat"]) ** 2))
    assert line.get_label() == f"tracker (RMS {rms:.3g})"
    assert fig._suptitle.get_text() == "c — linear: order not identified"
    (caption,) = _captions(fig)
    words = " ".join(caption.get_text().split())
    assert "…" not in words and reason in words
    assert "not identified: α 0.70 → 0.70 ± 0.47 (parameters stated constant; output offset given)" in words
    assert len(caption.get_text().splitlines()) >= 3  # wrapped, not one long line
    _inside_and_apart(fig)
    # an identified record: the same layout, its caption without a reason
    part = {"method": "kalman", "identified": True, "verdict": "identified",
            "answer": "identified: α 0.70 → 0.70 ± 0.05", "parameter_model": "free"}
    _plotting_record.record_figure(columns, {**summary, "kalman": part}, inputs, tmp_path / "g.png")
    assert kept[1]._suptitle.get_text() == "c — linear: order identified"
    assert "Why" not in _captions(kept[1])[0].get_text()
    _inside_and_apart(kept[1])


def test_parameters_carry_their_units():
    """η in stress·time^α/strain, the springs in stress/strain, a linear model's p_j in
    x/(u_j·time^α); a column without a unit stands for its unit, a length-scaled or
    unit-less strain is dimensionless."""
    from vojax._plotting_parts import parameter_label

    law = {"model": "kelvin-voigt", "input_columns": ["stress_kPa"], "output_column": "disp_mm",
           "time_column": "t_ms"}
    a = "$^{\\alpha}$"
    assert parameter_label("eta", law) == f"η (kPa·ms{a}/mm)"
    assert parameter_label("k", law) == "k (kPa/mm)"
    assert parameter_label("eta", dict(law, length=2.0)) == f"η (kPa·ms{a})"
    assert parameter_label("E0", dict(law, output_column="strain")) == "E₀ (kPa)"
    assert parameter_label("k", dict(law, units={"disp_mm": "1"})) == "k (kPa)"
    assert parameter_label("eta", dict(law, input_columns=["F"], time_column="Time",
                                       output_column="L")) == f"η (F·Time{a}/L)"
    assert parameter_label("eta", dict(law, area=3.0, length=1.0)) == f"η (kPa/area·ms{a})"
    linear = {"model": "linear", "input_columns": ["u1", "force_N"], "output_column": "x_um",
              "time_column": "time_s"}
    assert parameter_label("p_force_N", linear) == f"p_force_N (µm/(N·s{a}))"
    assert parameter_label("p_u1", dict(linear, units={"u1": "V"})) == f"p_u1 (µm/(V·s{a}))"


def test_a_log_spaced_clock_gets_a_log_axis_and_a_constant_no_offset(tmp_path, monkeypatch):
    """A creep record sampled at log-spaced times is drawn on a symmetric-log time axis (a
    uniform clock with a gap is not); a constant 500 Pa input with float jitter is drawn
    plainly within ±1 % of its level, not as ``1e-5 + 5e2``."""
    from vojax import _plotting_record
    from vojax._plotting_parts import log_clock

    uniform = np.r_[np.arange(50.0), 60.0 + np.arange(50.0)]
    t = np.r_[0.0, np.geomspace(1e-3, 60.0, 199)]
    assert log_clock(t) and not log_clock(uniform) and not log_clock(np.arange(5.0))
    kept = _drawn(monkeypatch, _plotting_record)
    columns = {"time": t, "y": 1 - np.exp(-t), "y_hat": 1 - np.exp(-t)}
    summary = {"record": "r", "model": "linear", "output_column": "x", "input_columns": ["s_Pa"],
               "parameter_names": [], "time_column": "time_s"}
    stress = 500.0 + 1e-5 * np.sin(np.arange(t.size))[:, None]
    _plotting_record.record_figure(columns, summary, stress, tmp_path / "f.png")
    fig = kept[0]
    assert {ax.get_xscale() for ax in fig.axes} == {"symlog"}
    inputs = fig.axes[2]
    assert inputs.yaxis.get_major_formatter().get_offset() == ""
    lo, hi = inputs.get_ylim()
    assert lo == pytest.approx(495.0, abs=1e-4) and hi == pytest.approx(505.0, abs=1e-4)
    # the next record, on a uniform clock, is drawn on linear axes again (the figure is reused)
    columns = {"time": uniform, "y": np.sin(uniform)}
    _plotting_record.record_figure(columns, summary, np.sin(uniform)[:, None], tmp_path / "g.png")
    assert {ax.get_xscale() for ax in kept[1].axes} == {"linear"}


def test_identification_plot_shows_data_fit_residuals_and_the_verdict(tmp_path):
    """`Identification.plot()` draws the measured output with the fit, the residuals y − ŷ and
    the order with its band, titled with the verdict and captioned with `verdict_line()`."""
    plt = pytest.importorskip("matplotlib.pyplot")
    import vojax

    dt = 0.05
    t = dt * np.arange(300)
    u = np.sin(0.7 * t) + 1.0
    y = np.asarray(vojax.simulate(u, 0.4, np.array([1.5]), dt))
    y = y + 0.01 * np.random.default_rng(0).standard_normal(t.size)
    res = vojax.identify(u, y, dt, method="gradient", gamma=0.5, lam=0.9, warn=False)
    np.testing.assert_array_equal(np.asarray(res.y), y)
    ax = res.plot(t=t)
    fig = ax.figure
    try:
        out, resid, order = fig.axes
        assert order is ax and out.get_title() == "output and fit" and ax.get_title() == f"order: {res.diagnostics.verdict}"
        np.testing.assert_array_equal(out.get_lines()[0].get_ydata(), y)
        (line,) = [ln for ln in resid.get_lines() if ln.get_label().startswith("paper's law")]
        np.testing.assert_allclose(line.get_ydata(), y - np.asarray(res.y_hat), rtol=0, atol=0)
        words = " ".join(_captions(fig)[0].get_text().split())
        assert res.verdict_line() in words and res.diagnostics.finding.split(";")[0] in words
        fig.canvas.draw()
        _inside_and_apart(fig)
    finally:
        plt.close(fig)
    # the tracker keeps the measured output too, for the same figure
    tracked = vojax.identify(u[:60], y[:60], dt, warn=False)
    np.testing.assert_array_equal(np.asarray(tracked.y), y[:60])
    plt.close(tracked.plot().figure)


def test_the_overview_counts_in_whole_records_and_says_when_drift_absorbs_the_fit(tmp_path, monkeypatch):
    """The histograms' count axes have whole ticks, the two estimators' bars stand side by
    side, and where the tracker fits far closer than the refit the fit panel says why."""
    from vojax import _plotting

    kept = _drawn(monkeypatch, _plotting)
    rows = [
        {"record": f"r{i}", "kalman_alpha_final": 0.3 + 0.01 * i, "kalman_alpha_final_std": 0.01,
         "kalman_identified": "False", "kalman_nrmse": 0.002 + 0.001 * i,
         "refit_order": 0.3 + 0.02 * i, "refit_order_lower": 0.29 + 0.02 * i,
         "refit_order_upper": 0.31 + 0.02 * i, "refit_nrmse": 0.05 + 0.01 * i}
        for i in range(5)
    ]  # at most two records a bin: matplotlib's own ticks would be fractional
    _plotting.overview_figure(rows, tmp_path / "o.png")
    fig = kept[0]
    for ax in fig.axes[1:]:
        ticks = ax.get_yticks()
        assert np.all(ticks == np.round(ticks)), ticks
    texts = " ".join(" ".join(t.get_text().split()) for t in fig.axes[2].texts)
    assert "because its parameters drift with the data" in texts and "(median 0.004)" in texts
    # bars side by side: the two series' bars never share an x position
    xs = [round(p.get_x(), 12) for p in fig.axes[1].patches if p.get_height() > 0]
    assert len(xs) == len(set(xs))
    # the same rows with the refit as close as the tracker: no such sentence
    for r in rows:
        r["refit_nrmse"] = r["kalman_nrmse"]
    _plotting.overview_figure(rows, tmp_path / "p.png")
    assert not kept[1].axes[2].texts


def test_the_studys_figures_hide_no_data_and_clip_no_estimate(tmp_path, monkeypatch):
    """Fig. 3 draws each estimate's error ŷ − x* in a panel of its own (on the output panel
    the three curves are one) and its legends above the panels, outside the data; Fig. 4 keeps
    every estimate after the start's transient inside its y-limits (the law's excursions
    included) and its legends beside the panels."""
    import types

    from vojax import _plotting

    kept = _drawn(monkeypatch, _plotting)
    rng = np.random.default_rng(1)
    t = np.linspace(0.0, 300.0, 600)
    x = 10 * np.sin(t / 10)
    truth = np.c_[3 + 4 * (t > 150), -5 + 0 * t]

    def estimate(spread):
        p = truth + spread * rng.standard_normal(truth.shape).cumsum(0)
        p[:30] += 50.0  # the start's transient
        return types.SimpleNamespace(alpha=0.5 + 0 * t, alpha_lower=0.4 + 0 * t,
                                     alpha_upper=0.6 + 0 * t, p=p, p_std=0.1 + 0 * p,
                                     y_hat=x + 0.1 * rng.standard_normal(t.size))

    law, tracker = estimate(0.3), estimate(0.05)
    law.p[[200, 350, 500], 1] -= 30.0  # the law's brief excursions, as in the study
    _plotting.study_figures(t, 0.5 + 0 * t, truth, x, x, law, tmp_path, tracker=tracker)
    _, fig3, fig4 = kept
    renderer = fig3.canvas.get_renderer()
    out, err = fig3.axes
    errors = {ln.get_label(): ln.get_ydata() for ln in err.get_lines()}
    np.testing.assert_array_equal(errors[r"$\hat x - x^*$, paper's law"], law.y_hat - x)
    np.testing.assert_array_equal(errors[r"$\hat x - x^*$, tracker"], tracker.y_hat - x)
    for ax in fig3.axes:
        assert not ax.get_legend().get_window_extent(renderer).overlaps(ax.get_window_extent(renderer))
    start = int(_plotting.SKIP_START * t.size)
    for i, ax in enumerate(fig4.axes):
        lo, hi = ax.get_ylim()
        for est in (law, tracker):
            assert lo <= est.p[start:, i].min() and est.p[start:, i].max() <= hi
        legend = ax.get_legend().get_window_extent(fig4.canvas.get_renderer())
        assert not legend.overlaps(ax.get_window_extent(fig4.canvas.get_renderer()))
