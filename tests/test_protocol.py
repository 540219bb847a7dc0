"""`optimal_protocol` with the parameters free to drift, against `fisher_information` computed
on its own; its refusals of a protocol it cannot use."""

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
    (lambda q, t: jnp.ones(t.size - 1), {}, r"must give shape \(40,\) or \(40, n\), got \(39,\)"),
    (lambda q, t: jnp.ones((t.size, 2, 2)), {}, r"must give shape \(40,\)"),
    (lambda q, t: t / q[0] - jnp.inf, {}, "not finite"),
    (lambda q, t: jnp.log(t - 1.0), {}, "not finite"),  # NaN before t = 1
    (lambda q, t: jnp.stack([t, t], 1), {}, r"`p` must be 2 finite number\(s\), one per input"),
    (lambda q, t: jnp.minimum(t / q[0], 1.0), dict(parameter_knots=1),
     "`parameter_knots` must be an integer from 2 to 20"),
    (lambda q, t: jnp.minimum(t / q[0], 1.0), dict(parameter_knots=2.5),
     "`parameter_knots` must be an integer"),
    (lambda q, t: jnp.minimum(t / q[0], 1.0), dict(num_samples=True), "`num_samples` must be"),
    (lambda q, t: jnp.minimum(t / q[0], 1.0), dict(noise_std=True), "`noise_std` must be"),
    (lambda q, t: jnp.minimum(t / q[0], 1.0), dict(knots=0), "`knots` must be an integer"),
])
def test_a_protocol_it_cannot_use_is_refused_with_a_reason(protocol, kwargs, words):
    """Inputs of the wrong shape, not finite at the start, or not one per parameter, and bad
    knots or counts: a `ValueError` naming what is wrong, before any search."""
    call = dict(noise_std=0.01, num_samples=40) | kwargs
    with pytest.raises(ValueError, match=words):
        vojax.optimal_protocol(protocol, [1.0], [0.5], [2.0], 0.4, [1.0], 0.05, **call)
