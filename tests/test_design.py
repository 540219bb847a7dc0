"""Experiment design: the Fisher information of a planned test against the closed form of a
step, against finite differences of the model, and against the spread of the refit over
noise seeds; under the tracker's random-walk prior, against the prior's own spread and the
tracker's spread and band over noise seeds."""

import math

import jax.numpy as jnp
import numpy as np
import pytest
from scipy.special import digamma, gamma

import vojax


def test_a_step_has_the_information_of_the_closed_form():
    """A unit step from t = 0 into a springpot of constant order q: Φ(t) = t^q/Γ(q + 1) and
    ∂Φ/∂q = Φ(t)(ln t − ψ(q + 1)), so J = [p ∂Φ/∂q, Φ, 1] and F = JᵀJ/σ², written out here.
    The quadrature of a constant input is exact, so the two agree to rounding."""
    q, p, sd, dt, n = 0.37, 2.5, 0.01, 0.02, 400
    t = dt * np.arange(n)
    phi = np.where(t > 0, t**q, 0.0) / gamma(q + 1)
    dphi = np.where(t > 0, phi * (np.log(np.where(t > 0, t, 1.0)) - digamma(q + 1)), 0.0)
    jac = np.column_stack([p * dphi, phi, np.ones(n)])
    want = jac.T @ jac / sd**2
    got = vojax.fisher_information(np.ones(n), q, [p], dt, noise_std=sd)
    np.testing.assert_allclose(got.information, want, rtol=1e-10)
    np.testing.assert_allclose(got.covariance @ got.information, np.eye(3), atol=1e-8)
    assert got.names == ("order", "p_1", "x0")
    # without the offset, and known: a smaller matrix, the same entries
    known = vojax.fisher_information(np.ones(n), q, [p], dt, noise_std=sd, x0=False)
    np.testing.assert_allclose(known.information, want[:2, :2], rtol=1e-10)
    assert np.all(known.stderr <= got.stderr[:2])


def test_knots_against_finite_differences_of_the_model():
    """Three knots on a moving order, two inputs: each column of the Jacobian is the model's
    change when one knot's hat function (or one parameter) is moved, by central differences of
    `vojax.fractional_integral` computed here; the information agrees to the differences'
    accuracy, and the predicted band of the order is hᵀ C h at each sample."""
    n, dt = 300, 0.05
    t = dt * np.arange(n)
    u = np.column_stack([1 - np.exp(-t / 2), np.sin(0.8 * t) + 1.2])
    order = 0.3 + 0.3 * t / t[-1]
    p = np.array([1.5, -0.7])
    sd = 0.02
    d = vojax.fisher_information(u, order, p, dt, noise_std=sd, knots=3)
    places = np.linspace(0, t[-1], 3)
    hats = np.stack([np.interp(t, places, np.eye(3)[k]) for k in range(3)], 1)

    def model(b, pp):
        return np.asarray(vojax.fractional_integral(u, b, dt)) @ pp

    eps = 1e-6
    cols = [(model(order + eps * hats[:, k], p) - model(order - eps * hats[:, k], p)) / (2 * eps)
            for k in range(3)]
    cols += [np.asarray(vojax.fractional_integral(u, order, dt))[:, j] for j in range(2)]
    jac = np.column_stack(cols + [np.ones(n)])
    np.testing.assert_allclose(d.information, jac.T @ jac / sd**2, rtol=1e-6)
    cov = np.linalg.inv(jac.T @ jac / sd**2)[:3, :3]
    want = np.sqrt(np.einsum("ni,ij,nj->n", hats, cov, hats))
    np.testing.assert_allclose(d.order_stderr, want, rtol=1e-5)
    assert d.order_band == pytest.approx(2 * np.median(want[n // 2 :]), rel=1e-5)


def test_the_refit_reaches_the_predicted_spread_over_noise_seeds():
    """A ramp–hold into a springpot (q = 0.45), noise 1 % of the output's range: over 40 noise
    seeds the refit's orders and η spread as the Cramér–Rao bound predicts (within 30 %), and
    its own reported standard error agrees with the prediction."""
    n, dt, q, p = 300, 0.05, 0.45, 2.0
    t = dt * np.arange(n)
    u = np.minimum(t / 3.0, 1.0)
    x = np.asarray(vojax.simulate(u, q, np.array([p]), dt))
    sd = 0.01 * np.ptp(x)
    d = vojax.fisher_information(u, q, [p], dt, noise_std=float(sd))
    rng = np.random.default_rng(7)
    fits = [vojax.refit(u, x + sd * rng.standard_normal(n), dt) for _ in range(40)]
    orders = np.array([f.order_value for f in fits])
    ps = np.array([float(f.p[0]) for f in fits])
    assert np.std(orders, ddof=1) == pytest.approx(d.stderr[0], rel=0.3)
    assert np.std(ps, ddof=1) == pytest.approx(d.stderr[1], rel=0.3)
    assert np.median([float(f.order_stderr[0]) for f in fits]) == pytest.approx(d.stderr[0], rel=0.3)
    assert abs(np.mean(orders) - q) < 3 * d.stderr[0] / math.sqrt(40) + 1e-3


def test_bad_plans_are_refused_with_a_reason():
    n, dt = 100, 0.1
    u = np.ones(n)
    with pytest.raises(ValueError, match="`noise_std` must be a positive finite number"):
        vojax.fisher_information(u, 0.4, [1.0], dt, noise_std=0.0)
    with pytest.raises(ValueError, match="`p` must be 1 finite number"):
        vojax.fisher_information(u, 0.4, [1.0, 2.0], dt, noise_std=0.1)
    with pytest.raises(ValueError, match="`knots` must be an integer from 1 to 50"):
        vojax.fisher_information(u, 0.4, [1.0], dt, noise_std=0.1, knots=51)
    with pytest.raises(ValueError, match="does not determine order, p_1 at all"):
        vojax.fisher_information(np.zeros(n), 0.4, [1.0], dt, noise_std=0.1)
    with pytest.raises(ValueError, match="does not determine"):  # two identical inputs
        vojax.fisher_information(np.column_stack([u, u]), 0.4, [1.0, 1.0], dt, noise_std=0.1)
    with pytest.raises(ValueError, match="`order_drift` must be a positive finite number"):
        vojax.fisher_information(u, 0.4, [1.0], dt, noise_std=0.1, order_drift=-1.0)
    with pytest.raises(ValueError, match="either `knots` or `order_drift`"):
        vojax.fisher_information(u, 0.4, [1.0], dt, noise_std=0.1, knots=3, order_drift=1.0)
    with pytest.raises(ValueError, match=r"`order` must lie in \(0.01, 0.99\), got 0.99"):
        vojax.fisher_information(u, 0.99, [1.0], dt, noise_std=0.1, order_drift=1.0)
    with pytest.raises(ValueError, match="at most 5000 samples"):
        vojax.fisher_information(np.ones(5001), 0.4, [1.0], dt, noise_std=0.1, order_drift=1.0)
    # an order outside its range, a reversed or NaN range, noise levels whose squares leave
    # float64: one sentence each (before: accepted silently, LinAlgError, OverflowError)
    with pytest.raises(ValueError, match=r"`order` must lie in \(0.01, 0.99\), got 1.2"):
        vojax.fisher_information(u, 1.2, [1.0], dt, noise_std=0.1)
    with pytest.raises(ValueError, match="`order` contains NaN"):
        vojax.fisher_information(u, np.full(n, np.nan), [1.0], dt, noise_std=0.1)
    for bad in [(0.9, 0.1), (float("nan"), 0.5)]:
        with pytest.raises(ValueError, match="`order_range` must satisfy 0.0 < lo < hi < 1.0"):
            vojax.fisher_information(u, 0.4, [1.0], dt, noise_std=0.1, order_range=bad)
    for noise in (1e-300, 1e300):
        with pytest.raises(ValueError, match=r"`noise_std` must lie in \(1e-150, 1e150\)"):
            vojax.fisher_information(u, 0.4, [1.0], dt, noise_std=noise)
    with pytest.raises(ValueError, match="the information overflows float64"):
        vojax.fisher_information(1e200 * u, 0.4, [1.0], dt, noise_std=1e-120)
    # the covariance scales as the noise's variance over every level a float64 holds
    a = vojax.fisher_information(u, 0.4, [1.0], dt, noise_std=1.0)
    b = vojax.fisher_information(u, 0.4, [1.0], dt, noise_std=1e-100)
    np.testing.assert_allclose(b.order_stderr, 1e-100 * a.order_stderr, rtol=1e-12)
    protocol = lambda q, t: jnp.minimum(t / q[0], 1.0)  # noqa: E731
    for kwargs, words in [(dict(max_steps=-1), "`max_steps` must be from 1"),
                          (dict(order_range=(0.9, 0.1)), "`order_range` must satisfy"),
                          (dict(order=1.5), "`order` must lie in")]:
        call = dict(order=0.4, noise_std=0.1, num_samples=40) | kwargs
        with pytest.raises(ValueError, match=words):
            vojax.optimal_protocol(protocol, [1.0], [0.5], [2.0], p=[1.0], dt=dt, **call)


def _ramp_hold(n=300, dt=0.05):
    t = dt * np.arange(n)
    order = 0.35 + 0.2 * t / t[-1]
    u = np.minimum(t / 3.0, 1.0)
    x = np.asarray(vojax.simulate(u, order, np.array([2.0]), dt))
    return t, u, order, x


@pytest.mark.parametrize("drift", [0.3, 3.0])
def test_without_information_the_order_spreads_as_the_trackers_random_walk(drift):
    """With noise so large that the data say nothing, the order's band is the prior's own:
    ``Var β_k = PRIOR_BETA_VAR + q (t_k − t_0)/T``, carried to the order by ``dα/dβ``."""
    PRIOR_BETA_VAR = vojax.TrackerSettings().prior_beta_var
    t, u, order, _ = _ramp_hold(120)
    d = vojax.fisher_information(u, order, [2.0], t[1], noise_std=1e8, order_drift=drift)
    z = (order - 0.01) / 0.98
    want = 0.98 * z * (1 - z) * np.sqrt(PRIOR_BETA_VAR + drift * t / t[-1])
    np.testing.assert_allclose(d.order_stderr, want, rtol=1e-8)
    assert d.names[:2] == ("order_at_1", "order_at_2") and d.names[-2:] == ("p_1", "x0")
    assert "order_at_" not in d.summary()


@pytest.mark.slow
def test_the_tracker_reaches_the_predicted_band_at_given_intensities():
    """A ramp–hold into a springpot whose order moves from 0.35 to 0.55, noise 1 % of the
    output's range, the tracker at fixed intensities (order drift 1, parameters held): over
    40 noise seeds its orders spread as the Bayesian bound predicts (within 30 %, median over
    the second half), and its own reported standard error agrees with the prediction.

    The parameter is constant in seconds (the prediction's and the simulation's unit), and
    the tracker is told so (``time_scale=1``). Held on the record's span instead (the
    default's clock), it would be a false statement: the order comes out about 0.25 off,
    with a band of about ±0.12 that refuses it (``wide_band``)."""
    t, u, order, x = _ramp_hold()
    sd = float(0.01 * np.ptp(x))
    d = vojax.fisher_information(u, order, [2.0], t[1], noise_std=sd, order_drift=1.0)
    noise = dict(order_drift=1.0, parameter_drift=1e-9, noise_std=sd)
    rng = np.random.default_rng(7)
    fits = [vojax.identify(u, x + sd * rng.standard_normal(t.size), t[1], method="kalman",
                           noise=noise, time_scale=1.0, warn=False) for _ in range(40)]
    alphas = np.array([np.asarray(f.alpha) for f in fits])
    half = slice(t.size // 2, None)
    predicted = np.median(d.order_stderr[half])
    assert np.median(np.std(alphas, axis=0, ddof=1)[half]) == pytest.approx(predicted, rel=0.3)
    reported = np.median([np.median(np.asarray(f.alpha_std)[half]) for f in fits])
    assert reported == pytest.approx(predicted, rel=0.3)
    # no bias beyond the spread: the truth within 3 standard errors of the seeds' mean
    assert np.max(np.abs(alphas.mean(0) - order)[half]) < 3 * predicted / math.sqrt(40)


@pytest.mark.parametrize("criterion", ["order", "D"])
def test_the_optimal_ramp_is_the_best_of_a_grid(criterion):
    """A ramp to a fixed peak, then a hold, in a test of fixed duration: the rise time that
    `optimal_protocol` finds (BFGS from 3 s) is the best of a grid of 137 rise times
    evaluated with `fisher_information` one by one, to the grid's spacing, and its criterion
    is no worse than the grid's best."""
    import jax.numpy as jnp

    n, dt, q, p, sd = 300, 0.05, 0.45, [2.0], 0.01
    t = dt * np.arange(n)

    def ramp_hold(params, times):
        return jnp.minimum(times / params[0], 1.0)

    best, design = vojax.optimal_protocol(ramp_hold, [3.0], [0.1], [14.0], q, p, dt,
                                          noise_std=sd, num_samples=n, criterion=criterion)
    grid = np.linspace(0.2, 13.8, 137)

    def value(d):
        if criterion == "order":
            return np.mean(d.order_stderr[n // 2 :] ** 2)
        return -np.linalg.slogdet(d.information)[1]

    values = [value(vojax.fisher_information(np.minimum(t / r, 1.0), q, p, dt, noise_std=sd))
              for r in grid]
    i = int(np.argmin(values))
    assert 0 < i < grid.size - 1  # an interior optimum: the search had something to find
    assert abs(float(best[0]) - grid[i]) <= grid[1] - grid[0]
    assert value(design) <= values[i] + 1e-9 * abs(values[i])


def test_drifting_parameters_information_against_a_hand_built_jacobian():
    """With `parameter_knots`, the information is JᵀJ/σ² of the model's Jacobian built here
    in NumPy (the order's column p ∂Φ/∂b, Φ, the offset, and Φ times each hat function but
    the first: the constant part is p itself), and the order's band is wider than with the
    parameters constant, since a drifting gain takes up part of what the order explains."""
    dt, n = 0.05, 200
    t = dt * np.arange(n)
    u = np.minimum(t / 3.0, 1.0)
    q, p, sd = 0.45, 2.0, 0.01
    d = vojax.fisher_information(u, q, [p], dt, noise_std=sd, parameter_knots=4, memory="direct")
    phi = np.asarray(vojax.fractional_integral(u, q, dt))
    dphi = np.asarray(vojax.order_sensitivity(u, q, dt))
    places = np.linspace(t[0], t[-1], 4)
    hats = np.stack([np.interp(t, places, np.eye(4)[k]) for k in range(4)], axis=1)
    jac = np.column_stack([p * dphi, phi, np.ones(n), phi[:, None] * hats[:, 1:]])
    np.testing.assert_allclose(d.information, jac.T @ jac / sd**2, rtol=1e-10)
    assert d.names[-3:] == ("drift_1_2", "drift_1_3", "drift_1_4")
    constant = vojax.fisher_information(u, q, [p], dt, noise_std=sd, memory="direct")
    assert d.order_band > 2 * constant.order_band


def test_settling_test_picks_the_narrowest_band_its_sampling_allows():
    """`settling_test` tries each number of cycles from each start: it returns the one whose
    band (`fisher_information` with drifting parameters, recomputed here) is the narrowest
    among those with at least 8 samples a cycle, never one with fewer, and its band is
    narrower than the load's alone."""
    dt, n = 0.05, 240
    t = dt * np.arange(n)
    u = np.minimum(t / 3.0, 1.0)
    test = vojax.settling_test(u, 0.45, [2.0], dt, noise_std=0.01, cycles=(5, 10, 20, 40))
    assert test.frequency * dt <= 1 / 8
    bands = {}
    for start in (0.0, 0.5 * t[-1]):
        for cycles in (5, 10, 20, 40):
            f = cycles / (t[-1] - start)
            if f * dt > 1 / 8:
                continue
            wave = np.where(t >= start, np.sin(2 * np.pi * f * (t - start)), 0.0)
            planned = u + 0.1 * np.sqrt(np.mean(u**2)) * wave
            bands[(start, cycles)] = vojax.fisher_information(
                planned, 0.45, [2.0], dt, noise_std=0.01, parameter_knots=8).order_band
    best = min(bands, key=bands.get)
    assert (test.start, test.cycles) == best
    assert test.band == pytest.approx(bands[best], rel=1e-10)
    assert test.band < test.band_without
    assert (0.0, 40) not in bands  # 40 cycles over 240 samples: 6 a cycle, too few
    # the sentence: its numbers, and what the band assumes (a slow drift, not any drift)
    said = test.sentence("s")
    assert f"10 % of the load's RMS ({0.1 * np.sqrt(np.mean(u**2)):.3g})" in said
    assert f"at {test.frequency:.3g} Hz from t = {test.start:.3g} s" in said
    assert f"±{test.band:.2g} with the parameters drifting slowly" in said
    assert "whatever the parameters do" not in said
    # only cycles too fast for the sampling from every start: no test, said so
    with pytest.raises(ValueError, match="8 samples a cycle"):
        vojax.settling_test(u, 0.45, [2.0], dt, noise_std=0.01, cycles=(40,))


def test_the_optimal_ramp_for_a_moving_order_weighs_the_second_half():
    """With the order free on five knots its predicted variance differs between the halves
    of the test: `optimal_protocol`'s A-criterion is the mean over the second half (where
    the tracker's verdict reads the band), so its rise time is the best of a grid by that
    mean, not by the first half's (whose best is 30 % worse on it), and the design it
    returns keeps the five knots."""
    import jax.numpy as jnp

    n, dt, q, p, sd = 300, 0.05, 0.45, [2.0], 0.01
    t = dt * np.arange(n)

    def ramp_hold(params, times):
        return jnp.minimum(times / params[0], 1.0)

    best, design = vojax.optimal_protocol(ramp_hold, [3.0], [0.1], [14.0], q, p, dt,
                                          noise_std=sd, num_samples=n, knots=5)
    assert design.names[:5] == tuple(f"order_knot_{k}" for k in range(1, 6))
    grid = np.linspace(0.2, 13.8, 69)
    designs = [vojax.fisher_information(np.minimum(t / r, 1.0), q, p, dt, noise_std=sd, knots=5)
               for r in grid]
    second = [np.mean(d.order_stderr[n // 2 :] ** 2) for d in designs]
    first = [np.mean(d.order_stderr[: n // 2] ** 2) for d in designs]
    i, j = int(np.argmin(second)), int(np.argmin(first))
    assert second[j] > 1.2 * second[i]  # the halves disagree here
    assert abs(float(best[0]) - grid[i]) <= grid[1] - grid[0]
    assert np.mean(design.order_stderr[n // 2 :] ** 2) <= second[i] * (1 + 1e-6)


@pytest.mark.parametrize("kwargs, error, words", [
    # the hypothesis: refused naming the argument, not as "no oscillation determines the order"
    (dict(p=[2.0, 1.0]), ValueError, "`p` must be 1 finite number"),
    (dict(p=[np.nan]), ValueError, "`p` must be 1 finite number"),
    (dict(noise_std=-1.0), ValueError, "`noise_std` must be a positive finite number"),
    (dict(noise_std=np.nan), ValueError, "`noise_std` must be a positive finite number"),
    (dict(order=1.5), ValueError, r"`order` must lie in \(0.01, 0.99\), got 1.5"),
    (dict(order=np.full(100, 0.4)), ValueError, r"`order` must be a scalar or have shape \(200,\)"),
    (dict(parameter_knots=1), ValueError, "`parameter_knots` must be an integer from 2"),
    (dict(order_drift=-1.0), ValueError, "`order_drift` must be a positive finite number"),
    (dict(memory="bogus"), ValueError, "`memory` must be"),
    (dict(order_range=(0.5, 0.2)), ValueError, "`order_range` must satisfy"),
    (dict(x0="yes"), TypeError, "`x0` must be True or False"),
    # the oscillations tried: before, a frequency of 0 or below was returned as a test
    (dict(cycles=()), ValueError, "`cycles` must be one or more positive numbers"),
    (dict(cycles=(0,)), ValueError, "`cycles` must be one or more positive numbers, got 0"),
    (dict(cycles=(-5,)), ValueError, "`cycles` must be one or more positive numbers, got -5"),
    (dict(cycles=("a",)), TypeError, "`cycles` must be one or more positive numbers"),
    (dict(cycles=None), TypeError, "`cycles` must be one or more positive numbers, got None"),
    (dict(starts=()), ValueError, r"`starts` must be one or more fractions of the span in \[0, 1\)"),
    (dict(starts=(1.5,)), ValueError, r"`starts` must be .* in \[0, 1\), got 1.5"),
    (dict(starts=(-0.5,)), ValueError, r"`starts` must be .* in \[0, 1\), got -0.5"),
    (dict(starts=(np.nan,)), ValueError, r"`starts` must be .* in \[0, 1\), got nan"),
    (dict(amplitude=True), TypeError, "`amplitude` must be a positive number"),
    (dict(amplitude=-0.1), ValueError, "`amplitude` must be a positive number"),
])
def test_settling_test_refuses_bad_arguments_naming_them(kwargs, error, words):
    dt, n = 0.05, 200
    u = np.minimum(dt * np.arange(n) / 2.0, 1.0)
    call = dict(order=0.4, p=[2.0], dt=dt, noise_std=0.01) | kwargs
    with pytest.raises(error, match=words):
        vojax.settling_test(u, **call)


def test_settling_test_of_a_zero_load_says_so_and_takes_bare_numbers():
    dt, n = 0.05, 200
    u = np.minimum(dt * np.arange(n) / 2.0, 1.0)
    with pytest.raises(ValueError, match="`u` is zero throughout"):
        vojax.settling_test(np.zeros(n), 0.4, [2.0], dt, noise_std=0.01)
    # one number of cycles and one start, given bare: the same test as in a tuple
    bare = vojax.settling_test(u, 0.4, [2.0], dt, noise_std=0.01, cycles=5, starts=0.5)
    tupled = vojax.settling_test(u, 0.4, [2.0], dt, noise_std=0.01, cycles=(5,), starts=(0.5,))
    assert (bare.frequency, bare.start, bare.band) == (tupled.frequency, tupled.start, tupled.band)
    assert bare.start == pytest.approx(0.5 * dt * (n - 1))
    # x0 is a flag of `fisher_information` too
    with pytest.raises(TypeError, match="`x0` must be True or False"):
        vojax.fisher_information(u, 0.4, [2.0], dt, noise_std=0.01, x0="no")


@pytest.mark.parametrize("grid", ["dt", "t"])
@pytest.mark.parametrize(
    "options",
    [dict(knots=3), dict(parameter_knots=4, x0=False), dict(order_drift=0.5)],
    ids=["knots", "drift-hats", "order-drift"],
)
def test_padding_the_grid_leaves_the_information_as_it_is(grid, options):
    """With `pad_to` the model runs on the grid continued past its end (zero input, the last
    order, the last step) and only the real samples' rows enter: the causal memory of the real
    samples does not see the padding, so the information, the order's band and the hats equal
    those of the unpadded grid. A hat spread over the padded span, or the padded rows summed,
    would change them by far more than rounding."""
    n, dt = 90, 0.05
    rng = np.random.default_rng(3)
    t = np.cumsum(rng.uniform(0.5, 1.5, n)) * dt if grid == "t" else None
    times = t if grid == "t" else dt * np.arange(n)
    u = np.column_stack([np.minimum(times, 1.0), np.sin(3 * times)])
    order = 0.3 + 0.2 * times / times[-1]
    where = dict(t=t) if grid == "t" else dict(dt=dt)
    plain = vojax.fisher_information(u, order, [2.0, 0.5], noise_std=0.01, **where, **options)
    padded = vojax.fisher_information(u, order, [2.0, 0.5], noise_std=0.01, pad_to=128, **where,
                                      **options)
    np.testing.assert_allclose(padded.information, plain.information, rtol=1e-12)
    np.testing.assert_allclose(padded.order_stderr, plain.order_stderr, rtol=1e-9)
    np.testing.assert_array_equal(padded.times, plain.times)
    assert padded.names == plain.names and padded.order_stderr.shape == (n,)
    # not padding at all where the grid is as long already
    same = vojax.fisher_information(u, order, [2.0, 0.5], noise_std=0.01, pad_to=n, **where,
                                    **options)
    np.testing.assert_array_equal(same.information, plain.information)


@pytest.mark.parametrize("pad_to", [0, 2.5, True, "128", 1025, 10**9])
def test_a_bad_padding_is_refused(pad_to):
    with pytest.raises((TypeError, ValueError), match="`pad_to` must be"):
        vojax.fisher_information(np.ones(50), 0.4, [1.0], 0.1, noise_std=0.01, pad_to=pad_to)


def test_the_settling_test_on_a_padded_grid_picks_the_same_oscillation():
    """`settling_test(pad_to=…)` (the batch's records, one program per padded length) gives
    the test and the bands of the unpadded grid."""
    dt, n = 0.05, 200
    u = np.minimum(dt * np.arange(n) / 3.0, 1.0)
    plain = vojax.settling_test(u, 0.45, [2.0], dt, noise_std=0.01)
    padded = vojax.settling_test(u, 0.45, [2.0], dt, noise_std=0.01, pad_to=256)
    assert (padded.start, padded.cycles) == (plain.start, plain.cycles)
    assert padded.band == pytest.approx(plain.band, rel=1e-9)
    assert padded.band_without == pytest.approx(plain.band_without, rel=1e-9)
