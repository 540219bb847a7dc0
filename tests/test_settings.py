"""`TrackerSettings` refuses, in one sentence naming the setting, every value the tracker
cannot use (values found to crash or hang it are among them), and still answers at the least
values it takes."""

import numpy as np
import pytest

import vojax
from vojax import TrackerSettings

from .helpers import band_calls


@pytest.mark.parametrize("kwargs, words", [
    # the level profile stepped by a factor of 1 ran the same scale for ever
    (dict(level_step=1.0), r"TrackerSettings.level_step must be a finite number > 1, got 1.0"),
    (dict(level_step=0.5), "level_step must be a finite number > 1"),
    (dict(level_max=0.5), r"level_max must be a finite number ≥ 1"),
    # a start outside the order's range failed in LAPACK (an SVD that did not converge)
    (dict(start_orders=(1.5,)), r"start_orders must hold finite numbers in \(0, 1\) \(a tuple\)"),
    (dict(start_orders=(0.0, 0.5)), r"start_orders must hold finite numbers in \(0, 1\)"),
    (dict(start_orders=()), r"start_orders must hold finite numbers in \(0, 1\)"),
    (dict(rho_starts=(1.0,)), r"rho_starts must hold finite numbers in \(0, 1\)"),
    # a measurement variance searched between 2 and 1 was taken
    (dict(noise_min=2.0, noise_max=1.0), "noise_min must be below noise_max, got 2.0 and 1.0"),
    # counts: none of an iteration, a thread or a knot leaves nothing to run
    (dict(max_iter=0), "TrackerSettings.max_iter must be a whole number ≥ 1, got 0"),
    (dict(max_iter=2.5), "max_iter must be a whole number ≥ 1, got 2.5"),
    (dict(run_threads=0), "run_threads must be a whole number ≥ 1, got 0"),
    (dict(block_refine=0), "block_refine must be a whole number ≥ 1, got 0"),
    (dict(block_refine_from=1), "block_refine_from must be a whole number ≥ 2, got 1"),
    (dict(trade_knots=1), "trade_knots must be a whole number ≥ 2"),
    (dict(constant_grid=2), "constant_grid must be a whole number ≥ 3"),
    (dict(max_points=99), r"max_points must be a whole number in \[100, 50000\], got 99"),
    (dict(max_points=50_001), r"max_points must be a whole number in \[100, 50000\]"),
    (dict(level_splits=-1), "level_splits must be a whole number ≥ 0"),
    (dict(level_max_iter=0), "level_max_iter must be a whole number ≥ 1, got 0"),
    # ranges: two positive numbers, the first the smaller
    (dict(order_drift_range=(1.0, 0.1)), "order_drift_range must hold finite numbers > 0, two"),
    (dict(order_drift_range=(0.0, 1.0)), "order_drift_range must hold finite numbers > 0"),
    (dict(parameter_drift_range=(1.0,)), "parameter_drift_range must hold finite numbers > 0"),
    # a bare number where several belong; a fraction above 1; not finite
    (dict(level_ratios=0.5), r"level_ratios must hold finite numbers > 0 \(a tuple\), got 0.5"),
    (dict(level_ratios=(0.0, 2.0)), "level_ratios must hold finite numbers > 0"),
    (dict(bound_fraction=2.0), r"bound_fraction must be a finite number in \[0, 1\], got 2.0"),
    (dict(bound_tol=0.5), r"bound_tol must be a finite number in \[0, 0.5\)"),
    (dict(band_scale=float("nan")), "band_scale must be a finite number > 0, got nan"),
    (dict(identified_halfwidth=0.0), "identified_halfwidth must be a finite number > 0"),
    (dict(level_pin="evidence"), "level_pin must be a finite number > 0, got 'evidence'"),
    (dict(held_ratio=True), "held_ratio must be a finite number ≥ 0, got True"),
    (dict(misfit_ratio=-1.0), "misfit_ratio must be a finite number ≥ 0, got -1.0"),
    # a negative lag-1 gate means nothing (0 restores the refusal limit); a NaN would shut it
    (dict(coloured_lag=-1.0), "coloured_lag must be a finite number ≥ 0, got -1.0"),
    (dict(coloured_lag=float("nan")), "coloured_lag must be a finite number ≥ 0, got nan"),
    # a held scale's χ² gap below 0 would leave out every scale, the tuned run's own level too;
    # ∞ is None (off)
    (dict(level_gap=-0.5), "level_gap must be a finite number ≥ 0 or None, got -0.5"),
    (dict(level_gap=float("inf")), "level_gap must be a finite number ≥ 0 or None, got inf"),
    # a negative tolerance would weigh runs below their own expectation apart again
    (dict(level_excess_alike=-1.0), "level_excess_alike must be a finite number ≥ 0, got -1.0"),
    # a negative gap would call the tuned run itself worse than itself; ∞ is None (off)
    (dict(relative_gap=-1.0), "relative_gap must be a finite number ≥ 0 or None, got -1.0"),
    (dict(relative_gap=float("inf")), "relative_gap must be a finite number ≥ 0 or None, got inf"),
    # choices, by value and type: 1 is not True
    (dict(second_climb=1), "`second_climb` must be True or False, got 1"),
    (dict(schedule="fast"), "`schedule` must be None, 'sequential', 'associative' or 'chunked'"),
    # 1 would read as True (the answer's own moves) where "both" was meant
    (dict(moving_base=1), "`moving_base` must be True, False, 'both' or 'stated', got 1"),
    (dict(moving_base="yes"), "`moving_base` must be True, False, 'both' or 'stated', got 'yes'"),
    (dict(moving_limit="best"), "`moving_limit` must be 'own', 'trade' or 'freedom', got 'best'"),
    (dict(level_weights="aic"), "`level_weights` must be 'evidence', 'chi2', 'profile', 'freedom' or 'excess', got 'aic'"),
])
def test_a_setting_the_tracker_cannot_use_is_refused_naming_it(kwargs, words):
    with pytest.raises(ValueError, match=words):
        TrackerSettings(**kwargs)


def test_a_list_is_kept_as_a_tuple_and_a_whole_float_as_an_int():
    """A list where a tuple belongs, and 200.0 where a count belongs, are taken as the tuple
    and the int (a frozen, hashable settings object; counts used in ``range``)."""
    s = TrackerSettings(level_ratios=[0.5, 2.0], max_iter=200.0, level_splits=0)
    assert s.level_ratios == (0.5, 2.0) and isinstance(s.level_ratios, tuple)
    assert s.max_iter == 200 and type(s.max_iter) is int
    assert hash(s) == hash(TrackerSettings(level_ratios=(0.5, 2.0), max_iter=200,
                                           level_splits=0))


def test_the_tracker_answers_at_the_least_settings_it_takes():
    """Every count at its least allowed value, every fraction and floor at its limit, every
    list of alternatives empty: the tracker still gives an order inside its range, with a
    verdict, free and with given intensities (a 200-sample springpot, order 0.4)."""
    n, dt = 200, 0.01
    t = dt * np.arange(n)
    u = np.sin(2 * np.pi * t) + 1.0
    y = np.asarray(vojax.simulate(u, 0.4, [1.0], dt))
    y = y + 1e-3 * np.random.default_rng(0).standard_normal(n)
    least = TrackerSettings(
        max_iter=1, grid_max_iter=1, refine_steps=1, climb_rounds=1, constant_grid=3,
        golden_steps=1, coloured_rounds=1, fatal_edge_rounds=1, held_order_climb=0,
        trade_knots=2, trade_orders=2, level_splits=0, max_points=100, batched_block=1,
        run_threads=1, block_refine=1, block_refine_from=2, level_step=1.01, level_max=1.0,
        noise_time_max=1.0, bound_tol=0.0,
        bound_fraction=0.0, start_orders=(0.5,), rho_starts=(0.5,), grid_order=(1.0,),
        held_order_drift=(1.0,), alt_order_drift=(), alt_param_drift=(), moving_offsets=(),
        level_ratios=(), noise_floor=0.0, edge=0.0, coloured_evidence=0.0, band_floor=0.0,
        drift_floor=0.0, clock_evidence=0.0, level_gap=0.0)
    given = dict(noise_std=1e-3, order_drift=1.0, parameter_drift=1e-6)
    for kwargs in ({}, dict(noise=given)):
        r = vojax.identify(u, y, dt, settings=least, warn=False, **kwargs)
        alpha = np.asarray(r.alpha)
        assert alpha.shape == (n,) and np.all((alpha > 0.01) & (alpha < 0.99))
        assert r.diagnostics.verdict in ("identified", "conditional", "not identified")


def test_the_band_gets_the_settings_held_scale_gap(monkeypatch):
    """`level_gap` reaches the band of a fit: each `bands` call of a constant-statement fit
    gets the settings' value (the χ² gap a held scale may lie above the tuned fit; see
    test_band)."""
    seen = band_calls(monkeypatch, parameters="constant",
                      settings=TrackerSettings(level_gap=1.75))
    assert seen and all(kwargs["level_gap"] == 1.75 for _, _, kwargs in seen)


def test_the_band_gets_the_settings_profile_level(monkeypatch):
    """`level_weights` and `level_profile_chi2` reach the band of a fit: each `bands` call
    of a constant-statement fit gets the settings' values."""
    seen = band_calls(monkeypatch, parameters="constant",
                      settings=TrackerSettings(level_weights="profile",
                                               level_profile_chi2=2.5))
    assert seen and all(kwargs["profile_chi2"] == 2.5 and kwargs["level_weights"] == "profile"
                        for _, _, kwargs in seen)


def test_the_band_gets_the_settings_excess_tolerance(monkeypatch):
    """`level_weights="excess"` and `level_excess_alike` reach the band of a fit."""
    seen = band_calls(monkeypatch, parameters="constant",
                      settings=TrackerSettings(level_weights="excess",
                                               level_excess_alike=0.75))
    assert seen and all(kwargs["excess_alike"] == 0.75 and kwargs["level_weights"] == "excess"
                        for _, _, kwargs in seen)
