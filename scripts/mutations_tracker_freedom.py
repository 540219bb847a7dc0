"""Planted bugs of `mutation_check.py`: a smoothing's fitted freedom (the trace of its
linearised hat matrix) and the level profile's rules that read it (the χ² floor, the excess over expectation)."""

T = "tests/test_freedom.py::"
# name: (file, [(old, new), ...], tests that should fail)
MUTATIONS = {
    "each step's shrinkage without its smoothed part (the filtered part alone)": (
        "vojax/_tracker/_explanations.py",
        [("    shrunk = q[:-1, :k] * smoothed + filtered", "    shrunk = filtered")],
        [T + "test_the_freedom_is_the_dense_trace_in_the_noises_own_metric"],
    ),
    "the freedom counts a coloured noise's AR(1) state": (
        "vojax/_tracker/_explanations.py",
        [("    k = min(np.asarray(sm.theta).shape[1], np.asarray(sm.phi).shape[1] + 2)",
          "    k = np.asarray(sm.theta).shape[1]")],
        [T + "test_the_freedom_is_the_dense_trace_in_the_noises_own_metric"],
    ),
    "the filtered part without the transition (a random walk's, whatever the noise)": (
        "vojax/_tracker/_explanations.py",
        [("np.einsum(\"tij,tj,tji->ti\", m, f[:-1], pf[:-1])",
          "np.einsum(\"tij,tji->ti\", m, pf[:-1])")],
        [T + "test_the_freedom_is_the_dense_trace_in_the_noises_own_metric"],
    ),
    "the predicted covariance without the transition": (
        "vojax/_tracker/_explanations.py",
        [("    pred = pf[:-1] * f[:-1, :, None] * f[:-1, None, :] + q[:-1, :, None]",
          "    pred = pf[:-1] + q[:-1, :, None]")],
        [T + "test_the_freedom_is_the_dense_trace_in_the_noises_own_metric"],
    ),
    "the start's prior pull left out (θ_0 counts n + 2 whatever the data)": (
        "vojax/_tracker/_explanations.py",
        [("    return float(k - np.trace(start) + steps_fit)", "    return float(steps_fit)")],
        [T + "test_a_smoothing_whose_states_do_not_drift_fits_n_plus_two_parameters",
         T + "test_the_freedom_is_the_trace_of_the_fitted_outputs_derivative",
         T + "test_the_freedom_is_the_dense_trace_in_the_noises_own_metric"],
    ),
    "the coloured noise's process variance without its transition": (
        "vojax/_tracker/_model.py",
        [("        cols.append(values[3] * (1.0 - f[:, -1] ** 2))", "        cols.append(values[3] + 0.0 * f[:, -1])")],
        [T + "test_the_freedom_is_the_dense_trace_in_the_noises_own_metric"],
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
    "the tuned run's freedom with its order and parameter drifts swapped": (
        "vojax/_tracker/_mixture.py",
        [("            [freedom(sm, tuning.values, *problem.host_clock, problem.p0), *traces])",
          "            [freedom(sm, (tuning.values[1], tuning.values[0], *tuning.values[2:]),\n"
          "                     *problem.host_clock, problem.p0), *traces])")],
        [T + "test_every_smoothing_of_a_fit_fits_between_the_constant_fit_and_the_samples",
         "tests/test_envelope.py::test_the_mixtures_runs_are_explanations_of_their_kinds"],
    ),
    "each level run's freedom at logarithms of its intensities": (
        "vojax/_tracker/_smoother.py",
        [("    rows = np.stack([np.broadcast_to(np.exp(np.asarray(v, float)).reshape(-1),",
          "    rows = np.stack([np.broadcast_to((np.asarray(v, float)).reshape(-1),")],
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
