"""Planted bugs of `mutation_check.py`: the tracker's band (explanations, the level profile, the mixture, the trade-off,
moving orders, the second clock)."""

# name: (file, [(old, new), ...], tests that should fail)
MUTATIONS = {
    'held smoothing keeps the tuned parameter drift': (
        'vojax/_tracker/_mixture.py',
        [
            ('        held = Hyper(jnp.log(to_device(np.asarray(np.exp(log_drift), dtype))),\n                     jnp.log(to_device(np.asarray(s.constant_drift, dtype))),',
             '        held = Hyper(jnp.log(to_device(np.asarray(np.exp(log_drift), dtype))),\n                     hyper.log_q_params,'),
        ],
        ['tests/test_held_level.py::test_the_held_smoothing_holds_the_parameters_whatever_the_tuned_drift'],
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
    "held smoothing not refined between its rungs": (
        'vojax/_tracker/_mixture.py',
        [('    for fraction in (0.5, 0.25):', '    for fraction in ():')],
        ['tests/test_held_search.py::test_the_search_ends_within_a_quarter_step_of_the_evidence_peak'],
    ),
    "the held scales' χ² gap ignored": (
        "vojax/_tracker/_band.py",
        [("    return var + level_spread(explanations, tuned, level_weights, gap=level_gap,",
          "    return var + level_spread(explanations, tuned, level_weights,")],
        ["tests/test_band_held.py::test_a_held_scale_far_above_the_tuned_fit_is_left_out_of_the_band"],
    ),
    "the held scales' χ² gap counted in units of χ², not of its standard deviation": (
        "vojax/_tracker/_band.py",
        [("reference.chi2 + gap * np.sqrt(2.0 * e.dof))]", "reference.chi2 + gap)]")],
        ["tests/test_band_held.py::test_a_held_scale_far_above_the_tuned_fit_is_left_out_of_the_band"],
    ),
    "the tracker's band without its χ² gap setting": (
        "vojax/_tracker/_fit.py",
        [("level_gap=s.level_gap, profile_chi2", "profile_chi2")],
        ["tests/test_settings.py::test_the_band_gets_the_settings_held_scale_gap"],
    ),
    "the profile's held scales counted in full however far above the tuned fit": (
        "vojax/_tracker/_band.py",
        [(" * moved_share(e.chi2 - reference.chi2, chi2)", "")],
        ["tests/test_band_profile.py::test_a_held_scale_further_above_is_moved_back_by_the_quadratic_profile"],
    ),
    "the profile's held scales that do not fit counted": (
        "vojax/_tracker/_band.py",
        [("profile_spread([e for e in levels if e.fits], reference,",
          "profile_spread(levels, reference,")],
        ["tests/test_band_profile.py::test_only_held_scales_that_fit_count_and_the_widest_moved_edge_sets_the_band"],
    ),
    "the profile's share without its square root": (
        "vojax/_tracker/_band.py",
        [("else float(np.sqrt(profile / gap))", "else float(profile / gap)")],
        ["tests/test_band_profile.py::test_an_account_the_statement_excludes_is_covered_moved_back_on_the_profile"],
    ),
    "the clock's excluded account covered where it lies, not moved": (
        "vojax/_tracker/_clock.py",
        [("        o_alpha = points[0] + move * (o_alpha - points[0])\n", "")],
        ["tests/test_band_profile.py::test_an_account_the_statement_excludes_is_covered_moved_back_on_the_profile"],
    ),
    "the tracker's band without the profile's Δχ² setting": (
        "vojax/_tracker/_fit.py",
        [("level_gap=s.level_gap, profile_chi2=s.level_profile_chi2,\n", "level_gap=s.level_gap,\n")],
        ["tests/test_settings.py::test_the_band_gets_the_settings_profile_level"],
    ),
    "the held answer without its held scales": (
        "vojax/_tracker/_band.py",
        [("held.var + spread", "held.var")],
        ["tests/test_band_held.py::test_the_held_answer_weighs_its_own_held_scales_by_their_likelihood"],
    ),
    "the held smoothing's scales floored at the degrees of freedom": (
        "vojax/_tracker/_band.py",
        [('    at_dof = kind == "level"\n', "    at_dof = True\n")],
        ["tests/test_band_held.py::test_the_held_answer_weighs_its_own_held_scales_by_their_likelihood"],
    ),
    "the held smoothing's scales weighed however far the evidence excludes them": (
        "vojax/_tracker/_band.py",
        [("level_spread([e for e in explanations if plausible(e)], held,",
          "level_spread(explanations, held,")],
        ["tests/test_band_held.py::test_the_held_answer_weighs_its_own_held_scales_by_their_likelihood"],
    ),
    "the held smoothing's scales unioned with the free band": (
        "vojax/_tracker/_band.py",
        [('INTEGRATED = (*OWN, "level")\n',
          'INTEGRATED = (*OWN, "level", "held_level")\n')],
        ["tests/test_band_held.py::test_the_held_answer_weighs_its_own_held_scales_by_their_likelihood"],
    ),
    "the least drift's constant parameters judged by the penalised ladder only": (
        "vojax/_tracker/_trade.py",
        [("    if float(res @ res) * scale <= limit:\n        return 0.0",
          "    if False:\n        return 0.0")],
        ["tests/test_band.py::test_least_drift_against_a_brute_force_search"],
    ),
    "trade interval without its χ² test": (
        "vojax/_tracker/_trade.py",
        [("        if not np.all(np.isfinite(c)) or not chi2_fits(c.min(), dof):",
          "        if not np.all(np.isfinite(c)):")],
        ["tests/test_trade_off.py::test_trade_interval_against_an_independent_profile"],
    ),
    "trade interval ends on grid orders": (
        "vojax/_tracker/_trade.py",
        [("        found.append(lo if i == 0 else crossing(i, i - 1))",
          "        found.append(lo if i == 0 else alphas[i - 1])")],
        ["tests/test_trade_off.py::test_trade_interval_against_an_independent_profile"],
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
            ('            spread = np.maximum(level_spread([e for e in explanations if plausible(e)], held,\n'
             '                                             level_weights, "held_level"), 0.0)',
             '            spread = level_spread([e for e in explanations if plausible(e)], held,\n'
             '                                             level_weights, "held_level")'),
        ],
        ['tests/test_band.py', 'tests/test_band_held.py'],
    ),
    "a run whose optimiser failed stands for the data if its chi2 passes": (
        'vojax/_tracker/_explanations.py',
        [
            ('        return self.fits and self.converged', '        return self.fits'),
        ],
        ['tests/test_band.py', 'tests/test_band_held.py'],
    ),
    "the band's members need not fit (every alternative widens the band)": (
        'vojax/_tracker/_band.py',
        [
            ('              and e.holds and plausible(e)]',
             '              and e.converged and plausible(e)]'),
        ],
        ['tests/test_band.py', 'tests/test_band_held.py'],
    ),
    "the held scales run on the tuned smoothing's iteration budget": (
        'vojax/_tracker/_level.py',
        [('                               s.level_max_iter, False, problem.schedule)',
          '                               s.max_iter, False, problem.schedule)')],
        ['tests/test_envelope.py::test_the_held_scales_run_on_their_own_iteration_budget'],
    ),
    'level profile keeps a run that did not converge': (
        'vojax/_tracker/_level.py',
        [
            ('fitting(residuals, problem.mask, n, fit_noise, whiten) & np.isfinite(scores)',
             'fitting(residuals, problem.mask, n, fit_noise, whiten)'),
        ],
        ['tests/test_envelope.py'],
    ),
    "trade-off's finer drift pays 2 per knot, not per coefficient of every input": (
        "vojax/_tracker/_trade.py",
        [("> 2 * n * (s.trade_knots_fine - s.trade_knots)",
          "> 2 * (s.trade_knots_fine - s.trade_knots)")],
        ["tests/test_trade_off.py::test_the_trade_offs_finer_drift_pays_two_per_coefficient_of_every_input"],
    ),
    "the widened band's σ is half its width (every widened band doubled)": (
        "vojax/_tracker/_band.py",
        [("hi) - np.minimum(lower, lo)) / 4)", "hi) - np.minimum(lower, lo)) / 2)")],
        ["tests/test_band.py::test_the_breakdown_drift_is_the_least_drift_of_an_order_outside_that_fits"],
    ),
    "the level profile rewards a fit below the noise": (
        "vojax/_tracker/_band.py",
        [("    return max(e.chi2, chi2_floor(e, level_weights))", "    return e.chi2")],
        ["tests/test_band_held.py::test_a_fit_below_the_noise_earns_no_weight_over_the_level_profile"],
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
        ['tests/test_band_held.py::test_integrated_alternatives_are_weighed_not_unioned'],
    ),
    'the breakdown set by any drifting alternative, inside the band or not': (
        'vojax/_tracker/_band.py',
        [
            ('if max(e.drift - reference.drift, 0.0) > drift_floor and outside(m[0], band, half):',
             'if max(e.drift - reference.drift, 0.0) > drift_floor:'),
        ],
        ['tests/test_band.py', 'tests/test_band_held.py'],
    ),
    "the relative test without the freedoms' difference": (
        'vojax/_tracker/_band.py',
        [("    gap = (e.chi2 + e.freedom) - (tuned.chi2 + tuned.freedom)",
          "    gap = e.chi2 - tuned.chi2")],
        ['tests/test_band_relative.py::test_the_gap_and_its_standard_deviation_in_closed_form',
         'tests/test_band_relative.py::test_the_rate_at_which_a_true_nested_model_fails_is_the_chi2_tail'],
    ),
    "the relative test's spread without the freedoms' difference": (
        'vojax/_tracker/_band.py',
        [("np.sqrt(2 * (abs(tuned.freedom - e.freedom) + 1) + 4 * abs(e.chi2 - tuned.chi2))",
          "np.sqrt(2 + 4 * abs(e.chi2 - tuned.chi2))")],
        ['tests/test_band_relative.py::test_the_gap_and_its_standard_deviation_in_closed_form',
         'tests/test_band_relative.py::test_the_rate_at_which_a_true_nested_model_fails_is_the_chi2_tail'],
    ),
    "the relative test's spread without the runs' own difference (nested only)": (
        'vojax/_tracker/_band.py',
        [(" + 4 * abs(e.chi2 - tuned.chi2))", ")")],
        ['tests/test_band_relative.py::test_the_gap_and_its_standard_deviation_in_closed_form',
         'tests/test_band_relative.py::test_the_rate_at_which_a_true_nested_model_fails_is_the_chi2_tail'],
    ),
    "the relative test drops the reach too": (
        'vojax/_tracker/_band.py',
        [("              and e.holds and plausible(e)]\n",
          "              and e.holds and plausible(e) and fits_as_well(e, tuned, gap_z)]\n")],
        ['tests/test_band_relative.py::test_a_worse_fitting_alternative_widens_no_free_band_and_keeps_the_reach'],
    ),
    "the relative test keeps a worse-fitting held smoothing as the stated band's reference": (
        'vojax/_tracker/_band.py',
        [("                about, stated = reference_of(None)", "                pass")],
        ['tests/test_band_relative.py::test_a_worse_fitting_alternative_widens_no_free_band_and_keeps_the_reach'],
    ),
    "the relative test made under a constant statement": (
        'vojax/_tracker/_band.py',
        [("    if stated_drift == 0 and near_evidence is not None and reference is tuned:\n"
          "        for e in near_alternatives(explanations, tuned, near_evidence):",
          "    if stated_drift == 0 and near_evidence is not None and reference is tuned:\n"
          "        for e in [e for e in near_alternatives(explanations, tuned, near_evidence)\n"
          "                  if fits_as_well(e, tuned, gap_z)]:")],
        ['tests/test_band_relative.py::test_a_constant_statement_is_untouched'],
    ),
    "the band about the drifting tuned run in place of the held one covers no drift": (
        'vojax/_tracker/_band.py',
        [("                drifting = tuned.drift > held.drift + drift_floor  # the band's own account\n", "")],
        ['tests/test_band_relative.py::test_a_worse_fitting_alternative_widens_no_free_band_and_keeps_the_reach'],
    ),
    "the tracker's band without its relative gap setting": (
        "vojax/_tracker/_fit.py",
        [(", gap_z=s.relative_gap)", ")")],
        ["tests/test_band_relative.py::test_the_band_gets_the_settings_relative_gap"],
    ),
    'the stated band ignores the statement about the parameters': (
        'vojax/_tracker/_band.py',
        [
            ('                    e.drift <= max(stated_drift, about.drift) + drift_floor):',
             '                    True):'),
        ],
        ['tests/test_band.py', 'tests/test_verdict.py::test_a_drift_bound_admits_the_explanations_that_drift_no_more'],
    ),
    "the level profile's held scales left out of the reference's variance": (
        'vojax/_tracker/_band.py',
        [
            ('    if not levels:\n        return 0.0\n    members',
             '    if True:\n        return 0.0\n    members'),
        ],
        ['tests/test_band.py', 'tests/test_band_held.py'],
    ),
    'the held scales weighted by exp(+Δχ²/2)': (
        'vojax/_tracker/_band.py',
        [
            ('    w = np.exp(-(chi2 - chi2.min()) / 2)',
             '    w = np.exp((chi2 - chi2.min()) / 2)'),
        ],
        ['tests/test_band.py', 'tests/test_band_held.py'],
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
    "the least drift's bisection keeps the failing side": (
        'vojax/_tracker/_trade.py',
        [
            ('        if c_mid <= limit:\n            lo, coef = mid, coef_mid',
             '        if c_mid > limit:\n            lo, coef = mid, coef_mid'),
        ],
        ['tests/test_band.py::test_least_drift_against_a_brute_force_search'],
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
        [("                if chi2 > limit:\n                    break\n", "")],
        ["tests/test_moving.py"],
    ),
    "moving orders kept inside the band": (
        "vojax/_tracker/_moving.py",
        [("                if outside(alpha[:span], band, half):\n", "                if True:\n")],
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
    "the fit test's 2σ with √dof instead of √(2·dof)": (
        "vojax/_tracker/_mixture.py",
        [("    return chi2 <= dof + 2 * np.sqrt(2 * dof)", "    return chi2 <= dof + 2 * np.sqrt(dof)")],
        ["tests/test_band.py::test_the_fit_test_rejects_a_correct_model_about_one_time_in_forty"],
    ),
    "the second clock's band never joins the span's": (
        "vojax/_tracker/_clock.py",
        [("    if not outside(o_alpha, (*points, 0.0), half):\n        cond",
          "    if True:\n        cond")],
        ["tests/test_clock.py"],
    ),
    "the second clock's union takes the span's band twice": (
        "vojax/_tracker/_clock.py",
        [("    _, lo, hi, _ = union((*points, 0.0), (*o_points, 0.0))",
          "    _, lo, hi, _ = union((*points, 0.0), (*points, 0.0))")],
        ["tests/test_clock.py"],
    ),
    "the second clock fitted where the span is one unit": (
        "vojax/_tracker/_clock.py",
        [("    return bool(abs(np.log(span)) > SAME_CLOCK)", "    return bool(abs(np.log(span)) >= 0)")],
        ["tests/test_clock.py"],
    ),
    "the band's second half from the record's middle, not the window's": (
        "vojax/_tracker/_band.py",
        [("    return first + (span - first) // 2", "    return span // 2")],
        ["tests/test_tracker_window.py::test_second_half_of_the_fitted_range"],
    ),
    "the moving orders' Jacobian without the penalty's unit moving with the columns": (
        "vojax/_tracker/_moving.py",
        [("    dunit = unit * 2.0 *", "    dunit = 0.0 * unit * 2.0 *")],
        ["tests/test_moving.py::test_the_shape_fits_jacobian_equals_central_differences"],
    ),
    "the moving orders' Jacobian on unwhitened columns": (
        "vojax/_tracker/_moving.py",
        [("        da = np.moveaxis(profile.whiten(np.moveaxis(da, 0, 1)), 1, 0)", "        pass")],
        ["tests/test_moving.py::test_the_shape_fits_jacobian_equals_central_differences"],
    ),
    "the moving orders' Jacobian without the mask's weights on the design's derivatives": (
        "vojax/_tracker/_moving.py",
        [("    da = da * np.sqrt(np.asarray(profile.mask, float))[None, :, None]  # (m, N, W)",
          "    da = da * 1.0  # (m, N, W)")],
        ["tests/test_moving.py::test_the_shape_fits_jacobian_equals_central_differences"],
    ),
    "the memory's slope in the order off by a factor": (
        "vojax/_tracker/_moving.py",
        [("    return out, np.where(held[:, None], 0.0, slope / h)",
          "    return out, np.where(held[:, None], 0.0, slope / h * 1.001)")],
        ["tests/test_moving.py::test_the_columns_slopes_are_the_interpolants_derivatives"],
    ),
    "the band leaves out the fastest order drift however near the tuned evidence": (
        "vojax/_tracker/_band.py",
        [("e.kind == \"order_drift\" and e.factor == top and e.evidence < tuned.evidence - limit)]",
          "e.kind == \"order_drift\" and e.factor == top)]")],
        ["tests/test_band_fastest.py::test_the_fastest_far_below_leaves_the_free_band_and_the_slower_stay"],
    ),
    "the band leaves out every far order drift, not the fastest alone": (
        "vojax/_tracker/_band.py",
        [("e.kind == \"order_drift\" and e.factor == top and e.evidence",
          "e.kind == \"order_drift\" and e.evidence")],
        ["tests/test_band_fastest.py::test_the_fastest_far_below_leaves_the_free_band_and_the_slower_stay"],
    ),
    "the band takes the last order drift listed for the fastest": (
        "vojax/_tracker/_band.py",
        [("    top = max(factors)\n", "    top = factors[-1]\n")],
        ["tests/test_band_fastest.py::test_only_the_largest_factor_is_weighed_whatever_the_order_of_the_list"],
    ),
    "the tracker leaves the fastest order drift in however far below": (
        "vojax/_tracker/_fit.py",
        [("fastest_evidence=s.fastest_evidence, near_evidence", "near_evidence")],
        ["tests/test_band_fastest.py::test_the_tracker_passes_its_setting_to_the_band"],
    ),
    "the order drifts' factors attached in reverse": (
        "vojax/_tracker/_mixture.py",
        [("    factors = [None] * len(kinds) + [float(f) for f in s.alt_order_drift]",
          "    factors = [None] * len(kinds) + [float(f) for f in s.alt_order_drift[::-1]]")],
        ["tests/test_envelope.py::test_each_order_drift_carries_the_factor_its_run_was_given"],
    ),
    "the constant band covers its near alternatives however far below": (
        "vojax/_tracker/_band.py",
        [("            and e.evidence >= tuned.evidence - limit]", "            ]")],
        ["tests/test_band_near.py::test_a_near_alternative_widens_the_constant_band_to_its_own"],
    ),
    "the near alternatives' limit measured from 0, not from the tuned evidence": (
        "vojax/_tracker/_band.py",
        [("            and e.evidence >= tuned.evidence - limit]", "            and e.evidence >= -limit]")],
        ["tests/test_band_near.py::test_the_limit_is_measured_from_the_tuned_evidence"],
    ),
    "the constant band covers the level profile's near scales and misfits": (
        "vojax/_tracker/_band.py",
        [("e.kind in OWN and e.holds", "e.kind in INTEGRATED")],
        ["tests/test_band_near.py::test_only_the_tuned_runs_own_alternatives_that_hold"],
    ),
    "the tracker weighs the near alternatives only": (
        "vojax/_tracker/_fit.py",
        [(", near_evidence=s.near_evidence,", ",")],
        ["tests/test_band_near.py::test_the_tracker_passes_its_setting_to_the_band"],
    ),
}
