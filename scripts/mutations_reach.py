"""Planted bugs of `mutation_check.py`: how far an answer under stated parameters carries
(its reach, the breakdown drift, in the verdict line), the moving orders that set it, and
the calibration table that scores it."""

V = "tests/test_verdict.py::"
H = "tests/test_calibration_held.py::"
C = "tests/test_calibration_tables.py::"
LINE = V + "test_an_answer_identified_under_a_statement_says_how_far_it_carries"
TABLE = C + "test_the_reach_table_splits_the_confidently_wrong_by_their_stated_reach"
NOISE = "tests/test_moving.py::test_moves_of_an_answer_that_fitted_the_noise_under_each_limit"
# name: (file, [(old, new), ...], tests that should fail)
MUTATIONS = {
    "the reach stated with the parameters free": (
        "vojax/_identification.py",
        [("                     if bound < d.breakdown_drift < np.inf else \"\")",
          "                     if (0.0 if np.isinf(bound) else bound) < d.breakdown_drift < np.inf "
          "else \"\")")],
        [LINE],
    ),
    "an infinite reach stated (no order outside the band found)": (
        "vojax/_identification.py",
        [("                     if bound < d.breakdown_drift < np.inf else \"\")",
          "                     if bound < d.breakdown_drift else \"\")")],
        [LINE],
    ),
    "a reach within the stated drift bound stated": (
        "vojax/_identification.py",
        [("            bound = np.inf if self.parameters is None else stated_drift(self.parameters)",
          "            bound = np.inf if self.parameters is None else 0.0")],
        [LINE],
    ),
    "moving orders searched under a statement only where a constant one broke the band": (
        "vojax/_tracker/_fit.py",
        [("(np.isfinite(found.breakdown_drift) or stated):",
          "np.isfinite(found.breakdown_drift):")],
        [H + "test_a_false_constant_statement_states_a_reach_below_the_drift_that_misled_it"],
    ),
    "a wrong answer counted as warned by a reach above its true drift": (
        "scripts/calibration_tables.py",
        [("_reach(r) and r[\"breakdown_drift\"] <= r[\"true_drift\"] for r in wrong)",
          "_reach(r) and r[\"breakdown_drift\"] >= r[\"true_drift\"] for r in wrong)")],
        [TABLE],
    ),
    "a reach within a stated drift bound counted as stated": (
        "scripts/calibration_tables.py",
        [("    return bool(bound < row[\"breakdown_drift\"] < np.inf)",
          "    return bool(0 < row[\"breakdown_drift\"] < np.inf)")],
        [TABLE],
    ),
    "the reach of refused records counted": (
        "scripts/calibration_tables.py",
        [("        stated = [r[\"breakdown_drift\"] for r in ident if _reach(r)]",
          "        stated = [r[\"breakdown_drift\"] for r in sel if _reach(r)]")],
        [TABLE],
    ),
    # the moving orders moved from the answer itself (`moving_base`)
    "the answer's moves fitted without the step it takes": (
        "vojax/_tracker/_moving.py",
        [("_at_shape(profile, shape, theta, level, form, base, lo, hi))",
          "_at_shape(profile, shape, theta, level, form, 0.0, lo, hi))")],
        ["tests/test_moving.py::test_moves_of_the_answer_keep_a_step_the_hats_cannot_follow"],
    ),
    "both searches keep only the answer's moves": (
        "vojax/_tracker/_moving.py",
        [('"both": [projected, answer]}', '"both": [answer]}')],
        ["tests/test_moving.py::test_moves_of_the_answer_keep_a_step_the_hats_cannot_follow"],
    ),
    # the two starts of the moving-order search compared (`scripts/moving_starts.py`)
    "the starts' table compares drifts below the floor": (
        "scripts/moving_starts.py",
        [("p[0], max(p[1], FLOOR), max(p[2], FLOOR))", "p[0], p[1], p[2])")],
        ["tests/test_moving_starts.py"],
    ),
    "the starts' table counts a skipped search that found more": (
        "scripts/moving_starts.py",
        [('lost = [f"{p[0]} {p[1]}" for p in lower if p[2] <= tol]',
          'lost = [f"{p[0]} {p[1]}" for p in pairs if p[2] <= tol and p not in higher]')],
        ["tests/test_moving_starts.py"],
    ),
    "the restarts' table compares drifts below the floor": (
        "scripts/moving_starts.py",
        [("min(max(d, FLOOR) for d in starts) >= (1 - NEAR) * max(projected, FLOOR)",
          "min(starts) >= (1 - NEAR) * projected")],
        ["tests/test_moving_starts.py"],
    ),
    # both searches where the call states the parameters (`moving_base="stated"`)
    "the fit never tells the search that the call states the parameters": (
        "vojax/_tracker/_fit.py",
        [("moving_orders(profile, found.conditional, half, stated,",
          "moving_orders(profile, found.conditional, half, False,")],
        ["tests/test_moving.py::test_the_fit_tells_the_search_whether_the_call_states_the_"
         "parameters"],
    ),
    "both searches where the parameters are free, the projection alone where stated": (
        "vojax/_tracker/_moving.py",
        [('mode = "both" if stated else False', 'mode = False if stated else "both"')],
        ["tests/test_moving.py::test_moves_of_the_answer_keep_a_step_the_hats_cannot_follow"],
    ),
    # the answer's moves held to the form's best constant-order fit (`moving_limit="trade"`)
    "the answer's moves held to their own best fit": (
        "vojax/_tracker/_moving.py",
        [("                            freedom if base is answer else None)]",
          "                            None)]")],
        [NOISE],
    ),
    "every search held to the form's best constant-order fit": (
        "vojax/_tracker/_moving.py",
        [("                            freedom if base is answer else None)]",
          "                            freedom)]")],
        [NOISE],
    ),
    "the answer's moves raised by no freedom": (
        "vojax/_tracker/_moving.py",
        [("    return max(freedom - hats, 0.0) if np.isfinite(freedom) else 0.0",
          "    return 0.0")],
        [NOISE],
    ),
    "the fit never tells the search the answer's freedom": (
        "vojax/_tracker/_fit.py",
        [("                                   found.reference_freedom)",
          "                                   np.nan)")],
        ["tests/test_moving.py::test_the_fit_tells_the_search_whether_the_call_states_the_"
         "parameters"],
    ),
    "the breakdown drift ten times the drift of the order that left the band": (
        "vojax/_tracker/_band.py",
        [("            breakdown = e.drift\n            break",
          "            breakdown = 10 * e.drift\n            break")],
        ["tests/test_trade_off.py::test_band_covers_a_moving_order_with_a_drifting_gain_or_"
         "refuses"],
    ),
    "a conditional answer however wide its conditional band": (
        "vojax/_diagnostics.py",
        [("    conditional_answer = (not identified and settled and cond_width <= "
          "s.identified_halfwidth",
          "    conditional_answer = (not identified and settled")],
        ["tests/test_calibration.py::test_default_tracker_is_never_confidently_wrong_where_a_"
         "parameter_drifts"],
    ),
    "the trade-off's constant orders left out of the free band": (
        "vojax/_tracker/_band.py",
        [("            if e.kind not in REACH_ONLY and (",
          "            if e.kind not in (*REACH_ONLY, \"trade\") and (")],
        ["tests/test_trade_off.py::test_parameters_constant_holds_their_drift_and_keeps_the_"
         "trade_out_of_its_band"],
    ),
    "the answer's moves held to their own best fit by default": (
        "vojax/_settings.py",
        [('    moving_limit: str = "freedom"', '    moving_limit: str = "own"')],
        [NOISE],
    ),
}
