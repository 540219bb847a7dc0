"""The tracker's climb over its noise intensities, as control flow: the smoothing and the
BFGS refinement are replaced by stand-ins whose answers are known, so that a rule of
`climb` (when a climb stops) is checked by itself. What the climbs reach on real records:
`tests/test_first_pass.py`, `tests/test_tracker.py` and `tests/test_coloured.py`."""

import types

import jax.numpy as jnp
import numpy as np

from vojax import TrackerSettings
from vojax._tracker import Hyper, _tuning

SETTINGS = TrackerSettings()


def _smoothing(ll, log_noise=None, converged=True):
    return types.SimpleNamespace(log_likelihood=ll, theta=log_noise, converged=converged)


def _score(sm):
    return sm.log_likelihood if sm.converged else -np.inf


def _hyper(values, limits):
    return Hyper(*(jnp.asarray(values[k]) for k in limits))


# ------------------------------------------------ the coloured climb's stop at the edge


def _fake_coloured_climb(monkeypatch, time_at):
    """`climb` with stand-ins: every refinement puts the correlation time at `time_at` (log)
    and every re-smoothing raises the evidence by 1, so that each round is accepted. Returns
    a function running the climb, with the refinements' count."""
    limits = _tuning.box(SETTINGS, 1e-4, hold=False, time_min=1e-3)
    mid = {k: (lo + hi) / 2 for k, (lo, hi) in limits.items()}
    calls = []

    def refine(problem, hyper, sm, *args):
        calls.append(1)
        return _hyper(dict(mid, noise_time=time_at), limits)

    monkeypatch.setattr(_tuning, "_refine", refine)
    monkeypatch.setattr(_tuning, "host_score", _score)
    problem = types.SimpleNamespace(settings=SETTINGS,
                                    smooth=lambda *a: _smoothing(float(len(calls))))

    def run(fatal):
        calls.clear()
        out = _tuning.climb(problem, limits, _hyper(mid, limits), _smoothing(0.0), rounds=6,
                            radius=float(np.log(3.0)), fatal=fatal)
        return out, len(calls)

    return run, limits


def test_a_climb_stops_once_its_correlation_time_stays_at_the_top(monkeypatch):
    top = _tuning.box(SETTINGS, 1e-4, hold=False, time_min=1e-3)["noise_time"][1]
    run, limits = _fake_coloured_climb(monkeypatch, time_at=top)
    (_, _, tuned), rounds = run(fatal="noise_time")
    assert rounds == SETTINGS.fatal_edge_rounds == 2
    assert "noise_time" in tuned.at_edge
    assert tuned.log_likelihood == float(SETTINGS.fatal_edge_rounds)  # the last accepted round's
    # without `fatal`, or with the correlation time inside its range or at its lower end
    # (white-like noise, which the coloured model may keep), every round runs
    assert run(fatal=None)[1] == 6
    bottom = limits["noise_time"][0]
    for time_at in ((bottom + top) / 2, bottom):
        run, _ = _fake_coloured_climb(monkeypatch, time_at=time_at)
        (_, _, tuned), rounds = run(fatal="noise_time")
        assert rounds == 6 and "noise_time" not in tuned.at_edge
