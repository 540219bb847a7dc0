"""Does the test suite catch small, plausible bugs? Each planted bug below is applied, one at a
time, to a temporary copy of the repository; the tests that should catch it are run there; the
table says which bugs survived. Run it before closing an issue that changes the law, the
refit, the models, the tracker or the batch, and report the count.

    python scripts/mutation_check.py [--only NAME ...] [--list] [--workers N]

A mutation whose text is no longer found in the code is reported as STALE (update it with the
code). Exit status: the number of survivors (0 = every planted bug was caught).
"""

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
LAW = "tests/test_law_transcription.py"

# name: (file, [(old, new), ...], tests that should fail)
MUTATIONS = {
    "order law uses the a-priori error": (
        "vojax/_adaptive/_law.py",
        [("self.order.step(alpha, lam_k, y_k - y_hat, h)",
          "self.order.step(alpha, lam_k, y_k - jnp.dot(state.p, phi), h)")],
        [LAW],
    ),
    "online tracker's y_pred taken after the update": (
        "vojax/_tracker/_filter.py",
        [("            if i == 0:\n                y_pred = h0", "            y_pred = h0")],
        ["tests/test_tracker.py::test_online_filter_against_a_textbook_iterated_ekf"],
    ),
    "online tracker relinearises from the iterate, not the prediction": (
        "vojax/_tracker/_filter.py",
        [("mean, cov, *_ = update(prior_mean, prior_cov, jac, z, r, mask_k)",
          "mean, cov, *_ = update(theta, prior_cov, jac, z, r, mask_k)")],
        ["tests/test_tracker.py::test_online_filter_against_a_textbook_iterated_ekf"],
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
    "refit covariance uses sigma, not sigma squared": (
        "vojax/_refit_solve.py",
        [("    cov = sigma2 * inverse\n    raw, raw_sd", "    cov = jnp.sqrt(sigma2) * inverse\n    raw, raw_sd")],
        ["tests/test_refit.py"],
    ),
    "batch writes the first record's law output for every record": (
        "vojax/_data/_law_batch.py",
        [("jax.tree_util.tree_map(lambda a: a[i][:num], batch)",
          "jax.tree_util.tree_map(lambda a: a[0][:num], batch)")],
        ["tests/test_batch.py"],
    ),
    "Kelvin–Voigt sign flipped in the regression and the parameter map": (
        "vojax/_models/_viscoelastic.py",
        [('"k": -p[..., 1] * eta', '"k": p[..., 1] * eta'),
         ("jnp.array([1.0 / eta, -k / eta])", "jnp.array([1.0 / eta, k / eta])")],
        ["tests/test_models.py"],
    ),
    '--area and --length swapped': (
        'vojax/_data/_regressors.py',
        [
            ('stress = record.inputs[:, 0] / (area or 1.0)',
             'stress = record.inputs[:, 0] / (length or 1.0)'),
            ('strain = record.output / output_scale(model, length)',
             'strain = record.output / (area or 1.0)'),
        ],
        ['tests/test_data_cli.py'],
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
    'RTS smoother gain transposed': (
        'vojax/_tracker/_kalman.py',
        [
            ('g = cholesky_solve(p_pred, p if not f_k else p * f_k[0][:, None]).T',
             'g = cholesky_solve(p_pred, p if not f_k else p * f_k[0][:, None])'),
        ],
        ['tests/test_tracker.py'],
    ),
    'diagnostics trust an unconverged estimate': (
        'vojax/_diagnostics.py',
        [
            ('at_bound < s.bound_fraction and bool(converged) and not noise_edge',
             'at_bound < s.bound_fraction and not noise_edge'),
        ],
        ['tests/test_tracker.py'],
    ),
    "tracker's chain rule dα/dβ dropped": (
        "vojax/_tracker/_model.py",
        [("h_beta = jnp.sum(p * dphi, axis=-1) * dalpha", "h_beta = jnp.sum(p * dphi, axis=-1)")],
        ["tests/test_tracker.py"],
    ),
    "tracker's order drift doubled": (
        "vojax/_tracker/_model.py",
        [("qo = jnp.exp(self.log_q_order) * frac", "qo = jnp.exp(self.log_q_order) * frac * 2")],
        ["tests/test_tracker.py"],
    ),
    "the second opinion starts on a bound of the order's range": (
        "vojax/_refit.py",
        [("    order0 = _start(order0, bounds)\n    u2, y, _, x0, _ = check_options(u, y, dt, None, order0, bounds, memory, rule, x0, None)",
          "    u2, y, _, x0, _ = check_options(u, y, dt, None, order0, bounds, memory, rule, x0, None)")],
        ["tests/test_refit.py::test_the_second_opinion_also_starts_inside_a_bound"],
    ),
    "a refit's start left on the bound (no margin)": (
        "vojax/_refit_inputs.py",
        [("margin = BOUND_MARGIN * (bounds[1] - bounds[0])\n    return", "margin = 0.0 * (bounds[1] - bounds[0])\n    return")],
        ["tests/test_refit.py::test_a_start_on_a_bound_starts_inside_and_an_order_beyond_the_range_sits_at_its_bound",
         "tests/test_refit.py::test_the_second_opinion_also_starts_inside_a_bound"],
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
    "the command prints the next steps in Python's words": (
        "vojax/_cli/_commands.py",
        [('block = say_block(answer, a["finding"], a["next_steps"], "cli")',
          'block = [answer, a["message"]]')],
        ["tests/test_data_cli.py::test_cli_identify_end_to_end"],
    ),
    "the tracker forgets that the offset was given": (
        "vojax/_tracker/_estimator.py",
        [("(self.x0 is not None, Step.X0)", "(False, Step.X0)")],
        ["tests/test_steps.py::test_the_tracker_names_what_its_options_already_said"],
    ),
    "refit mask ignored in the residuals": (
        "vojax/_refit_solve.py",
        [("        * sw / y_scale,\n        optx.LevenbergMarquardt(", "        / y_scale,\n        optx.LevenbergMarquardt(")],
        ["tests/test_refit.py"],
    ),
    "refit's tolerance passed as a Python number (a retrace per value)": (
        'vojax/_refit_active.py',
        [
            ('np.asarray(solver["rtol"], dtype),\n            np.asarray(solver["atol"], dtype),',
             'float(solver["rtol"]),\n            float(solver["atol"]),'),
        ],
        ['tests/test_retracing.py::test_refit_traces_once'],
    ),
    "order-free history read one sample late": (
        "vojax/_kernels/_exponential.py",
        [("return jnp.concatenate([jnp.zeros_like(after[:1]), after[:-1]]), previous",
          "return jnp.concatenate([jnp.zeros_like(after[:2]), after[:-2]]), previous")],
        ["tests/test_kernels.py::test_order_free_history_equals_the_scan"],
    ),
    "refit Jacobian's order column without the chain rule dβ/draw": (
        "vojax/_refit_solve.py",
        [("by_order = (dphi_t @ (p_t[:width] * active[:width]))[:, None] * dbeta",
          "by_order = (dphi_t @ (p_t[:width] * active[:width]))[:, None] * jnp.ones_like(dbeta)")],
        ["tests/test_refit.py::test_standard_errors_are_the_gauss_newton_covariance",
         "tests/test_refit.py::test_knot_standard_errors_from_an_autodiff_jacobian"],
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
    "refit with an origin fits the added sample": (
        "vojax/_refit_inputs.py",
        [("np.concatenate([[0.0], w]))", "np.concatenate([[1.0], w]))")],
        ["tests/test_refit_recordings.py"],
    ),
    "sign constraints never hold a coefficient": (
        "vojax/_refit_solve.py",
        [("broken = (active[:count] > 0) & (signs * coefficients < 0)",
          "broken = (active[:count] > 0) & (signs * coefficients < -np.inf)")],
        ["tests/test_refit_recordings.py::test_sign_constraint_holds_the_broken_coefficient_at_zero"],
    ),
    "refit weights not square-rooted in the residuals": (
        "vojax/_refit.py",
        [("sw = jnp.asarray(np.sqrt(w), u2.dtype)", "sw = jnp.asarray(w, u2.dtype)")],
        ["tests/test_refit_recordings.py::test_weights_are_weighted_least_squares"],
    ),
    "Zener's E1 from the wrong sum": (
        "vojax/_models/_viscoelastic.py",
        [("e1 = total - e0", "e1 = total + e0")],
        ["tests/test_models.py"],
    ),
    "resampling smooths away a fast phase": (
        "vojax/_data/_record.py",
        [("if step > RESAMPLE_MAX_RATIO * steps[shortest]:", "if step > 1e9 * steps[shortest]:")],
        ["tests/test_data_cli.py"],
    ),
    "refit covariance by a pseudo-inverse of the normal matrix": (
        "vojax/_refit_solve.py",
        [("    cov = scale[:, None] * ((vt.T * inv_s2) @ vt) * scale[None, :]",
          "    cov = jnp.linalg.pinv(jac.T @ jac + jnp.diag(1.0 - free))")],
        ["tests/test_refit_recordings.py"],
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
    "identification.csv loses the NaN blanks": (
        "vojax/_data/_outputs.py",
        [("[repr(v) if ok else \"\" for v, ok in zip(row, oks)]", "[repr(v) for v in row]")],
        ["tests/test_outputs.py::test_identification_table_round_trips_floats_and_leaves_non_finite_blank"],
    ),
    "small SPD solve divides by the wrong pivot": (
        "vojax/_linalg.py",
        [("            low[i][j] = (a[i, j] - sum(low[i][k] * low[j][k] for k in range(j))) / low[j][j]",
          "            low[i][j] = (a[i, j] - sum(low[i][k] * low[j][k] for k in range(j))) / low[i][i]")],
        ["tests/test_tracker.py::test_small_spd_solve_equals_lapack"],
    ),
    "first pass forgets which run was best": (
        "vojax/_tracker/_smoother.py",
        [("            best, i_best, s_best = sm, b, s\n", "            best, s_best = sm, s\n")],
        ["tests/test_tracker.py::test_first_pass_keeps_the_best_run_and_falls_back_on_the_full_budget",
         "tests/test_tracker.py::test_a_batch_of_runs_keeps_the_best_by_evidence_and_by_objective"],
    ),
    'first pass never retried with the full budget': (
        'vojax/_tracker/_tuning.py',
        [
            ('    passes = [(noise, budget) for budget in budgets for noise in noises]',
             '    passes = [(noise, s.grid_max_iter) for noise in noises]'),
        ],
        ['tests/test_tracker.py::test_first_pass_keeps_the_best_run_and_falls_back_on_the_full_budget',
         'tests/test_tracker.py::test_tune_tries_each_noise_level_then_the_full_budget'],
    ),
    'the full budget tried at the first noise level only': (
        'vojax/_tracker/_tuning.py',
        [
            ('    passes = [(noise, budget) for budget in budgets for noise in noises]',
             '    passes = [*((noise, s.grid_max_iter) for noise in noises), (noises[0], s.max_iter)]'),
        ],
        ['tests/test_tracker.py::test_tune_tries_each_noise_level_then_the_full_budget'],
    ),
    "golden section keeps the wrong side": (
        "vojax/_tracker/_start.py",
        [("        if fa < fb:\n            hi, b, fb = b, a, fa", "        if fa > fb:\n            hi, b, fb = b, a, fa")],
        ["tests/test_tracker.py::test_constant_fit_finds_the_least_squares_order_of_a_dense_scan"],
    ),
    "diagnostics ignore the order's trade-off with the parameters' drift": (
        "vojax/_diagnostics.py",
        [("    traded = held_shift is not None and held_shift > width\n", "    traded = False\n")],
        ["tests/test_tracker.py::test_diagnostics_refuse_unconverged_or_noise_at_its_floor"],
    ),
    'held smoothing keeps the tuned parameter drift': (
        'vojax/_tracker/_mixture.py',
        [
            ('        held = Hyper(jnp.log(to_device(np.asarray(np.exp(log_drift), dtype))),\n                     jnp.log(to_device(np.asarray(s.constant_drift, dtype))),',
             '        held = Hyper(jnp.log(to_device(np.asarray(np.exp(log_drift), dtype))),\n                     hyper.log_q_params,'),
        ],
        ['tests/test_held_level.py::test_the_held_smoothing_holds_the_parameters_whatever_the_tuned_drift'],
    ),
    "first pass never tried at the constant fit's misfit": (
        'vojax/_tracker/_fit.py',
        [
            ('    if misfit >= s.misfit_ratio * noise0:\n',
             '    if False:\n'),
        ],
        ['tests/test_tracker.py::test_output_smoother_than_the_model_converges_with_the_noise_it_leaves',
         'tests/test_tracker.py::test_first_pass_noise_levels_follow_the_data_and_the_constant_fits_misfit'],
    ),
    "first pass noise taken from the constant fit's misfit always": (
        'vojax/_tracker/_fit.py',
        [
            ('    noises = (noise0,)\n',
             '    noises = (misfit,)\n'),
            ('        noises = (misfit, noise0) if noise_data < s.noise_min else (noise0, misfit)',
             '        noises = (misfit,)'),
        ],
        ['tests/test_tracker.py::test_smoother_recovers_a_ramp_order_driven_by_the_myocardium_stretch'],
    ),
    "noise floor from the second differences alone": (
        'vojax/_tracker/_fit.py',
        [
            ('max(s.noise_floor * least, s.noise_min)',
             'max(s.noise_floor * noise_data, s.noise_min)'),
        ],
        ['tests/test_tracker.py::test_noise_floor_is_the_noise_where_the_signal_curves_at_the_sampling_scale',
         'tests/test_tracker.py::test_an_oscillation_sampled_coarsely_is_identified'],
    ),
    "held smoothing stops at its first ladder": (
        'vojax/_tracker/_mixture.py',
        [('    while len(runs) < budget:', '    while False:')],
        ['tests/test_held_search.py::test_the_search_ends_within_a_quarter_step_of_the_evidence_peak'],
    ),
    "held smoothing's pair of refinements run as one side only": (
        'vojax/_tracker/_mixture.py',
        [('            at(best - fraction * step, best + fraction * step)',
          '            at(best - fraction * step)')],
        ['tests/test_held_search.py::test_the_runs_side_by_side_are_the_runs_one_by_one'],
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
    "held smoothing not refined between its rungs": (
        'vojax/_tracker/_mixture.py',
        [('    for fraction in (0.5, 0.25):', '    for fraction in ():')],
        ['tests/test_held_search.py::test_the_search_ends_within_a_quarter_step_of_the_evidence_peak'],
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
    "the held answer without its held scales": (
        "vojax/_tracker/_band.py",
        [("held.var + spread", "held.var")],
        ["tests/test_band.py::test_the_held_answer_weighs_its_own_held_scales_by_their_likelihood"],
    ),
    "the level profile about the tuned smoothing where the held one answers": (
        "vojax/_tracker/_fit.py",
        [("level_profile(problem, *held, fit_noise, whiten, kind=\"held_level\")",
          "level_profile(problem, tuning, sm, fit_noise, whiten, kind=\"held_level\")")],
        ["tests/test_held_level.py::test_the_level_profile_runs_about_the_smoothing_with_the_parameters_constant"],
    ),
    "the held smoothing's scales floored at the degrees of freedom": (
        "vojax/_tracker/_band.py",
        [('    at_dof = kind == "level"\n', "    at_dof = True\n")],
        ["tests/test_band.py::test_the_held_answer_weighs_its_own_held_scales_by_their_likelihood"],
    ),
    "the held smoothing's scales weighed however far the evidence excludes them": (
        "vojax/_tracker/_band.py",
        [("level_spread([e for e in explanations if plausible(e)], held,",
          "level_spread(explanations, held,")],
        ["tests/test_band.py::test_the_held_answer_weighs_its_own_held_scales_by_their_likelihood"],
    ),
    "the held smoothing's scales unioned with the free band": (
        "vojax/_tracker/_band.py",
        [('INTEGRATED = ("start", "order_drift", "level")\n',
          'INTEGRATED = ("start", "order_drift", "level", "held_level")\n')],
        ["tests/test_band.py::test_the_held_answer_weighs_its_own_held_scales_by_their_likelihood"],
    ),
    "a climb collapsed whatever the parameters do": (
        'vojax/_tracker/_tuning.py',
        [('            and tuning.parameter_drift > s.held_ratio * s.constant_drift)', '            )')],
        ['tests/test_tuning_starts.py::test_a_climb_has_collapsed_only_with_the_order_at_its_floor_and_the_parameters_drifting'],
    ),
    "refit keeps coefficients that are rounding": (
        "vojax/_refit_solve.py",
        [("ROUNDING = 1e-12\n", "ROUNDING = 0.0\n")],
        ["tests/test_refit.py::test_a_coefficient_fitted_to_rounding_is_exactly_zero",
         "tests/test_cli_recordings.py::test_an_undetermined_parameter_is_written_not_failed"],
    ),
    "parameter check compares the recursion with itself": (
        "vojax/testing.py",
        [('_compare("p", "recursion vs batch sums (23)", p, p_batch, rtol)',
          '_compare("p", "recursion vs batch sums (23)", p, p, rtol)')],
        ["tests/test_checks_io.py::test_check_parameter_sensitivity_fails_on_a_recursion_that_is_not_23"],
    ),
    "refit's active set ranks sign violations by magnitude": (
        "vojax/_refit_active.py",
        [("        if not _hold_worst(active, signs, out[\"p\"], se):",
          "        if not _hold_worst(active, signs, out[\"p\"], 1.0):")],
        ["tests/test_refit.py::test_sign_constraints_do_not_depend_on_the_units_of_the_inputs"],
    ),
    "fixed-order refit's active set ranks by magnitude": (
        "vojax/_refit_solve.py",
        [("        if not _hold_worst(active, signs, np.asarray(p[:count]), scale):",
          "        if not _hold_worst(active, signs, np.asarray(p[:count]), 1.0):")],
        ["tests/test_refit.py::test_sign_constraints_do_not_depend_on_the_units_of_the_inputs"],
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
        ["tests/test_data_cli.py::test_one_default_and_one_name_per_estimator"],
    ),
    "the law's settings silently ignored by the tracker": (
        "vojax/_identify.py",
        [("        if given:\n            raise ValueError(\n                f\"{', '.join(given)} set the paper's law",
          "        if False:\n            raise ValueError(\n                f\"{', '.join(given)} set the paper's law")],
        ["tests/test_tracker.py::test_identify_kalman_validation"],
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
        ["tests/test_outputs.py::test_a_folder_is_current_only_with_the_summary_of_its_own_run"],
    ),
    "a varying order read as one number": (
        "vojax/_refit_result.py",
        [("        if not self.constant:\n            raise ValueError(", "        if False:\n            raise ValueError(")],
        ["tests/test_results.py::test_a_varying_refit_refuses_a_single_number"],
    ),
    "a decimal comma read as a separator of thousands": (
        "vojax/_data/_read.py",
        [('values.append(float(text.replace(",", ".") if decimal == "," else text))',
          'values.append(float(text.replace(",", "") if decimal == "," else text))')],
        ["tests/test_data_cli.py::test_semicolons_decimal_commas_and_a_hint_for_them"],
    ),
    "the overview hides what was not identified": (
        "vojax/_plotting.py",
        [('        known = np.array([str(r.get(f"{tracker}_identified")) == "True" for r in rows])',
          '        known = np.array([True for r in rows])')],
        ["tests/test_figures.py::test_the_overview_marks_what_was_not_identified_and_what_failed"],
    ),
    "an undetermined physical parameter fails the record": (
        "vojax/_data/_outputs.py",
        [("    if \"refit\" in parts:\n", "    if False:\n")],
        ["tests/test_cli_recordings.py::test_an_undetermined_parameter_is_written_not_failed"],
    ),
    "mixture weights ignore the evidence": (
        "vojax/_tracker/_smoother.py",
        [("    weights[kept] = np.exp(scores[kept] - top)", "    weights[kept] = 1.0")],
        ["tests/test_tracker.py::test_mixture_of_modes_is_the_evidence_weighted_spread"],
    ),
    "mixture counts a mode found twice": (
        "vojax/_tracker/_smoother.py",
        [(") >= same\n", ") >= -1.0\n")],
        ["tests/test_tracker.py::test_mixture_of_modes_is_the_evidence_weighted_spread"],
    ),
    "tracker's band without its alternatives": (
        'vojax/_tracker/_fit.py',
        [
            ('    if not tuning.tuned:\n        return np.asarray(sm.cov)[:, 0, 0], None, []',
             '    if True:\n        return np.asarray(sm.cov)[:, 0, 0], None, []'),
        ],
        ['tests/test_tracker.py::test_band_covers_the_other_modes_in_proportion_to_their_evidence'],
    ),
    'correlated prediction errors not refused': (
        'vojax/_diagnostics.py',
        [
            ('        and calibrated and not coloured and unstable_from is None and not coarse',
             '        and calibrated and unstable_from is None and not coarse'),
        ],
        ['tests/test_tracker.py::test_correlated_prediction_errors_are_refused_and_coloured_noise_is_modelled'],
    ),
    'the law claims identified': (
        'vojax/_diagnostics.py',
        [
            ('        and calibrated and not coloured and unstable_from is None and not coarse',
             '        and not coloured and unstable_from is None and not coarse'),
        ],
        ['tests/test_adaptive.py::test_the_law_never_claims_a_confidence_band'],
    ),
    "disagreement reported for overlapping bands": (
        "vojax/_data/_parts.py",
        [("    if not (hi_a < lo_r or hi_r < lo_a):", "    if False:")],
        ["tests/test_outputs.py::test_disjoint_bands_of_two_estimators_are_reported_with_what_the_data_support"],
    ),
    "disagreement credits the tracker without correlated refit residuals": (
        "vojax/_data/_parts.py",
        [('    if verdict == "identified" and correlated:', '    if verdict == "identified":')],
        ["tests/test_outputs.py::test_disjoint_bands_of_two_estimators_are_reported_with_what_the_data_support"],
    ),
    "tables keep spreadsheet formulas": (
        "vojax/_data/_tables.py",
        [("    if isinstance(value, str) and value.startswith(GUARDED):",
          "    if False:")],
        ["tests/test_outputs.py::test_tables_do_not_carry_spreadsheet_formulas"],
    ),
    "Φ at a constant order takes the columns out of order": (
        "vojax/_tracker/_start.py",
        [("    padded[:, :m] = x\n", "    padded[:, :m] = x[:, ::-1]\n")],
        ["tests/test_tracker.py::test_phi_of_each_column_equals_the_memory_run_on_all_columns"],
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
    "--noise with a key missing let through": (
        "vojax/_cli/_types.py",
        [("    if sorted(keys) != sorted(NOISE_KEYS) or", "    if")],
        ["tests/test_noise_option.py::test_the_command_line_noise_is_in_the_files_unit"],
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
    "the least drift's constant parameters judged by the penalised ladder only": (
        "vojax/_tracker/_trade.py",
        [("    if float(res @ res) * scale <= limit:\n        return 0.0",
          "    if False:\n        return 0.0")],
        ["tests/test_band.py::test_least_drift_against_a_brute_force_search"],
    ),
    "compare's likelihood counts every sample, not the window's": (
        "vojax/_compare.py",
        [("    num = int(inside.sum())\n    res = scaled(fit)[inside]\n",
          "    num = strain.size\n    res = scaled(fit)\n")],
        ["tests/test_compare_window.py::test_a_window_leaves_the_ringing_out_and_counts_only_its_samples"],
    ),
    "compare's held-out end is the record's, not the window's": (
        "vojax/_compare.py",
        [("times[idx[int(round((1 - holdout) * (idx.size - 1)))]]",
          "times[int(round((1 - holdout) * (times.size - 1)))]")],
        ["tests/test_compare_window.py::test_a_window_leaves_the_ringing_out_and_counts_only_its_samples"],
    ),
    "compare's relative likelihood without its Jacobian": (
        "vojax/_compare.py",
        [("        loglik -= float(np.sum(np.log(np.abs(strain[inside]))))\n",
          "        loglik -= 0.0\n")],
        ["tests/test_compare_window.py::test_relative_residuals_have_the_likelihood_of_proportional_noise"],
    ),
    "compare counts a given offset as a free number": (
        "vojax/_compare.py",
        [("    offset = 1 if isinstance(x0, str) else 0", "    offset = 1")],
        ["tests/test_compare_window.py::test_a_given_offset_is_held_and_not_counted"],
    ),
    "the batch compares over the whole record, not the refit's window": (
        "vojax/_data/_compute.py",
        [("r, area, length, **{k: fit[k] for k in FIT_OPTIONS if k in fit})",
          "r, area, length)")],
        ["tests/test_compare_window.py::test_the_batch_compares_over_the_refits_window_in_the_files_time"],
    ),
    "compare's fit of the first part ignores the relative option": (
        "vojax/_compare.py",
        [("    fitting = dict(x0=x0, origin=origin, relative=relative)",
          "    fitting = dict(x0=x0, origin=origin)")],
        ["tests/test_compare_window.py::test_relative_residuals_have_the_likelihood_of_proportional_noise"],
    ),
    "the comparison's Zener row always takes the Maxwell fit": (
        "vojax/_compare.py",
        [("    if rss(nested, inside) < rss(fit, inside):\n", "    if True:\n")],
        ["tests/test_compare.py::test_the_comparison_finds_each_law_with_the_noise_below_its_feature"],
    ),
    "trade interval without its χ² test": (
        "vojax/_tracker/_trade.py",
        [("        if not np.all(np.isfinite(c)) or not chi2_fits(c.min(), dof):",
          "        if not np.all(np.isfinite(c)):")],
        ["tests/test_tracker.py::test_trade_interval_against_an_independent_profile"],
    ),
    "trade interval ends on grid orders": (
        "vojax/_tracker/_trade.py",
        [("        found.append(lo if i == 0 else crossing(i, i - 1))",
          "        found.append(lo if i == 0 else alphas[i - 1])")],
        ["tests/test_tracker.py::test_trade_interval_against_an_independent_profile"],
    ),
    'trade interval not widening the band': (
        'vojax/_tracker/_fit.py',
        [
            ('    explanations = tuple(explanations + ([] if held is None else [held]) + traded)',
             '    explanations = tuple(explanations + ([] if held is None else [held]))'),
        ],
        ['tests/test_tracker.py::test_parameters_constant_holds_their_drift_and_keeps_the_trade_out_of_its_band'],
    ),
    "parameters='constant' still lets them drift": (
        "vojax/_tracker/_fit.py",
        [('    hold = parameters == "constant"', "    hold = False")],
        ["tests/test_tracker.py::test_parameters_constant_holds_their_drift_and_keeps_the_trade_out_of_its_band"],
    ),
    "autocorrelation limit ignores the record's length": (
        "vojax/_stats.py",
        [("    return float(min(MAX_CORRELATION, max(z, CORRELATION_FLOOR)))",
          "    return MAX_CORRELATION")],
        ["tests/test_tracker.py::test_correlated_prediction_errors_are_refused_and_coloured_noise_is_modelled"],
    ),
    "a file vojax did not write is overwritten": (
        "vojax/_data/_paths.py",
        [("        if name not in known and (target.exists() or target.is_symlink()):",
          "        if False:")],
        ["tests/test_outputs.py::test_vojax_overwrites_only_what_it_wrote"],
    ),
    "time left paced from the start": (
        "vojax/_progress.py",
        [("    return (elapsed - first) / (done - 1) * (total - done)",
          "    return elapsed / done * (total - done)")],
        ["tests/test_batch.py::test_time_left_is_paced_after_the_first_record"],
    ),
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
        ["tests/test_tracker.py::test_kalman_and_rts_with_an_ar1_state_equal_the_dense_posterior"],
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
        ["tests/test_tracker.py::test_smoother_mode_and_bands_against_a_dense_numpy_posterior"],
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
         "tests/test_tracker.py::test_output_smoother_than_the_model_converges_with_the_noise_it_leaves"],
    ),
    "coloured noise never tried": (
        "vojax/_tracker/_coloured.py",
        [("    if not r1 > correlation_limit(count):", "    if True:")],
        ["tests/test_tracker.py::test_correlated_prediction_errors_are_refused_and_coloured_noise_is_modelled"],
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
    "level profile's runs not pinned (the parameters' prior left wide)": (
        'vojax/_tracker/_level.py',
        [
            ('p[1 : 1 + n, 1 : 1 + n] = np.diag(s.level_pin',
             'p[1 : 1 + n, 1 : 1 + n] = np.diag(1e4'),
        ],
        ['tests/test_envelope.py'],
    ),
    "the held scales may narrow the held band": (
        'vojax/_tracker/_band.py',
        [
            ('        spread = np.maximum(level_spread([e for e in explanations if plausible(e)], held,\n'
             '                                         level_weights, "held_level"), 0.0)',
             '        spread = level_spread([e for e in explanations if plausible(e)], held,\n'
             '                                         level_weights, "held_level")'),
        ],
        ['tests/test_band.py'],
    ),
    "the held scales profiled about a held band too wide to answer": (
        'vojax/_tracker/_fit.py',
        [
            ('        problem.span) <= s.identified_halfwidth', '        problem.span) <= np.inf'),
        ],
        ['tests/test_held_level.py'],
    ),
    "a run whose optimiser failed stands for the data if its chi2 passes": (
        'vojax/_tracker/_explanations.py',
        [
            ('        return self.fits and self.converged', '        return self.fits'),
        ],
        ['tests/test_band.py'],
    ),
    "the band's members need not fit (every alternative widens the band)": (
        'vojax/_tracker/_band.py',
        [
            ('              and e.holds and plausible(e)]',
             '              and e.converged and plausible(e)]'),
        ],
        ['tests/test_band.py'],
    ),
    "level profile never run (the constant setting's band as before it)": (
        'vojax/_tracker/_fit.py',
        [
            ('    if hold or tuning.parameter_drift <= s.held_ratio * s.constant_drift:\n        explanations += level_profile(',
             '    if False:\n        explanations += level_profile('),
        ],
        ['tests/test_calibration.py::test_constant_parameters_band_covers_the_level_another_scale_allows',
         'tests/test_tracker.py::test_parameters_constant_holds_their_drift_and_keeps_the_trade_out_of_its_band'],
    ),
    'level profile keeps a run that did not converge': (
        'vojax/_tracker/_level.py',
        [
            ('fitting(residuals, problem.mask, n, fit_noise, whiten) & np.isfinite(scores)',
             'fitting(residuals, problem.mask, n, fit_noise, whiten)'),
        ],
        ['tests/test_envelope.py'],
    ),
    "smoother's damping falls by ρ, not by Nielsen's cubic": (
        "vojax/_tracker/_smoother.py",
        [("scale = jnp.maximum(MU_DOWN, 1.0 - (2.0 * rho - 1.0) ** 3)",
          "scale = jnp.maximum(MU_DOWN, 1.0 - rho)")],
        ["tests/test_tracker.py::test_damping_follows_nielsens_rule"],
    ),
    "smoother's damping keeps growing after an accepted step (ν not reset)": (
        "vojax/_tracker/_smoother.py",
        [("jnp.where(accepted, jnp.full_like(nu, 2.0), 2.0 * nu)", "2.0 * nu")],
        ["tests/test_tracker.py::test_damping_follows_nielsens_rule"],
    ),
    "a heavily damped step's tiny decrease ends the smoother's iteration": (
        "vojax/_tracker/_smoother.py",
        [("jnp.where(accepted & (mu <= MU_START), dec,", "jnp.where(accepted, dec,")],
        ["tests/test_tracker.py::test_only_a_barely_damped_step_can_end_the_iteration"],
    ),
    "trade-off's finer drift pays 2 per knot, not per coefficient of every input": (
        "vojax/_tracker/_trade.py",
        [("> 2 * n * (s.trade_knots_fine - s.trade_knots)",
          "> 2 * (s.trade_knots_fine - s.trade_knots)")],
        ["tests/test_tracker.py::test_the_trade_offs_finer_drift_pays_two_per_coefficient_of_every_input"],
    ),
    "the widened band's σ is half its width (every widened band doubled)": (
        "vojax/_tracker/_band.py",
        [("hi) - np.minimum(lower, lo)) / 4)", "hi) - np.minimum(lower, lo)) / 2)")],
        ["tests/test_band.py::test_the_breakdown_drift_is_the_least_drift_of_an_order_outside_that_fits"],
    ),
    "the level profile rewards a fit below the noise": (
        "vojax/_tracker/_band.py",
        [("np.array([max(e.chi2, e.dof) if at_dof else e.chi2 for e in members])",
          "np.array([e.chi2 for e in members])")],
        ["tests/test_band.py::test_a_fit_below_the_noise_earns_no_weight_over_the_level_profile"],
    ),
    "posterior cost ignores the mask (unfitted samples counted)": (
        "vojax/_tracker/_model.py",
        [("    data = jnp.sum(mask * residuals * residuals) / r",
          "    data = jnp.sum(residuals * residuals) / r")],
        ["tests/test_tracker.py::test_damped_step_minimises_the_linearised_posterior_it_predicts"],
    ),
    "the band ignores the evidence floor of alternative smoothings": (
        'vojax/_tracker/_band.py',
        [
            ('        and e.evidence < tuned.evidence - evidence_floor)',
             '        and False)'),
        ],
        ['tests/test_band.py::test_a_drifting_smoothing_far_below_the_tuned_evidence_does_not_count',
         'tests/test_band.py::test_no_smoothing_far_below_the_tuned_evidence_widens_the_free_band'],
    ),
    "the free band covers integrated smoothings the evidence excludes": (
        'vojax/_tracker/_band.py',
        [
            ('                  if e.kind in INTEGRATED and e.holds and plausible(e)]',
             '                  if e.kind in INTEGRATED and e.holds]'),
        ],
        ['tests/test_band.py::test_no_smoothing_far_below_the_tuned_evidence_widens_the_free_band'],
    ),
    "the held scales' spread about the reference order left out of the band": (
        'vojax/_tracker/_band.py',
        [
            ('    spread = sum(wi * (e.var + (e.beta - reference.beta) ** 2) for wi, e in zip(w, members))',
             '    spread = sum(wi * e.var for wi, e in zip(w, members))'),
        ],
        ['tests/test_band.py::test_integrated_alternatives_are_weighed_not_unioned'],
    ),
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
    "refit's padding left in the coefficients' covariance": (
        "vojax/_refit_active.py",
        [('        out["p_cov"] = out["p_cov"][np.ix_(real, real)]\n', "")],
        ["tests/test_refit.py::test_the_four_laws_share_a_program_and_padding_changes_no_fit"],
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
    "the command line's offset not in the model's output unit": (
        "vojax/_data/_pipeline.py",
        [('extra["x0"] = float(settings["x0"]) / output_scale(model, length)',
          'extra["x0"] = float(settings["x0"])')],
        ["tests/test_offset.py::test_the_command_line_offset_is_in_the_files_unit"],
    ),
    'a known offset reported as estimated': (
        'vojax/_tracker/_fit.py',
        [
            ('x0=to_device(scales.y_ref if known else',
             'x0=to_device(scales.y_ref + 0.0 if False else'),
        ],
        ['tests/test_offset.py'],
    ),
    'the breakdown set by any drifting alternative, inside the band or not': (
        'vojax/_tracker/_band.py',
        [
            ('if max(e.drift - reference.drift, 0.0) > drift_floor and outside(m[0], band, half):',
             'if max(e.drift - reference.drift, 0.0) > drift_floor:'),
        ],
        ['tests/test_band.py'],
    ),
    'the stated band ignores the statement about the parameters': (
        'vojax/_tracker/_band.py',
        [
            ('                    e.drift <= max(stated_drift, reference.drift) + drift_floor):',
             '                    True):'),
        ],
        ['tests/test_band.py', 'tests/test_verdict.py::test_a_drift_bound_admits_the_explanations_that_drift_no_more'],
    ),
    "the level profile's held scales left out of the reference's variance": (
        'vojax/_tracker/_band.py',
        [
            ('    if not levels:',
             '    if True:'),
        ],
        ['tests/test_band.py'],
    ),
    'the held scales weighted by exp(+Δχ²/2)': (
        'vojax/_tracker/_band.py',
        [
            ('    w = np.exp(-(chi2 - chi2.min()) / 2)',
             '    w = np.exp((chi2 - chi2.min()) / 2)'),
        ],
        ['tests/test_band.py'],
    ),
    'outside judged over the first half': (
        'vojax/_tracker/_band.py',
        [
            ('    return bool(np.mean(out[half:]) > 0.5)',
             '    return bool(np.mean(out[:half]) > 0.5)'),
        ],
        ['tests/test_band.py::test_outside_is_judged_over_the_second_half'],
    ),
    "the parameters' drift measured over the padding too": (
        'vojax/_tracker/_explanations.py',
        [
            ('    p = np.asarray(params)[:span]',
             '    p = np.asarray(params)'),
        ],
        ['tests/test_band.py::test_relative_drift'],
    ),
    'a conditional verdict without reach': (
        'vojax/_diagnostics.py',
        [
            ('                          and reach > s.drift_floor)',
             '                          )'),
        ],
        ['tests/test_verdict.py::test_verdict_words_follow_the_stated_and_the_conditional_bands'],
    ),
    "the least drift's bisection keeps the failing side": (
        'vojax/_tracker/_trade.py',
        [
            ('        if c_mid <= limit:\n            lo, coef = mid, coef_mid',
             '        if c_mid > limit:\n            lo, coef = mid, coef_mid'),
        ],
        ['tests/test_band.py::test_least_drift_against_a_brute_force_search'],
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
    "refit's inflation inverted": (
        'vojax/_refit.py',
        [
            ('    return float(rho), float(np.sqrt((1 + r) / (1 - r)))',
             '    return float(rho), float(np.sqrt((1 - r) / (1 + r)))'),
        ],
        ['tests/test_refit.py::test_correlated_residuals_inflate_the_gauss_newton_errors'],
    ),
    "refit's order interval not widened with its errors": (
        'vojax/_refit.py',
        [
            ('    out["order_upper"] = lo + (hi - lo) * sig(raw + 2 * raw_sd)',
             '    pass'),
        ],
        ['tests/test_refit.py::test_correlated_residuals_inflate_the_gauss_newton_errors'],
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

    # --- the newer surface (issue: tests that fail when it is wrong) ---
    "a record named with a leading quote gains a row at each re-run": (
        "vojax/_data/_tables.py",
        [('GUARDED = FORMULA_START + ("\'",)', "GUARDED = FORMULA_START")],
        ["tests/test_properties.py::test_tables_read_back_exactly_what_was_written"],
    ),
    "compare answers a record with no stress": (
        "vojax/_compare.py",
        [("    if not np.any(stress):", "    if False:")],
        ["tests/test_compare.py::test_a_record_no_law_can_describe_is_refused_not_answered_with_nan"],
    ),
    "numbers whose squares leave float64 taken": (
        "vojax/_validate.py",
        [("    if size > hi or (0 < size < lo and not tiny):", "    if False:")],
        ["tests/test_compare.py::test_a_record_no_law_can_describe_is_refused_not_answered_with_nan"],
    ),
    "Bayes factor of a model not compared: a KeyError": (
        "vojax/_compare.py",
        [("            if not isinstance(name, str) or name not in ev:",
          "            if not isinstance(name, str):")],
        ["tests/test_compare.py::test_every_number_of_a_comparison_is_finite_and_its_questions_name_the_models"],
    ),
    "compare fits every sample of a long record": (
        "vojax/_compare.py",
        [("    if block > 1:  # block means", "    if False:  # block means")],
        ["tests/test_compare.py::test_a_long_record_is_compared_on_its_block_means"],
    ),
    "held-out error from the fit that saw the end": (
        "vojax/_compare.py",
        [("    miss = scaled(early)[tail]", "    miss = scaled(fit)[tail]")],
        ["tests/test_compare.py::test_the_held_out_error_is_the_prediction_of_a_fit_that_did_not_see_the_end"],
    ),
    '"strongly favoured" from a Bayes factor of 3': (
        "vojax/_compare.py",
        [('            strength = "strongly " if bf >= STRONG_BF else ""',
          '            strength = "strongly " if bf >= UNDECIDED_BF else ""')],
        ["tests/test_compare.py::test_the_verdict_words_follow_the_bayes_factor"],
    ),
    "A-criterion over the first half of the test": (
        "vojax/_protocol.py",
        [('hats_j[half:], cov[:k, :k], hats_j[half:])', 'hats_j[:half], cov[:k, :k], hats_j[:half])')],
        ["tests/test_design.py::test_the_optimal_ramp_for_a_moving_order_weighs_the_second_half"],
    ),
    "the tracker takes a truthy number for smooth": (
        "vojax/_tracker/_estimator.py",
        [('        object.__setattr__(self, "smooth", check.flag(self.smooth, "smooth"))\n', "")],
        ["tests/test_validation.py::test_a_bad_argument_is_named_not_left_to_numpy"],
    ),
    "refit takes no solver steps, a negative tolerance and 2 for a flag": (
        "vojax/_refit.py",
        [('    max_steps = check.count(max_steps, "max_steps", 1, 100_000)\n', ""),
         ('    throw, warn = check.flag(throw, "throw"), check.flag(warn, "warn")\n', "")],
        ["tests/test_refit_settles.py::test_the_solvers_options_are_checked"],
    ),
    "compare takes a fractional number of knots (as a constant order)": (
        "vojax/_compare.py",
        [('        knots = check.count(knots, "knots", 2, max(2, min(stress.size, max_points) // 4))',
          '        pass')],
        ["tests/test_compare.py::test_bad_calls_are_refused"],
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
    "the settling test never tries its chirp": (
        "vojax/_settling.py",
        [("            tries.append((min(cycles) / length, top, None))", "            pass")],
        ["tests/test_protocol.py::test_with_a_chirp_the_settling_test_picks_the_narrowest_of_sines_and_chirps"],
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
    "the threads split a pass's runs into equal shares (one idles behind the long runs)": (
        "vojax/_tracker/_threads.py",
        [("    size = 1 if workers > 1 and not batched else -(-count // workers)",
          "    size = -(-count // workers)")],
        ["tests/test_mappings.py::test_a_thread_that_is_done_takes_the_next_run"],
    ),
    "write_results writes before it checks (a bad summary loses the old one)": (
        "vojax/io.py",
        [("    _check_results(folder, columns, summary, record)\n", "")],
        ["tests/test_checks_io.py::test_bad_results_are_refused_before_anything_is_written"],
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
    "a stated drift bound ignored by the second clock (the union as with free parameters)": (
        "vojax/_tracker/_clock.py",
        [("    excluded = (bound is not None and clock_drift(o_alpha, scale) > bound) or (",
          "    excluded = False or (")],
        ["tests/test_clock.py::test_a_stated_bound_excludes_the_data_units_account_unless_covering_it_keeps_an_answer",
         "tests/test_clock.py::test_parameters_stated_constant_are_constant_on_the_spans_clock"],
    ),
    "a drift bound excludes the data unit's account as a constant statement does": (
        "vojax/_tracker/_estimator.py",
        [('            stated = self.settings.drift_floor if self.parameters == "constant" else None',
          '            stated = {"free": None, "constant": self.settings.drift_floor}.get(\n'
          '                self.parameters, self.parameters)')],
        ["tests/test_clock.py::test_parameters_stated_constant_are_constant_on_the_spans_clock"],
    ),
    "free parameters treated as a statement of none by the second clock": (
        "vojax/_tracker/_clock.py",
        [("    excluded = (bound is not None and clock_drift(o_alpha, scale) > bound) or (",
          "    excluded = (clock_drift(o_alpha, scale) > (bound or 0.0)) or (")],
        ["tests/test_clock.py::test_a_stated_bound_excludes_the_data_units_account_unless_covering_it_keeps_an_answer"],
    ),
    "the evidence between the two clocks never excludes the data unit's account": (
        "vojax/_tracker/_clock.py",
        [("        evidence_apart(res, fit, other) > evidence)", "        False)")],
        ["tests/test_clock.py::test_an_account_the_evidence_excludes_is_not_covered_whatever_the_statement",
         "tests/test_clock.py::test_the_data_exclude_the_data_units_account_where_an_oscillation_tells_them_apart"],
    ),
    "the clocks' evidence excludes an account under a drift bound too": (
        "vojax/_tracker/_estimator.py",
        [("            evidence = np.inf if bounded else self.settings.clock_evidence",
          "            evidence = self.settings.clock_evidence")],
        ["tests/test_clock.py::test_the_data_exclude_the_data_units_account_where_an_oscillation_tells_them_apart"],
    ),
    "the clocks' evidence taken whole, not per fitted point": (
        "vojax/_tracker/_clock.py",
        [("    return float(gain / max(points, 1))", "    return float(gain)")],
        ["tests/test_clock.py::test_the_evidence_per_fitted_point_between_the_two_clocks"],
    ),
    "the clocks' evidence counts masked points": (
        "vojax/_tracker/_clock.py",
        [("    points = span if mask is None else int(np.sum(np.asarray(mask)[:span] > 0))",
          "    points = span")],
        ["tests/test_clock.py::test_the_evidence_per_fitted_point_between_the_two_clocks"],
    ),
    "the clocks' evidence read the wrong way round": (
        "vojax/_tracker/_clock.py",
        [("    gain = res.tuning.log_likelihood - other.tuning.log_likelihood",
          "    gain = other.tuning.log_likelihood - res.tuning.log_likelihood")],
        ["tests/test_clock.py::test_the_evidence_per_fitted_point_between_the_two_clocks",
         "tests/test_clock.py::test_an_account_the_evidence_excludes_is_not_covered_whatever_the_statement"],
    ),
    "the tracker never hands the clocks' evidence threshold to the weighing": (
        "vojax/_tracker/_estimator.py",
        [("            evidence = np.inf if bounded else self.settings.clock_evidence",
          "            evidence = np.inf")],
        ["tests/test_clock.py::test_the_data_exclude_the_data_units_account_where_an_oscillation_tells_them_apart"],
    ),
    "an excluded clock covered whatever the union's width": (
        "vojax/_tracker/_clock.py",
        [("    if excluded and np.median(hi[half:] - lo[half:]) / 2 > answer:",
          "    if excluded and False:")],
        ["tests/test_clock.py::test_a_stated_bound_excludes_the_data_units_account_unless_covering_it_keeps_an_answer"],
    ),
    "the clock's drift measured without the span's unit": (
        "vojax/_tracker/_clock.py",
        [("    g = np.exp(np.log(scale) * (np.asarray(alpha) - np.mean(alpha)))",
          "    g = np.exp(np.asarray(alpha) - np.mean(alpha))")],
        ["tests/test_clock.py::test_the_drift_on_the_spans_clock_of_parameters_constant_in_the_data_unit"],
    ),
    "r0's symmetry left to an eigenvalue routine that reads one triangle": (
        "vojax/_validate.py",
        [("    if np.max(np.abs(m - m.T)) > 1e-10 * np.max(np.abs(m)):", "    if False:")],
        ["tests/test_validation.py::test_one_rule_for_r0_wherever_it_is_taken"],
    ),
    "r0's symmetry judged on an absolute scale (a tiny matrix passes)": (
        "vojax/_validate.py",
        [("    if np.max(np.abs(m - m.T)) > 1e-10 * np.max(np.abs(m)):",
          "    if np.max(np.abs(m - m.T)) > 1e-10:")],
        ["tests/test_validation.py::test_a_symmetric_r0_built_by_rounding_is_taken"],
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
    "the study's signals take a step of 0": (
        "vojax/_study.py",
        [("    if not (0 < dt < math.inf and 0 < duration < math.inf):", "    if False:")],
        ["tests/test_validation.py::test_the_studys_signals_refuse_a_grid_they_cannot_draw"],
    ),
    "refit_lbfgsb returns a NaN answer": (
        "vojax/_refit.py",
        [("    if not np.all(np.isfinite(np.asarray(theta))):", "    if False:")],
        ["tests/test_refit.py::test_the_second_opinion_checks_its_solver_settings_and_its_answer"],
    ),
    "the order a constant statement excluded is not reported": (
        "vojax/_tracker/_estimator.py",
        [("            clock_at = clock_order(fit, *other)", "            clock_at = float('nan')")],
        ["tests/test_clock.py::test_parameters_stated_constant_are_constant_on_the_spans_clock"],
    ),
    "the excluded order is named even inside the band": (
        "vojax/_identification.py",
        [("        return d.clock_order if not lo <= d.clock_order <= hi else None",
          "        return d.clock_order")],
        ["tests/test_clock.py::test_an_identified_answer_names_the_order_its_statement_excluded"],
    ),
    "refit_lbfgsb is silent where it stopped unconverged": (
        "vojax/_refit.py",
        [("    if warn and not error <= tol:", "    if warn and error > 1e300:")],
        ["tests/test_refit.py::test_the_second_opinion_says_when_it_stopped_before_converging"],
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
    "Mittag-Leffler integral without the grading at w_c": (
        "vojax/_models/_closed.py",
        [("        if c < 0:  # the steep rise of θ near w_c (a step at α = 1)",
          "        if False:")],
        ["tests/test_closed_forms.py"],
    ),
    "Mittag-Leffler sin απ from απ near α = 1": (
        "vojax/_models/_closed.py",
        [("        s, c = math.sin((1 - alpha) * math.pi), -math.cos((1 - alpha) * math.pi)",
          "        s, c = math.sin(alpha * math.pi), math.cos(alpha * math.pi)")],
        ["tests/test_closed_forms.py"],
    ),
    "Mittag-Leffler asymptotic series one term short": (
        "vojax/_models/_closed.py",
        [("def _asymptotic(alpha, x, beta=1.0, terms=12):",
          "def _asymptotic(alpha, x, beta=1.0, terms=1):")],
        ["tests/test_closed_forms.py"],
    ),
    "JAX Mittag-Leffler without the panels about w_c": (
        "vojax/_models/_closed_jax.py",
        [("    points = jnp.concatenate([jnp.zeros(1), jnp.asarray(graded), rise])",
          "    points = jnp.concatenate([jnp.zeros(1), jnp.asarray(graded)])")],
        ["tests/test_mittag_leffler_jax.py"],
    ),
    "JAX Mittag-Leffler 1/Γ's reflection with the sign of n + 1": (
        "vojax/_models/_closed_jax.py",
        [("    sign = jnp.where(jnp.mod(n, 2) == 0, 1.0, -1.0)",
          "    sign = jnp.where(jnp.mod(n, 2) == 1, 1.0, -1.0)")],
        ["tests/test_mittag_leffler_jax.py"],
    ),
    "JAX Mittag-Leffler w^α at w = 0 without the guard": (
        "vojax/_models/_closed_jax.py",
        [("    return jnp.where(positive, jnp.where(positive, w, 1.0) ** alpha, 0.0)",
          "    return w**alpha")],
        ["tests/test_mittag_leffler_jax.py"],
    ),
    "JAX route of G*(ω) with the phase πq instead of πq/2": (
        "vojax/_models/_closed_jax.py",
        [("    s = jax.lax.complex(w * jnp.cos(jnp.pi * q / 2), w * jnp.sin(jnp.pi * q / 2))",
          "    s = jax.lax.complex(w * jnp.cos(jnp.pi * q), w * jnp.sin(jnp.pi * q))")],
        ["tests/test_mittag_leffler_jax.py"],
    ),
    "moving orders' columns interpolated linearly between two profiled orders": (
        "vojax/_tracker/_moving.py",
        [("    for m in range(4):\n", "    for m in (1, 2):\n"),
         ("        w = d[o[0]] / (m - o[0]) * (d[o[1]] / (m - o[1])) * (d[o[2]] / (m - o[2]))",
          "        w = d[3 - m] / (m - (3 - m))")],
        ["tests/test_moving.py"],
    ),
    "moving orders' coarse inside design without the refinement": (
        "vojax/_tracker/_moving.py",
        [("        if level == 0:\n            c = c @ refinement(profile.settings.trade_knots)\n",
          "")],
        ["tests/test_moving.py"],
    ),
    "the shape fit's design kept from the first θ asked for": (
        "vojax/_tracker/_moving.py",
        [("        if not kept or kept[0] != key:", "        if not kept:")],
        ["tests/test_moving.py"],
    ),
    "moving orders kept whatever their χ²": (
        "vojax/_tracker/_moving.py",
        [("                    if chi2 > limit:\n                        break\n", "")],
        ["tests/test_moving.py"],
    ),
    "moving orders kept inside the band": (
        "vojax/_tracker/_moving.py",
        [("                    if outside(alpha[:span], band, half):\n", "                    if True:\n")],
        ["tests/test_moving.py"],
    ),
    "moving orders' penalty rows left out of the shape fit's residuals": (
        "vojax/_tracker/_moving.py",
        [("        return np.concatenate([res, rows]), float(res @ res), None",
          "        return res, float(res @ res), None")],
        ["tests/test_moving.py"],
    ),
    "a moving order inside the band joins the conditional band": (
        "vojax/_tracker/_band.py",
        [("        if e.kind in REACH_ONLY:\n            continue\n", "")],
        ["tests/test_band.py::test_a_moving_order_lowers_the_breakdown_drift_and_widens_no_band"],
    ),
    "a moving order widens the stated band": (
        "vojax/_tracker/_band.py",
        [("            if e.kind not in REACH_ONLY and (", "            if True and (")],
        ["tests/test_band.py::test_a_moving_order_lowers_the_breakdown_drift_and_widens_no_band"],
    ),
    "JAX Mittag-Leffler ramp tail dropped": (
        "vojax/_models/_closed_jax.py",
        [("        total += jnp.sum(weight * jnp.arctan2(s, x * _power(v, alpha) + c))",
          "        total += 0.0")],
        ["tests/test_mittag_leffler_jax.py"],
    ),
    "Zener creep rate E1/η instead of E0E1/((E0+E1)η)": (
        "vojax/_models/_closed.py",
        [("    rate = e0 * e1 / (total * p[\"eta\"])", "    rate = e1 / p[\"eta\"]")],
        ["tests/test_closed_forms.py"],
    ),
    "Maxwell complex modulus with E and η swapped in the denominator": (
        "vojax/_models/_closed.py",
        [("        return p[\"E\"] * p[\"eta\"] * s / (p[\"eta\"] * s + p[\"E\"])",
          "        return p[\"E\"] * p[\"eta\"] * s / (p[\"E\"] * s + p[\"eta\"])")],
        ["tests/test_closed_forms.py"],
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
    "progress bar's time left re-stamped at every update": (
        "vojax/_progress.py",
        [("(self.first or now) - self.started", "now - self.started")],
        ["tests/test_batch.py::test_the_bars_time_left_is_paced_on_the_records_after_the_first"],
    ),
    "reserved device names with an extension not hashed": (
        "vojax/_data/_paths.py",
        [("        or stem in RESERVED\n", "")],
        ["tests/test_properties.py::test_record_folders_are_distinct_safe_names"],
    ),
    "manifest rewritten with this run's names only": (
        "vojax/_data/_paths.py",
        [("    new = known | set(names)", "    new = set(names)")],
        ["tests/test_outputs.py::test_the_manifest_keeps_what_every_run_wrote"],
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
    "an input that is 0 throughout fitted": (
        "vojax/_validate.py",
        [("        if np.any(silent):", "        if False:")],
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
        ["tests/test_outputs.py::test_a_batch_whose_out_is_its_input_folder_says_so"],
    ),
    "more local workers than cores": (
        "vojax/_cli/_commands.py",
        [("    if args.workers is not None and args.workers > (os.cpu_count() or 1):",
          "    if False:")],
        ["tests/test_batch.py::test_workers_and_clients_that_cannot_work_are_refused"],
    ),
    "a client that is not a Dask client taken": (
        "vojax/_data/_batch.py",
        [('    if client is not None and not all(hasattr(client, a) for a in ("submit", "nthreads")):',
          "    if False:")],
        ["tests/test_batch.py::test_workers_and_clients_that_cannot_work_are_refused"],
    ),
    "a scheduler's loss fails every record instead of stopping the run": (
        "vojax/_data/_dask.py",
        [("                if _scheduler_lost(client, text):", "                if False:")],
        ["tests/test_batch.py::test_a_scheduler_that_dies_mid_run_leaves_a_folder_that_resumes"],
    ),
    "the fit test's 2σ with √dof instead of √(2·dof)": (
        "vojax/_tracker/_mixture.py",
        [("    return chi2 <= dof + 2 * np.sqrt(2 * dof)", "    return chi2 <= dof + 2 * np.sqrt(dof)")],
        ["tests/test_band.py::test_the_fit_test_rejects_a_correct_model_about_one_time_in_forty"],
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
    "the second clock's band never joins the span's": (
        "vojax/_tracker/_clock.py",
        [("    if not outside(o_alpha, (*points, 0.0), half):", "    if True:")],
        ["tests/test_clock.py"],
    ),
    "the second clock's union takes the span's band twice": (
        "vojax/_tracker/_clock.py",
        [("    _, lo, hi, _ = union((*points, 0.0), (*o_points, 0.0))",
          "    _, lo, hi, _ = union((*points, 0.0), (*points, 0.0))")],
        ["tests/test_clock.py"],
    ),
    "the clock's disagreement leaves the conditional answer standing": (
        "vojax/_diagnostics.py",
        [("    settled = sound and not clocked", "    settled = sound")],
        ["tests/test_clock.py"],
    ),
    "the default fits only on the span's clock": (
        "vojax/_tracker/_estimator.py",
        [("        both = self.time_scale is None and second_clock(scale)",
          "        both = False")],
        ["tests/test_verdict.py::test_the_default_band_holds_an_order_whose_parameter_is_constant_in_another_unit"],
    ),
    "the second clock fitted where the span is one unit": (
        "vojax/_tracker/_clock.py",
        [("    return bool(abs(np.log(span)) > SAME_CLOCK)", "    return bool(abs(np.log(span)) >= 0)")],
        ["tests/test_clock.py"],
    ),
    "the tracker's diagnostics over the whole record, not the fit window": (
        "vojax/_tracker/_estimator.py",
        [("        cut = slice(first, span)", "        cut = slice(0, span)")],
        ["tests/test_tracker_window.py"],
    ),
    "the band's second half from the record's middle, not the window's": (
        "vojax/_tracker/_band.py",
        [("    return first + (span - first) // 2", "    return span // 2")],
        ["tests/test_tracker_window.py::test_second_half_of_the_fitted_range"],
    ),
    "the tracker's window ignored": (
        "vojax/_tracker/_estimator.py",
        [("            mask = _windowed(mask, window, dt, t, u2.shape)", "            pass")],
        ["tests/test_tracker_window.py"],
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
    "the padded fit's coefficients read from the wrong columns": (
        "vojax/_refit_active.py",
        [("    return u_pad, v_pad, np.r_[np.arange(width), wide + np.arange(v.shape[1])]",
          "    return u_pad, v_pad, np.arange(width + v.shape[1])")],
        ["tests/test_refit.py::test_the_four_laws_share_a_program_and_padding_changes_no_fit"],
    ),
    "short records not padded to two inputs": (
        "vojax/_refit_active.py",
        [("if num_knots == 1 and n_all <= PAD_INPUTS_UP_TO else width",
          "if num_knots == 1 and n_all > PAD_INPUTS_UP_TO else width")],
        ["tests/test_refit.py::test_the_four_laws_share_a_program_and_padding_changes_no_fit"],
    ),
    "a refit whose every input is held is not run again": (
        "vojax/_refit_active.py",
        [(" and bool(active[:width].any())", "")],
        ["tests/test_refit_settles.py"],
    ),
    "the refit's restarts keep the largest sum of squares": (
        "vojax/_refit_active.py",
        [("        if (settled(fit), -rss(fit)) > (settled(best), -rss(best) * (1 - 1e-12)):",
          "        if (settled(fit), rss(fit)) > (settled(best), rss(best) * (1 - 1e-12)):")],
        ["tests/test_refit_settles.py"],
    ),
    "the decimal-comma hint on any cell that is not a number": (
        "vojax/_data/_read.py",
        [('            if decimal != "," and _is_number(text.replace(",", ".")):',
          '            if decimal != ",":')],
        ["tests/test_data_cli.py::test_a_decimal_comma_is_named_where_it_would_read"],
    ),
    "the record figure's residuals are the fit, not measured − fit": (
        "vojax/_plotting_parts.py",
        [("        r = y - np.asarray(fit, dtype=float)", "        r = np.asarray(fit, dtype=float)")],
        ["tests/test_figures.py::test_the_record_figure_shows_the_fit_its_residuals_and_the_verdict_uncut"],
    ),
    "the caption cuts the reason to its first clause": (
        "vojax/_plotting_parts.py",
        [('            lines.append("Why: " + finding.rstrip(".") + ".")',
          '            lines.append("Why: " + finding.split(":")[0] + ".")')],
        ["tests/test_figures.py::test_the_record_figure_shows_the_fit_its_residuals_and_the_verdict_uncut"],
    ),
    "the caption's lines are not wrapped": (
        "vojax/_plotting_parts.py",
        [("int(CAPTION_CHARS * width)", "10_000")],
        ["tests/test_figures.py::test_the_record_figure_shows_the_fit_its_residuals_and_the_verdict_uncut"],
    ),
    "the caption forgets the stated assumptions": (
        "vojax/_plotting_parts.py",
        [('(f" ({assumed})." if assumed else ".")', '"."')],
        ["tests/test_figures.py::test_the_record_figure_shows_the_fit_its_residuals_and_the_verdict_uncut"],
    ),
    "eta's unit without the time to the order": (
        "vojax/_plotting_parts.py",
        [('unit = f"{stress}·{tau}{per}" if name == "eta" else f"{stress}{per}"',
          'unit = f"{stress}{per}"')],
        ["tests/test_figures.py::test_parameters_carry_their_units"],
    ),
    "a log-spaced clock on a linear axis": (
        "vojax/_plotting_parts.py",
        [("    return bool(np.median(steps[-quarter:]) > LOG_CLOCK * np.median(steps[:quarter]))",
          "    return False")],
        ["tests/test_figures.py::test_a_log_spaced_clock_gets_a_log_axis_and_a_constant_no_offset"],
    ),
    "a reused figure keeps the last record's log axis": (
        "vojax/_plotting_record.py",
        [('        ax.set_xscale("linear")\n', '')],
        ["tests/test_figures.py::test_a_log_spaced_clock_gets_a_log_axis_and_a_constant_no_offset"],
    ),
    "a constant input zoomed on its jitter": (
        "vojax/_plotting_parts.py",
        [("    flat = level > 0 and hi - lo < FLAT * level", "    flat = False")],
        ["tests/test_figures.py::test_a_log_spaced_clock_gets_a_log_axis_and_a_constant_no_offset"],
    ),
    "Identification.plot draws the order alone": (
        "vojax/_identification.py",
        [("        if ax is None:\n            from ._plotting_record", "        if False:\n            from ._plotting_record")],
        ["tests/test_figures.py::test_identification_plot_shows_data_fit_residuals_and_the_verdict"],
    ),
    "the tracker forgets the measured output": (
        "vojax/_tracker/_estimator.py",
        [("_fitted_range(mask, length), y=y,", "_fitted_range(mask, length),")],
        ["tests/test_figures.py::test_identification_plot_shows_data_fit_residuals_and_the_verdict"],
    ),
    "the overview says nothing where drift absorbs the fit": (
        "vojax/_plotting.py",
        [("    note = _absorbed_note(rows, tracker)", '    note = ""')],
        ["tests/test_figures.py::test_the_overview_counts_in_whole_records_and_says_when_drift_absorbs_the_fit"],
    ),
    "the overview's counts on fractional ticks": (
        "vojax/_plotting.py",
        [("        ax.yaxis.set_major_locator(MaxNLocator(integer=True))  # counts of records", "        pass")],
        ["tests/test_figures.py::test_the_overview_counts_in_whole_records_and_says_when_drift_absorbs_the_fit"],
    ),
    "the study's Fig. 4 clips the law's excursions": (
        "vojax/_plotting.py",
        [("        _robust_limits(ax, series, percentiles=(0, 100))", "        _robust_limits(ax, series)")],
        ["tests/test_figures.py::test_the_studys_figures_hide_no_data_and_clip_no_estimate"],
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
    "the command's next steps run together on one line": (
        "vojax/_steps.py",
        [('        lines += [f"    ({i}) {w}" for i, w in enumerate(words, 1)]',
          '        lines.append("    " + "; ".join(words))')],
        ["tests/test_data_cli.py::test_cli_identify_end_to_end"],
    ),
    "a law's response convolves the ramp response, not its pulses": (
        "vojax/_models/_respond.py",
        [("out[1:] = _convolve(slopes, pulse)[: num - 1]",
          "out[1:] = _convolve(slopes, ramp(lags)[1:])[: num - 1]")],
        ["tests/test_responses.py"],
    ),
    "Kelvin–Voigt's response coefficients with k's sign flipped": (
        "vojax/_models/_viscoelastic.py",
        [("return 1.0 / eta, -k / eta, 0.0", "return 1.0 / eta, k / eta, 0.0")],
        ["tests/test_responses.py"],
    ),
    "a stress response's rate inverted (c/a for a/c)": (
        "vojax/_models/_respond.py",
        [("return _ratio_kernels(q, 1.0 / c, -b / c, a / c)",
          "return _ratio_kernels(q, 1.0 / c, -b / c, c / a)")],
        ["tests/test_responses.py"],
    ),
    "a response on a general clock turns its ramps off before on": (
        "vojax/_models/_respond.py",
        [("(ramp_at[:, :-1] - ramp_at[:, 1:]) @ slopes", "(ramp_at[:, 1:] - ramp_at[:, :-1]) @ slopes")],
        ["tests/test_responses.py"],
    ),
    "the command forgets to quiet XLA's log lines": (
        "vojax/_cli/_main.py",
        [("    quiet_xla_logs()\n", "")],
        ["tests/test_quiet_logs.py"],
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
    "E_{α,2}'s weight series cut short": (
        "vojax/_models/_closed.py",
        [("for k in range(24))", "for k in range(6))")],
        ["tests/test_responses.py"],
    ),
    "fitted law solved: the offset added, not relaxing through the law": (
        "vojax/_models/_fitted.py",
        [("strain + x0 * pair(q, -b * since**q, 1.0)[0]", "strain + x0")],
        ["tests/test_fitted_strain.py"],
    ),
    "fitted law solved from the first sample, not the origin": (
        "vojax/_models/_fitted.py",
        [("        since = times - origin", "        since = times - times[0]")],
        ["tests/test_fitted_strain.py"],
    ),
    "fitted Zener's viscosity from the wrong spring": (
        "vojax/_models/_fitted.py",
        [("dict(eta=zener_e1 * c / a, E0=e0", "dict(eta=e0 * c / a, E0=e0")],
        ["tests/test_fitted_strain.py"],
    ),
    "fitted law read with the spring's and the feedback's coefficients swapped": (
        "vojax/_models/_viscoelastic.py",
        [("        return p[0], p[1], p[2]", "        return p[0], p[2], p[1]")],
        ["tests/test_fitted_strain.py"],
    ),
    "fitted spring alone loses its offset": (
        "vojax/_models/_fitted.py",
        [("        return x0 + c * stress", "        return c * stress")],
        ["tests/test_fitted_strain.py"],
    ),
    "record summary reports the regression's residual as the solved law's": (
        "vojax/_data/_pipeline.py",
        [("nrmse=nrmse(y, solved)", "nrmse=regression")],
        ["tests/test_fitted_strain.py"],
    ),
    "refit's profile check skipped (a stalled or local fit kept)": (
        "vojax/_refit_active.py",
        [("    if start is None:\n        return best\n", "    return best\n")],
        ["tests/test_refit_settles.py"],
    ),
    "profile's faces ignore the signs": (
        "vojax/_refit_profile.py",
        [("        if np.any(signs[free] * p[: free.size] < 0):\n            continue\n", "")],
        ["tests/test_refit_settles.py::test_the_profiles_face_is_the_constrained_least_squares"],
    ),
    "profile's sum of squares forgets the part outside the design": (
        "vojax/_refit_profile.py",
        [("        rss = rest + float(", "        rss = float(")],
        ["tests/test_refit_settles.py::test_the_profiles_face_is_the_constrained_least_squares"],
    ),
    "profile narrows only the fit's own basin": (
        "vojax/_refit_profile.py",
        [("        if a <= fit_order <= b and not rss[k] < best[0]:",
          "        if not rss[k] < best[0]:")],
        ["tests/test_refit_settles.py"],
    ),
    "profile's narrowing keeps the grid's order, not the narrowed one": (
        "vojax/_refit_profile.py",
        [("            best = (values[k][0], float(orders[k]), values[k][1])\n        a, b",
          "            best = (values[k][0], best[1], values[k][1])\n        a, b")],
        ["tests/test_refit_settles.py"],
    ),
    "refit from the profile's order ignores its face": (
        "vojax/_refit_active.py",
        [("dict(solver, order0=start[0]), active=start[1])", "dict(solver, order0=start[0]))")],
        ["tests/test_refit_settles.py"],
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
    "the moving orders' Jacobian without the penalty's unit moving with the columns": (
        "vojax/_tracker/_moving.py",
        [("    dunit = unit * 2.0 *", "    dunit = 0.0 * unit * 2.0 *")],
        ["tests/test_moving.py::test_the_shape_fits_jacobian_equals_central_differences"],
    ),
    "the moving orders' Jacobian on unwhitened columns": (
        "vojax/_tracker/_moving.py",
        [("        cols = profile.whiten(cols)", "        pass")],
        ["tests/test_moving.py::test_the_shape_fits_jacobian_equals_central_differences"],
    ),
    "the memory's slope in the order off by a factor": (
        "vojax/_tracker/_moving.py",
        [("    return out, np.where(held[:, None], 0.0, slope / h)",
          "    return out, np.where(held[:, None], 0.0, slope / h * 1.001)")],
        ["tests/test_moving.py::test_the_columns_slopes_are_the_interpolants_derivatives"],
    ),
    "the whitener's doubling scan one step short": (
        "vojax/_tracker/_coloured.py",
        [("range(max(num - 1, 1).bit_length())", "range(max(num - 1, 1).bit_length() - 1)")],
        ["tests/test_coloured.py::test_whitener_equals_the_kalman_filter_step_by_step"],
    ),
}


def _copy(dst: Path):
    ignore = shutil.ignore_patterns(".venv", ".git", "__pycache__", "*.egg-info", ".pytest_cache")
    shutil.copytree(ROOT, dst, ignore=ignore, dirs_exist_ok=True)


def plant(text: str, edits):
    """`text` with a planted bug's `edits` (old, new) applied in order, and the old texts not
    found exactly once in `text` (a stale entry: it plants nothing)."""
    stale = [old for old, _ in edits if text.count(old) != 1]
    for old, new in edits:
        text = text.replace(old, new)
    return text, stale


def _run_one(tmp: Path, index: int, name: str, path: str, edits, tests, timeout: int):
    """Plants one bug in a fresh copy of the repository and runs its tests: (status, s)."""
    work = tmp / f"repo{index}"
    _copy(work)
    try:
        target = work / path
        text, stale = plant(target.read_text(), edits)
        if stale:
            print(f"STALE     {name}: {stale[0][:60]!r} not found exactly once", flush=True)
            return "STALE", 0.0
        target.write_text(text)
        # the copy's package must be the one imported (cwd first on sys.path)
        env = dict(os.environ, PYTHONPATH=str(work))
        env.pop("XLA_FLAGS", None)
        started = time.perf_counter()
        try:
            proc = subprocess.run(
                [sys.executable, "-m", "pytest", "-q", "-x", "-n", "0", "-p", "no:cacheprovider",
                 "-m", "slow or not slow", *tests],  # both tiers
                cwd=work, env=env, capture_output=True, text=True, timeout=timeout,
            )
            status = "caught" if proc.returncode != 0 else "SURVIVED"
        except subprocess.TimeoutExpired:
            status = "timeout"
        took = time.perf_counter() - started
        print(f"{status:9s} {name} ({took:.0f} s)", flush=True)
        return status, took
    finally:
        shutil.rmtree(work, ignore_errors=True)


def main() -> int:
    parser = argparse.ArgumentParser()
    parser.add_argument("--only", nargs="*")
    parser.add_argument("--list", action="store_true")
    parser.add_argument("--timeout", type=int, default=900)
    parser.add_argument("--workers", type=int, default=1,
                        help="planted bugs tested at once, each in its own copy and one "
                        "process (the tests of one bug are too few to gain from pytest-xdist)")
    args = parser.parse_args()
    chosen = {k: v for k, v in MUTATIONS.items() if not args.only or k in args.only}
    if args.list:
        print("\n".join(chosen))
        return 0
    from concurrent.futures import ThreadPoolExecutor

    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        # the recorded inputs, where tests look for them (../shared), or the checkout's copy
        for shared in (ROOT.parent / "shared", ROOT / "shared"):
            if (shared / "data").is_dir():
                (tmp / "shared").symlink_to(shared)
                break
        with ThreadPoolExecutor(max(args.workers, 1)) as pool:
            futures = [pool.submit(_run_one, tmp, i, name, *entry, args.timeout)
                       for i, (name, entry) in enumerate(chosen.items())]
            rows = [(name, *f.result()) for name, f in zip(chosen, futures)]
    survived = [r for r in rows if r[1] in ("SURVIVED", "STALE")]
    print(f"\n{len(rows) - len(survived)} of {len(rows)} planted bugs caught")
    print("| planted bug | result | s |\n|---|---|---|")
    for name, status, took in rows:
        print(f"| {name} | {status} | {took:.0f} |")
    return len(survived)


if __name__ == "__main__":
    sys.exit(main())
