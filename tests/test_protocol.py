"""`optimal_protocol` with the parameters free to drift, against `fisher_information` computed
on its own; its refusals of a protocol it cannot use; `settling_test`'s chirp against its
integral and against sines."""

import jax.numpy as jnp
import numpy as np
import pytest

import vojax

N, DT, ORDER, P, SD = 200, 0.05, 0.4, [1.0], 0.01
TIMES = DT * np.arange(N)


def _oscillation(params, times):
    """A unit load with a 20 % oscillation of `params[0]` cycles over the test."""
    return 1.0 + 0.2 * jnp.sin(2 * jnp.pi * params[0] * times / (N * DT))


def _criterion(cycles, parameter_knots):
    """The A-criterion (the order's mean predicted variance over the second half) of an
    oscillation of `cycles` cycles, from `fisher_information`."""
    u = np.asarray(_oscillation(jnp.array([cycles]), jnp.asarray(TIMES)))
    design = vojax.fisher_information(u, ORDER, P, DT, noise_std=SD,
                                      parameter_knots=parameter_knots)
    return float(np.mean(design.order_stderr[N // 2 :] ** 2))


def test_the_best_oscillation_under_drifting_parameters_is_a_minimum_of_its_own_bound():
    """A 20 % oscillation on a unit load, its number of cycles searched from 4.5 (limits 0.3
    and 30) with the parameter free to drift on 8 knots: the cycles found are a local minimum
    of the criterion `fisher_information` gives with those knots (1 % either side is no
    better), the returned design is that one (its drift columns named, the same band), and
    the search with the parameter constant, from the same start, ends elsewhere (slower:
    0.85 cycles against 6.9): on the drifting parameter's criterion at least ten times as
    bad (23 times)."""
    common = dict(noise_std=SD, num_samples=N)
    best, design = vojax.optimal_protocol(_oscillation, [4.5], [0.3], [30.0], ORDER, P, DT,
                                          parameter_knots=8, **common)
    cycles = float(best[0])
    assert 0.3 < cycles < 30.0
    at_best = _criterion(cycles, 8)
    for step in (0.99, 1.01):
        assert _criterion(step * cycles, 8) >= at_best * (1 - 1e-6)
    assert design.names[-1] == "drift_1_8" and len(design.names) == 1 + 1 + 1 + 7
    assert np.mean(design.order_stderr[N // 2 :] ** 2) == pytest.approx(at_best, rel=1e-9)
    constant, _ = vojax.optimal_protocol(_oscillation, [4.5], [0.3], [30.0], ORDER, P, DT,
                                         **common)
    assert _criterion(float(constant[0]), 8) > 10.0 * at_best


@pytest.mark.parametrize("protocol, kwargs, words", [
    (lambda q, t: jnp.ones(t.size - 1), {}, r"must give 40 samples \(one per time\), got \(39,\)"),
    (lambda q, t: jnp.ones((t.size, 2, 2)), {}, r"must have shape \(N,\) or \(N, n\), got shape \(40, 2, 2\)"),
    (lambda q, t: t / q[0] - jnp.inf, {}, r"contains NaN or inf \(first at index \(0,\)\)"),
    (lambda q, t: jnp.log(t - 1.0), {}, "contains NaN or inf"),  # NaN before t = 1
    (lambda q, t: jnp.stack([t, t], 1), {}, r"`p` must be 2 finite number\(s\), one per input"),
    (lambda q, t: jnp.minimum(t / q[0], 1.0), dict(parameter_knots=1),
     "`parameter_knots` must be an integer from 2 to 20"),
    (lambda q, t: jnp.minimum(t / q[0], 1.0), dict(parameter_knots=2.5),
     "`parameter_knots` must be an integer"),
    (lambda q, t: jnp.minimum(t / q[0], 1.0), dict(num_samples=True), "`num_samples` must be"),
    (lambda q, t: jnp.minimum(t / q[0], 1.0), dict(noise_std=True), "`noise_std` must be"),
    (lambda q, t: jnp.minimum(t / q[0], 1.0), dict(knots=0), "`knots` must be an integer"),
    # a count that would fill the memory with its times, before they are made
    (lambda q, t: jnp.minimum(t / q[0], 1.0), dict(num_samples=10**9),
     "`num_samples` must be an integer from 4 to 1,000,000, got 1000000000"),
])
def test_a_protocol_it_cannot_use_is_refused_with_a_reason(protocol, kwargs, words):
    """Inputs of the wrong shape, not finite at the start, or not one per parameter, and bad
    knots or counts: a `ValueError` naming what is wrong, before any search."""
    call = dict(noise_std=0.01, num_samples=40) | kwargs
    with pytest.raises(ValueError, match=words):
        vojax.optimal_protocol(protocol, [1.0], [0.5], [2.0], 0.4, [1.0], 0.05, **call)


@pytest.mark.parametrize("where", ["start", "lower", "upper"])
@pytest.mark.parametrize("bad, words", [("abc", "must be a number or an array of numbers"),
                                        ([[1.0, 2.0], [3.0]], "must be a number or a rectangular array"),
                                        (np.array(["a"]), "must hold real numbers")])
def test_limits_and_starts_that_are_not_numbers_are_refused_by_name(where, bad, words):
    """Text, ragged lists and arrays of text as `start`, `lower` or `upper`: a `TypeError`
    naming the argument (NumPy's own message names none)."""
    call = dict(start=[1.0], lower=[0.5], upper=[2.0]) | {where: bad}
    with pytest.raises(TypeError, match=f"`{where}` {words}"):
        vojax.optimal_protocol(lambda q, t: jnp.minimum(t / q[0], 1.0), **call, order=0.4,
                               p=[1.0], dt=0.05, noise_std=0.01, num_samples=40, max_steps=3)


def test_an_integer_noise_level_plans_as_its_float():
    """`noise_std` given as a Python integer (2**63 overflows a traced 64-bit integer) plans
    the same protocol as the same level given as a float."""
    call = dict(order=0.4, p=[1.0], dt=0.05, num_samples=40, max_steps=20)
    protocol = lambda q, t: jnp.minimum(t / q[0], 1.0)  # noqa: E731
    big, design = vojax.optimal_protocol(protocol, [1.0], [0.5], [2.0], noise_std=2**63, **call)
    same, twin = vojax.optimal_protocol(protocol, [1.0], [0.5], [2.0],
                                        noise_std=float(2**63), **call)
    np.testing.assert_array_equal(big, same)
    np.testing.assert_allclose(design.order_stderr, twin.order_stderr, rtol=1e-12)
    assert np.all(np.isfinite(design.order_stderr)) and np.all(design.order_stderr > 1e17)


def _ramp_hold(n=240, dt=0.05):
    t = dt * np.arange(n)
    return t, np.minimum(t / 3.0, 1.0)


def test_a_chirp_is_the_integral_of_its_rising_frequency():
    """The chirp `settling_test` proposes: its phase is the integral of a frequency rising
    exponentially from f₀ at its start to f₁ at the test's end, here integrated by the
    trapezoid rule on a grid 1,000 times finer than the samples; the wave it superposes
    matches to 1e-6 of its amplitude, and its `cycles` are that integral over 2π."""
    t, u = _ramp_hold()
    test = vojax.settling_test(u, 0.45, [2.0], t[1], noise_std=0.01, cycles=(2, 30), chirp=True)
    assert test.frequency_end is not None and test.frequency_end > test.frequency
    f0, f1, start, end = test.frequency, test.frequency_end, test.start, t[-1]
    fine = np.linspace(start, end, 1000 * t.size + 1)
    rate = f0 * (f1 / f0) ** ((fine - start) / (end - start))
    phase = 2 * np.pi * np.concatenate(
        [[0.0], np.cumsum(0.5 * (rate[1:] + rate[:-1]) * np.diff(fine))])
    wave = np.where(t >= start, np.sin(np.interp(t, fine, phase)), 0.0)
    np.testing.assert_allclose((test.inputs(u, t) - u) / test.amplitude, wave, atol=1e-6)
    assert test.cycles == pytest.approx(phase[-1] / (2 * np.pi), rel=1e-6)
    assert f"sweeping from {f0:.3g} to {f1:.3g} Hz (a chirp) from t = {start:.3g} s" in (
        test.sentence("s"))
    # a clock in another unit, or in none, says what its frequencies count
    assert f"to {f1:.3g} cycles per ms (a chirp) from t = {start:.3g} ms" in test.sentence("ms")
    assert f"to {f1:.3g} cycles per unit of time (a chirp) from t = {start:.3g} would" in (
        test.sentence(""))


def test_with_a_chirp_the_settling_test_picks_the_narrowest_of_sines_and_chirps():
    """Cycles 2 and 30 over a 240-sample ramp–hold (dt 0.05): from each start (0 and half
    the span) the sines of 2 and 30 cycles (where 8 samples a cycle allow) and a chirp from 2
    cycles' frequency to the fastest the sampling allows, each band recomputed here with
    `fisher_information`: `settling_test(chirp=True)` returns the narrowest (the chirp from
    0, ±0.0074, against the best sine's ±0.0095, which it returns without `chirp`)."""
    t, u = _ramp_hold()
    dt, end, rms = t[1], t[-1], 0.1 * np.sqrt(np.mean(u**2))
    bands = {}
    for start in (0.0, 0.5 * end):
        tau, length = np.maximum(t - start, 0.0), end - start
        f0, top = 2 / length, min(30 / length, 1 / (8 * dt))
        waves = {("chirp", start): 2 * np.pi * f0 * length / np.log(top / f0)
                 * (np.exp(np.log(top / f0) * tau / length) - 1)}
        for cycles in (2, 30):
            if cycles / length * dt <= 1 / 8:
                waves[(cycles, start)] = 2 * np.pi * cycles / length * tau
        for key, phase in waves.items():
            planned = u + rms * np.where(t >= start, np.sin(phase), 0.0)
            bands[key] = vojax.fisher_information(planned, 0.45, [2.0], dt, noise_std=0.01,
                                                  parameter_knots=8).order_band
    best = min(bands, key=bands.get)
    assert best == ("chirp", 0.0)
    common = dict(noise_std=0.01, cycles=(2, 30))
    chosen = vojax.settling_test(u, 0.45, [2.0], dt, chirp=True, **common)
    assert chosen.frequency_end is not None and chosen.start == 0.0
    assert chosen.band == pytest.approx(bands[best], rel=1e-10)
    sines = {k: v for k, v in bands.items() if k[0] != "chirp"}
    sine = vojax.settling_test(u, 0.45, [2.0], dt, **common)
    assert sine.frequency_end is None and (sine.cycles, sine.start) == min(sines, key=sines.get)
    assert sine.band == pytest.approx(min(sines.values()), rel=1e-10) and sine.band > chosen.band
    with pytest.raises(TypeError, match="`chirp` must be True or False"):
        vojax.settling_test(u, 0.45, [2.0], dt, chirp="yes", **common)


def test_the_settling_test_scales_the_trackers_band_by_the_bounds_narrowing():
    """`band_now` (the tracker's band on the record as it is) gives `expected`: band_now ×
    (band / band_without)^¼ (`TrackerSettings.settling_exponent`), the same through
    `expect` at any exponent in [0, 1] (0: the band stays; 1: it narrows as the bound);
    None, and the sentence's caution instead, where the load alone does not determine the
    order. A band that is not a positive number is refused naming it."""
    t, u = _ramp_hold()
    dt = t[1]
    plain = vojax.settling_test(u, 0.45, [2.0], dt, noise_std=0.01)
    test = vojax.settling_test(u, 0.45, [2.0], dt, noise_std=0.01, band_now=0.3)
    ratio = plain.band / plain.band_without
    assert plain.expected is None and 0 < ratio < 0.9
    assert (test.band, test.band_without) == (plain.band, plain.band_without)
    assert test.expected == pytest.approx(0.3 * ratio**0.25, rel=1e-12)
    assert vojax.TrackerSettings().settling_exponent == 0.25
    assert f"about ±{test.expected:.2g}" in test.sentence("s") and "expected=±" in repr(test)
    assert plain.expect(0.3, 0.0) == pytest.approx(0.3, rel=1e-12)
    assert plain.expect(0.3, 1.0) == pytest.approx(0.3 * ratio, rel=1e-12)
    plain.band_without = np.inf  # the load alone does not determine the order
    assert plain.expect(0.3) is None and "several times wider" in plain.sentence("s")
    for bad, error in ((True, TypeError), ("0.3", TypeError), (0.0, ValueError),
                       (np.nan, ValueError), (np.inf, ValueError)):
        with pytest.raises(error, match="`band_now` must be a positive number"):
            vojax.settling_test(u, 0.45, [2.0], dt, noise_std=0.01, band_now=bad)
    with pytest.raises(ValueError, match=r"`exponent` must be a number in \[0, 1\], got 2"):
        test.expect(0.3, 2)
    with pytest.raises(ValueError, match=r"settling_exponent must be a finite number in \[0, 1\]"):
        vojax.TrackerSettings(settling_exponent=1.5)


def test_a_planned_test_states_the_trackers_expected_band_on_the_calibrated_design():
    """`Design.expected` is `TrackerSettings.protocol_factor` (6.8) × the bound's median ±2σ
    half-width over the second half, on the design the factor was calibrated on (one order
    shift, the offset estimated, the parameters free on 8 hat functions), from
    `fisher_information` and from the design `optimal_protocol` returns; in `summary` and
    `repr`. Any other design has none: the factor was not calibrated there. A factor that
    is not a positive finite number is refused naming it."""
    u = np.asarray(_oscillation(jnp.array([6.0]), jnp.asarray(TIMES)))
    factor = vojax.TrackerSettings().protocol_factor
    assert factor == 6.8
    design = vojax.fisher_information(u, ORDER, P, DT, noise_std=SD, parameter_knots=8)
    bound = 2 * np.median(design.order_stderr[N // 2 :])
    assert design.expected == pytest.approx(factor * bound, rel=1e-12)
    assert f"{design.expected:.4g}" in design.summary()
    assert f"tracker ±{design.expected:.3g} expected" in repr(design)
    for other in (dict(), dict(parameter_knots=4), dict(parameter_knots=8, knots=2),
                  dict(parameter_knots=8, x0=False), dict(order_drift=0.1)):
        d = vojax.fisher_information(u, ORDER, P, DT, noise_std=SD, **other)
        assert d.expected is None and "tracker" not in d.summary() + repr(d), other
    _, planned = vojax.optimal_protocol(_oscillation, [6.0], [0.3], [30.0], ORDER, P, DT,
                                        noise_std=SD, num_samples=N, parameter_knots=8,
                                        max_steps=3)
    assert planned.expected == pytest.approx(factor * planned.order_band, rel=1e-12)
    for bad in (0.0, -1.0, np.inf, np.nan):
        with pytest.raises(ValueError, match="protocol_factor must be a finite number > 0"):
            vojax.TrackerSettings(protocol_factor=bad)


def test_several_starts_give_the_best_of_their_single_searches():
    """Starts of 1, 4.5 and 12 cycles (S, 1): the cycles returned are those of the single
    search whose criterion (recomputed with `fisher_information`) is the lowest, here not the
    first start's; shapes that do not match the limits are refused."""
    common = dict(noise_std=SD, num_samples=N, parameter_knots=8)
    singles = [float(vojax.optimal_protocol(_oscillation, [s], [0.3], [30.0], ORDER, P, DT,
                                            **common)[0][0]) for s in (1.0, 4.5, 12.0)]
    criteria = [_criterion(c, 8) for c in singles]
    best, _ = vojax.optimal_protocol(_oscillation, [[1.0], [4.5], [12.0]], [0.3], [30.0], ORDER,
                                     P, DT, **common)
    assert int(np.argmin(criteria)) != 0
    assert float(best[0]) == pytest.approx(singles[int(np.argmin(criteria))], rel=1e-9)
    for start in ([], [[1.0, 2.0]], [[[1.0]]]):
        with pytest.raises(ValueError, match=r"`start` the shape \(k,\) or \(S, k\)"):
            vojax.optimal_protocol(_oscillation, start, [0.3], [30.0], ORDER, P, DT, **common)
