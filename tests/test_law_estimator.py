"""`LawEstimator`: the paper's law as one object. Its options reach the law (each one moves
the result the way its meaning says), bad options are refused when it is built, and
`identify(method="gradient")` is the same computation."""

import dataclasses

import equinox as eqx
import jax.numpy as jnp
import numpy as np
import pytest

import vojax
from vojax._adaptive._build import assemble_law
from vojax._integral import make_memory

H = 0.05


@pytest.fixture(scope="module")
def record():
    t, u, alpha, p = vojax.study_signals(H, 20.0)
    y = np.asarray(vojax.simulate(u, alpha, p, H)) + 0.05 * np.sin(3.1 * t) + 1.5
    return u, y


@eqx.filter_jit
def _step(law, state, u, y):
    return law.step(state, u, y)


def _by_hand(u, y, *, gamma, lam, alpha0, bounds, x0, r0, memory="exponential"):
    """The law stepped sample by sample in a Python loop (no scan, no checkpoint), each step
    one compiled program: stepped op by op instead, the recursion's rounding alone moves
    α̂ by up to 2e-12 relative on JAX 0.4.30 (as far as a change of y by 1e-15 relative
    moves it: 3e-12), against about 1e-13 absolute for the compiled step."""
    mem = make_memory(memory, H, u.shape[0], rule="trapezoid", tol=1e-10, order_range=bounds)
    law = assemble_law(mem, H, lam, gamma, alpha0, bounds, jnp.asarray(r0))
    state = law.init(u.shape[1])
    alpha, y_hat = [], []
    for k in range(u.shape[0]):
        state, out = _step(law, state, jnp.asarray(u[k]), jnp.asarray(y[k] - x0))
        alpha.append(float(out.alpha))
        y_hat.append(float(out.y_hat) + x0)
    return np.array(alpha), np.array(y_hat)


def _rounding(est, base, u, y):
    """How far rounding alone moves the estimator's ``(α̂, ŷ)`` (its fit `base` of `u`, `y`):
    the largest change of each when the data change in their last digits (y × (1 ± 1e-15)),
    the scale on which two computations of the same recursion (a scan, a loop of compiled
    steps) can differ."""
    moved = [est.fit(u, y * (1.0 + sign * 1e-15), H, warn=False) for sign in (1.0, -1.0)]
    return tuple(max(float(np.max(np.abs(np.asarray(getattr(m, name))
                                          - np.asarray(getattr(base, name)))))
                     for m in moved) for name in ("alpha", "y_hat"))


def _agree(got, want, rounding):
    """`got` equals `want` to 1e-12 relative or, where the recursion amplifies rounding
    more, to 10 times the change that rounding alone makes (`_rounding`)."""
    got, want = np.asarray(got), np.asarray(want)
    tol = np.maximum(1e-12 * np.abs(want) + 1e-14, 10.0 * rounding)
    assert np.all(np.abs(got - want) <= tol), float(np.max(np.abs(got - want) - tol))


def test_the_estimator_runs_the_law_with_its_own_options(record):
    """Every option given reaches the law: the result equals the law stepped by hand with
    the same γ, λ, α̂(0), bounds, offset and R_0, to rounding (a field dropped on the way,
    or a default put in its place, changes the trajectory by far more). The recursion
    amplifies rounding: a change of y in its last digits moves α̂ by about 1e-13–3e-12 on
    some CPUs and JAX versions, and the two computations may differ by as much."""
    u, y = record
    opts = dict(gamma=0.3, lam=0.7, alpha0=0.35, bounds=(0.1, 0.8), x0=1.25, r0=2.0 * np.eye(2))
    est = vojax.LawEstimator(gamma=0.3, lam=0.7, alpha0=0.35, alpha_bounds=(0.1, 0.8),
                             x0=1.25, r0=2.0 * np.eye(2))
    res = est.fit(u, y, H, warn=False)
    alpha, y_hat = _by_hand(u, y, **opts)
    rounding = _rounding(est, res, u, y)
    assert max(rounding) < 1e-10  # rounding, not a different computation
    _agree(res.alpha, alpha, rounding[0])
    _agree(res.y_hat, y_hat, rounding[1])
    assert float(res.gamma) == 0.3 and float(res.lam) == 0.7 and float(res.alpha0) == 0.35
    assert float(res.x0) == 1.25 and res.alpha_bounds == (0.1, 0.8)
    assert res.method == "gradient" and res.memory == "exponential"
    # the defaults are the paper's λ and y[0] as the offset
    default = vojax.LawEstimator(gamma=0.3, r0=2.0 * np.eye(2))
    paper = default.fit(u, y, H, warn=False)
    assert float(paper.lam) == 0.9 and float(paper.x0) == y[0]
    alpha, _ = _by_hand(u, y, gamma=0.3, lam=0.9, alpha0=0.5, bounds=(0.05, 0.95), x0=y[0],
                        r0=2.0 * np.eye(2))
    _agree(paper.alpha, alpha, _rounding(default, paper, u, y)[0])


def test_identify_with_the_law_is_the_estimators_fit(record):
    """`identify(method="gradient")` builds the estimator from its arguments: the same
    numbers to the last bit, tuned gains included (gamma None → "auto")."""
    u, y = record
    a = vojax.identify(u, y, H, method="gradient", gamma=0.2, lam=0.5, alpha0=0.4, warn=False)
    b = vojax.LawEstimator(gamma=0.2, lam=0.5, alpha0=0.4).fit(u, y, H, warn=False)
    for name in ("alpha", "alpha_std", "p", "p_std", "y_hat"):
        np.testing.assert_array_equal(np.asarray(getattr(a, name)), np.asarray(getattr(b, name)))
    m = 120  # tuning is a grid of runs: a short record keeps it quick
    tuned = vojax.identify(u[:m], y[:m], H, method="gradient", warn=False)
    est = vojax.LawEstimator().fit(u[:m], y[:m], H, warn=False)
    assert float(tuned.gamma) == float(est.gamma) and float(tuned.lam) == float(est.lam)
    assert float(est.gamma) != 0.01  # tuned, not the paper's number
    np.testing.assert_array_equal(np.asarray(tuned.alpha), np.asarray(est.alpha))


def test_a_record_is_fitted_on_its_own_clock(record):
    """A `Record` alone is fitted on its own clock: the same numbers as its arrays with its
    step; with a step beside it, an error that says why."""
    import vojax.io

    u, y = record
    n = u.shape[0]
    rec = vojax.io.Record("r", "r.csv", np.arange(n) * H, u, y, ("u1", "u2"), "y", H)
    est = vojax.LawEstimator(gamma=0.2)
    a, b = est.fit(rec, warn=False), est.fit(u, y, H, warn=False)
    np.testing.assert_array_equal(np.asarray(a.alpha), np.asarray(b.alpha))
    with pytest.raises(ValueError, match="a Record carries its own output and clock"):
        est.fit(rec, dt=H)
    with pytest.raises(TypeError, match="`y` .* is missing"):
        est.fit(u)


@pytest.mark.parametrize(
    "options, message",
    [
        (dict(gamma=-1.0), "`gamma`"),
        (dict(gamma="fast"), "`gamma` must be a positive number or 'auto'"),
        (dict(lam="paper"), "`lam` must be a positive number or None"),
        (dict(lam=0.0), "`lam`"),
        (dict(alpha0=0.99), r"`alpha0` must lie inside `alpha_bounds` \(0.05, 0.95\)"),
        (dict(alpha_bounds=(0.5, 0.2)), "`alpha_bounds`"),
        (dict(memory="fft"), "`memory`"),
        (dict(rule="simpson"), "`rule`"),
        (dict(x0=float("nan")), "`x0`"),
        (dict(r0="eye"), "`r0` must be 'auto' or an"),
        (dict(tol=0.0), "`tol`"),
    ],
)
def test_bad_options_are_refused_when_the_estimator_is_built(options, message):
    """Before any record is read: one sentence naming the option."""
    with pytest.raises(ValueError, match=message) as info:
        vojax.LawEstimator(**options)
    assert "\n" not in str(info.value)


def test_the_estimator_is_frozen():
    est = vojax.LawEstimator(gamma=0.5)
    with pytest.raises(dataclasses.FrozenInstanceError):
        est.gamma = 1.0
    assert vojax.LawEstimator(r0=None).r0 == "auto"


def test_the_tracker_takes_a_record_on_its_own_clock_too():
    """`Tracker.fit(record)` as `LawEstimator.fit(record)`: its arrays on its non-uniform
    clock (a step given beside it is refused)."""
    import vojax.io

    t = np.cumsum(np.r_[0.0, np.geomspace(0.01, 0.2, 79)])
    u = 1.0 + 0.3 * np.sin(t)
    y = np.asarray(vojax.simulate(u, 0.4, 2.0, t=t)) + 0.01 * np.cos(7 * t)
    rec = vojax.io.Record("r", "r.csv", t, u[:, None], y, ("u",), "y", float(np.median(np.diff(t))),
                          uniform=False)
    tracker = vojax.Tracker(parameters="constant")
    a, b = tracker.fit(rec, warn=False), tracker.fit(u, y, t=t, warn=False)
    np.testing.assert_array_equal(np.asarray(a.alpha), np.asarray(b.alpha))
    with pytest.raises(ValueError, match="a Record carries its own output and clock"):
        tracker.fit(rec, t=t)
    with pytest.raises(TypeError, match="`y` .* is missing"):
        tracker.fit(u)
