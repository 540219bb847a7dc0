"""Planted bugs of `mutation_check.py`: the planned and recorded tests' design (Fisher information, `optimal_protocol`, `settling_test`)."""

# name: (file, [(old, new), ...], tests that should fail)
MUTATIONS = {
    "design's drift prior per step, not per record": (
        "vojax/_design.py",
        [("step_var = order_drift * np.diff(times) / (times[-1] - times[0])",
          "step_var = order_drift * np.diff(times)")],
        ["tests/test_design.py::test_without_information_the_order_spreads_as_the_trackers_random_walk"],
    ),
    "design's drift prior on the order, not its logistic coordinate": (
        "vojax/_design.py",
        [("diff = np.diff(np.eye(times.size), axis=0) / slope",
          "diff = np.diff(np.eye(times.size), axis=0)")],
        ["tests/test_design.py::test_without_information_the_order_spreads_as_the_trackers_random_walk"],
    ),
    "design's drift prior without its start": (
        "vojax/_design.py",
        [("    precision[0, 0] += 1.0 / (slope[0] ** 2 * PRIOR_BETA_VAR)\n", "")],
        ["tests/test_design.py::test_without_information_the_order_spreads_as_the_trackers_random_walk"],
    ),
    'settling_test takes oscillations faster than its sampling': (
        'vojax/_settling.py',
        [
            ('            if frequency * step > 1 / 8:  # fewer than 8 samples a cycle',
             '            if False:  # fewer than 8 samples a cycle'),
        ],
        ['tests/test_design.py::test_settling_test_picks_the_narrowest_band_its_sampling_allows'],
    ),
    "the drifting parameters' columns left out of the design": (
        'vojax/_design.py',
        [
            ('        cols.append((phi[:, :, None] * drift_hats[:, None, :]).reshape(u2.shape[0], -1))',
             '        pass'),
        ],
        ['tests/test_design.py::test_drifting_parameters_information_against_a_hand_built_jacobian'],
    ),
    "A-criterion over the first half of the test": (
        "vojax/_protocol.py",
        [('hats_j[half:], cov[:k, :k], hats_j[half:])', 'hats_j[:half], cov[:k, :k], hats_j[:half])')],
        ["tests/test_design.py::test_the_optimal_ramp_for_a_moving_order_weighs_the_second_half"],
    ),
    "optimal protocol returns the first start's end, not the best": (
        "vojax/_protocol.py",
        [("    pick = int(np.argmin(np.where(np.isnan(values), np.inf, values)))", "    pick = 0")],
        ["tests/test_protocol.py::test_several_starts_give_the_best_of_their_single_searches"],
    ),
    "a chirp's frequency does not rise (a sine)": (
        "vojax/_settling.py",
        [("        return 2 * np.pi * f0 * length * np.expm1(rate * tau / length) / rate",
          "        return 2 * np.pi * f0 * tau")],
        ["tests/test_protocol.py::test_a_chirp_is_the_integral_of_its_rising_frequency"],
    ),
    "the settling test's expectation narrows as the bound does": (
        "vojax/_settling.py",
        [("        self.expected = (band_now * ratio**exponent",
          "        self.expected = (band_now * ratio")],
        ["tests/test_protocol.py::test_the_settling_test_scales_the_trackers_band_by_the_bounds_narrowing",
         "tests/test_batch_settling.py"],
    ),
    "a planned test's expected band given on designs the factor was not calibrated on": (
        "vojax/_design.py",
        [("    if knots == 1 and x0 and parameter_knots == PROTOCOL_KNOTS and order_drift is None:",
          "    if knots == 1 and parameter_knots == PROTOCOL_KNOTS and order_drift is None:")],
        ["tests/test_protocol.py::test_a_planned_test_states_the_trackers_expected_band_on_the_calibrated_design"],
    ),
    "a planned test's expected band is the bound itself": (
        "vojax/_design.py",
        [("        design.expected = TrackerSettings().protocol_factor * design.order_band",
          "        design.expected = design.order_band")],
        ["tests/test_protocol.py::test_a_planned_test_states_the_trackers_expected_band_on_the_calibrated_design"],
    ),
    "the settling test never tries its chirp": (
        "vojax/_settling.py",
        [("            tries.append((min(cycles) / length, top, None))", "            pass")],
        ["tests/test_protocol.py::test_with_a_chirp_the_settling_test_picks_the_narrowest_of_sines_and_chirps"],
    ),
    "optimal protocol searches with the parameters constant whatever parameter_knots says": (
        "vojax/_protocol.py",
        [("jac = _jacobian(mem, u2, b, jnp.asarray(pj), hats_j, x0, drift_hats)",
          "jac = _jacobian(mem, u2, b, jnp.asarray(pj), hats_j, x0, None)")],
        ["tests/test_protocol.py::test_the_best_oscillation_under_drifting_parameters_is_a_minimum_of_its_own_bound"],
    ),
    "optimal protocol's Design forgets its drifting parameters": (
        "vojax/_protocol.py",
        [("                                parameter_knots=parameter_knots)",
          "                                parameter_knots=None)")],
        ["tests/test_protocol.py::test_the_best_oscillation_under_drifting_parameters_is_a_minimum_of_its_own_bound"],
    ),
    "optimal protocol takes a protocol whose inputs are not finite": (
        "vojax/_protocol.py",
        [("        u = check.samples(np.asarray(protocol(jnp.asarray(start), jnp.asarray(t)), float), name)",
          "        u = np.asarray(protocol(jnp.asarray(start), jnp.asarray(t)), float)")],
        ["tests/test_protocol.py::test_a_protocol_it_cannot_use_is_refused_with_a_reason"],
    ),
    "optimal protocol traces an integer noise level (2**63 overflows)": (
        "vojax/_protocol.py",
        [("    noise_std = float(noise_std)  # an integer as large as 2**63 overflows a traced int\n",
          "")],
        ["tests/test_protocol.py::test_an_integer_noise_level_plans_as_its_float"],
    ),
    "optimal protocol reads text limits with NumPy's message": (
        "vojax/_protocol.py",
        [("    lo, hi, x = (np.atleast_1d(check.reals(a, name))",
          "    lo, hi, x = (np.atleast_1d(np.asarray(a, float))")],
        ["tests/test_protocol.py::test_limits_and_starts_that_are_not_numbers_are_refused_by_name"],
    ),
    "optimal protocol's Design forgets its knots": (
        "vojax/_protocol.py",
        [("noise_std=noise_std, knots=knots, x0=x0,", "noise_std=noise_std, knots=1, x0=x0,")],
        ["tests/test_design.py::test_the_optimal_ramp_for_a_moving_order_weighs_the_second_half"],
    ),
    "fisher_information takes an order outside its range": (
        "vojax/_design.py",
        [("    check.order(order, num, bounds=order_range)\n", "")],
        ["tests/test_design.py::test_bad_plans_are_refused_with_a_reason"],
    ),
    "fisher_information answers an information that overflowed": (
        "vojax/_design.py",
        [("    if not np.all(np.isfinite(information)):", "    if False:")],
        ["tests/test_design.py::test_bad_plans_are_refused_with_a_reason"],
    ),
}
