"""The memory kernels against closed forms, each other, and finite differences."""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest
from jax.test_util import check_grads

import vojax
from vojax import reference
from vojax._integral import TRACES

from .helpers import paper_inputs, power_law, rel_max, slope

RULES = ["trapezoid", "rectangle"]
MEMORIES = ["direct", "exponential"]


# (rule, μ) → measured order of the max error in h, or None where the rule is exact
EXPECTED_ORDER = {
    ("trapezoid", 0.0): None,
    ("trapezoid", 1.0): None,
    ("trapezoid", 2.0): 2.0,
    ("rectangle", 0.0): None,
    ("rectangle", 1.0): 1.0,
    ("rectangle", 2.0): 1.0,
}


@pytest.mark.parametrize("rule", RULES)
@pytest.mark.parametrize("mu", [0.0, 1.0, 2.0, 0.5])
@pytest.mark.parametrize("variable", [False, True])
def test_power_law_closed_form_and_convergence_order(rule, mu, variable):
    """u = t^μ against Φ = Γ(μ+1)/Γ(μ+1+b) t^{μ+b}, ∂Φ/∂b = Φ (ln t − ψ(μ+1+b)) (NOTES §1)."""
    hs = np.array([0.04, 0.02, 0.01, 0.005])
    errors, derrors, end_errors = [], [], []
    for h in hs:
        t = np.arange(int(round(4.0 / h)) + 1) * h
        order = 0.3 + 0.4 * np.sin(t) ** 2 if variable else 0.35
        phi_exact, dphi_exact = power_law(t, mu, order)
        errors.append(
            np.max(np.abs(vojax.fractional_integral(t**mu, order, h, rule=rule) - phi_exact))
        )
        dphi = vojax.order_sensitivity(t**mu, order, h, rule=rule)
        derrors.append(np.max(np.abs(dphi - dphi_exact)))
        end_errors.append(abs(dphi[-1] - dphi_exact[-1]))
    errors, derrors = np.array(errors), np.array(derrors)
    if mu == 0.5:
        # u = √t is not smooth at 0: the max error is O(h^{μ + b(0)}), b(0) = 0.3 or 0.35
        b0 = 0.3 if variable else 0.35
        assert abs(slope(hs, errors) - (mu + b0)) < 0.05
        # … while away from t = 0 both rules keep their order, capped at 1 + μ
        assert abs(slope(hs, end_errors) - (1.5 if rule == "trapezoid" else 1.0)) < 0.05
        return
    expected = EXPECTED_ORDER[(rule, mu)]
    if expected is None:
        assert errors.max() < 1e-13 * 4**mu and derrors.max() < 1e-12 * 4**mu
    else:
        assert abs(slope(hs, errors) - expected) < 0.1
        assert abs(slope(hs, derrors) - expected) < 0.15


@pytest.mark.parametrize("rule", RULES)
@pytest.mark.parametrize("memory", MEMORIES)
def test_sensitivity_three_ways(rule, memory):
    n, dt = 300, 0.05
    _, u, alpha = paper_inputs(n, dt)
    ad = vojax.order_sensitivity(u, alpha, dt, rule=rule, memory=memory)
    closed = reference.order_sensitivity(u, alpha, dt, rule=rule, memory=memory)
    assert rel_max(ad, closed) < 1e-12
    eps = 1e-6
    plus = vojax.fractional_integral(u, alpha + eps, dt, rule=rule, memory=memory)
    minus = vojax.fractional_integral(u, alpha - eps, dt, rule=rule, memory=memory)
    assert rel_max((plus - minus) / (2 * eps), closed) < 1e-7
    # the values themselves agree with the NumPy transcription too
    phi = vojax.fractional_integral(u, alpha, dt, rule=rule, memory=memory)
    assert (
        rel_max(phi, reference.fractional_integral(u, alpha, dt, rule=rule, memory=memory)) < 1e-13
    )


@pytest.mark.parametrize("memory", MEMORIES)
def test_grad_of_sum_is_the_sensitivity(memory):
    # φ_k depends on order[k] only, so the gradient of Σφ is the pointwise sensitivity
    n, dt = 200, 0.05
    _, u, alpha = paper_inputs(n, dt)
    u1 = jnp.asarray(u[:, 0])
    g = jax.grad(lambda a: jnp.sum(vojax.fractional_integral(u1, a, dt, memory=memory)))(
        jnp.asarray(alpha)
    )
    sens = vojax.order_sensitivity(u1, alpha, dt, memory=memory)
    closed = reference.order_sensitivity(u1, alpha, dt, memory=memory)
    assert rel_max(g, sens) < 1e-13
    assert rel_max(g, closed) < 1e-12


@pytest.mark.parametrize(
    "memory", [pytest.param("direct", marks=pytest.mark.slow), "exponential"]
)
def test_derivatives_finite_at_start_and_extreme_orders(memory):
    dt = 0.1
    u = jnp.linspace(0.0, 1.0, 16)
    for b in (0.011, 0.5, 0.989):
        order = jnp.full((16,), b)
        g_order = jax.grad(lambda a: jnp.sum(vojax.fractional_integral(u, a, dt, memory=memory)))(
            order
        )
        g_u = jax.grad(lambda x: jnp.sum(vojax.order_sensitivity(x, order, dt, memory=memory)))(u)
        assert np.all(np.isfinite(g_order)) and np.all(np.isfinite(g_u))
        assert float(g_order[0]) == 0.0  # sample 0 is 0 for every order
    check_grads(
        lambda x: vojax.fractional_integral(x, 0.4, dt, memory=memory),
        (u,),
        order=2,
        modes=["fwd", "rev"],
    )


@pytest.mark.parametrize("rule", RULES)
@pytest.mark.parametrize(
    "n, dt", [(500, 0.2), (3000, 0.05), pytest.param(8000, 0.03, marks=pytest.mark.slow)]
)
def test_exponential_matches_direct(rule, n, dt):
    t, u, alpha = paper_inputs(n, dt)
    for order in (alpha, 0.62):
        phi_d = vojax.fractional_integral(u, order, dt, rule=rule)
        phi_e = vojax.fractional_integral(u, order, dt, rule=rule, memory="exponential")
        assert rel_max(phi_e, phi_d) < 1e-10
        dphi_d = vojax.order_sensitivity(u, order, dt, rule=rule)
        dphi_e = vojax.order_sensitivity(u, order, dt, rule=rule, memory="exponential")
        assert rel_max(dphi_e, dphi_d) < 1e-8


def test_exponential_tolerance_is_respected():
    n, dt = 2000, 0.05
    _, u, _ = paper_inputs(n, dt)
    direct = vojax.fractional_integral(u, 0.8, dt)
    loose = vojax.fractional_integral(u, 0.8, dt, memory="exponential", tol=1e-6)
    err = rel_max(loose, direct)
    assert err < 1e-6
    assert err > 1e-13  # a looser design really is a different (cheaper) memory


def test_exponential_long_record():
    """N = 1e5: the last samples against the direct sums of the reference."""
    from vojax._kernels._special import lgamma
    from vojax.reference import _weights

    n, dt = 100_000, 0.003
    _, u, alpha = paper_inputs(n, dt)
    phi_e = np.asarray(vojax.fractional_integral(u, alpha, dt, memory="exponential"))
    for k in range(n - 3, n):
        w, _ = _weights(k, alpha[k], dt, "trapezoid")
        phi_k = np.exp(-lgamma(alpha[k])) * (w @ u[k::-1])
        assert rel_max(phi_e[k], phi_k) < 1e-10


def test_streaming_equals_batch():
    n, dt = 120, 0.05
    _, u, alpha = paper_inputs(n, dt)
    for memory in (
        vojax.DirectMemory(dt=jnp.asarray(dt), capacity=n),
        vojax.ExponentialMemory.design(dt, n),
    ):
        state = memory.init(2)
        step = eqx.filter_jit(memory.step)
        phis, dphis = [], []
        for k in range(n):
            state, (phi, dphi) = step(state, jnp.asarray(u[k]), jnp.asarray(alpha[k]))
            phis.append(phi)
            dphis.append(dphi)
        kind = "direct" if isinstance(memory, vojax.DirectMemory) else "exponential"
        assert rel_max(np.stack(phis), vojax.fractional_integral(u, alpha, dt, memory=kind)) < 1e-14
        assert rel_max(np.stack(dphis), vojax.order_sensitivity(u, alpha, dt, memory=kind)) < 1e-14


@pytest.mark.parametrize("rule", RULES)
def test_order_free_history_equals_the_scan(rule):
    """The exponential memory's history computed once for the record (an associative
    recurrence) and read out at any orders equals the sample-by-sample scan, Φ and ∂Φ/∂b; a
    record beyond the history limit falls back to the scan."""
    from vojax._integral import order_map

    n, dt = 700, 0.04
    _, u, alpha = paper_inputs(n, dt)
    mem = vojax.ExponentialMemory.design(dt, n, rule=rule)
    u, alpha = jnp.asarray(u), jnp.asarray(alpha)
    scan_phi, scan_dphi = mem.run(u, alpha, True)
    evaluate = order_map(mem, u)
    for order in (alpha, jnp.full((n,), 0.83)):
        assert rel_max(evaluate(order), mem.run(u, order, False)) < 1e-13
    phi, dphi = evaluate(alpha, True)
    assert rel_max(phi, scan_phi) < 1e-13 and rel_max(dphi, scan_dphi) < 1e-13
    h, previous = mem.histories(u)
    assert h.shape == (n, mem.num_modes, 2) and float(jnp.max(jnp.abs(h[:2]))) == 0.0
    limit = n * mem.num_modes * 2 - 1
    assert mem.history_fits(n, 2, limit + 1) and not mem.history_fits(n, 2, limit)
    assert rel_max(order_map(mem, u, history_limit=limit)(alpha), scan_phi) == 0.0


def test_lemma3_integrals_and_the_misprint():
    """Lemma 3's integrals of H = (t−τ)^{β−1}/Γ(β) by quadrature; the third has 2, not 1."""
    import math

    # r = t − τ = t e^{−w/β} maps τ ∈ (0, t) to w ∈ (0, ∞) and r^{β−1} dr to t^β/β e^{−w} dw
    w = np.linspace(0.0, 80.0, 800_001)
    simpson = np.where(np.arange(w.size) % 2 == 1, 4.0, 2.0)
    simpson[[0, -1]] = 1.0
    simpson *= (w[1] - w[0]) / 3

    def integral(f_of_log_r, beta, t):
        g = f_of_log_r(math.log(t) - w / beta) * np.exp(-w)
        return simpson @ g * t**beta / beta / math.gamma(beta)

    for beta, t in [(0.3, 0.5), (0.6, 2.0), (0.8, 7.0)]:
        lt, gb = math.log(t), math.gamma(beta)
        assert abs(integral(np.ones_like, beta, t) - t**beta / (beta * gb)) < 1e-9
        if t <= 1:
            closed1 = t**beta * (1 - beta * lt) / (beta**2 * gb)
        else:
            closed1 = (2 + t**beta * (beta * lt - 1)) / (beta**2 * gb)
        assert abs(integral(np.abs, beta, t) - closed1) / closed1 < 1e-7
        quad = integral(np.square, beta, t)
        printed = t**beta * (1 + beta**2 * lt**2 - 2 * beta * lt) / (beta**3 * gb)
        corrected = t**beta * (2 + beta**2 * lt**2 - 2 * beta * lt) / (beta**3 * gb)
        assert abs(quad - corrected) / corrected < 1e-8
        assert abs(quad - printed) / corrected > 1e-2


def test_one_trace_per_entry_point():
    n, dt = 64, 0.1
    _, u, alpha = paper_inputs(n, dt)
    for memory in MEMORIES:
        vojax.fractional_integral(u, alpha, dt, memory=memory)
        before = TRACES["scan"]
        vojax.fractional_integral(u * 2.0, alpha * 0.9, dt, memory=memory)
        vojax.fractional_integral(u + 1.0, 0.4, dt, memory=memory)
        assert TRACES["scan"] == before
        vojax.order_sensitivity(u, alpha, dt, memory=memory)
        before = TRACES["scan"]
        vojax.order_sensitivity(u * 3.0, alpha, dt, memory=memory)
        assert TRACES["scan"] == before


def test_lgamma1p_series():
    """The Chebyshev ln Γ(1+b) of the weights' normalisation, and its derivative ψ(1+b)."""
    import math

    from vojax._kernels._special import digamma
    from vojax._kernels._weights import lgamma1p

    b = np.linspace(0.0, 1.0, 2001)
    value = np.asarray(lgamma1p(jnp.asarray(b)))
    exact = np.array([math.lgamma(1.0 + x) for x in b])
    assert np.max(np.abs(value - exact)) < 4e-15
    slope = np.asarray(jax.vmap(jax.grad(lgamma1p))(jnp.asarray(b)))
    assert np.max(np.abs(slope - digamma(1.0 + b))) < 1e-12
    # the end points are zeros of ln Γ: Γ(1) = Γ(2) = 1
    assert abs(float(lgamma1p(jnp.asarray(0.0)))) < 1e-15
    assert abs(float(lgamma1p(jnp.asarray(1.0)))) < 1e-15


@pytest.mark.parametrize("unroll", [1, 8])
@pytest.mark.parametrize("memory", MEMORIES)
def test_scan_memory_orders_is_one_scan_per_order(memory, unroll):
    """The batched scan over K order trajectories gives, row by row, what K separate scans
    give (a different compiled program: the vmapped carry), for two input columns; also with
    the loop unrolled by 8 samples a step (300 samples: a remainder of 4)."""
    from vojax._integral import make_memory, scan_memory, scan_memory_orders

    n, dt = 300, 0.02
    _, u, _ = paper_inputs(n, dt)
    u2 = jnp.asarray(u)  # (n, 2)
    s = np.linspace(0.0, 1.0, n)
    orders = np.stack([np.full(n, 0.4), 0.2 + 0.6 * s, 0.5 + 0.3 * np.sin(6 * s)])
    mem = make_memory(memory, dt, n, order_range=(0.1, 0.9))
    batched = np.asarray(scan_memory_orders(mem, u2, jnp.asarray(orders), unroll))
    assert batched.shape == (3, n, 2)
    for k in range(3):
        one = np.asarray(scan_memory(mem, u2, jnp.asarray(orders[k]), False))
        assert rel_max(batched[k], one) < 1e-12
    # the rows differ: each is its own order's (a batch that broadcast one row would pass above
    # only if the orders were equal)
    assert rel_max(batched[0], batched[1]) > 1e-2
