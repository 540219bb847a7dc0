"""Planted bugs of `mutation_check.py`: the second clock (the data's unit of time against the
record's span: when a statement or the evidence excludes its account, the evidence per
fitted point, the drift on the span's clock)."""

# name: (file, [(old, new), ...], tests that should fail)
MUTATIONS = {
    "a stated drift bound ignored by the second clock (the union as with free parameters)": (
        "vojax/_tracker/_clock.py",
        [("    excluded = bound is not None and clock_drift(o_alpha, scale) > bound",
          "    excluded = False")],
        ["tests/test_clock.py::test_a_stated_bound_excludes_the_data_units_account_unless_covering_it_keeps_an_answer",
         "tests/test_clock.py::test_parameters_stated_constant_are_constant_on_the_spans_clock"],
    ),
    "free parameters treated as a statement of none by the second clock": (
        "vojax/_tracker/_clock.py",
        [("    excluded = bound is not None and clock_drift(o_alpha, scale) > bound",
          "    excluded = clock_drift(o_alpha, scale) > (bound or 0.0)")],
        ["tests/test_clock.py::test_a_stated_bound_excludes_the_data_units_account_unless_covering_it_keeps_an_answer"],
    ),
    "the evidence between the two clocks never excludes the data unit's account": (
        "vojax/_tracker/_clock.py",
        [("    if apart > evidence:", "    if False:")],
        ["tests/test_clock.py::test_an_account_the_evidence_excludes_is_not_covered_whatever_the_statement",
         "tests/test_clock.py::test_the_data_exclude_the_data_units_account_where_an_oscillation_tells_them_apart"],
    ),
    "the evidence excludes the data unit's account only under a statement": (
        "vojax/_tracker/_clock.py",
        [("    if apart > evidence:", "    if apart > evidence and bound is not None:")],
        ["tests/test_clock.py::test_an_account_the_evidence_excludes_is_not_covered_whatever_the_statement"],
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
    "an excluded clock covered whatever the union's width": (
        "vojax/_tracker/_clock.py",
        [("    if excluded and (apart > 0.0 or np.median(hi[half:] - lo[half:]) / 2 > answer):",
          "    if excluded and (apart > 0.0 or False):")],
        ["tests/test_clock.py::test_a_stated_bound_excludes_the_data_units_account_unless_covering_it_keeps_an_answer"],
    ),
    "the clock's drift measured without the span's unit": (
        "vojax/_tracker/_clock.py",
        [("    g = np.exp(np.log(scale) * (np.asarray(alpha) - np.mean(alpha)))",
          "    g = np.exp(np.asarray(alpha) - np.mean(alpha))")],
        ["tests/test_clock.py::test_the_drift_on_the_spans_clock_of_parameters_constant_in_the_data_unit"],
    ),
    "a statement's excluded account covered where the span's fit is ahead": (
        "vojax/_tracker/_clock.py",
        [("    if excluded and (apart > 0.0 or np.median(hi[half:] - lo[half:]) / 2 > answer):",
          "    if excluded and (np.median(hi[half:] - lo[half:]) / 2 > answer):")],
        ["tests/test_clock.py::test_a_statements_excluded_account_is_covered_only_where_the_data_favour_it_as_much"],
    ),
}
