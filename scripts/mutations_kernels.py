"""Planted bugs of `mutation_check.py`: the memories' direct kernels, the fractional
integral's front end and `simulate`, the host's ψ, the Mittag-Leffler table, the tuner's
BFGS, the parallel-in-time Kalman filter, the law's estimator object and the command line's
shared options (modules the other areas plant nothing in), the statistics from the data
alone (`vojax._stats`), the plain values' checks and the atomic output files."""

KERNELS = "tests/test_kernels.py"
GRID = "tests/test_grid.py"
BFGS = "tests/test_bfgs.py"
LAW = "tests/test_law_estimator.py"
OPTIONS = "vojax/_cli/_options.py"

# name: (file, [(old, new), ...], tests that should fail)
MUTATIONS = {
    "direct memory reads a nonzero integral at the first sample": (
        "vojax/_kernels/_direct.py",
        [("        return jnp.where(state.k > 0, phi, 0.0)", "        return phi")],
        [KERNELS, GRID],
    ),
    "grid memory leaves out the newest sample's weight": (
        "vojax/_kernels/_direct.py",
        [("        return history + w[state.k] * u_k", "        return history")],
        [GRID],
    ),
    "grid memory's step is the first interval's everywhere": (
        "vojax/_kernels/_direct.py",
        [("        return self.times[k] - self.times[k - 1]",
          "        return self.times[1] - self.times[0]")],
        [GRID],
    ),
    "an order below the exponential memory's design range passes": (
        "vojax/_integral.py",
        [("            (order < lo) | (order > hi),", "            order > hi,"),
         ("            check.order(order, order.shape[0], bounds=(lo, hi), closed=True)\n",
          "            pass\n")],
        [KERNELS, GRID, "tests/test_validation.py"],
    ),
    "order_map's sensitivity along half the direction": (
        "vojax/_integral.py",
        [("(jax.numpy.ones_like(order),))", "(0.5 * jax.numpy.ones_like(order),))")],
        [KERNELS, GRID, "tests/test_refit.py"],
    ),
    "BFGS accepts any decrease (no Armijo fraction)": (
        "vojax/_tracker/_bfgs.py",
        [("(f_eval - f <= SLOPE * predicted)", "(f_eval - f <= 0.0)")],
        [BFGS],
    ),
    "BFGS never updates its inverse Hessian": (
        "vojax/_tracker/_bfgs.py",
        [("        h_new = jnp.where(inner > eps, updated, h)", "        h_new = h")],
        [BFGS],
    ),
    "BFGS stops on a small step alone": (
        "vojax/_tracker/_bfgs.py",
        [("        return y_ok & f_ok", "        return y_ok")],
        [BFGS],
    ),
    "BFGS keeps its step after a rejected point": (
        "vojax/_tracker/_bfgs.py",
        [("        step = jnp.where(accept, one, DECREASE * step)",
          "        step = jnp.where(accept, one, step)")],
        [BFGS],
    ),
    "the law's estimator runs on the output without its offset removed": (
        "vojax/_adaptive/_estimator.py",
        [("        out = run_law(law, u2, y - x0)", "        out = run_law(law, u2, y)")],
        [LAW, "tests/test_adaptive.py"],
    ),
    "the law's estimator defaults λ to 1 instead of the paper's": (
        "vojax/_adaptive/_estimator.py",
        [("            lam = PAPER_LAM", "            lam = 1.0")],
        [LAW, "tests/test_adaptive.py"],
    ),
    "the law's estimator drops its own r0": (
        "vojax/_adaptive/_estimator.py",
        [("        shared = dict(alpha0=self.alpha0, alpha_bounds=bounds, memory=self.memory,\n"
          "                      rule=self.rule, r0=r0, tol=self.tol)",
          "        shared = dict(alpha0=self.alpha0, alpha_bounds=bounds, memory=self.memory,\n"
          "                      rule=self.rule, r0=None, tol=self.tol)")],
        [LAW, "tests/test_adaptive.py"],
    ),
    "--gamma and --lam pass silently beside the tracker": (
        OPTIONS,
        [("    if not args.method.startswith(\"gradient\"):", "    if args.method == \"refit\":")],
        ["tests/test_notebooks_cli.py::test_cli_errors_are_one_sentence"],
    ),
    "--model maxwell passes to the tracker": (
        OPTIONS,
        [("    if args.method != \"refit\" and args.model in (\"maxwell\", \"zener\"):",
          "    if args.method == \"gradient\" and args.model in (\"maxwell\", \"zener\"):")],
        ["tests/test_cli_recordings.py::test_maxwell_and_signs_from_the_command_line"],
    ),
    "--max-points below the least passes": (
        OPTIONS,
        [("    if points is not None and not MIN_POINTS <= points <= TRACKER_MAX_POINTS:",
          "    if points is not None and points > TRACKER_MAX_POINTS:")],
        ["tests/test_cli_identify.py::test_max_points_option_blocks_a_record_and_is_checked"],
    ),
    "--origin passes to the tracker alone": (
        OPTIONS,
        [("    if getattr(args, \"origin\", None) is not None and not args.method.endswith(\"refit\"):",
          "    if getattr(args, \"origin\", None) is not None and args.method == \"gradient\":")],
        ["tests/test_cli_recordings.py::test_maxwell_and_signs_from_the_command_line"],
    ),
    "--fit-from passes to the paper's law": (
        OPTIONS,
        [("    if window and args.method == \"gradient\":", "    if window and args.method == \"refit\":")],
        ["tests/test_tracker_window.py::test_command_line_window_is_the_python_window"],
    ),
    "digamma's recurrence stops at 2 (the series from there)": (
        "vojax/_kernels/_special.py",
        [("    while x < 8.0:", "    while x < 2.0:")],
        [KERNELS, GRID],
    ),
    "simulate leaves out x0": (
        "vojax/_simulate.py",
        [("    return x0 + fractional_integral(", "    return fractional_integral(")],
        [GRID, "tests/test_adaptive.py"],
    ),
    "simulate holds a moving p at its first row": (
        "vojax/_simulate.py",
        [("jnp.sum(u2 * p, axis=-1) if p.ndim", "jnp.sum(u2 * p.reshape(-1, n)[0], axis=-1) if p.ndim")],
        [KERNELS, "tests/test_adaptive.py", "tests/test_closed_forms.py",
         "tests/test_law_transcription.py"],
    ),
    "the Mittag-Leffler table's shifted function divides by Γ(base + 1)": (
        "vojax/_models/_ml_table.py",
        [("    shifted[middle] = (1.0 / math.gamma(base) - plain[middle]) / xm",
          "    shifted[middle] = (1.0 / math.gamma(base + 1) - plain[middle]) / xm")],
        ["tests/test_ml_table.py"],
    ),
    "the Mittag-Leffler table reads its last panel's arguments from the one before": (
        "vojax/_models/_ml_table.py",
        [("astype(np.intp), 0, PANELS - 1)", "astype(np.intp), 0, PANELS - 2)")],
        ["tests/test_ml_table.py"],
    ),
    "the noise variance from second differences divided by C(4, 1)": (
        "vojax/_stats.py",
        [("/ math.comb(2 * order, order))", "/ math.comb(2 * order, order - 1))")],
        ["tests/test_stats.py::test_noise_variance_estimate"],
    ),
    "the noise of an output flat over most of the record taken over every difference": (
        "vojax/_stats.py",
        [("    if 2 * moving.size < dk.size:  # most exactly zero", "    if False:")],
        ["tests/test_stats.py::test_noise_variance_of_an_output_flat_over_most_of_the_record",
         "tests/test_blocks.py::test_the_block_error_of_an_output_flat_over_most_of_the_record"],
    ),
    "the noise's zeros left out however few": (
        "vojax/_stats.py",
        [("    if 2 * moving.size < dk.size:  # most exactly zero", "    if moving.size:")],
        ["tests/test_stats.py::test_noise_variance_of_an_output_flat_over_most_of_the_record"],
    ),
    "the lag-1 correlation with the mean left in": (
        "vojax/_stats.py",
        [("    e = e - np.mean(e)\n", "")],
        ["tests/test_stats.py::test_lag1_correlation_is_of_the_sequence_about_its_mean"],
    ),
    "the prediction errors' correlation counts the first error": (
        "vojax/_stats.py",
        [("    errors = (np.asarray(y) - np.asarray(y_pred))[np.asarray(fitted)][1:]",
          "    errors = (np.asarray(y) - np.asarray(y_pred))[np.asarray(fitted)]")],
        ["tests/test_first_pass.py", "tests/test_coloured.py", "tests/test_tracker.py"],
    ),
    "the delta method gives a finite error on an undetermined coefficient": (
        "vojax/_stats.py",
        [("    var = np.where(np.any((np.abs(jac) > 0) & loose[None, :], axis=1), np.inf, var)\n",
          "")],
        ["tests/test_refit_recordings.py"],
    ),
    "every memory's order sensitivity along twice the direction": (
        "vojax/_kernels/_base.py",
        [("(b,), (jnp.ones_like(b),))", "(b,), (2.0 * jnp.ones_like(b),))")],
        [KERNELS],
    ),
    "a count below its least passes": (
        "vojax/_values.py",
        [("    if not low <= int(value) <= high:", "    if not int(value) <= high:")],
        ["tests/test_compare.py::test_bad_calls_are_refused", "tests/test_blocks.py"],
    ),
    "a flag takes any truthy value": (
        "vojax/_values.py",
        [("    if not isinstance(value, (bool, np.bool_)):\n        raise TypeError(f\"`{name}` must be True or False",
          "    if value is None:\n        raise TypeError(f\"`{name}` must be True or False")],
        ["tests/test_validation.py::test_a_bad_argument_is_named_not_left_to_numpy"],
    ),
    "output files keep the temporary file's 0600": (
        "vojax/_io.py",
        [("        os.chmod(tmp, _file_mode())  # mkstemp creates 0600 whatever the umask\n", "")],
        ["tests/test_tables.py::test_json_is_strict_and_files_honour_the_umask"],
    ),
    "strict JSON leaves the non-finite numbers of a tuple": (
        "vojax/_io.py",
        [("    if isinstance(data, (list, tuple)):", "    if isinstance(data, list):")],
        ["tests/test_checks_io.py::test_json_outputs_hold_no_non_finite_number_at_any_depth"],
    ),
    "the parallel filter's mean loses the later element's information": (
        "vojax/_tracker/_parallel.py",
        [("        _mv(m, b1 + _mv(c1, e2)) + b2,", "        _mv(m, b1) + b2,")],
        ["tests/test_parallel.py::test_tracker_through_the_parallel_schedule_equals_the_sequential_one"],
    ),
    "the parallel filter's information vector loses the earlier mean": (
        "vojax/_tracker/_parallel.py",
        [("        _mv(n, e2 - _mv(j2, b1)) + e1,", "        _mv(n, e2) + e1,")],
        ["tests/test_parallel.py::test_tracker_through_the_parallel_schedule_equals_the_sequential_one"],
    ),
    "the parallel filter's likelihood blind to the innovation variance's gradient": (
        "vojax/_tracker/_parallel.py",
        [("(LOG_2PI + jnp.log(s) +", "(LOG_2PI + jnp.log(jax.lax.stop_gradient(s)) +")],
        ["tests/test_parallel.py::test_parallel_likelihood_gradient_equals_the_sequential_one"],
    ),
}
