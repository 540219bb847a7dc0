"""Planted bugs of `mutation_check.py`: a smoothing's fitted freedom (the trace of its
linearised hat matrix) and the level profile's rules that read it (the χ² floor, the excess over expectation)."""

T = "tests/test_freedom.py::"
# name: (file, [(old, new), ...], tests that should fail)
MUTATIONS = {
    "the freedom summed over every sample, the fit window ignored": (
        "vojax/_tracker/_explanations.py",
        [("    return float(np.sum(np.asarray(mask) * np.einsum(", "    return float(np.sum(1.0 * np.einsum(")],
        [T + "test_the_coloured_noise_state_is_left_out",
         T + "test_the_freedom_is_the_dense_trace_with_samples_outside_the_fit"],
    ),
    "the freedom counts a coloured noise's AR(1) state": (
        "vojax/_tracker/_explanations.py",
        [("    k = min(np.asarray(sm.theta).shape[1], np.asarray(sm.phi).shape[1] + 2)",
          "    k = np.asarray(sm.theta).shape[1]")],
        [T + "test_the_coloured_noise_state_is_left_out"],
    ),
    "the freedom over the measurement's standard deviation, not its variance": (
        "vojax/_tracker/_explanations.py",
        [("np.einsum(\"ti,tij,tj->t\", jac, cov, jac)) / float(r))",
          "np.einsum(\"ti,tij,tj->t\", jac, cov, jac)) / float(r) ** 0.5)")],
        [T + "test_a_smoothing_whose_states_do_not_drift_fits_n_plus_two_parameters",
         T + "test_the_freedom_is_the_trace_of_the_fitted_outputs_derivative"],
    ),
    "the freedom at the smoothed covariance of the sample before": (
        "vojax/_tracker/_explanations.py",
        [("    jac, cov = np.asarray(sm.jacobian)[:, :k], np.asarray(sm.cov)[:, :k, :k]",
          "    jac, cov = np.asarray(sm.jacobian)[:, :k], np.roll(np.asarray(sm.cov)[:, :k, :k], 1, 0)")],
        [T + "test_the_freedom_is_the_dense_trace_with_samples_outside_the_fit"],
    ),
    "the freedom of the order alone (the parameters' and offset's columns left out)": (
        "vojax/_tracker/_explanations.py",
        [("    jac, cov = np.asarray(sm.jacobian)[:, :k], np.asarray(sm.cov)[:, :k, :k]",
          "    jac, cov = np.asarray(sm.jacobian)[:, :1], np.asarray(sm.cov)[:, :1, :1]")],
        [T + "test_a_smoothing_whose_states_do_not_drift_fits_n_plus_two_parameters"],
    ),
    "an explanation's freedom kept as the whole trace (the constant fit's n + 2 not taken off)": (
        "vojax/_tracker/_explanations.py",
        [("                    freedom=float(e) - problem.n - 2)", "                    freedom=float(e))")],
        [T + "test_an_explanation_counts_the_freedom_beyond_the_constant_fit"],
    ),
    "the freedom kept under a coloured noise's whitening": (
        "vojax/_tracker/_explanations.py",
        [("                                             if freedoms is None or whiten is not None",
          "                                             if freedoms is None")],
        [T + "test_an_explanation_counts_the_freedom_beyond_the_constant_fit"],
    ),
    "the tuned run's freedom at its parameters' drift, not its measurement variance": (
        "vojax/_tracker/_mixture.py",
        [("            [freedom(sm, tuning.values[2], problem.mask), *traces])",
          "            [freedom(sm, tuning.values[1], problem.mask), *traces])")],
        [T + "test_every_smoothing_of_a_fit_fits_between_the_constant_fit_and_the_samples"],
    ),
    "the freedom floor raised by the freedom, not lowered": (
        "vojax/_tracker/_band.py",
        [("        return e.dof - max(e.freedom, 0.0)", "        return e.dof + max(e.freedom, 0.0)")],
        [T + "test_the_freedom_floor_counts_what_each_run_fits"],
    ),
    "the freedom floor read whatever the setting": (
        "vojax/_tracker/_band.py",
        [("    if level_weights == \"freedom\" and np.isfinite(e.freedom):",
          "    if np.isfinite(e.freedom):")],
        [T + "test_the_freedom_floor_counts_what_each_run_fits"],
    ),
    "the excess rule's floor at dof alone (its tolerance ignored)": (
        "vojax/_tracker/_band.py",
        [("        return max(e.chi2 + free, e.dof + excess_alike * np.sqrt(2.0 * e.dof))",
          "        return max(e.chi2 + free, e.dof)")],
        [T + "test_the_excess_rule_weighs_each_run_by_its_chi2_over_its_own_expectation"],
    ),
    "the excess rule without the freedom (the χ² floor at dof plus the tolerance)": (
        "vojax/_tracker/_band.py",
        [("        free = max(e.freedom, 0.0) if np.isfinite(e.freedom) else 0.0\n        return max(e.chi2 + free,",
          "        free = 0.0\n        return max(e.chi2 + free,")],
        [T + "test_the_excess_rule_weighs_each_run_by_its_chi2_over_its_own_expectation"],
    ),
    "the level profile's tolerance not passed on (its default whatever the setting)": (
        "vojax/_tracker/_band.py",
        [("                              profile_chi2=profile_chi2, excess_alike=excess_alike)",
          "                              profile_chi2=profile_chi2)")],
        [T + "test_the_excess_rule_weighs_each_run_by_its_chi2_over_its_own_expectation"],
    ),
}
