"""`compare` reports each constant-order law's residuals as those of its fit solved exactly
(`fitted_strain`: the laws' closed-form responses, no quadrature), the laws that feed their
strain back through the memory (Kelvin–Voigt, Zener) fitted by output error: the strain
regressor replaced by the fit's own strain, refitted `OUTPUT_ERROR_ROUNDS` times. Here every
row's likelihood is recomputed from its fit solved exactly; it must be the row's, and on the
rheometer creep the ranking must be that of each law's own refit, solved exactly."""

import math
from pathlib import Path

import numpy as np
import pytest

import vojax

LAWS = {"springpot": vojax.Springpot(), "kelvin-voigt": vojax.KelvinVoigt(),
        "maxwell": vojax.FractionalMaxwell(), "zener": vojax.FractionalZener()}
CREEP = (Path(__file__).resolve().parents[2] / "shared" / "data" / "rheometer-creep-hermes"
         / "creep_experiment.csv")


TIE = 1e-6  # nats: laws whose fits are one law (a spring at 0) tie to rounding


def _ranked_as(order, evidence):
    """Whether the models in `order` come in decreasing `evidence` (ties in any order)."""
    return all(evidence[a] >= evidence[b] - TIE for a, b in zip(order, order[1:]))


def _solved(c, stress, strain, grid, inside):
    """Each row's log-likelihood over `inside` with its fit solved exactly, and the evidence
    that gives."""
    n = int(inside.sum())
    lls, evidence = {}, {}
    for r in c.rows:
        law = LAWS["maxwell" if r.get("note") else r["model"]]  # the Zener as its Maxwell
        res = (strain - np.asarray(law.fitted_strain(r["refit"], stress, **grid)))[inside]
        lls[r["model"]] = -0.5 * n * (math.log(2 * math.pi * float(res @ res) / n) + 1)
        evidence[r["model"]] = lls[r["model"]] - 0.5 * r["quantities"] * math.log(n)
    return lls, evidence


def _check(c, stress, strain, grid, inside):
    lls, evidence = _solved(c, stress, strain, grid, inside)
    assert _ranked_as([r["model"] for r in c.rows], evidence), evidence
    for r in c.rows:
        assert r["solved"], r["model"]
        assert r["log_likelihood"] == pytest.approx(lls[r["model"]], rel=1e-12), r["model"]


@pytest.mark.parametrize("noise", [0.002, 0.01])
@pytest.mark.parametrize("model", ["kelvin-voigt", "zener"])
def test_the_ranking_is_that_of_the_fitted_laws_solved_exactly(model, noise):
    """Records of a Kelvin–Voigt or a Zener law (exact responses to a ramp, a hold and a
    second step; the springs at the springpot's compliance at the end, so that each law's
    feature shows), noise 0.2 % and 1 % of the range: each row's likelihood is that of its
    fit solved exactly, and the rows come in that order."""
    n, dt, q = 300, 0.05, 0.4
    t = dt * np.arange(n)
    stress = np.minimum(t / 2.0, 1.0) + 0.5 * (t > 6.0)
    spring = math.gamma(1 + q) / t[-1] ** q  # η = 1: the springpot's compliance at the end
    truth = (dict(eta=1.0, k=spring) if model == "kelvin-voigt"
             else dict(eta=1.0, E0=spring, E1=1.5 * spring))
    strain = LAWS[model].strain_response(stress, dt, q=q, **truth)
    rng = np.random.default_rng(7)
    strain = strain + noise * np.ptp(strain) * rng.standard_normal(n)
    c = vojax.compare(stress, strain, dt, models=tuple(LAWS))
    _check(c, stress, strain, dict(dt=dt), np.ones(n, bool))


@pytest.mark.skipif(not CREEP.is_file(), reason=f"{CREEP} is not here (shared data)")
def test_the_rheometer_creep_ranks_as_the_refits_over_its_window():
    """The rheometer's creep (483 log-spaced samples) with its first 0.5 s of inertial
    ringing left out: `compare` ranks the laws as each law's own refit over the same window
    (the measured strain as its regressor), solved exactly, does."""
    (rec,) = vojax.load_records(CREEP, time="time_s", inputs=["stress_Pa"], output="strain")
    stress, strain = np.asarray(rec.inputs)[:, 0], np.asarray(rec.output)
    inside = rec.time >= 0.5
    c = vojax.compare(rec, window=(0.5, None), models=tuple(LAWS))
    _check(c, stress, strain, dict(t=rec.time), inside)
    n, evidence = int(inside.sum()), {}
    for r in c.rows:
        law = LAWS[r["model"]]
        own = vojax.refit(law.inputs(stress, strain), strain, t=rec.time, window=(0.5, None),
                          direct=law.direct(stress, strain), p_signs=law.p_signs, warn=False)
        res = (strain - np.asarray(law.fitted_strain(own, stress, t=rec.time)))[inside]
        evidence[r["model"]] = (-0.5 * n * (math.log(2 * math.pi * float(res @ res) / n) + 1)
                                - 0.5 * r["quantities"] * math.log(n))
    assert _ranked_as([r["model"] for r in c.rows], evidence), evidence


def _record(n=120, dt=0.05):
    t = dt * np.arange(n)
    stress = np.minimum(t / 2.0, 1.0) + 0.5 * (t > 3.0)
    strain = LAWS["kelvin-voigt"].strain_response(stress, dt, q=0.4, eta=1.0, k=0.5)
    return t, stress, strain + 0.002 * np.random.default_rng(2).standard_normal(n)


def _refit_loglik(r, strain):
    res = strain - np.asarray(r["refit"].y_hat)
    n = strain.size
    return -0.5 * n * (math.log(2 * math.pi * float(res @ res) / n) + 1)


def test_a_clock_too_irregular_to_solve_keeps_the_refits_residual_and_says_so(monkeypatch):
    """On a jittered clock (uniform nowhere) with `EXACT_SOLVE_LAGS` below its (N − 1)·N lags, no law is
    solved: each row's likelihood is its refit's, ``solved`` is False and the row and the
    table say why; with the default the same record is solved."""
    from vojax._models import _fitted

    t, stress, strain = _record()
    t = t + 1e-4 * np.random.default_rng(4).uniform(size=t.size)  # 0.2 % of a step
    models = ("springpot", "kelvin-voigt")
    solved = vojax.compare(stress, strain, t=t, models=models)
    assert all(r["solved"] and "unsolved" not in r for r in solved.rows)
    monkeypatch.setattr(_fitted, "EXACT_SOLVE_LAGS", (t.size - 1) * t.size - 1)
    c = vojax.compare(stress, strain, t=t, models=models)
    for r in c.rows:
        assert not r["solved"] and "119 of its 120 samples" in r["unsolved"]
        assert r["log_likelihood"] == pytest.approx(_refit_loglik(r, strain), rel=1e-12)
    assert c.table().count("the refit's residual") == 2


def test_a_law_that_cannot_be_solved_keeps_the_refits_residual_and_says_why(monkeypatch):
    """Where the fitted law cannot be solved (`fitted_strain` refuses it: here made to), its
    row keeps the refit's residual and carries the refusal; the other rows are solved."""
    def refuse(self, fit, stress, dt=None, *, t=None, origin=None):
        raise ValueError("the fitted law is not physical (made so here)")

    monkeypatch.setattr(vojax.KelvinVoigt, "fitted_strain", refuse)
    t, stress, strain = _record()
    c = vojax.compare(stress, strain, 0.05, models=("springpot", "kelvin-voigt"))
    rows = {r["model"]: r for r in c.rows}
    assert rows["springpot"]["solved"] and not rows["kelvin-voigt"]["solved"]
    assert rows["kelvin-voigt"]["unsolved"] == (
        "the refit's residual: the fitted law is not physical (made so here)")
    kv = rows["kelvin-voigt"]
    assert kv["log_likelihood"] == pytest.approx(_refit_loglik(kv, strain), rel=1e-12)
