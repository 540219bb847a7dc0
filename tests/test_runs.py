"""How the tracker's runs are made: side by side in threads, batched, blocked, one column of
Φ at a time; each the same as the plain way."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import vojax

from .helpers import normalised_problem


def test_threaded_smoothings_leave_sys_stderr_as_they_found_it():
    """A second tracker call on a record shape runs its smoothings in threads. Libraries that
    swap ``sys.stderr`` around a compiled call without a lock (equinox before 0.11.6) leave a
    wrapper behind when two threads overlap, and the process then exits with status 120 at
    shutdown (the wrapper has no ``flush``). Both calls here must leave ``sys.stderr`` as it was."""
    import sys

    dt = 0.1
    t = np.arange(187) * dt  # a length no other test uses: the first call compiles, the second threads
    u = np.minimum(t, 5.0) + 0.2 * np.sin(t)
    y = np.asarray(vojax.reference.fractional_integral(u, 0.3 + 0.3 * t / t[-1], dt))
    y = y + 0.01 * np.ptp(y) * np.random.default_rng(0).standard_normal(t.size)
    before = sys.stderr
    for scale in (1.0, 1.01):
        vojax.identify(u, scale * y, dt, method="kalman", warn=False)
        assert sys.stderr is before


def test_phi_of_each_column_equals_the_memory_run_on_all_columns():
    """`phi_columns` (the constant fit's and the trade-off profile's Φ, one input column at
    a time through one compiled program) equals one run of the memory over all the columns
    at once, and the direct sum of `vojax.reference` to the memory's accuracy."""
    from vojax._integral import make_memory
    from vojax._tracker._start import phi_columns

    n, dt = 240, 0.05
    t = dt * np.arange(n)
    x = np.stack([np.sin(t) + 1.0, np.minimum(t, 4.0), np.cos(0.3 * t)], axis=1)
    memory = make_memory("exponential", dt, n, order_range=(0.01, 0.99))
    got = phi_columns(memory, x, 0.37, vojax.TrackerSettings().phi_block)
    whole = np.asarray(memory.run(jnp.asarray(x), jnp.full((n,), 0.37), False))
    np.testing.assert_allclose(got, whole, rtol=1e-13, atol=1e-13)
    direct = np.stack([np.asarray(vojax.reference.fractional_integral(x[:, j], 0.37, dt))
                       for j in range(3)], axis=1)
    np.testing.assert_allclose(got, direct, rtol=1e-6, atol=1e-6 * np.abs(direct).max())


def test_coloured_starts_side_by_side_equal_one_after_another(monkeypatch):
    """The coloured-noise model's starting smoothings (one per starting correlation) run one
    after another the first time a record shape is seen, then in threads: the two calls give
    the same estimates and band, to the last digit (the same compiled program, the runs in
    the same order)."""
    from vojax._tracker import _coloured, _problem, _threads

    monkeypatch.setattr(_threads.os, "cpu_count", lambda: 2)
    seen = []
    original = _threads.in_threads

    def spy(problem, fn, count, call, key):
        seen.append((fn.__name__, count))
        return original(problem, fn, count, call, key)

    monkeypatch.setattr(_coloured, "in_threads", spy)
    times = []  # the AR(1) part's correlation time of each coloured smoothing, in call order
    smoother = _problem.iterated_smoother

    def spy_smoother(memory, u, y, mask, steps, horizon, hyper, *rest):
        if hyper.coloured:
            times.append(float(hyper.log_ar_time))
        return smoother(memory, u, y, mask, steps, horizon, hyper, *rest)

    monkeypatch.setattr(_problem, "iterated_smoother", spy_smoother)
    dt = 0.05
    t = np.arange(211) * dt  # a length no other test uses: the first call runs them in turn
    u = np.where(t < 3.0, t / 3.0, 1.0) + 0.3 * np.sin(0.4 * t)
    x = np.asarray(vojax.simulate(u, np.full(t.size, 0.45), np.array([1.0]), dt))
    white = np.random.default_rng(5).standard_normal(t.size)
    ar = np.zeros(t.size)
    for k in range(1, t.size):
        ar[k] = 0.9 * ar[k - 1] + np.sqrt(1 - 0.81) * white[k]
    y = x + 0.01 * np.ptp(x) * ar
    # the span stated as the time scale: one fit per call (no second clock, see test_clock)
    first, second = (vojax.identify(u, y, dt, parameters="constant", warn=False,
                                    time_scale=dt * (t.size - 1)) for _ in range(2))
    rho_starts = vojax.TrackerSettings().rho_starts
    assert seen.count(("coloured", len(rho_starts))) == 2
    # each call starts once from every starting correlation (the shares cover them all)
    starts = len(rho_starts)
    assert len(times) >= 2 * starts and len(set(times[:starts])) == starts
    assert first.tuning == second.tuning
    for name in ("alpha", "alpha_lower", "alpha_upper", "p", "y_hat"):
        np.testing.assert_array_equal(getattr(first, name), getattr(second, name))


def test_batched_runs_equal_the_runs_one_by_one(ramp):
    """`smoother_batch` and `smoother_modes` with ``batched=True`` (chunks of `RUN_BATCH`
    runs through one vmapped program, the last chunk padded with copies of its last run):
    11 runs (a full chunk and a padded one) give the same best run, index, iteration counts,
    scores and modes as the runs one after another, to the smoother's convergence test (a
    relative decrease of 1e-9: the two programs round differently)."""
    from vojax._tracker._smoother import RUN_BATCH, smoother_batch, smoother_modes
    from vojax._tracker._threads import stack_hypers

    problem, starts = normalised_problem(ramp, 150)
    rows = [(q, d, r) for q in (0.1, 1.0, 10.0) for d, r in ((1e-6, 1e-3), (1e-4, 1e-2))]
    rows = (rows + rows[:5])[:11]
    assert RUN_BATCH < len(rows) < 2 * RUN_BATCH
    firsts = jnp.asarray(np.resize(starts, (len(rows), starts.shape[1])))
    hyper = stack_hypers(rows)
    args = (*problem.record, hyper, problem.m0, problem.p0, firsts, problem.bounds, 400)
    one = smoother_batch(*args)
    many = smoother_batch(*args, batched=True)
    assert many[1] == one[1] and many[2] == one[2]
    assert np.array_equal(many[4], one[4])  # iterations
    assert np.all(np.isfinite(one[3][one[3] > -np.inf])) and np.sum(np.isfinite(one[3])) >= 6
    np.testing.assert_allclose(many[3], one[3], rtol=1e-8)
    np.testing.assert_allclose(many[0].theta, one[0].theta, rtol=0, atol=1e-6)
    assert isinstance(many[0].theta, jax.Array)  # the best run handed on as JAX arrays
    modes_one = smoother_modes(*args)
    modes_many = smoother_modes(*args, batched=True)
    for a, b in zip(modes_many, modes_one):
        assert a.shape == b.shape
        np.testing.assert_allclose(a, b, rtol=1e-6, atol=1e-6)


def test_blocked_records_batch_their_passes_where_it_pays(monkeypatch):
    """Block means of ≥ `batched_block` samples run the first pass's and the mixture's
    smoothings batched under XLA's default loops, with the estimates of the runs one by one
    to rounding; under `use_fast_cpu_loops` (its flag in XLA_FLAGS) and for shorter blocks
    they run one by one."""
    from vojax._tracker import _smoother

    calls = []
    original = _smoother.smooth_batched

    def spy(*args):
        calls.append(args[1].shape)
        return original(*args)

    monkeypatch.setattr(_smoother, "smooth_batched", spy)
    dt = 0.01
    t = np.arange(1090) * dt
    u = np.minimum(t / 2.0, 1.0) + 0.1 * np.sin(2 * t)
    x = np.asarray(vojax.simulate(u, 0.35 + 0.2 * t / t[-1], np.array([2.0]), dt,
                                  memory="exponential"))
    y = x + 0.01 * np.ptp(x) * np.random.default_rng(2).standard_normal(t.size)
    kwargs = dict(max_points=100, warn=False)  # blocks of 11 samples
    monkeypatch.delenv("XLA_FLAGS", raising=False)
    batched = vojax.identify(u, y, dt, **kwargs)
    # 100 block means, fitted padded to 128 points (a multiple of `POINT_BUCKET`, 32)
    assert calls and all(shape[0] == 128 for shape in calls)
    del calls[:]
    alone = vojax.identify(u, y, dt, **kwargs,
                           settings=vojax.TrackerSettings(batched_block=12))
    assert not calls
    assert batched.tuning.values == pytest.approx(alone.tuning.values, rel=1e-5)
    for name in ("alpha", "alpha_lower", "alpha_upper", "y_hat"):
        np.testing.assert_allclose(getattr(batched, name), getattr(alone, name), rtol=0,
                                   atol=1e-6)
    monkeypatch.setenv("XLA_FLAGS", "--xla_backend_extra_options="
                       "xla_cpu_small_while_loop_byte_threshold=1048576")
    vojax.identify(u, y, dt, **kwargs)
    assert not calls
