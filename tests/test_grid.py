"""The memories on arbitrary increasing sample times (`t=`): exact interval weights against a
50-digit evaluation, closed forms on log-spaced and random grids, the uniform grid against the
`dt` path, the exponential memory against the direct one, convergence on graded grids."""

import math
from decimal import Decimal, getcontext

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import vojax
from vojax._integral import make_memory, order_map, scan_memory
from vojax._kernels._special import digamma
from vojax._kernels._weights import interval_weights

from .helpers import slope

RULES = ["trapezoid", "rectangle"]


def _decimal_weights(a: float, h: float, b: float, rule: str):
    """The weights of one interval from their closed forms in 50-digit decimal arithmetic:
    ``w_{i+1} = [a^{b+1} − B^b (a + b h)]/(h Γ(b+2))``, ``w_i = [a^b (b h − B) + B^{b+1}]/(h Γ(b+2))``
    with ``B = a − h``; rectangle: ``(a^b − B^b)/Γ(b+1)``. Γ is taken in double precision (a
    common factor, so it cannot hide an error in the bracket)."""
    getcontext().prec = 50

    def pw(x, e):
        return (e * x.ln()).exp() if x > 0 else Decimal(0)

    A, H, bb = Decimal(a), Decimal(h), Decimal(b)
    B = A - H
    if rule == "rectangle":
        return (pw(A, bb) - pw(B, bb)) / Decimal(math.gamma(b + 1)), Decimal(0)
    g = Decimal(math.gamma(b + 2))
    return (pw(A, bb) * (bb * H - B) + pw(B, bb + 1)) / (H * g), (
        pw(A, bb + 1) - pw(B, bb) * (A + bb * H)
    ) / (H * g)


@pytest.mark.parametrize("rule", RULES)
def test_interval_weights_against_50_digit_closed_forms(rule):
    """Both branches (the closed forms above lag ratio 1/4 and the binomial series below it) are
    accurate to a few ulps for every order, from the last interval to lags of 1e8 steps, where
    the plain closed forms in double precision would have lost every digit."""
    worst = 0.0
    for b in (0.01, 0.2, 0.5, 0.83, 0.99):
        for ratio in (1.0, 1.3, 2.0, 3.9, 4.0, 4.1, 7.0, 50.0, 1e4, 1e8):
            h = 0.37
            got = interval_weights(jnp.asarray(ratio * h), jnp.asarray(h), jnp.asarray(b), rule)
            want = _decimal_weights(ratio * h, h, b, rule)
            for g, w in zip(got, want):
                if w != 0:
                    worst = max(worst, float(abs(Decimal(float(g)) - w) / abs(w)))
                else:
                    assert float(g) == 0.0
    assert worst < 1e-14


def _grids():
    rng = np.random.default_rng(7)
    log_spaced = np.concatenate([[0.0], np.geomspace(1e-4, 10.0, 300)])
    random = 2.0 + np.cumsum(rng.uniform(0.001, 0.1, 250))  # starts at t_0 ≠ 0
    return {"log": log_spaced, "random": random}


def _exact(t, order, mu):
    """``I^b[(τ − t_0)^μ](t) = Γ(μ+1)/Γ(μ+1+b) (t − t_0)^{μ+b}`` and its b-derivative."""
    s = t - t[0]
    g = np.array([math.lgamma(mu + 1.0) - math.lgamma(mu + 1.0 + b) for b in order])
    psi = digamma(mu + 1.0 + np.asarray(order))
    log_s = np.log(np.where(s > 0, s, 1.0))
    phi = np.where(s > 0, np.exp(g + (mu + order) * log_s), 0.0)
    return phi, np.where(s > 0, phi * (log_s - psi), 0.0)


@pytest.mark.parametrize("grid", ["log", "random"])
@pytest.mark.parametrize("memory", ["direct", "exponential"])
@pytest.mark.parametrize("rule", RULES)
def test_closed_forms_on_irregular_grids(grid, memory, rule):
    """u = 1 (both rules) and u = t − t_0 (trapezoid) are reproduced by the interpolant, so Φ
    and ∂Φ/∂b are exact: to rounding with the direct memory, to the design tolerance (1e-10 of
    the kernel) with the exponential one. A variable order."""
    t = _grids()[grid]
    order = 0.2 + 0.6 * np.sin(3.0 * (t - t[0]) / (t[-1] - t[0])) ** 2
    tol = 1e-13 if memory == "direct" else 2e-9
    for mu in (0.0, 1.0) if rule == "trapezoid" else (0.0,):
        u = (t - t[0]) ** mu
        phi = vojax.fractional_integral(u, order, t=t, rule=rule, memory=memory)
        dphi = vojax.order_sensitivity(u, order, t=t, rule=rule, memory=memory)
        phi_exact, dphi_exact = _exact(t, order, mu)
        scale = np.max(np.abs(phi_exact))
        assert np.max(np.abs(phi - phi_exact)) < tol * scale
        assert np.max(np.abs(dphi - dphi_exact)) < 10 * tol * np.max(np.abs(dphi_exact))
        # sample by sample, relative (the log grid spans six decades of Φ)
        later = slice(1, None)
        rel = np.abs(phi[later] - phi_exact[later]) / phi_exact[later]
        assert np.max(rel) < (1e-12 if memory == "direct" else 1e-8)


@pytest.mark.parametrize("rule", RULES)
def test_exponential_equals_direct_on_a_log_grid(rule):
    """A rough input (white noise) on a clock spanning five decades: the sum-of-exponentials
    memory, with its modes designed from the smallest step, equals exact product integration
    to its design tolerance, Φ and ∂Φ/∂b, at a variable order."""
    t = _grids()["log"]
    u = np.random.default_rng(3).standard_normal((t.size, 2))
    order = 0.05 + 0.9 * np.random.default_rng(4).uniform(size=t.size)
    for fn in (vojax.fractional_integral, vojax.order_sensitivity):
        exact = np.asarray(fn(u, order, t=t, rule=rule))
        fast = np.asarray(fn(u, order, t=t, rule=rule, memory="exponential"))
        assert np.max(np.abs(fast - exact)) < 1e-9 * np.max(np.abs(exact))


@pytest.mark.parametrize("memory", ["direct", "exponential"])
@pytest.mark.parametrize("rule", RULES)
def test_uniform_times_equal_the_step(memory, rule):
    """``t = k·dt`` goes through the grid weights (computed from the times) and must give the
    `dt` path's Diethelm weights: the two formulas agree to rounding."""
    dt, num = 0.013, 400
    t = dt * np.arange(num)
    u = np.stack([np.cos(3 * t) + t, np.exp(-t)], axis=1)
    order = 0.05 + 0.9 * (t / t[-1]) ** 2
    for fn in (vojax.fractional_integral, vojax.order_sensitivity):
        a = fn(u, order, dt, rule=rule, memory=memory)
        b = fn(u, order, t=t, rule=rule, memory=memory)
        assert np.max(np.abs(a - b)) < 1e-11 * np.max(np.abs(a))


@pytest.mark.parametrize("rule, mu, expected", [("trapezoid", 2.0, 2.0), ("rectangle", 1.0, 1.0)])
def test_convergence_order_on_graded_grids(rule, mu, expected):
    """On graded grids ``t_j = T (j/N)^2`` the maximum error of u = t^μ falls like N^{−p} with the
    rule's order p (2 for the trapezoid on a smooth u, 1 for the rectangle)."""
    ns = np.array([50, 100, 200, 400])
    errors = []
    for n in ns:
        t = 4.0 * (np.arange(n + 1) / n) ** 2
        order = 0.3 + 0.4 * np.sin(t) ** 2
        phi = vojax.fractional_integral(t**mu, order, t=t, rule=rule)
        errors.append(np.max(np.abs(phi - _exact(t, order, mu)[0])))
    assert abs(slope(1.0 / ns, np.array(errors)) - expected) < 0.1


@pytest.mark.slow
def test_exponential_history_equals_scan_on_a_grid():
    """The order-free history of a grid (per-step decays and weights in an associative scan)
    read out at an order trajectory equals the sample-by-sample scan, Φ and ∂Φ/∂b."""
    t = _grids()["log"]
    rng = np.random.default_rng(1)
    u = jnp.asarray(rng.normal(size=(t.size, 2)))
    order = jnp.asarray(0.1 + 0.8 * rng.uniform(size=t.size))
    for rule in RULES:
        mem = make_memory("exponential", None, t.size, rule=rule, times=t)
        assert mem.history_fits(*u.shape)
        evaluate = order_map(mem, u)
        phi, dphi = evaluate(order, True)
        phi_s, dphi_s = scan_memory(mem, u, order, True)
        assert np.max(np.abs(phi - phi_s)) < 1e-13 * np.max(np.abs(phi_s))
        assert np.max(np.abs(dphi - dphi_s)) < 1e-13 * np.max(np.abs(dphi_s))


@pytest.mark.parametrize("memory", ["direct", "exponential"])
def test_gradients_on_a_grid_are_finite_and_match_differences(memory):
    """Reverse-mode gradients with respect to the order trajectory (through the scan) are finite
    at every sample, the first included, and equal central differences."""
    t = _grids()["log"][:120]
    u = np.cos(t)
    order = jnp.full(t.size, 0.4)

    def loss(o):
        return jnp.sum(vojax.fractional_integral(u, o, t=t, memory=memory) ** 2)

    g = jax.grad(loss)(order)
    assert np.all(np.isfinite(g))
    direction = jnp.asarray(np.random.default_rng(2).normal(size=t.size))
    eps = 1e-6
    fd = (loss(order + eps * direction) - loss(order - eps * direction)) / (2 * eps)
    assert abs(float(g @ direction) - float(fd)) < 1e-6 * abs(float(fd))


@pytest.mark.parametrize("memory", ["direct", "exponential"])
@pytest.mark.parametrize("grid", ["log", "random"])
def test_each_memorys_step_on_a_grid_is_the_interval_ending_at_the_sample(memory, grid):
    """What the laws driven by a memory integrate over at sample k (its `step_size`): on a
    grid, ``t_k − t_{k−1}``, and at sample 0 the first step; read from the memory's state as
    the law's scan steps it."""
    t = _grids()[grid]
    mem = make_memory(memory, None, t.size, times=t)
    state = mem.init(1)
    steps = []
    for k in range(t.size):
        steps.append(float(mem.step_size(state)))
        state = mem.update(state, jnp.ones(1))
    expected = np.diff(t, prepend=2 * t[0] - t[1])
    np.testing.assert_allclose(steps, expected, rtol=1e-15, atol=0)


def test_the_law_on_a_grid_is_the_same_with_either_memory():
    """The paper's law on a random clock (steps 0.001–0.1) with the direct memory and with
    the exponential one (its modes designed to 1e-10): one estimate to the design tolerance,
    though each memory gives the law its steps its own way."""
    t = _grids()["random"]
    u = np.stack([np.sin(3 * t), np.cos(t)], axis=1)
    alpha = 0.4 + 0.1 * np.sin(t)
    y = vojax.simulate(u, alpha, np.array([1.0, -0.5]), t=t)
    runs = [vojax.identify(u, y, t=t, method="gradient", gamma=0.05, lam=0.9, x0=0.0,
                           r0=np.eye(2), memory=memory, warn=False)
            for memory in ("direct", "exponential")]
    direct, fast = (np.asarray(r.alpha) for r in runs)
    assert np.ptp(direct) > 1e-3  # the law moves: the steps it takes matter
    assert np.max(np.abs(direct - fast)) < 1e-9  # 7e-13; the first step everywhere: 0.03


def test_simulate_on_a_grid():
    """`simulate` with ``t=`` on a step load gives x0 + p t^b/Γ(b+1) from t_0."""
    t = np.concatenate([[0.0], np.geomspace(1e-3, 100.0, 200)])
    x = vojax.simulate(np.full(t.size, 2.0), 0.3, np.array([0.5]), t=t, x0=1.0)
    np.testing.assert_allclose(x, 1.0 + t**0.3 / math.gamma(1.3), rtol=1e-13)


def test_time_grid_errors():
    t = np.linspace(0.0, 1.0, 10)
    u = np.ones(10)
    with pytest.raises(TypeError, match="exactly one of `dt`"):
        vojax.fractional_integral(u, 0.5, 0.1, t=t)
    with pytest.raises(TypeError, match="got neither"):
        vojax.fractional_integral(u, 0.5)
    bad = t.copy()
    bad[4] = bad[3]
    with pytest.raises(ValueError, match=r"strictly increasing, but t\[4\]"):
        vojax.fractional_integral(u, 0.5, t=bad)
    with pytest.raises(ValueError, match=r"shape \(10,\)"):
        vojax.fractional_integral(u, 0.5, t=t[:9])
    bad = t.copy()
    bad[2] = np.nan
    with pytest.raises(ValueError, match="NaN"):
        vojax.order_sensitivity(u, 0.5, t=bad, memory="exponential")
