"""Planted bugs of `mutation_check.py`: the tracker's fit (start, tuning, Kalman passes,
smoothing, runs in threads, the estimator, the two clocks); its long records and noise models
are in `mutations_tracker_noise.py`."""

# name: (file, [(old, new), ...], tests that should fail)
MUTATIONS = {
    "online tracker's y_pred taken after the update": (
        "vojax/_tracker/_filter.py",
        [("            if i == 0:\n                y_pred = h0", "            y_pred = h0")],
        ["tests/test_kalman.py::test_online_filter_against_a_textbook_iterated_ekf"],
    ),
    "online tracker relinearises from the iterate, not the prediction": (
        "vojax/_tracker/_filter.py",
        [("mean, cov, *_ = update(prior_mean, prior_cov, jac, z, r, mask_k)",
          "mean, cov, *_ = update(theta, prior_cov, jac, z, r, mask_k)")],
        ["tests/test_kalman.py::test_online_filter_against_a_textbook_iterated_ekf"],
    ),
    'RTS smoother gain transposed': (
        'vojax/_tracker/_kalman.py',
        [
            ('g = cholesky_solve(p_pred, p if not f_k else p * f_k[0][:, None]).T',
             'g = cholesky_solve(p_pred, p if not f_k else p * f_k[0][:, None])'),
        ],
        ["tests/test_kalman.py", "tests/test_tracker.py", "tests/test_first_pass.py",
         "tests/test_trade_off.py", "tests/test_runs.py"],
    ),
    "tracker's chain rule dα/dβ dropped": (
        "vojax/_tracker/_model.py",
        [("h_beta = jnp.sum(p * dphi, axis=-1) * dalpha", "h_beta = jnp.sum(p * dphi, axis=-1)")],
        ["tests/test_kalman.py", "tests/test_tracker.py", "tests/test_first_pass.py",
         "tests/test_trade_off.py", "tests/test_runs.py"],
    ),
    "tracker's order drift doubled": (
        "vojax/_tracker/_model.py",
        [("qo = jnp.exp(self.log_q_order) * frac", "qo = jnp.exp(self.log_q_order) * frac * 2")],
        ["tests/test_kalman.py", "tests/test_tracker.py", "tests/test_first_pass.py",
         "tests/test_trade_off.py", "tests/test_runs.py"],
    ),
    "the tracker forgets that the offset was given": (
        "vojax/_tracker/_estimator.py",
        [("(self.x0 is not None, Step.X0)", "(False, Step.X0)")],
        ["tests/test_steps.py::test_the_tracker_names_what_its_options_already_said"],
    ),
    "first pass forgets which run was best": (
        "vojax/_tracker/_smoother.py",
        [("            best, i_best, s_best = sm, b, s\n", "            best, s_best = sm, s\n")],
        ["tests/test_first_pass.py::test_first_pass_keeps_the_best_run_and_falls_back_on_the_full_budget",
         "tests/test_first_pass.py::test_a_batch_of_runs_keeps_the_best_by_evidence_and_by_objective"],
    ),
    'first pass never retried with the full budget': (
        'vojax/_tracker/_tuning.py',
        [
            ('    passes = [(noise, budget) for budget in budgets for noise in noises]',
             '    passes = [(noise, s.grid_max_iter) for noise in noises]'),
        ],
        ['tests/test_first_pass.py::test_first_pass_keeps_the_best_run_and_falls_back_on_the_full_budget',
         'tests/test_first_pass.py::test_tune_tries_each_noise_level_then_the_full_budget'],
    ),
    'the full budget tried at the first noise level only': (
        'vojax/_tracker/_tuning.py',
        [
            ('    passes = [(noise, budget) for budget in budgets for noise in noises]',
             '    passes = [*((noise, s.grid_max_iter) for noise in noises), (noises[0], s.max_iter)]'),
        ],
        ['tests/test_first_pass.py::test_tune_tries_each_noise_level_then_the_full_budget'],
    ),
    "golden section keeps the wrong side": (
        "vojax/_tracker/_start.py",
        [("        if fa < fb:\n            hi, b, fb = b, a, fa", "        if fa > fb:\n            hi, b, fb = b, a, fa")],
        ["tests/test_first_pass.py::test_constant_fit_finds_the_least_squares_order_of_a_dense_scan"],
    ),
    "first pass never tried at the constant fit's misfit": (
        'vojax/_tracker/_fit.py',
        [
            ('    if misfit >= s.misfit_ratio * noise0:\n',
             '    if False:\n'),
        ],
        ['tests/test_first_pass.py::test_output_smoother_than_the_model_converges_with_the_noise_it_leaves',
         'tests/test_first_pass.py::test_first_pass_noise_levels_follow_the_data_and_the_constant_fits_misfit'],
    ),
    "first pass noise taken from the constant fit's misfit always": (
        'vojax/_tracker/_fit.py',
        [
            ('    noises = (noise0,)\n',
             '    noises = (misfit,)\n'),
            ('        noises = (misfit, noise0) if noise_data < s.noise_min else (noise0, misfit)',
             '        noises = (misfit,)'),
        ],
        ['tests/test_first_pass.py::test_smoother_recovers_a_ramp_order_driven_by_the_myocardium_stretch'],
    ),
    "noise floor from the second differences alone": (
        'vojax/_tracker/_fit.py',
        [
            ('max(s.noise_floor * least, s.noise_min)',
             'max(s.noise_floor * noise_data, s.noise_min)'),
        ],
        ['tests/test_first_pass.py::test_noise_floor_is_the_noise_where_the_signal_curves_at_the_sampling_scale',
         'tests/test_first_pass.py::test_an_oscillation_sampled_coarsely_is_identified'],
    ),
    "threads run side by side while cold (the two clocks, a pass's shares)": (
        'vojax/_tracker/_threads.py',
        [('    if warm and side_by_side is not None:', '    if side_by_side is not None:')],
        ['tests/test_mappings.py::test_two_at_once_runs_the_second_beside_the_first_only_once_warm_and_where_allowed'],
    ),
    "the two clocks side by side whatever run_threads says": (
        'vojax/_tracker/_threads.py',
        [('    two = min(os.cpu_count() or 1, thread_limit(settings, schedule)) >= 2',
          '    two = (os.cpu_count() or 1) >= 2')],
        ['tests/test_mappings.py::test_two_at_once_runs_the_second_beside_the_first_only_once_warm_and_where_allowed'],
    ),
    "the two clocks' outputs swapped when side by side": (
        'vojax/_tracker/_threads.py',
        [('        return first(), later.result()', '        return later.result(), first()')],
        ['tests/test_clock.py::test_the_two_clocks_side_by_side_give_the_answer_of_one_after_the_other'],
    ),
    "a pass's threads run without the caller's scopes": (
        'vojax/_tracker/_threads.py',
        [('            return list(pool.map(lambda share: scoped(*share), shares))',
          '            return list(pool.map(lambda share: call(*share), shares))')],
        ['tests/test_mappings.py::test_identify_under_a_float64_scope_runs_its_threads_in_float64'],
    ),
    "a thread's float64 scope not carried over": (
        'vojax/_tracker/_threads.py',
        [('                scopes.enter_context(x64_scope(x64))', '                pass')],
        ['tests/test_mappings.py::test_a_thread_runs_under_the_callers_float64_and_device_scopes'],
    ),
    "tuning keeps a second climb of lower evidence": (
        'vojax/_tracker/_tuning.py',
        [('        if host_score(other[1]) > host_score(out[1]):', '        if True:')],
        ['tests/test_tuning_starts.py::test_tune_keeps_the_second_climb_where_its_evidence_is_higher'],
    ),
    "tuning climbs again with the parameters held": (
        'vojax/_tracker/_tuning.py',
        [('    if s.second_climb and not hold and j >= 0', '    if s.second_climb and j >= 0')],
        ['tests/test_tuning_starts.py::test_tune_keeps_the_second_climb_where_its_evidence_is_higher'],
    ),
    "tuning's second start at the first one's order drift": (
        'vojax/_tracker/_tuning.py',
        [('if r[0] != rows[i][0] and np.isfinite', 'if np.isfinite')],
        ['tests/test_tuning_starts.py::test_the_second_start_is_the_best_run_at_another_order_drift'],
    ),
    "no level profile about the held smoothing": (
        "vojax/_tracker/_fit.py",
        [("        explanations += level_profile(problem, *held, fit_noise, whiten, kind=\"held_level\")\n",
          "        pass\n")],
        ["tests/test_held_level.py::test_the_level_profile_runs_about_the_smoothing_with_the_parameters_constant"],
    ),
    "the level profile about the tuned smoothing where the held one answers": (
        "vojax/_tracker/_fit.py",
        [("level_profile(problem, *held, fit_noise, whiten, kind=\"held_level\")",
          "level_profile(problem, tuning, sm, fit_noise, whiten, kind=\"held_level\")")],
        ["tests/test_held_level.py::test_the_level_profile_runs_about_the_smoothing_with_the_parameters_constant"],
    ),
    "a climb collapsed whatever the parameters do": (
        'vojax/_tracker/_tuning.py',
        [('            and tuning.parameter_drift > s.held_ratio * s.constant_drift)', '            )')],
        ['tests/test_tuning_starts.py::test_a_climb_has_collapsed_only_with_the_order_at_its_floor_and_the_parameters_drifting'],
    ),
    "mixture weights ignore the evidence": (
        "vojax/_tracker/_smoother.py",
        [("    weights[kept] = np.exp(scores[kept] - top)", "    weights[kept] = 1.0")],
        ["tests/test_first_pass.py::test_mixture_of_modes_is_the_evidence_weighted_spread"],
    ),
    "mixture counts a mode found twice": (
        "vojax/_tracker/_smoother.py",
        [(") >= same\n", ") >= -1.0\n")],
        ["tests/test_first_pass.py::test_mixture_of_modes_is_the_evidence_weighted_spread"],
    ),
    "tracker's band without its alternatives": (
        'vojax/_tracker/_fit.py',
        [
            ('    if not tuning.tuned:\n        return np.asarray(sm.cov)[:, 0, 0], None, []',
             '    if True:\n        return np.asarray(sm.cov)[:, 0, 0], None, []'),
        ],
        ['tests/test_first_pass.py::test_band_covers_the_other_modes_in_proportion_to_their_evidence'],
    ),
    "Φ at a constant order takes the columns out of order": (
        "vojax/_tracker/_start.py",
        [("    padded[:, :m] = x\n", "    padded[:, :m] = x[:, ::-1]\n")],
        ["tests/test_runs.py::test_phi_of_each_column_equals_the_memory_run_on_all_columns"],
    ),
    "--noise beside --parameters constant let through": (
        "vojax/_tracker/_estimator.py",
        [("    if parameters == \"constant\":\n        raise ValueError(\n            \"`noise` sets",
          "    if False:\n        raise ValueError(\n            \"`noise` sets")],
        ["tests/test_noise_option.py::test_the_command_line_noise_is_in_the_files_unit"],
    ),
    "a noise intensity of 1e300 let through": (
        "vojax/_tracker/_estimator.py",
        [("check.positive(v, f\"noise[{k!r}]\", upper=NOISE_LIMIT)",
          "check.positive(v, f\"noise[{k!r}]\")")],
        ["tests/test_noise_option.py::test_an_intensity_whose_square_overflows_is_refused"],
    ),
    'trade interval not widening the band': (
        'vojax/_tracker/_fit.py',
        [
            ('    explanations = tuple(explanations + ([] if held is None else [held]) + traded)',
             '    explanations = tuple(explanations + ([] if held is None else [held]))'),
        ],
        ['tests/test_trade_off.py::test_parameters_constant_holds_their_drift_and_keeps_the_trade_out_of_its_band'],
    ),
    "parameters='constant' still lets them drift": (
        "vojax/_tracker/_fit.py",
        [('    hold = parameters == "constant"', "    hold = False")],
        ["tests/test_trade_off.py::test_parameters_constant_holds_their_drift_and_keeps_the_trade_out_of_its_band"],
    ),
    "the held scales profiled about a held band too wide to answer": (
        'vojax/_tracker/_fit.py',
        [
            ('        problem.span) <= s.identified_halfwidth', '        problem.span) <= np.inf'),
        ],
        ['tests/test_held_level.py'],
    ),
    "level profile never run (the constant setting's band as before it)": (
        'vojax/_tracker/_fit.py',
        [
            ('    if hold or tuning.parameter_drift <= s.held_ratio * s.constant_drift:\n        explanations += level_profile(',
             '    if False:\n        explanations += level_profile('),
        ],
        ['tests/test_calibration.py::test_constant_parameters_band_covers_the_level_another_scale_allows',
         'tests/test_trade_off.py::test_parameters_constant_holds_their_drift_and_keeps_the_trade_out_of_its_band'],
    ),
    "posterior cost ignores the mask (unfitted samples counted)": (
        "vojax/_tracker/_model.py",
        [("    data = jnp.sum(mask * residuals * residuals) / r",
          "    data = jnp.sum(residuals * residuals) / r")],
        ["tests/test_kalman.py::test_damped_step_minimises_the_linearised_posterior_it_predicts"],
    ),
    "a known offset's prior left wide": (
        'vojax/_tracker/_problem.py',
        [
            ('    offset = s.offset_pin if offset_known else s.prior_var',
             '    offset = s.prior_var'),
        ],
        ['tests/test_offset.py'],
    ),
    "a known offset not made the output's reference": (
        "vojax/_tracker/_fit.py",
        [("        scales = dataclasses.replace(scales, y_ref=float(x0))", "        pass")],
        ["tests/test_offset.py"],
    ),
    "a known offset's least squares keep their offset column": (
        "vojax/_tracker/_start.py",
        [("    if offset:\n        x = np.concatenate", "    if True:\n        x = np.concatenate")],
        ["tests/test_offset.py"],
    ),
    'a known offset reported as estimated': (
        'vojax/_tracker/_fit.py',
        [
            ('x0=to_device(scales.y_ref if known else',
             'x0=to_device(scales.y_ref + 0.0 if False else'),
        ],
        ['tests/test_offset.py'],
    ),
    "the parameters brought to the user's clock with the wrong sign of the order": (
        'vojax/_tracker/_fit.py',
        [
            ('    factor = np.exp(-log_ts * alpha)[:, None]',
             '    factor = np.exp(log_ts * alpha)[:, None]'),
        ],
        ['tests/test_verdict.py::test_the_order_does_not_depend_on_the_unit_of_time'],
    ),
    "the tracker's clock left in the user's unit": (
        'vojax/_tracker/_estimator.py',
        [
            ('        scale = self._time_scale(dt, t, length)',
             '        scale = 1.0'),
        ],
        ['tests/test_verdict.py::test_the_order_does_not_depend_on_the_unit_of_time'],
    ),
    'a drift bound of 0 not read as constant': (
        'vojax/_tracker/_estimator.py',
        [
            ('    return "constant" if bound == 0 else bound',
             '    return bound'),
        ],
        ['tests/test_verdict.py::test_a_drift_bound_admits_the_explanations_that_drift_no_more'],
    ),
    "the tracker takes a truthy number for smooth": (
        "vojax/_tracker/_estimator.py",
        [('        object.__setattr__(self, "smooth", check.flag(self.smooth, "smooth"))\n', "")],
        ["tests/test_validation.py::test_a_bad_argument_is_named_not_left_to_numpy"],
    ),
    "the threads split a pass's runs into equal shares (one idles behind the long runs)": (
        "vojax/_tracker/_threads.py",
        [("    size = 1 if workers > 1 and not batched else -(-count // workers)",
          "    size = -(-count // workers)")],
        ["tests/test_mappings.py::test_a_thread_that_is_done_takes_the_next_run"],
    ),
    "a drift bound excludes the data unit's account as a constant statement does": (
        "vojax/_tracker/_estimator.py",
        [('            stated = self.settings.drift_floor if self.parameters == "constant" else None',
          '            stated = {"free": None, "constant": self.settings.drift_floor}.get(\n'
          '                self.parameters, self.parameters)')],
        ["tests/test_clock.py::test_parameters_stated_constant_are_constant_on_the_spans_clock"],
    ),
    "the clocks' evidence excludes an account under a drift bound too": (
        "vojax/_tracker/_estimator.py",
        [("            evidence = np.inf if bounded else self.settings.clock_evidence",
          "            evidence = self.settings.clock_evidence")],
        ["tests/test_clock.py::test_the_data_exclude_the_data_units_account_where_an_oscillation_tells_them_apart"],
    ),
    "the tracker never hands the clocks' evidence threshold to the weighing": (
        "vojax/_tracker/_estimator.py",
        [("            evidence = np.inf if bounded else self.settings.clock_evidence",
          "            evidence = np.inf")],
        ["tests/test_clock.py::test_the_data_exclude_the_data_units_account_where_an_oscillation_tells_them_apart"],
    ),
    "the order a constant statement excluded is not reported": (
        "vojax/_tracker/_estimator.py",
        [("            clock_at = clock_order(fit, *other)", "            clock_at = float('nan')")],
        ["tests/test_clock.py::test_parameters_stated_constant_are_constant_on_the_spans_clock"],
    ),
    "the default fits only on the span's clock": (
        "vojax/_tracker/_estimator.py",
        [("        both = self.time_scale is None and second_clock(scale)",
          "        both = False")],
        ["tests/test_verdict.py::test_the_default_band_holds_an_order_whose_parameter_is_constant_in_another_unit"],
    ),
    "the tracker's diagnostics over the whole record, not the fit window": (
        "vojax/_tracker/_estimator.py",
        [("        cut = slice(first, span)", "        cut = slice(0, span)")],
        ["tests/test_tracker_window.py"],
    ),
    "the tracker's window ignored": (
        "vojax/_tracker/_estimator.py",
        [("            mask = _windowed(mask, window, dt, t, u2.shape)", "            pass")],
        ["tests/test_tracker_window.py"],
    ),
    "the tracker forgets the measured output": (
        "vojax/_tracker/_estimator.py",
        [("_fitted_range(mask, length), y=y,", "_fitted_range(mask, length),")],
        ["tests/test_figure_content.py::test_identification_plot_shows_data_fit_residuals_and_the_verdict"],
    ),
    "the second clock's quick look runs the memory over every sample": (
        "vojax/_tracker/_blocks.py",
        [("    if not weigh:\n        return _at_samples(", "    if False:\n        return _at_samples(")],
        ["tests/test_blocks.py::test_the_second_clocks_quick_look_runs_no_memory_over_every_sample"],
    ),
    "a blocked fit's output from the quick look's order": (
        "vojax/_tracker/_blocks.py",
        [("    full = _at_samples(res, at_samples, alpha, p_user,",
          "    alpha = alpha + 0.01\n    full = _at_samples(res, at_samples, alpha, p_user,")],
        ["tests/test_blocks.py::test_the_second_clocks_quick_look_runs_no_memory_over_every_sample"],
    ),
    "long blocks refitted whatever the reason they were refused for": (
        "vojax/_tracker/_estimator.py",
        [("        if first is None or (refine and Reason.CORRELATED in first[2].reasons):",
          "        if first is None or refine:")],
        ["tests/test_blocks.py::test_long_blocks_whose_prediction_errors_correlate_are_fitted_again_on_shorter_ones"],
    ),
    "blocks of any length refitted where the prediction errors correlate": (
        "vojax/_tracker/_estimator.py",
        [("        refine = size >= s.block_refine_from and finer < size",
          "        refine = finer < size")],
        ["tests/test_blocks.py::test_long_blocks_whose_prediction_errors_correlate_are_fitted_again_on_shorter_ones"],
    ),
    "the block means' padding fitted as data": (
        "vojax/_tracker/_blocks.py",
        [("np.concatenate([mask, np.zeros(extra, mask.dtype)])",
          "np.concatenate([mask, np.ones(extra, mask.dtype)])")],
        ["tests/test_blocks.py::test_block_means_padded_to_a_bucket_by_hand",
         "tests/test_blocks.py::test_block_counts_in_one_bucket_share_the_program_and_the_padding_changes_nothing"],
    ),
    "block means padded to no bucket": (
        "vojax/_tracker/_blocks.py",
        [("pad_points(t_b, u_b, y_b, mask_b, bucket_points(points))",
          "pad_points(t_b, u_b, y_b, mask_b, points)")],
        ["tests/test_blocks.py::test_block_counts_in_one_bucket_share_the_program_and_the_padding_changes_nothing"],
    ),
    "the refit's answer is the coarse fit's": (
        "vojax/_tracker/_estimator.py",
        [("            size = finer\n            first = self._fit_sized(",
          "            first = self._fit_sized(")],
        ["tests/test_blocks.py::test_long_blocks_whose_prediction_errors_correlate_are_fitted_again_on_shorter_ones"],
    ),
    "the first fit given up whatever its prediction errors": (
        "vojax/_tracker/_blocks.py",
        [("give_up=(lambda y_pred: errors_correlate(", "give_up=(lambda y_pred: True or errors_correlate(")],
        ["tests/test_blocks.py::test_the_first_fit_stops_once_its_prediction_errors_correlate_and_the_answer_is_the_same"],
    ),
    "the first fit never stopped early": (
        "vojax/_tracker/_estimator.py",
        [("first = self._fit_sized(u2, y, dt, t, mask, length, size, bounds, refine)",
          "first = self._fit_sized(u2, y, dt, t, mask, length, size, bounds, False)")],
        ["tests/test_blocks.py::test_the_first_fit_stops_once_its_prediction_errors_correlate_and_the_answer_is_the_same"],
    ),
    "the second clock fitted after a first fit given up": (
        "vojax/_tracker/_threads.py",
        [("return out, None if out is None else second()", "return out, second()")],
        ["tests/test_mappings.py::test_two_at_once_runs_the_second_beside_the_first_only_once_warm_and_where_allowed"],
    ),
    "the early stop reads the normalised predictions": (
        "vojax/_tracker/_fit.py",
        [("give_up(st.scales.output(sm.y_pred))", "give_up(np.asarray(sm.y_pred))")],
        ["tests/test_blocks.py::test_the_first_fit_stops_once_its_prediction_errors_correlate_and_the_answer_is_the_same"],
    ),
}
