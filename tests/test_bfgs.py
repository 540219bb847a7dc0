"""The tuner's BFGS (`vojax._tracker._bfgs`): its iterates follow the rules its docstring
states (a NumPy transcription of them, written here), it reaches the minima optimistix's
`BFGS` reaches (the second, independent implementation, compared at the solvers' tolerance,
not in their last digits), on test functions and on the tracker's own refinement of the noise
intensities; it reaches a known minimum; it skips the update where the gradient does not
change."""

import jax
import jax.numpy as jnp
import numpy as np
import optimistix as optx
import pytest

from vojax._tracker import Hyper
from vojax._tracker._bfgs import minimise
from vojax._tracker._smoother import linearised_log_likelihood
from vojax._tracker._threads import host_hyper
from vojax._tracker._tuning import _refine, box

from .helpers import normalised_problem, ramp_case

RTOL, ATOL = 1e-7, 1e-9


def _rosenbrock(y):
    return (1 - y[0]) ** 2 + 100 * (y[1] - y[0] ** 2) ** 2


def _coupled(y):
    a = jnp.array([[3.0, 1.0, 0.5], [1.0, 2.0, 0.2], [0.5, 0.2, 1.0]])
    return 0.5 * y @ a @ y - jnp.array([1.0, 2.0, 3.0]) @ y + jnp.sum(jnp.cos(y))


def _rules(loss, y0, max_steps):
    """The module docstring's rules, one evaluation at a time in NumPy (the loss and its
    gradient from JAX, evaluated point by point): ``(last accepted point, evaluations)``."""
    grad = jax.grad(loss)
    y = y_eval = np.asarray(y0, float)
    f, g, h = 0.0, np.zeros_like(y), np.eye(y.size)
    direction, step, first = np.zeros_like(y), 1.0, True
    for count in range(1, max_steps + 1):
        f_eval = float(loss(jnp.asarray(y_eval)))
        s = y_eval - y
        predicted = float(g @ s)
        if first or (f_eval - f <= 0.1 * predicted and predicted <= 0):
            g_eval = np.asarray(grad(jnp.asarray(y_eval)))
            d = g_eval - g
            inner = float(d @ s)
            if inner > np.finfo(float).eps:
                hd = h @ d
                h = h + (inner + d @ hd) * np.outer(s, s) / inner**2 - (
                    np.outer(hd, s) + np.outer(s, hd)) / inner
            stop = not first and (
                np.max(np.abs(s) / (ATOL + RTOL * np.abs(y_eval))) < 1
                and abs(f_eval - f) / (ATOL + RTOL * abs(f_eval)) < 1)
            y, f, g, direction, step = y_eval, f_eval, g_eval, h @ g_eval, 1.0
            if stop:
                return y, count
        else:
            step *= 0.5
        first = False
        y_eval = y - step * direction
    return y, max_steps


def _hilltop(y):
    """Negative curvature about its start: BFGS's first moves have (g' − g)·s < 0, where the
    update is skipped."""
    return jnp.sum(jnp.cos(y)) + 0.05 * jnp.sum(y**2)


def _far(y):
    """A minimum of 0 far from the origin, at (1e6, −2e6): the points' tolerance
    (``rtol·|y|``, about 0.1) passes moves that still change the loss by far more than its
    own (``atol``, the loss near 0), so the stop must wait for both."""
    return jnp.sum(jnp.cosh(y - jnp.asarray([1e6, -2e6]))) - 2.0


CASES = [(_rosenbrock, [-1.2, 1.0]), (_rosenbrock, [2.0, -1.0]), (_coupled, [0.0, 0.0, 0.0]),
         (_hilltop, [0.3, -0.2]), (_far, [1e6 + 0.3, -2e6 - 0.2])]


@pytest.mark.parametrize("loss, y0", CASES)
@pytest.mark.parametrize("max_steps", [5, 60])
def test_bfgs_iterates_follow_its_rules(loss, y0, max_steps):
    """Cut short by `max_steps` (5) or run to its tolerance (60): the same last accepted point
    and the same count of evaluations as the rules transcribed in NumPy."""
    want, steps = _rules(loss, y0, max_steps)
    got, count = jax.jit(lambda y: minimise(loss, y, max_steps, RTOL, ATOL))(jnp.asarray(y0))
    assert int(count) == steps
    np.testing.assert_allclose(np.asarray(got), want, rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize("loss, y0", CASES)
def test_bfgs_reaches_the_minimum_optimistix_reaches(loss, y0):
    """Run to convergence, its minimum is `optimistix.BFGS(rtol, atol)`'s, within the
    tolerance."""
    y0 = jnp.asarray(y0)
    sol = optx.minimise(lambda y, _: loss(y), optx.BFGS(rtol=RTOL, atol=ATOL), y0,
                        max_steps=200)
    got, count = minimise(loss, y0, 200, RTOL, ATOL)
    assert int(count) < 200
    np.testing.assert_allclose(np.asarray(got), np.asarray(sol.value), rtol=1e-6, atol=1e-8)


def test_bfgs_reaches_rosenbrocks_minimum():
    """The minimum of Rosenbrock's function is (1, 1) (its closed form), reached within the
    tolerance from the classical start."""
    got, count = minimise(_rosenbrock, jnp.asarray([-1.2, 1.0]), 200, RTOL, ATOL)
    np.testing.assert_allclose(np.asarray(got), [1.0, 1.0], atol=1e-6)
    assert 10 < int(count) < 200


def test_bfgs_keeps_its_inverse_hessian_where_the_gradient_does_not_change():
    """A linear loss has a constant gradient c: no update of the inverse Hessian (the identity
    stays), every unit step along −c is accepted, and after m evaluations the last accepted
    point is y0 − (m − 1)c exactly. The start has a loss of 0, which the first iteration,
    whose move is 0, must not read as converged."""
    c = jnp.asarray([0.5, -2.0, 1.0])
    y0 = jnp.asarray([2.0, 1.0, 1.0])
    assert float(c @ y0) == 0.0
    got, count = minimise(lambda y: c @ y, y0, 7, RTOL, ATOL)
    assert int(count) == 7
    np.testing.assert_array_equal(np.asarray(got), np.asarray(y0 - 6 * c))


def _refine_with_optimistix(hyper, sm, mask, steps, horizon, m0, p0, limits, max_steps=60):
    """The tracker's refinement (`_tuning._refine`) computed with `optimistix.BFGS`."""
    lo = jnp.asarray([v[0] for v in limits.values()])
    hi = jnp.asarray([v[1] for v in limits.values()])
    count = jnp.sum(mask)

    def loss(zeta, _):
        x = lo + (hi - lo) * jax.nn.sigmoid(zeta)
        return -linearised_log_likelihood(Hyper.from_array(x), sm.jacobian, sm.pseudo, mask,
                                          steps, horizon, m0, p0) / count

    x0 = jnp.asarray(host_hyper(hyper))
    margin = jnp.minimum(1e-3, (hi - lo) / 2)
    x0 = jnp.clip(x0, lo + margin, hi - margin)
    zeta0 = jnp.where(hi > lo, jnp.log((x0 - lo) / jnp.where(hi > lo, hi - x0, 1.0)), 0.0)
    sol = optx.minimise(loss, optx.BFGS(rtol=RTOL, atol=ATOL), zeta0, max_steps=max_steps,
                        throw=False)
    return np.asarray(lo + (hi - lo) * jax.nn.sigmoid(sol.value))


@pytest.mark.parametrize("hold", [False, True])
def test_refinement_of_the_intensities_is_optimistix_bfgs(hold):
    """The tracker's refinement of its three log-intensities on the likelihood of a smoothing
    linearised at its mode, the parameters' drift free or held (a box of zero width): the
    intensities optimistix's BFGS reaches from the same start (both converge within their 60
    evaluations), to 1e-6."""
    problem, starts = normalised_problem(ramp_case(n=200), 200, columns=1)
    hyper = Hyper(*(jnp.log(jnp.asarray(v)) for v in (0.05, 1e-5, 1e-2)))
    sm = problem.smooth_from(hyper, starts[0])
    limits = box(problem.settings, 1e-4, hold)
    got = np.asarray(jax.tree_util.tree_leaves(_refine(problem, hyper, sm, limits)))
    want = _refine_with_optimistix(hyper, sm, problem.mask, problem.steps, problem.horizon,
                                   problem.m0, problem.p0, limits)
    assert np.max(np.abs(got - want)) <= 1e-6 * np.max(np.abs(want))
    assert np.max(np.abs(got - host_hyper(hyper))) > 0.1  # it moved
