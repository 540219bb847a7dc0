"""Planted bugs of `mutation_check.py`: recorded datasets, the command line, the batch and its
outputs (its figures: `mutations_figures.py`)."""

# name: (file, [(old, new), ...], tests that should fail)
MUTATIONS = {
    "batch writes the first record's law output for every record": (
        "vojax/_data/_law_batch.py",
        [("jax.tree_util.tree_map(lambda a: a[i][:num], batch)",
          "jax.tree_util.tree_map(lambda a: a[0][:num], batch)")],
        ["tests/test_batch.py", "tests/test_batch_dask.py"],
    ),
    '--area and --length swapped': (
        'vojax/_data/_regressors.py',
        [
            ('stress = record.inputs[:, 0] / (area or 1.0)',
             'stress = record.inputs[:, 0] / (length or 1.0)'),
            ('strain = record.output / output_scale(model, length)',
             'strain = record.output / (area or 1.0)'),
        ],
        ['tests/test_data_cli.py', 'tests/test_cli_identify.py'],
    ),
    "the command prints the next steps in Python's words": (
        "vojax/_cli/_commands.py",
        [('block = say_block(answer, a["finding"], a["next_steps"], "cli")',
          'block = [answer, a["message"]]')],
        ["tests/test_cli_identify.py::test_cli_identify_end_to_end"],
    ),
    "the command says a settling test settles whatever the tracker is expected to give": (
        "vojax/_cli/_commands.py",
        [("    if expected is None or expected <= limit:", "    if True:")],
        ["tests/test_batch_settling.py"],
    ),
    "resampling smooths away a fast phase": (
        "vojax/_data/_record.py",
        [("if step > RESAMPLE_MAX_RATIO * steps[shortest]:", "if step > 1e9 * steps[shortest]:")],
        ["tests/test_data_cli.py"],
    ),
    "the CLI's fit window ignores the file's time offset": (
        "vojax/_data/_regressors.py",
        [("    shift = record.time_offset", "    shift = 0.0")],
        ["tests/test_cli_recordings.py"],
    ),
    "bucket plan pads to the first length of a run, not the last": (
        "vojax/_data/_buckets.py",
        [("            padded[s] = sizes[j - 1]", "            padded[s] = sizes[i]")],
        ["tests/test_batch.py::test_plan_buckets_is_the_cheapest_cut_of_the_sorted_lengths"],
    ),
    "bucket plan forgets the compile cost of a run": (
        "vojax/_data/_buckets.py",
        [("(best[i] + compile_cost + sizes[j - 1] * sum(counts[i:j]), i)",
          "(best[i] + sizes[j - 1] * sum(counts[i:j]), i)")],
        ["tests/test_batch.py::test_plan_buckets_is_the_cheapest_cut_of_the_sorted_lengths"],
    ),
    "identification.csv loses the NaN blanks": (
        "vojax/_data/_outputs.py",
        [("[repr(v) if ok else \"\" for v, ok in zip(row, oks)]", "[repr(v) for v in row]")],
        ["tests/test_tables.py::test_identification_table_round_trips_floats_and_leaves_non_finite_blank"],
    ),
    "--out may hold the input": (
        "vojax/_data/_paths.py",
        [("        if path == root or root in path.parents:", "        if False:")],
        ["tests/test_outputs.py::test_out_never_holds_the_inputs_and_follows_no_link"],
    ),
    "the batch's lock follows a link": (
        "vojax/_data/_lock.py",
        [('os.O_APPEND | getattr(os, "O_NOFOLLOW", 0)', "os.O_APPEND")],
        ["tests/test_outputs.py::test_out_never_holds_the_inputs_and_follows_no_link"],
    ),
    "NPZ of complex numbers read as their real part": (
        "vojax/_data/_read.py",
        [('    if dtype.kind not in "biuf":', '    if dtype.kind not in "biufcMmUSOV":')],
        ["tests/test_data_cli.py::test_hostile_npz_files_fail_alone_with_one_sentence"],
    ),
    "NPZ of many dimensions flattened": (
        "vojax/_data/_read.py",
        [("    if sum(1 for n in shape if n != 1) > 1:", "    if False:")],
        ["tests/test_data_cli.py::test_hostile_npz_files_fail_alone_with_one_sentence"],
    ),
    "NPZ header's sample count trusted": (
        "vojax/_data/_read.py",
        [("    if size > MAX_SAMPLES:", "    if False:")],
        ["tests/test_data_cli.py::test_hostile_npz_files_fail_alone_with_one_sentence"],
    ),
    "a non-finite --area accepted": (
        "vojax/_cli/_types.py",
        [("    if not (1.0 / BIG <= value <= BIG):", "    if not value > 0:")],
        ["tests/test_notebooks_cli.py::test_cli_errors_are_one_sentence"],
    ),
    "a summary.json holding NaN taken as current": (
        "vojax/_data/_batch.py",
        [("        old = strict_json(summary.read_text())", "        old = json.loads(summary.read_text())")],
        ["tests/test_outputs.py::test_reruns_redo_what_changed_and_only_that"],
    ),
    "--no-overwrite drops the rows it did not redo": (
        "vojax/_data/_tables.py",
        [("    if not overwrite:  # a row of the table", "    if False:  # a row of the table")],
        ["tests/test_outputs.py::test_reruns_redo_what_changed_and_only_that"],
    ),
    "a new table left under the old summary": (
        "vojax/_data/_outputs.py",
        [("    if summary.is_file() or summary.is_symlink():\n        summary.unlink()", "    pass")],
        ["tests/test_batch_folders.py::test_a_folder_is_current_only_with_the_summary_of_its_own_run"],
    ),
    "a decimal comma read as a separator of thousands": (
        "vojax/_data/_read.py",
        [('values.append(float(text.replace(",", ".") if decimal == "," else text))',
          'values.append(float(text.replace(",", "") if decimal == "," else text))')],
        ["tests/test_data_cli.py::test_semicolons_decimal_commas_and_a_hint_for_them"],
    ),
    "an undetermined physical parameter fails the record": (
        "vojax/_data/_outputs.py",
        [("    if \"refit\" in parts:\n", "    if False:\n")],
        ["tests/test_cli_recordings.py::test_an_undetermined_parameter_is_written_not_failed"],
    ),
    "disagreement reported for overlapping bands": (
        "vojax/_data/_parts.py",
        [("    if not (hi_a < lo_r or hi_r < lo_a):", "    if False:")],
        ["tests/test_tables.py::test_disjoint_bands_of_two_estimators_are_reported_with_what_the_data_support"],
    ),
    "disagreement credits the tracker without correlated refit residuals": (
        "vojax/_data/_parts.py",
        [('    if verdict == "identified" and correlated:', '    if verdict == "identified":')],
        ["tests/test_tables.py::test_disjoint_bands_of_two_estimators_are_reported_with_what_the_data_support"],
    ),
    "tables keep spreadsheet formulas": (
        "vojax/_data/_tables.py",
        [("    if isinstance(value, str) and value.startswith(GUARDED):",
          "    if False:")],
        ["tests/test_tables.py::test_tables_do_not_carry_spreadsheet_formulas"],
    ),
    "a per-record length multiplies the displacement": (
        "vojax/_data/_scales.py",
        [("output = output / _initial(record, self.length, extra[self.length])",
          "output = output * _initial(record, self.length, extra[self.length])")],
        ["tests/test_scales.py::test_a_length_and_an_area_per_record_from_columns"],
    ),
    "a per-record length taken at the last sample, not the first": (
        "vojax/_data/_scales.py",
        [("    value = float(values[0])", "    value = float(values[-1])")],
        ["tests/test_scales.py::test_a_length_and_an_area_per_record_from_columns"],
    ),
    "the length and the area columns read in each other's place": (
        "vojax/_data/_scales.py",
        [("extra = dict(zip(self.columns, inputs[:, count:].T))",
          "extra = dict(zip(self.columns[::-1], inputs[:, count:].T))")],
        ["tests/test_scales.py::test_the_batch_takes_each_specimens_gap_and_area_from_its_columns"],
    ),
    "a strain from a length divided by the length, not the rest length": (
        "vojax/_data/_scales.py",
        [("    return (length - rest) / rest", "    return (length - rest) / length")],
        ["tests/test_scales.py::test_the_output_is_the_strain_of_the_length_over_its_rest_length"],
    ),
    "--strain-from-length beside --length let through": (
        "vojax/_cli/_args.py",
        [("        if args.length is not None or length_column is not None:",
          "        if length_column is not None:")],
        ["tests/test_scales.py::test_the_command_identifies_the_strain_of_a_length_column"],
    ),
    "a length column reaching 0 let through": (
        "vojax/_data/_scales.py",
        [("    if not length[low] > 0.0:", "    if False:")],
        ["tests/test_scales.py::test_a_record_that_is_not_a_length_is_refused_not_divided_by_zero"],
    ),
    "the command's noise level not divided by --length": (
        "vojax/_data/_pipeline.py",
        [("settings[\"noise\"][\"noise_std\"]) / abs(output_scale(model, length))",
          "settings[\"noise\"][\"noise_std\"])")],
        ["tests/test_noise_option.py::test_the_command_line_noise_is_in_the_files_unit"],
    ),
    "--noise with a key missing let through": (
        "vojax/_cli/_types.py",
        [("    if sorted(keys) != sorted(NOISE_KEYS) or", "    if")],
        ["tests/test_noise_option.py::test_the_command_line_noise_is_in_the_files_unit"],
    ),
    "the batch compares over the whole record, not the refit's window": (
        "vojax/_data/_compute.py",
        [("r, area, length, **{k: fit[k] for k in FIT_OPTIONS if k in fit})",
          "r, area, length)")],
        ["tests/test_compare_window.py::test_the_batch_compares_over_the_refits_window_in_the_files_time"],
    ),
    "a file vojax did not write is overwritten": (
        "vojax/_data/_paths.py",
        [("        if name not in known and (target.exists() or target.is_symlink()):",
          "        if False:")],
        ["tests/test_outputs.py::test_vojax_overwrites_only_what_it_wrote"],
    ),
    "the command line's offset not in the model's output unit": (
        "vojax/_data/_pipeline.py",
        [('extra["x0"] = float(settings["x0"]) / output_scale(model, length)',
          'extra["x0"] = float(settings["x0"])')],
        ["tests/test_offset.py::test_the_command_line_offset_is_in_the_files_unit"],
    ),
    # --- the newer surface (issue: tests that fail when it is wrong) ---
    "a record named with a leading quote gains a row at each re-run": (
        "vojax/_data/_tables.py",
        [('GUARDED = FORMULA_START + ("\'",)', "GUARDED = FORMULA_START")],
        ["tests/test_properties.py::test_tables_read_back_exactly_what_was_written"],
    ),
    "write_results writes before it checks (a bad summary loses the old one)": (
        "vojax/io.py",
        [("    _check_results(folder, columns, summary, record)\n", "")],
        ["tests/test_checks_io.py::test_bad_results_are_refused_before_anything_is_written"],
    ),
    "the study's signals take a step of 0": (
        "vojax/_study.py",
        [("    if not (0 < dt < math.inf and 0 < duration < math.inf):", "    if False:")],
        ["tests/test_validation.py::test_the_studys_signals_refuse_a_grid_they_cannot_draw"],
    ),
    "AFM contact one sample late (fit)": (
        "vojax/_data/_contact.py",
        [("        c = int(part[inside[0]])", "        c = int(part[inside[0]]) + 1")],
        ["tests/test_afm_contact.py::test_the_hertz_fit_recovers_the_modulus_the_contact_and_the_strain",
         "tests/test_afm.py::test_contact_indentation_and_hertz_strain"],
    ),
    "AFM estimator's contact not offset to the loading": (
        "vojax/_data/_contact.py",
        [("        c = int(part[_poc(nanite, force[part], contact, label)])",
          "        c = int(_poc(nanite, force[part], contact, label))")],
        ["tests/test_afm_contact.py::test_a_named_estimator_is_nanites_on_the_loading"],
    ),
    "AFM estimator run on the whole curve, not the loading": (
        "vojax/_data/_contact.py",
        [("        c = int(part[_poc(nanite, force[part], contact, label)])",
          "        c = int(_poc(nanite, force, contact, label))")],
        ["tests/test_afm_contact.py::test_a_named_estimator_is_nanites_on_the_loading"],
    ),
    "AFM loading taken as the first segment": (
        "vojax/_data/_contact.py",
        [("    return segment[first]", "    return segment[0]")],
        ["tests/test_afm_contact.py::test_the_hertz_fit_recovers_the_modulus_the_contact_and_the_strain"],
    ),
    "AFM Poisson ratio not given to the fit": (
        "vojax/_data/_contact.py",
        [('    params["nu"].set(value=poisson, min=-1.0)', '    params["nu"].set(min=-1.0)')],
        ["tests/test_afm_contact.py::test_the_hertz_fit_recovers_the_modulus_the_contact_and_the_strain"],
    ),
    "AFM force rise from the fit's baseline left out": (
        "vojax/_data/_contact.py",
        [("    return force - f0, z_c - z, c, block", "    return force, z_c - z, c, block")],
        ["tests/test_afm_contact.py::test_the_hertz_fit_recovers_the_modulus_the_contact_and_the_strain",
         "tests/test_afm_contact.py::test_a_named_estimator_is_nanites_on_the_loading"],
    ),
    "AFM pyramid strain with the cone's factor": (
        "vojax/_data/_afm.py",
        [("    return 2.0 * PYRAMID_FACTOR * math.tan", "    return 4.0 / math.pi * math.tan")],
        ["tests/test_afm_contact.py::test_contact_strain_times_g_is_nanites_model_force"],
    ),
    "AFM pyramid's face angle capped at nanite's 30°": (
        "vojax/_data/_contact.py",
        [("    params[key].set(value=size, min=0.0, max=math.inf)", "    params[key].set(value=size)")],
        ["tests/test_afm_contact.py::test_the_hertz_fit_recovers_the_modulus_the_contact_and_the_strain"],
    ),
    "AFM export's height: the piezo's before the measured": (
        "vojax/_data/_afm_records.py",
        [('EXPORT_HEIGHTS = ("height_measured_m", "height_piezo_m")',
          'EXPORT_HEIGHTS = ("height_piezo_m", "height_measured_m")'),
         ("    present = [h for h in EXPORT_HEIGHTS if h in header]",
          "    present = [h for h in EXPORT_HEIGHTS if h in header][:1]")],
        ["tests/test_afm_contact.py::test_a_csv_export_is_read_as_its_raw_file"],
    ),
    "AFM export's groups all one curve": (
        "vojax/_data/_afm_records.py",
        [("        curve = _ExportCurve({names[c]: v[idx] for c, v in raw.items()},",
          "        curve = _ExportCurve({names[c]: v for c, v in raw.items()},")],
        ["tests/test_afm_contact.py::test_a_csv_export_is_read_as_its_raw_file"],
    ),
    "AFM record kept after the tip leaves the sample": (
        "vojax/_data/_afm_records.py",
        [('        keep[released(cols["indentation_m"], keep):] = False\n', "")],
        ["tests/test_afm.py::test_a_record_ends_where_the_tip_leaves_the_sample"],
    ),
    "AFM record ends at the first sample out of contact, before the deepest indentation": (
        "vojax/_data/_afm_records.py",
        [("    after = np.flatnonzero(depth[deepest:] <= 0)",
          "    after = np.flatnonzero(depth <= 0)")],
        ["tests/test_afm.py::test_a_record_ends_where_the_tip_leaves_the_sample"],
    ),
    "AFM channels of different lengths taken": (
        "vojax/_data/_afm.py",
        [("    if len(set(sizes.values())) > 1:", "    if False:")],
        ["tests/test_afm.py::test_a_damaged_jpk_channel_is_a_data_error_naming_file_and_curve"],
    ),
    "AFM damaged channel raises afmformats' or NumPy's error": (
        "vojax/_data/_afm.py",
        [("            except fatal as e:  # noqa: BLE001 - a damaged channel: this curve's error",
          "            except KeyboardInterrupt as e:  # a damaged channel")],
        ["tests/test_afm.py::test_a_damaged_jpk_channel_is_a_data_error_naming_file_and_curve"],
    ),
    "AFM sphere radius of any size": (
        "vojax/_data/_afm.py",
        [("        if not lo <= size <= hi:", "        if not 0 < size < math.inf:")],
        ["tests/test_afm.py::test_records_from_contact_by_segment"],
    ),
    "reserved device names with an extension not hashed": (
        "vojax/_data/_paths.py",
        [("        or stem in RESERVED\n", "")],
        ["tests/test_properties.py::test_record_folders_are_distinct_safe_names"],
    ),
    "manifest rewritten with this run's names only": (
        "vojax/_data/_paths.py",
        [("    new = known | set(names)", "    new = set(names)")],
        ["tests/test_batch_folders.py::test_the_manifest_keeps_what_every_run_wrote"],
    ),
    "the output taken as its own input": (
        "vojax/_data/_records.py",
        [("        if name in inputs:", "        if False:")],
        ["tests/test_data_cli.py::test_each_column_has_one_role_and_a_lone_input_may_be_a_string"],
    ),
    "a lone input name read as its letters": (
        "vojax/_data/_records.py",
        [("    if isinstance(inputs, str):\n        inputs = [inputs]\n", "")],
        ["tests/test_data_cli.py::test_each_column_has_one_role_and_a_lone_input_may_be_a_string"],
    ),
    "CSV lines split at U+2028 and form feeds": (
        "vojax/_data/_read.py",
        [('enumerate(io.StringIO(text, newline=""))', "enumerate(text.splitlines(keepends=True))")],
        ["tests/test_data_cli.py::test_hostile_cells_clocks_and_silent_inputs_get_one_sentence"],
    ),
    "a record's silent input column not named": (
        "vojax/_data/_pipeline.py",
        [("    if silent:\n", "    if False:\n")],
        ["tests/test_data_cli.py::test_hostile_cells_clocks_and_silent_inputs_get_one_sentence"],
    ),
    "a clock reaching 1e308 taken": (
        "vojax/_data/_record.py",
        [("    far = np.abs(t) > TIME_LIMIT", "    far = np.abs(t) > np.inf")],
        ["tests/test_data_cli.py::test_hostile_cells_clocks_and_silent_inputs_get_one_sentence"],
    ),
    "command-line options abbreviated": (
        "vojax/_cli/_types.py",
        [('kwargs.setdefault("allow_abbrev", False)', 'kwargs.setdefault("allow_abbrev", True)')],
        ["tests/test_afm.py::test_a_damaged_file_in_a_batch_fails_only_its_own_record"],
    ),
    "--out as the input folder called a folder without files": (
        "vojax/_cli/_commands.py",
        [("            if found and inside_out(folder):", "            if False:")],
        ["tests/test_batch_folders.py::test_a_batch_whose_out_is_its_input_folder_says_so"],
    ),
    "more local workers than cores": (
        "vojax/_cli/_commands.py",
        [("    if args.workers is not None and args.workers > (os.cpu_count() or 1):",
          "    if False:")],
        ["tests/test_batch_dask.py::test_workers_and_clients_that_cannot_work_are_refused"],
    ),
    "a client that is not a Dask client taken": (
        "vojax/_data/_batch.py",
        [('    if client is not None and not all(hasattr(client, a) for a in ("submit", "nthreads")):',
          "    if False:")],
        ["tests/test_batch_dask.py::test_workers_and_clients_that_cannot_work_are_refused"],
    ),
    "a scheduler's loss fails every record instead of stopping the run": (
        "vojax/_data/_dask.py",
        [("                if _scheduler_lost(client, text):", "                if False:")],
        ["tests/test_batch_dask.py::test_a_scheduler_that_dies_mid_run_leaves_a_folder_that_resumes"],
    ),
    "the command's window not shifted to the record's clock": (
        "vojax/_data/_pipeline.py",
        [("    shift = record.time_offset\n    window = (None", "    shift = 0.0\n    window = (None")],
        ["tests/test_tracker_window.py::test_command_line_window_is_the_python_window"],
    ),
    "the command's summary over the whole record with a window": (
        "vojax/_data/_parts.py",
        [("    cut = slice(None) if fitted is None else slice(*fitted)", "    cut = slice(None)")],
        ["tests/test_tracker_window.py::test_command_line_window_is_the_python_window"],
    ),
    "the decimal-comma hint on any cell that is not a number": (
        "vojax/_data/_read.py",
        [('            if decimal != "," and _is_number(text.replace(",", ".")):',
          '            if decimal != ",":')],
        ["tests/test_data_cli.py::test_a_decimal_comma_is_named_where_it_would_read"],
    ),
    "the tilt of an AFM baseline not removed": (
        "vojax/_data/_contact.py",
        [('        PREPROCESSING + ([] if slope is None else ["correct_force_slope"]),',
          '        PREPROCESSING,')],
        ["tests/test_afm_contact.py::test_a_tilted_baseline_is_corrected_with_baseline_tilt"],
    ),
    "--baseline not passed to the loader": (
        "vojax/_cli/_args.py",
        [('    if args.baseline is not None:\n        out["baseline"] = args.baseline\n', '')],
        ["tests/test_afm_contact.py::test_the_baseline_option_from_python_and_the_command_line"],
    ),
    "the command forgets to quiet XLA's log lines": (
        "vojax/_cli/_main.py",
        [("    quiet_xla_logs()\n", "")],
        ["tests/test_quiet_logs.py"],
    ),
    "record summary reports the regression's residual as the solved law's": (
        "vojax/_data/_pipeline.py",
        [("nrmse=nrmse(y, solved)", "nrmse=regression")],
        ["tests/test_fitted_strain.py"],
    ),
}
