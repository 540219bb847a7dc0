"""The level profile about the held smoothing: where the tuned parameters drift and the
smoothing with them held fits, that smoothing is the conditional answer's reference, and the
parameters' scale along the level ridge is integrated about it (the profile runs about the
held run, not the tuned one). Checked here on `held_order`'s run (its intensities, its
smoothing, its parameters held whatever the tuned drift) and on which smoothing
`alternatives` profiles; the band's rule on stand-ins is in
`test_band_held.py`, a record that needs it (white draw 16, the offset stated) in the slow tier
(`test_calibration.py`)."""

import importlib
from types import SimpleNamespace

import jax.numpy as jnp
import numpy as np
import pytest

import vojax
from vojax import reference
from vojax._integral import make_memory
from vojax._tracker import Hyper
from vojax._tracker._band import bands, own_halfwidth
from vojax._tracker._explanations import Explanation, relative_drift
from vojax._tracker._fit import alternatives, profiles_held, start
from vojax._tracker._mixture import held_order
from vojax._tracker._tuning import Tuning

_fit = importlib.import_module("vojax._tracker._fit")  # the module, not a name in it


@pytest.fixture(scope="module")
def record():
    """A springpot of order 0.4 under a step with an oscillation, 200 samples, 2 % noise."""
    s = vojax.TrackerSettings()
    dt, num = 0.05, 200
    t = dt * np.arange(num)
    u = 1 - np.exp(-t / 2) + 0.3 * np.sin(1.3 * t)
    x = np.asarray(reference.fractional_integral(u[:, None], 0.4, dt))[:, 0]
    y = x + 0.02 * np.ptp(x) * np.random.default_rng(0).standard_normal(num)
    memory = make_memory("exponential", dt, num, order_range=(0.01, 0.99))
    return start(memory, jnp.asarray(u[:, None]), jnp.asarray(y), dt, (0.01, 0.99), s, None,
                 None, None, False)


def test_the_held_run_is_the_held_smoothing_at_its_own_intensities(record):
    """`held_order`'s run: the parameters' drift at `constant_drift`, the noise the one
    given, the order drift the one it chose, and the smoothing whose β its explanation is."""
    st, s = record, record.problem.settings
    noise = st.noises[0]
    hyper = Hyper(jnp.log(1e-2), jnp.log(1.0), jnp.log(noise))
    _, held, (tuning, sm) = held_order(st.problem, hyper, st.starts[0], noise, noise)
    assert tuning.parameter_drift == pytest.approx(s.constant_drift, rel=1e-12)
    assert tuning.noise == pytest.approx(noise, rel=1e-12)
    lo, hi = s.order_drift_range  # within rounding of the search's range (logs, and back)
    assert lo * (1 - 1e-9) <= tuning.order_drift <= hi * (1 + 1e-9)
    assert tuning.tuned and tuning.log_likelihood == held.evidence
    np.testing.assert_array_equal(np.asarray(sm.theta)[:, 0], held.beta)


def test_the_held_smoothing_holds_the_parameters_whatever_the_tuned_drift(record):
    """`held_order` smooths again with the parameters held at the floor drift: its
    parameters' drift is the same (to 1e-6) from intensities whose parameters drift freely
    (variance 1 over the record: that smoothing drifts by more than 10 %) as from held ones,
    and below 1e-3."""
    st = record
    drifts = {}
    for q in (1e-6, 1.0):
        hyper = Hyper(jnp.log(1e-2), jnp.log(q), jnp.log(st.noises[0]))
        _, held, _ = held_order(st.problem, hyper, st.starts[0], st.noises[0], st.noises[0])
        drifts[q] = held.drift
    free = st.problem.smooth_from(hyper, st.starts[0])
    assert relative_drift(np.asarray(free.theta)[:, 1:2], st.problem.span) > 0.1
    assert drifts[1.0] == pytest.approx(drifts[1e-6], rel=1e-6) and drifts[1.0] < 1e-3


def _drifting(s, ratio):
    return Tuning(0.01, ratio * s.held_ratio * s.constant_drift, 1e-3, (), 0.0, True)


@pytest.mark.parametrize("case", ["drifting, held run", "drifting, none", "held by tuning",
                                  "stated constant"])
def test_the_level_profile_runs_about_the_smoothing_with_the_parameters_constant(
        monkeypatch, case):
    """`alternatives` with the mixture and the profile stubbed: the profile runs about the
    tuned smoothing where the parameters are stated constant or tuned constant, about the
    held run where they drift and it is given (its scales of kind "held_level"), and not at
    all where it is not."""
    s = vojax.TrackerSettings()
    calls = []
    monkeypatch.setattr(_fit, "mixture", lambda *a: (np.zeros(3), None, []))
    monkeypatch.setattr(_fit, "level_profile", lambda problem, tuning, sm, *a, kind="level":
                        calls.append((tuning, sm, kind)) or [])
    problem = SimpleNamespace(settings=s)
    tuned_sm, held_sm = SimpleNamespace(name="tuned"), SimpleNamespace(name="held")
    held_tuning = _drifting(s, 0.0)
    drifting, constant = _drifting(s, 10.0), _drifting(s, 1.0)
    tuning, hold, held = {
        "drifting, held run": (drifting, False, (held_tuning, held_sm)),
        "drifting, none": (drifting, False, None),
        "held by tuning": (constant, False, (held_tuning, held_sm)),
        "stated constant": (drifting, True, None),
    }[case]
    alternatives(problem, tuning, [], tuned_sm, hold, 1e-3, None, held)
    want = {  # about the held run, its scales are of their own kind (`bands` weighs them)
        "drifting, held run": [(held_tuning, held_sm, "held_level")],
        "drifting, none": [],
        "held by tuning": [(constant, tuned_sm, "level")],
        "stated constant": [(drifting, tuned_sm, "level")],
    }[case]
    assert calls == want


def _held(halfwidth, chi2=10.0, evidence=0.0, num=40):
    """A held explanation of constant β 0 whose own ±2σ band is ±`halfwidth` on the order
    scale (bounds (0, 1): dα/dβ = 1/4 at β 0, to first order; exact below)."""
    sd = np.log((0.5 + halfwidth) / (0.5 - halfwidth)) / 2  # logit(0.5 ± h) = ±2σ
    return Explanation("held", np.zeros(num), np.full(num, sd**2), chi2, 30.0, evidence, 0.0)


def test_the_held_scales_are_profiled_only_about_a_band_narrow_enough_to_answer():
    """`profiles_held`: the held smoothing's own band at ±0.099 is profiled, at ±0.101 not
    (above `identified_halfwidth`, 0.1: its scales only widen it); one that does not fit or
    did not converge, or none, is not. Its width is the one the verdict reads: the
    conditional band `bands` builds about it alone, its median half-width over the second
    half."""
    s = vojax.TrackerSettings()
    num = 40
    problem = SimpleNamespace(settings=s, bounds=(0.0, 1.0), mask=None, span=num)
    assert profiles_held(_held(0.099), problem)
    assert not profiles_held(_held(0.101), problem)
    assert not profiles_held(_held(0.05, chi2=1e3), problem)  # does not fit
    assert not profiles_held(_held(0.05, evidence=-np.inf), problem)  # did not converge
    assert not profiles_held(None, problem)
    held = _held(0.1)
    tuned = Explanation("tuned", np.zeros(num), held.var, 10.0, 30.0, 0.0, 0.2)
    b = bands([tuned, held], (0.0, 1.0), num, np.inf, 1.0, s.drift_floor, s.band_floor)
    _, lower, upper, _ = b.conditional
    width = np.median((upper - lower)[num // 2:]) / 2
    assert own_halfwidth(held, (0.0, 1.0), 1.0, s.band_floor, num // 2, num) == pytest.approx(
        width, rel=1e-12)
    assert width == pytest.approx(0.1, rel=1e-12)
