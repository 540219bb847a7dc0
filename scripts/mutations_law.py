"""Planted bugs of `mutation_check.py`: the paper's law and its kernels, the estimators' front end (validation, settings,
diagnostics, results); the test design's are in `mutations_design.py`."""

LAW = "tests/test_law_transcription.py"

# name: (file, [(old, new), ...], tests that should fail)
MUTATIONS = {
    "order law uses the a-priori error": (
        "vojax/_adaptive/_law.py",
        [("self.order.step(alpha, lam_k, y_k - y_hat, h)",
          "self.order.step(alpha, lam_k, y_k - jnp.dot(state.p, phi), h)")],
        [LAW],
    ),
    "y_pred returns the a-posteriori output": (
        "vojax/_adaptive/_law.py",
        [("LawOutput(alpha, p, dp, y_hat, jnp.dot(state.p, phi), lam_k, phi)",
          "LawOutput(alpha, p, dp, y_hat, y_hat, lam_k, phi)")],
        [LAW],
    ),
    "R0 forgotten (always I)": (
        "vojax/_adaptive/_lsff.py",
        [("r0 = jnp.eye(num_inputs, dtype=dtype) if self.r0 is None else self.r0",
          "r0 = jnp.eye(num_inputs, dtype=dtype)")],
        [LAW],
    ),
    "identify(r0=...) ignored": (
        "vojax/_adaptive/_build.py",
        [("LSFF(jnp.asarray(lam, dt_arr.dtype), dt_arr, r0)",
          "LSFF(jnp.asarray(lam, dt_arr.dtype), dt_arr, None)")],
        [LAW],
    ),
    "sign of the order law flipped": (
        "vojax/_adaptive/_order.py",
        [("alpha + h * self.gamma", "alpha - h * self.gamma")],
        [LAW],
    ),
    "h dropped from the order law": (
        "vojax/_adaptive/_order.py",
        [("alpha + h * self.gamma * sensitivity", "alpha + self.gamma * sensitivity")],
        [LAW],
    ),
    "tuner's lag dropped": (
        "vojax/_tune.py",
        [("pred = jnp.sum(jnp.roll(p, data.lag, axis=0) * phi, axis=1)",
          "pred = jnp.sum(p * phi, axis=1)"),
         ("back = k - data.lag  # the sample", "back = k  # the sample")],
        ["tests/test_tune.py"],
    ),
    "tuner's refinement discarded (grid point kept, reported as refined)": (
        "vojax/_tune.py",
        [("best, best_loss, done = (float(z[0]), float(z[1])), value, True",
          "done = True")],
        ["tests/test_tune.py"],
    ),
    "psi dropped from the closed form (14)": (
        "vojax/reference.py",
        [("dphi[k] = -digamma(b) * phi[k] + inv_gamma * (lw @ u2[k::-1])",
          "dphi[k] = inv_gamma * (lw @ u2[k::-1])")],
        ["tests/test_kernels.py"],
    ),
    "history weight off by one lag": (
        "vojax/_kernels/_weights.py",
        [("lags = jnp.arange(1, num + 1, dtype=b.dtype)", "lags = jnp.arange(2, num + 2, dtype=b.dtype)")],
        ["tests/test_kernels.py"],
    ),
    'diagnostics trust an unconverged estimate': (
        'vojax/_diagnostics.py',
        [
            ('at_bound < s.bound_fraction and bool(converged) and not noise_edge',
             'at_bound < s.bound_fraction and not noise_edge'),
        ],
        ["tests/test_kalman.py", "tests/test_tracker.py", "tests/test_first_pass.py",
         "tests/test_trade_off.py", "tests/test_runs.py"],
    ),
    "a step the call already took suggested again": (
        "vojax/_diagnostics.py",
        [("for step in r.steps(**context) if step not in taken",
          "for step in r.steps(**context) if True")],
        ["tests/test_steps.py::test_steps_the_call_already_took_are_not_suggested_again"],
    ),
    "the same step said once per reason": (
        "vojax/_diagnostics.py",
        [("steps = tuple(dict.fromkeys(", "steps = tuple(list(")],
        ["tests/test_steps.py::test_steps_of_several_reasons_are_said_once_each"],
    ),
    "a command-line step names an option the command does not have": (
        "vojax/_steps.py",
        [('"widen the order\'s range: --alpha-bounds LO,HI"', '"widen the order\'s range: --alpha-range LO,HI"')],
        ["tests/test_steps.py"],
    ),
    "order-free history read one sample late": (
        "vojax/_kernels/_exponential.py",
        [("return jnp.concatenate([jnp.zeros_like(after[:1]), after[:-1]]), previous",
          "return jnp.concatenate([jnp.zeros_like(after[:2]), after[:-2]]), previous")],
        ["tests/test_kernels.py::test_order_free_history_equals_the_scan"],
    ),
    "tuner's streamed grid loss reads p̂ one sample late": (
        "vojax/_tune.py",
        [("back = k - data.lag  # the sample", "back = k - data.lag - 1  # the sample")],
        ["tests/test_tune.py"],
    ),

    "grid weights of u_i and u_{i+1} swapped": (
        "vojax/_kernels/_weights.py",
        [("        return scale * w_this, scale * w_next", "        return scale * w_next, scale * w_this")],
        ["tests/test_grid.py"],
    ),
    "grid weights' long-lag series with a wrong coefficient": (
        "vojax/_kernels/_weights.py",
        [("s_this = _poly([c / ((j + 1) * (j + 2))", "s_this = _poly([c / ((j + 1) * (j + 3))")],
        ["tests/test_grid.py::test_interval_weights_against_50_digit_closed_forms"],
    ),
    "exponential memory on a grid decays by the smallest step": (
        "vojax/_kernels/_exponential.py",
        [("return h, self.log_q - s * h, jnp.exp(-s * h), w_prev, w_cur",
          "return h, self.log_q - s * h, jnp.exp(-s * self.dt), w_prev, w_cur")],
        ["tests/test_grid.py"],
    ),
    "the law's LSFF ignores the local step": (
        "vojax/_adaptive/_law.py",
        [("lambda s, ph: self.lsff.step(s, ph, y_k, h)", "lambda s, ph: self.lsff.step(s, ph, y_k)")],
        ["tests/test_grid_identify.py"],
    ),
    "small SPD solve divides by the wrong pivot": (
        "vojax/_linalg.py",
        [("            low[i][j] = (a[i, j] - sum(low[i][k] * low[j][k] for k in range(j))) / low[j][j]",
          "            low[i][j] = (a[i, j] - sum(low[i][k] * low[j][k] for k in range(j))) / low[i][i]")],
        ["tests/test_linalg.py::test_small_spd_solve_equals_lapack"],
    ),
    "diagnostics ignore the order's trade-off with the parameters' drift": (
        "vojax/_diagnostics.py",
        [("    traded = held_shift is not None and held_shift > width\n", "    traded = False\n")],
        ["tests/test_tracker.py::test_diagnostics_refuse_unconverged_or_noise_at_its_floor"],
    ),
    "parameter check compares the recursion with itself": (
        "vojax/testing.py",
        [('_compare("p", "recursion vs batch sums (23)", p, p_batch, rtol)',
          '_compare("p", "recursion vs batch sums (23)", p, p, rtol)')],
        ["tests/test_checks_io.py::test_check_parameter_sensitivity_fails_on_a_recursion_that_is_not_23"],
    ),
    "law's band covariance never renormalised": (
        "vojax/_adaptive/_bands.py",
        [("renorm = jnp.isfinite(big) & (big > rescale)", "renorm = big < 0.0")],
        ["tests/test_tracker.py::test_an_unstable_law_reports_an_infinite_band_with_its_reason"],
    ),
    "law's band rescaled with the wrong sign": (
        "vojax/_adaptive/_bands.py",
        [("jnp.log(jnp.where(v > 0, v, 1.0)) + log_scale", "jnp.log(jnp.where(v > 0, v, 1.0)) - log_scale")],
        ["tests/test_tracker.py::test_an_unstable_law_reports_an_infinite_band_with_its_reason"],
    ),
    "an unstable law not named in the diagnostics": (
        "vojax/_adaptive/_build.py",
        [("unstable_from=int(wild[0]) if wild.size else None,", "unstable_from=None,")],
        ["tests/test_tracker.py::test_an_unstable_law_reports_an_infinite_band_with_its_reason"],
    ),
    "gain box per second": (
        "vojax/_tune.py",
        [("gammas = scale / horizon * np.logspace", "gammas = scale * np.logspace")],
        ["tests/test_tune.py::test_the_gain_search_box_does_not_depend_on_the_units"],
    ),
    "identify defaults to the law": (
        "vojax/_identify.py",
        [('    method: str = "kalman",\n    smooth: bool = True,', '    method: str = "gradient",\n    smooth: bool = True,')],
        ["tests/test_cli_identify.py::test_one_default_and_one_name_per_estimator"],
    ),
    "the law's settings silently ignored by the tracker": (
        "vojax/_identify.py",
        [("        if given:\n            raise ValueError(\n                f\"{', '.join(given)} set the paper's law",
          "        if False:\n            raise ValueError(\n                f\"{', '.join(given)} set the paper's law")],
        ["tests/test_tracker.py::test_identify_kalman_validation"],
    ),
    'correlated prediction errors not refused': (
        'vojax/_diagnostics.py',
        [
            ('        and calibrated and not coloured and unstable_from is None and not coarse',
             '        and calibrated and unstable_from is None and not coarse'),
        ],
        ['tests/test_first_pass.py::test_correlated_prediction_errors_are_refused_and_coloured_noise_is_modelled'],
    ),
    'the law claims identified': (
        'vojax/_diagnostics.py',
        [
            ('        and calibrated and not coloured and unstable_from is None and not coarse',
             '        and not coloured and unstable_from is None and not coarse'),
        ],
        ['tests/test_adaptive.py::test_the_law_never_claims_a_confidence_band'],
    ),
    "autocorrelation limit ignores the record's length": (
        "vojax/_stats.py",
        [("    return float(min(MAX_CORRELATION, max(z, CORRELATION_FLOOR)))",
          "    return MAX_CORRELATION")],
        ["tests/test_first_pass.py::test_correlated_prediction_errors_are_refused_and_coloured_noise_is_modelled"],
    ),
    'a conditional verdict without reach': (
        'vojax/_diagnostics.py',
        [
            ('                          and reach > s.drift_floor)',
             '                          )'),
        ],
        ['tests/test_verdict.py::test_verdict_words_follow_the_stated_and_the_conditional_bands'],
    ),

    "numbers whose squares leave float64 taken": (
        "vojax/_validate.py",
        [("    if size > hi or (0 < size < lo and not tiny):", "    if False:")],
        ["tests/test_compare.py::test_a_record_no_law_can_describe_is_refused_not_answered_with_nan"],
    ),
    "the batch's settling test is given no band now": (
        "vojax/_data/_parts.py",
        [("                             band_now=band_now if 0 < band_now < np.inf else None)",
          "                             band_now=None)")],
        ["tests/test_batch_settling.py"],
    ),
    "settings take a level step of 1 (the level profile loops for ever)": (
        "vojax/_settings.py",
        [(""" "level_step": ((1.0,), math.inf, False),""", """ "level_step": POSITIVE,""")],
        ["tests/test_settings.py::test_a_setting_the_tracker_cannot_use_is_refused_naming_it"],
    ),
    "settings take a noise range upside down": (
        "vojax/_settings.py",
        [("        if not self.noise_min < self.noise_max:", "        if False:")],
        ["tests/test_settings.py::test_a_setting_the_tracker_cannot_use_is_refused_naming_it"],
    ),
    "settings take 1 for True": (
        "vojax/_settings.py",
        [("if not any(type(value) is type(c) and value == c for c in choices):",
          "if value not in choices:")],
        ["tests/test_settings.py::test_a_setting_the_tracker_cannot_use_is_refused_naming_it"],
    ),
    "settings keep a whole float as a float": (
        "vojax/_settings.py",
        [("                value = int(value)\n", "")],
        ["tests/test_settings.py::test_a_list_is_kept_as_a_tuple_and_a_whole_float_as_an_int"],
    ),
    "the reference reads its arguments with NumPy's messages": (
        "vojax/reference.py",
        [("        _prepare(u, order, dt, None, rule, memory, tol, order_range)\n", "        pass\n")],
        ["tests/test_validation.py::test_the_cross_checks_name_a_bad_argument"],
    ),
    "the reference's checks need JAX's float64 setting": (
        "vojax/reference.py",
        [("    with x64_scope(True):\n        _prepare(", "    if True:\n        _prepare(")],
        ["tests/test_validation.py::test_the_closed_forms_hold_down_to_their_least_order_and_need_no_float64_setting"],
    ),
    "the closed form (14) is evaluated at any order (it cancels below 1e-6)": (
        "vojax/reference.py",
        [("    if np.min(np.asarray(order, float)) < MIN_CLOSED_ORDER:", "    if False:")],
        ["tests/test_validation.py::test_the_cross_checks_name_a_bad_argument"],
    ),
    "the gradient checks take 2 for raise_on_failure": (
        "vojax/testing.py",
        [('    check.flag(raise_on_failure, "raise_on_failure")\n', "")],
        ["tests/test_validation.py::test_the_cross_checks_name_a_bad_argument"],
    ),
    "r0's symmetry left to an eigenvalue routine that reads one triangle": (
        "vojax/_validate.py",
        [("    if np.max(np.abs(m - m.T)) > 1e-10 * np.max(np.abs(m)):", "    if False:")],
        ["tests/test_validation_r0.py::test_one_rule_for_r0_wherever_it_is_taken"],
    ),
    "r0's symmetry judged on an absolute scale (a tiny matrix passes)": (
        "vojax/_validate.py",
        [("    if np.max(np.abs(m - m.T)) > 1e-10 * np.max(np.abs(m)):",
          "    if np.max(np.abs(m - m.T)) > 1e-10:")],
        ["tests/test_validation_r0.py::test_a_symmetric_r0_built_by_rounding_is_taken"],
    ),
    "the excluded order is named even inside the band": (
        "vojax/_identification.py",
        [("        return d.clock_order if not lo <= d.clock_order <= hi else None",
          "        return d.clock_order")],
        ["tests/test_clock.py::test_an_identified_answer_names_the_order_its_statement_excluded"],
    ),
    "an order bound of 0 admitted": (
        "vojax/_validate.py",
        [("    if not (within[0] < lo < hi < within[1]):", "    if not (within[0] <= lo < hi < within[1]):")],
        ["tests/test_validation.py::test_an_order_bound_at_zero_or_one_is_refused"],
    ),
    "summary values printed in fixed point": (
        "vojax/_results.py",
        [('    return f"{x:.6g}"', '    return f"{x:.6f}"')],
        ["tests/test_results.py::test_the_summary_table_prints_tiny_and_huge_numbers_as_they_are"],
    ),
    "a number given as text parsed": (
        "vojax/_validate.py",
        [("    if isinstance(x, (str, bytes, bool)) or x is None:", "    if x is None:")],
        ["tests/test_validation.py::test_a_number_given_as_text_is_refused_not_parsed"],
    ),
    "an input that is 0 throughout fitted": (
        "vojax/_validate.py",
        [("        if np.any(silent):", "        if False:")],
        ["tests/test_data_cli.py::test_hostile_cells_clocks_and_silent_inputs_get_one_sentence"],
    ),
    "the verdict's half-width over the first half of the record": (
        "vojax/_diagnostics.py",
        [("    width = float(np.median((upper - lower)[half:]) / 2)",
          "    width = float(np.median((upper - lower)[:half]) / 2)")],
        ["tests/test_verdict.py::test_the_verdict_reads_the_band_over_the_second_half_of_the_record"],
    ),
    "repeated parameter names taken": (
        "vojax/_results.py",
        [("    if len(set(names)) != count:", "    if False:")],
        ["tests/test_results.py::test_names_and_times_given_to_a_result_are_checked_in_one_sentence"],
    ),
    "a DataFrame's time of the wrong length taken": (
        "vojax/_results.py",
        [("    if times.shape != (num,) or not np.all(np.isfinite(times)):", "    if False:")],
        ["tests/test_results.py::test_names_and_times_given_to_a_result_are_checked_in_one_sentence"],
    ),
    "the clock's disagreement leaves the conditional answer standing": (
        "vojax/_diagnostics.py",
        [("    settled = sound and not clocked", "    settled = sound")],
        ["tests/test_clock.py"],
    ),
    "the window's end excluded": (
        "vojax/_validate.py",
        [("    return ((times >= lo) & (times <= hi)).astype(float)",
          "    return ((times >= lo) & (times < hi)).astype(float)")],
        ["tests/test_tracker_window.py"],
    ),
    "the summary's final order the record's, not the window's": (
        "vojax/_identification.py",
        [("        return a if self.fitted is None else a[slice(*self.fitted)]", "        return a")],
        ["tests/test_tracker_window.py"],
    ),
    "Identification.plot draws the order alone": (
        "vojax/_identification.py",
        [("        if ax is None:\n            from ._plotting_record", "        if False:\n            from ._plotting_record")],
        ["tests/test_figure_content.py::test_identification_plot_shows_data_fit_residuals_and_the_verdict"],
    ),
    "the command's next steps run together on one line": (
        "vojax/_steps.py",
        [('        lines += [f"    ({i}) {w}" for i, w in enumerate(words, 1)]',
          '        lines.append("    " + "; ".join(words))')],
        ["tests/test_cli_identify.py::test_cli_identify_end_to_end"],
    ),
    "XLA's log level set by the variable alone (newer jaxlib reads it once)": (
        "vojax/_xla.py",
        [("        set_level(3)", "        pass")],
        ["tests/test_quiet_logs.py"],
    ),
    "the user's own XLA log level overridden": (
        "vojax/_xla.py",
        [('not in ("", "1")', 'not in ("", "1", "0", "2")')],
        ["tests/test_quiet_logs.py"],
    ),
    "the conditional message quotes an infinite breakdown drift as a percentage": (
        "vojax/_diagnostics.py",
        [('            "well" if np.isfinite(c["breakdown"]) else', '            "well" if True else')],
        ["tests/test_verdict.py::test_verdict_words_follow_the_stated_and_the_conditional_bands"],
    ),
    "the verdict line promises a drift below inf %": (
        "vojax/_identification.py",
        [('        if not np.isfinite(d.breakdown_drift):  # no drift tried left the conditional band',
          '        if False:')],
        ["tests/test_verdict.py::test_a_conditional_answer_no_drift_breaks_says_so_in_words"],
    ),
    "the conditional band's legend says less than inf %": (
        "vojax/_identification.py",
        [('    if not np.isfinite(breakdown_drift):\n        return "any drift tried"\n', "")],
        ["tests/test_verdict.py::test_a_conditional_answer_no_drift_breaks_says_so_in_words"],
    ),
}
