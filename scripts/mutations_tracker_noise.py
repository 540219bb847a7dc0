"""Planted bugs of `mutation_check.py`: the tracker's long records and noise models (block
means, the AR(1) noise state, the coloured model's gates and climb, the whitener)."""

# name: (file, [(old, new), ...], tests that should fail)
MUTATIONS = {
    "block size from the padded length": (
        "vojax/_tracker/_estimator.py",
        [("    length = u2.shape[0] if mask is None else int(np.flatnonzero(np.asarray(mask))[-1]) + 1",
          "    length = u2.shape[0]")],
        ["tests/test_blocks.py::test_blocks_on_a_non_uniform_clock_and_with_padding"],
    ),
    "block mean read at the block's first time": (
        "vojax/_tracker/_blocks.py",
        [("        block_average(np.asarray(times, float), size),",
          "        np.asarray(times, float)[np.r_[0, 1 : len(times) : size]],")],
        ["tests/test_blocks.py::test_block_means_by_hand",
         "tests/test_blocks.py::test_the_blocked_order_agrees_with_the_fit_of_every_sample"],
    ),
    "first sample not kept alone": (
        "vojax/_tracker/_blocks.py",
        [("    starts = np.concatenate([[0], np.arange(1, values.shape[0], size)])",
          "    starts = np.arange(0, values.shape[0], size)")],
        ["tests/test_blocks.py::test_block_means_by_hand",
         "tests/test_blocks.py::test_the_blocked_order_agrees_with_the_fit_of_every_sample"],
    ),
    'noise edge measured on the full box': (
        'vojax/_tracker/_tuning.py',
        [
            ('        if hi > lo and min(v - lo, hi - v) < edge * (hi - lo):',
             '        if hi > lo and min(v - lo, hi - v) < edge * (\n                np.log(2.0) - np.log(1e-10) if name == "noise" else hi - lo):'),
        ],
        ['tests/test_tracker.py::test_an_intensity_is_at_the_edge_of_the_box_searched_not_of_the_full_box'],
    ),
    "block noise from the coarse clock": (
        "vojax/_tracker/_blocks.py",
        [("    block_noise = max(noise_variance(y_np[:span][fitted]) / size, 1e-300)",
          "    block_noise = max(noise_variance(y_b[mask_b > 0]), 1e-300)")],
        ["tests/test_blocks.py::test_blocks_that_misrepresent_the_record_are_reported"],
    ),
    "RTS gain without the transition": (
        "vojax/_tracker/_kalman.py",
        [("        g = cholesky_solve(p_pred, p if not f_k else p * f_k[0][:, None]).T",
          "        g = cholesky_solve(p_pred, p).T")],
        ["tests/test_kalman.py::test_kalman_and_rts_with_an_ar1_state_equal_the_dense_posterior"],
    ),
    "AR(1) noise not stationary": (
        "vojax/_tracker/_model.py",
        [("            cols.append((jnp.exp(self.log_ar_var) * (1.0 - a * a))[:, None])",
          "            cols.append((jnp.exp(self.log_ar_var) * (1.0 - a))[:, None])")],
        ["tests/test_coloured.py::test_hyper_transition_keeps_the_ar_part_stationary"],
    ),
    "objective's increments without the transition": (
        "vojax/_tracker/_model.py",
        [("    inc = theta[1:] - (theta[:-1] if f is None else f[:-1] * theta[:-1])",
          "    inc = theta[1:] - theta[:-1]")],
        ["tests/test_kalman.py::test_smoother_mode_and_bands_against_a_dense_numpy_posterior"],
    ),
    "whitener skips the gain": (
        "vojax/_tracker/_coloured.py",
        [("    c = a * (1.0 - gain)", "    c = a"),
         ("mult, acc = c.copy(), (a * gain)[extra] * x", "mult, acc = c.copy(), 0.0 * x")],
        ["tests/test_coloured.py::test_whitener_gives_the_dense_quadratic_form_and_gls"],
    ),
    "coloured noise kept at the longest correlation time": (
        "vojax/_tracker/_coloured.py",
        [('    if "noise_time" in tuned.at_edge or not (', "    if not (")],
        ["tests/test_tracker.py::test_order_traded_against_drifting_parameters_is_refused",
         "tests/test_first_pass.py::test_output_smoother_than_the_model_converges_with_the_noise_it_leaves"],
    ),
    "coloured noise never tried": (
        "vojax/_tracker/_coloured.py",
        [("    if not (r1 > limit or absorbed):", "    if True:")],
        ["tests/test_first_pass.py::test_correlated_prediction_errors_are_refused_and_coloured_noise_is_modelled"],
    ),
    "coloured noise tried at the refusal limit whatever coloured_lag says": (
        "vojax/_tracker/_coloured.py",
        [("else s.coloured_lag / np.sqrt(count)", "else correlation_limit(count)")],
        ["tests/test_coloured.py::test_the_coloured_model_is_tried_where_the_lag1_passes_coloured_lag_over_root_n"],
    ),
    "coloured noise's lag-1 gate scaled by 1/n, not 1/√n": (
        "vojax/_tracker/_coloured.py",
        [("else s.coloured_lag / np.sqrt(count)", "else s.coloured_lag / count")],
        ["tests/test_coloured.py::test_the_coloured_model_is_tried_where_the_lag1_passes_coloured_lag_over_root_n"],
    ),
    "coloured_lag 0 does not restore the refusal limit": (
        "vojax/_tracker/_coloured.py",
        [("if s.coloured_lag <= 0 else", "if s.coloured_lag < 0 else")],
        ["tests/test_coloured.py::test_the_coloured_model_is_tried_where_the_lag1_passes_coloured_lag_over_root_n"],
    ),
    "coloured noise tried where the white model's noise is above the data's, not below": (
        "vojax/_tracker/_coloured.py",
        [("absorbed = tuning.noise < s.coloured_absorbed", "absorbed = tuning.noise > s.coloured_absorbed")],
        ["tests/test_coloured.py::test_the_coloured_model_is_tried_where_the_white_ones_noise_fell_below_the_datas"],
    ),
    "the coloured model's gate compares with the second differences' noise": (
        "vojax/_tracker/_fit.py",
        [("                         st.noise_higher[0])", "                         st.noise_data)")],
        ["tests/test_coloured.py::test_the_coloured_model_is_tried_where_the_white_ones_noise_fell_below_the_datas"],
    ),
    "the coloured model's gate is never given the data's noise": (
        "vojax/_tracker/_fit.py",
        [("                         st.noise_higher[0])", "                         0.0)")],
        ["tests/test_coloured.py::test_the_coloured_model_is_tried_where_the_white_ones_noise_fell_below_the_datas"],
    ),
    "coloured climb's stop at the correlation time's edge never counts": (
        "vojax/_tracker/_tuning.py",
        [("edged = edged + 1 if fatal in at_edges", "edged = edged + 0 if fatal in at_edges")],
        ["tests/test_climb.py::test_a_climb_stops_once_its_correlation_time_stays_at_the_top"],
    ),
    'coloured climb stops at any edge of the correlation time': (
        'vojax/_tracker/_tuning.py',
        [
            ('if fatal in at_edges(host_hyper(hyper), limits, s.edge)',
             'if any(k.startswith(fatal) for k in at_edges(host_hyper(hyper), limits, s.edge))'),
        ],
        ['tests/test_climb.py::test_a_climb_stops_once_its_correlation_time_stays_at_the_top'],
    ),
    "the whitener's doubling scan one step short": (
        "vojax/_tracker/_coloured.py",
        [("range(max(num - 1, 1).bit_length())", "range(max(num - 1, 1).bit_length() - 1)")],
        ["tests/test_coloured.py::test_whitener_equals_the_kalman_filter_step_by_step"],
    ),
}
