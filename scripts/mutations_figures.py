"""Planted bugs of `mutation_check.py`: the figures (a record's, a map's, the batch overview) and the progress line."""

# name: (file, [(old, new), ...], tests that should fail)
MUTATIONS = {
    "reused record figure keeps the colour cycle": (
        "vojax/_plotting_record.py",
        [("        ax.set_prop_cycle(None)  # colours from C0 again\n", "")],
        ["tests/test_figures.py::test_a_reused_record_figure_equals_a_fresh_one_pixel_for_pixel"],
    ),
    "figure queue drops what this process draws": (
        "vojax/_data/_figures.py",
        [("        else:\n            self.ready.append((key, None))\n\n    def _hand_over",
          "\n    def _hand_over")],
        ["tests/test_figures.py::test_the_figure_queue_reports_every_record_once_with_its_error"],
    ),
    "a killed figure worker fails its records": (
        "vojax/_data/_figures.py",
        [("                except concurrent.futures.BrokenExecutor:\n                    # a worker was killed",
          "                except ZeroDivisionError:\n                    # a worker was killed")],
        ["tests/test_figures.py::test_a_killed_figure_worker_costs_no_record"],
    ),
    "figure workers outlive a killed batch": (
        "vojax/_data/_figures.py",
        [("initializer=_figure_worker_init, initargs=(os.getpid(),),", "")],
        ["tests/test_outputs.py::test_a_killed_batch_leaves_no_process_behind"],
    ),
    "the overview hides what was not identified": (
        "vojax/_plotting.py",
        [('        known = np.array([str(r.get(f"{tracker}_identified")) == "True" for r in rows])',
          '        known = np.array([True for r in rows])')],
        ["tests/test_figures.py::test_the_overview_marks_what_was_not_identified_and_what_failed"],
    ),
    "time left paced from the start": (
        "vojax/_progress.py",
        [("    return (elapsed - first) / (done - 1) * (total - done)",
          "    return elapsed / done * (total - done)")],
        ["tests/test_batch_progress.py::test_time_left_is_paced_after_the_first_record"],
    ),
    "AFM map image transposed": (
        "vojax/_plotting_maps.py",
        [("            image[iy - y0, ix - x0] = [value(r) for r in curves]",
          "            image[ix - x0, iy - y0] = [value(r) for r in curves]")],
        ["tests/test_afm_contact.py::test_a_force_map_gives_a_record_per_curve_and_maps_over_its_grid"],
    ),
    "AFM map not cut to the part measured": (
        "vojax/_plotting_maps.py",
        [("        x0, y0 = ix.min(), iy.min()", "        x0, y0 = 0, 0")],
        ["tests/test_afm_contact.py::test_a_force_map_gives_a_record_per_curve_and_maps_over_its_grid"],
    ),
    "progress bar's time left re-stamped at every update": (
        "vojax/_progress.py",
        [("(self.first or now) - self.started", "now - self.started")],
        ["tests/test_batch_progress.py::test_the_bars_time_left_is_paced_on_the_records_after_the_first"],
    ),
    "the record figure's residuals are the fit, not measured − fit": (
        "vojax/_plotting_parts.py",
        [("        r = y - np.asarray(fit, dtype=float)", "        r = np.asarray(fit, dtype=float)")],
        ["tests/test_figure_content.py::test_the_record_figure_shows_the_fit_its_residuals_and_the_verdict_uncut"],
    ),
    "the caption cuts the reason to its first clause": (
        "vojax/_plotting_parts.py",
        [('            lines.append("Why: " + finding.rstrip(".") + ".")',
          '            lines.append("Why: " + finding.split(":")[0] + ".")')],
        ["tests/test_figure_content.py::test_the_record_figure_shows_the_fit_its_residuals_and_the_verdict_uncut"],
    ),
    "the caption's lines are not wrapped": (
        "vojax/_plotting_parts.py",
        [("int(CAPTION_CHARS * width)", "10_000")],
        ["tests/test_figure_content.py::test_the_record_figure_shows_the_fit_its_residuals_and_the_verdict_uncut"],
    ),
    "the caption forgets the stated assumptions": (
        "vojax/_plotting_parts.py",
        [('(f" ({assumed})." if assumed else ".")', '"."')],
        ["tests/test_figure_content.py::test_the_record_figure_shows_the_fit_its_residuals_and_the_verdict_uncut"],
    ),
    "eta's unit without the time to the order": (
        "vojax/_plotting_parts.py",
        [('unit = f"{stress}·{tau}{per}" if name == "eta" else f"{stress}{per}"',
          'unit = f"{stress}{per}"')],
        ["tests/test_figure_content.py::test_parameters_carry_their_units"],
    ),
    "a log-spaced clock on a linear axis": (
        "vojax/_plotting_parts.py",
        [("    return bool(np.median(steps[-quarter:]) > LOG_CLOCK * np.median(steps[:quarter]))",
          "    return False")],
        ["tests/test_figure_content.py::test_a_log_spaced_clock_gets_a_log_axis_and_a_constant_no_offset"],
    ),
    "a reused figure keeps the last record's log axis": (
        "vojax/_plotting_record.py",
        [('        ax.set_xscale("linear")\n', '')],
        ["tests/test_figure_content.py::test_a_log_spaced_clock_gets_a_log_axis_and_a_constant_no_offset"],
    ),
    "a constant input zoomed on its jitter": (
        "vojax/_plotting_parts.py",
        [("    flat = level > 0 and hi - lo < FLAT * level", "    flat = False")],
        ["tests/test_figure_content.py::test_a_log_spaced_clock_gets_a_log_axis_and_a_constant_no_offset"],
    ),
    "the overview says nothing where drift absorbs the fit": (
        "vojax/_plotting.py",
        [("    note = _absorbed_note(rows, tracker)", '    note = ""')],
        ["tests/test_figure_content.py::test_the_overview_counts_in_whole_records_and_says_when_drift_absorbs_the_fit"],
    ),
    "the overview's counts on fractional ticks": (
        "vojax/_plotting.py",
        [("        ax.yaxis.set_major_locator(MaxNLocator(integer=True))  # counts of records", "        pass")],
        ["tests/test_figure_content.py::test_the_overview_counts_in_whole_records_and_says_when_drift_absorbs_the_fit"],
    ),
    "the study's Fig. 4 clips the law's excursions": (
        "vojax/_plotting.py",
        [("        _robust_limits(ax, series, percentiles=(0, 100))", "        _robust_limits(ax, series)")],
        ["tests/test_figure_content.py::test_the_studys_figures_hide_no_data_and_clip_no_estimate"],
    ),
}
