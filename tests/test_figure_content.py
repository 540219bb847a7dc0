"""What the figures show: the fit, its residuals and the verdict uncut, parameters with their
units and a constant shown plainly, axis labels from the column names, a log axis for a
log-spaced clock, the overview's counts, and the study's figures hiding no data."""

import numpy as np
import pytest

from .test_figures import _records

matplotlib = pytest.importorskip("matplotlib")


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
