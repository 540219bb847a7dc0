"""The parallel-in-time filter and smoother (the tracker's schedule on a GPU): equal to the
sequential scans and to the dense posterior, with every option the tracker uses (masked
samples, the Levenberg–Marquardt anchor, an AR(1) state, a constant component), their
likelihood's gradient, and the tracker run through them."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import vojax
from vojax._tracker import _smoother, kalman_filter, rts_smoother
from vojax._tracker._parallel import chunked_scan, parallel_filter, parallel_smoother

from .test_kalman import _batch_posterior

SCHEDULES = ("associative", "chunked")


def _problem(n, d=3, seed=0):
    rng = np.random.default_rng(seed)
    h = rng.standard_normal((n, d))
    z = rng.standard_normal(n)
    q = np.abs(rng.standard_normal((n, d))) * 0.05
    q[:, -1] = 0.0  # a constant component, as the tracker's offset
    m0 = rng.standard_normal(d)
    a = rng.standard_normal((d, d))
    p0 = a @ a.T + np.eye(d)
    mask = (rng.random(n) > 0.2).astype(float)
    anchor = rng.standard_normal((n, d))
    f = np.ones((n, d))
    f[:, 0] = 0.9  # an AR(1) component, as the coloured noise's state
    return h, z, 0.3, q, m0, p0, mask, anchor, f


def _close(a, b, rtol):
    a, b = np.asarray(a), np.asarray(b)
    assert np.max(np.abs(a - b)) <= rtol * np.max(np.abs(b)), np.max(np.abs(a - b))


@pytest.mark.parametrize("schedule", SCHEDULES)
@pytest.mark.parametrize("n", [1, 2, 37, 400])
def test_parallel_filter_and_smoother_equal_the_sequential_scans(schedule, n):
    h, z, r, q, m0, p0, mask, anchor, f = (jnp.asarray(x) for x in _problem(n))
    for options in [dict(), dict(mask=mask), dict(mask=mask, anchor=anchor, damping=0.7, f=f)]:
        ref = kalman_filter(h, z, r, q, m0, p0, **options)
        got = parallel_filter(h, z, r, q, m0, p0, **options, schedule=schedule)
        for name in ("mean", "cov", "pred_mean", "pred_cov", "innovation", "innovation_var"):
            _close(getattr(got, name), getattr(ref, name), 1e-11)
        assert abs(float(got.log_likelihood - ref.log_likelihood)) <= 1e-11 * abs(
            float(ref.log_likelihood)) + 1e-12
        fk = options.get("f")
        for a, b in zip(parallel_smoother(got, q, fk, schedule=schedule), rts_smoother(ref, q, fk)):
            _close(a, b, 1e-11)


@pytest.mark.parametrize("schedule", SCHEDULES)
def test_parallel_smoother_equals_the_dense_posterior(schedule):
    h, z, r, q, m0, p0, *_ = _problem(30, seed=4)
    mean, covs, loglik = _batch_posterior(h, z, r, q, m0, p0)
    filt = parallel_filter(*(jnp.asarray(x) for x in (h, z, r, q, m0, p0)), schedule=schedule)
    ms, ps = parallel_smoother(filt, jnp.asarray(q), schedule=schedule)
    _close(ms, mean, 1e-9)
    _close(ps, covs, 1e-9)
    assert float(filt.log_likelihood) == pytest.approx(loglik, rel=1e-10)


@pytest.mark.parametrize("schedule", SCHEDULES)
def test_parallel_likelihood_gradient_equals_the_sequential_one(schedule):
    """The tracker tunes its noise intensities on the gradient of this likelihood."""
    h, z, _, q, m0, p0, mask, _, f = (jnp.asarray(x) for x in _problem(50, seed=2))

    def loglik(run, log_r, log_q):
        return run(h, z, jnp.exp(log_r), q * jnp.exp(log_q), m0, p0, mask, f=f).log_likelihood

    args = (jnp.log(0.3), jnp.zeros(3))
    # compiled whole, as the tracker runs it (dispatched op by op, the associative scan's
    # gradient took 25 s of this test's 30)
    ref = jax.jit(jax.grad(lambda a, b: loglik(kalman_filter, a, b), argnums=(0, 1)))(*args)
    got = jax.jit(jax.grad(lambda a, b: loglik(
        lambda *x, **k: parallel_filter(*x, **k, schedule=schedule), a, b),
        argnums=(0, 1)))(*args)
    for a, b in zip(got, ref):
        _close(a, b, 1e-9)


@pytest.mark.parametrize("n", [1, 5, 16, 17, 101])
@pytest.mark.parametrize("reverse", [False, True])
def test_chunked_scan_equals_cumulative_sums_and_products(n, reverse):
    """Against NumPy's cumulative sums, and a non-commutative operation (2 × 2 products)."""
    rng = np.random.default_rng(n)
    x = rng.standard_normal(n)
    got = chunked_scan(lambda a, b: a + b, jnp.asarray(x), jnp.zeros(()), reverse)
    want = np.cumsum(x[::-1])[::-1] if reverse else np.cumsum(x)
    np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12)
    m = rng.standard_normal((n, 2, 2))
    # associative_scan's order: fn(earlier, later); with reverse, fn(later, earlier)
    got = chunked_scan(lambda a, b: b @ a, jnp.asarray(m), jnp.eye(2), reverse)
    want, acc = [], np.eye(2)
    for k in (range(n - 1, -1, -1) if reverse else range(n)):
        acc = m[k] @ acc
        want.append(acc)
    want = np.stack(want[::-1] if reverse else want)
    np.testing.assert_allclose(got, want, rtol=1e-10, atol=1e-10)


def test_schedule_is_sequential_on_a_cpu_and_parallel_elsewhere(monkeypatch):
    monkeypatch.setattr(jax, "default_backend", lambda: "cpu")
    assert _smoother.resolve_schedule(None) == "sequential"
    monkeypatch.setattr(jax, "default_backend", lambda: "gpu")
    assert _smoother.resolve_schedule(None) == _smoother.ACCELERATOR_SCHEDULE == "chunked"
    assert _smoother.resolve_schedule("associative") == "associative"
    with pytest.raises(ValueError, match="`schedule` must be None, 'sequential'"):
        vojax.TrackerSettings(schedule="fast")


@pytest.mark.slow
@pytest.mark.parametrize("schedule, n, max_points", [
    ("associative", 200, None), ("chunked", 200, None),
    # block means of 21 samples: the first pass's smoothings run vmapped, 9 at a time
    ("chunked", 4000, 200), ("associative", 4000, 200),
])
def test_tracker_through_the_parallel_schedule_equals_the_sequential_one(
        schedule, n, max_points, monkeypatch):
    """`identify`, its filters and smoothers run as prefix sums (the GPU's path, here on the
    CPU): the same order and band to the smoother's own stopping rule. The iteration stops
    once the objective J (about one unit per point fitted, in the tracker's normalised units)
    falls by less than `REL_TOL` of itself, so two schedules whose sums round differently may
    stop one step apart, at states within ``δᵀHδ ≲ 2·REL_TOL·J`` of each other: an order
    within ``√(2·REL_TOL·points)`` of its posterior σ. That bound (6.3e-4 σ at 200 points,
    1.2e-4 in the order here, where σ is about 0.19) is what the schedules must meet; the
    planted prefix-sum bugs of `scripts/mutation_check.py` fail it. (An absolute 1e-7 held where both stopped on the same step, and failed by 2.1e-7 on
    chunked-200 under jax 0.10.2 with numpy 2.4.6.)"""
    dt = 0.05
    t = dt * np.arange(n)
    u = np.minimum(t / (0.2 * t[-1]), 1.0) + 0.05 * np.sin(t)
    x = np.asarray(vojax.simulate(u, 0.35 + 0.2 * t / t[-1], np.array([2.0]), dt,
                                  memory="exponential"))
    y = x + 0.01 * np.ptp(x) * np.random.default_rng(0).standard_normal(n)
    kwargs = dict(warn=False) if max_points is None else dict(warn=False, max_points=max_points)
    ref = vojax.identify(u, y, dt, **kwargs,
                         settings=vojax.TrackerSettings(schedule="sequential"))
    calls, batched = [], []
    monkeypatch.setattr(_smoother, "parallel_filter",
                        lambda *a, **k: calls.append(1) or parallel_filter(*a, **k))
    run_batched = _smoother.smooth_batched
    monkeypatch.setattr(_smoother, "smooth_batched",
                        lambda *a, **k: batched.append(1) or run_batched(*a, **k))
    jax.clear_caches()  # the spies are seen where a program is traced
    try:
        got = vojax.identify(u, y, dt, **kwargs, settings=vojax.TrackerSettings(schedule=schedule))
    finally:
        jax.clear_caches()  # later tests trace without the spies
    assert calls, "the parallel filter was not traced"
    assert bool(batched) == (max_points is not None)  # the vmapped runs on the blocked record
    assert got.diagnostics.block == ref.diagnostics.block
    batched_block = vojax.TrackerSettings().batched_block
    assert (got.diagnostics.block >= batched_block) == (max_points is not None)
    from vojax._tracker._damping import REL_TOL

    points = min(n, max_points or n)
    bound = np.sqrt(2 * REL_TOL * points) * np.asarray(ref.alpha_std)
    assert np.all(np.abs(np.asarray(got.alpha) - np.asarray(ref.alpha)) <= bound)
    np.testing.assert_allclose(got.alpha_std, ref.alpha_std, rtol=1e-5)
    assert got.diagnostics.identified == ref.diagnostics.identified


def test_tracker_runs_one_thread_with_a_parallel_schedule_on_a_cpu(monkeypatch):
    """XLA:CPU deadlocked running the prefix sums' programs from two threads at once: with a
    parallel schedule on a CPU the tracker's runs go one after another, in one share; with
    the sequential one each run is a share of its own (a free thread takes the next), and
    batched runs go in equal shares, one per core."""
    import types

    from vojax._tracker import _threads

    monkeypatch.setattr(_threads.os, "cpu_count", lambda: 4)
    shares = {}
    for how, batched in (("sequential", False), ("chunked", False), ("sequential", True)):
        problem = types.SimpleNamespace(settings=vojax.TrackerSettings(), schedule=how)
        for _ in range(2):  # the second time warm: the shares run side by side
            out = _threads.in_threads(problem, _problem, 8, lambda lo, hi: hi - lo,
                                      ("test", how, batched), batched)
        assert [size for _, size in out] == [hi - lo for (lo, hi), _ in out]
        shares[how, batched] = [share for share, _ in out]
    assert shares["sequential", False] == [(k, k + 1) for k in range(8)]
    assert shares["chunked", False] == [(0, 8)]
    assert shares["sequential", True] == [(0, 2), (2, 4), (4, 6), (6, 8)]
