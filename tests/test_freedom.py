"""A smoothing's fitted freedom (`vojax._tracker._explanations.freedom`): the trace of its
linearised hat matrix, checked against closed forms and against the derivative of its fitted
output with respect to the data, computed independently by finite differences; and the band
rule that reads it (`TrackerSettings(level_weights="freedom")`, `_band.chi2_floor`)."""

import jax.numpy as jnp
import numpy as np
import pytest

from .helpers import band_calls, load_script, normalised_problem


def _run(problem, y, hyper, p0, nominal):
    from vojax._tracker._smoother import iterated_smoother

    record = list(problem.record)
    record[2] = jnp.asarray(y)  # (memory, u, y, mask, steps, horizon)
    return iterated_smoother(*record, hyper, problem.m0, p0, nominal, problem.bounds, 400)


def _setup(ramp, num, q_order, q_params, pin_order=False):
    from vojax._tracker._model import Hyper

    problem, starts = normalised_problem(ramp, num, columns=1)
    hyper = Hyper(*(jnp.log(jnp.asarray(v)) for v in (q_order, q_params, 1e-3)))
    p0 = np.array(problem.p0)
    if pin_order:  # the order held at its start: the model is linear in the other states
        p0[0, :] = p0[:, 0] = 0.0
        p0[0, 0] = 1e-14
    nominal = jnp.asarray(np.broadcast_to(starts[0], (num, starts.shape[1])))
    return problem, hyper, jnp.asarray(p0), nominal


def test_a_smoothing_whose_states_do_not_drift_fits_n_plus_two_parameters(ramp):
    """With drifts 1e-12 of the record's scale, the smoothing is a least-squares fit of the
    order, one parameter and the offset under a broad prior: its hat matrix's trace is 3 (to
    the prior's pull, under 1e-3)."""
    from vojax._tracker._explanations import freedom

    problem, hyper, p0, nominal = _setup(ramp, 200, 1e-12, 1e-12)
    sm = _run(problem, problem.y, hyper, p0, nominal)
    assert bool(sm.converged)
    assert freedom(sm, float(hyper.r), problem.mask) == pytest.approx(3.0, abs=1e-3)


@pytest.mark.parametrize("q_params", [1e-4, 1e-1])
def test_the_freedom_is_the_trace_of_the_fitted_outputs_derivative(ramp, q_params):
    """With the order held (a prior of variance 1e-14 on it), the model is linear in the
    parameter and the offset, so the smoothed output is a linear function of the data and
    its hat matrix's trace is ``Σ_k ∂ŷ_k/∂y_k``, here by a finite difference on each sample
    in turn (60 runs). The parameter's drift adds to the 2 fitted constants: the two agree
    to 1e-6 at either drift, and the freedom grows with it."""
    from vojax._tracker._explanations import freedom
    from vojax._tracker._model import model_output

    num, eps = 60, 1e-4
    problem, hyper, p0, nominal = _setup(ramp, num, 1e-12, q_params, pin_order=True)
    y = np.asarray(problem.y)
    base = _run(problem, y, hyper, p0, nominal)
    assert bool(base.converged)

    def fitted(sm):
        return np.asarray(model_output(np.asarray(sm.theta), np.asarray(sm.phi), 1))

    y0, trace = fitted(base), 0.0
    for k in range(num):
        moved = y.copy()
        moved[k] += eps
        trace += (fitted(_run(problem, moved, hyper, p0, nominal))[k] - y0[k]) / eps
    found = freedom(base, float(hyper.r), problem.mask)
    assert found == pytest.approx(trace, abs=1e-6 * num)
    assert found > 2.0 + (0.5 if q_params > 1e-2 else 0.0)


def _dense_trace(problem, sm, q_order, q_params, r, p0):
    """``tr(H P Hᵀ)/r`` over the fitted samples from dense matrices: the outputs' map H from
    the independent variables (θ_0's order, parameter and offset, and each step of the two
    drifting ones), their prior Q and ``P = (HᵀH/r + Q⁻¹)⁻¹``, at the run's linearisation."""
    jac, k = np.asarray(sm.jacobian), 3
    num = jac.shape[0]
    steps, horizon = np.asarray(problem.steps), float(problem.horizon)
    columns, prior_var = [jac[:, i] for i in range(k)], []
    for i, q in ((0, q_order), (1, q_params)):
        for j in range(num - 1):  # the step from sample j to j + 1 moves every later output
            columns.append(np.where(np.arange(num) > j, jac[:, i], 0.0))
            prior_var.append(q * steps[j] / horizon)
    h = np.stack(columns, axis=1)[np.asarray(problem.mask) > 0]
    q_inv = np.zeros((h.shape[1], h.shape[1]))
    q_inv[:k, :k] = np.linalg.inv(np.asarray(p0)[:k, :k])
    q_inv[k:, k:] = np.diag(1.0 / np.asarray(prior_var))
    return float(np.trace(h @ np.linalg.inv(h.T @ h / r + q_inv) @ h.T) / r)


def test_the_freedom_is_the_dense_trace_with_samples_outside_the_fit(ramp):
    """With the order and the parameter both drifting and 10 of 80 samples outside the fit
    (mask 0), the sum over samples equals the trace from dense matrices (`_dense_trace`,
    which knows nothing of the smoother) to 1e-9: a sum that counted the skipped samples,
    or took the smoothed covariance at the wrong sample, would not."""
    import dataclasses

    from vojax._tracker._explanations import freedom

    num = 80
    problem, hyper, p0, nominal = _setup(ramp, num, 1e-3, 1e-2)
    mask = np.ones(num)
    mask[30:40] = 0.0
    problem = dataclasses.replace(problem, mask=jnp.asarray(mask))
    sm = _run(problem, problem.y, hyper, p0, nominal)
    assert bool(sm.converged)
    found = freedom(sm, float(hyper.r), problem.mask)
    assert found == pytest.approx(_dense_trace(problem, sm, 1e-3, 1e-2, float(hyper.r), p0),
                                  abs=1e-9 * num)
    assert 3.0 < found < 70.0


def test_the_coloured_noise_state_is_left_out():
    """A coloured noise's AR(1) state (the last of n + 3) does not count: the trace is over
    the order, the parameters and the offset. On a stand-in run with a unit Jacobian and a
    diagonal covariance, ``Σ_t (P_00 + P_11 + P_22)/r``."""
    from types import SimpleNamespace

    from vojax._tracker._explanations import freedom

    num, d = 10, 4
    cov = np.zeros((num, d, d))
    cov[:, 0, 0], cov[:, 1, 1], cov[:, 2, 2], cov[:, 3, 3] = 0.1, 0.2, 0.3, 5.0
    sm = SimpleNamespace(theta=np.zeros((num, d)), phi=np.zeros((num, 1)),
                         jacobian=np.ones((num, d)), cov=cov)
    mask = np.ones(num)
    mask[:2] = 0.0  # samples outside the fit window do not count
    assert freedom(sm, 0.5, mask) == pytest.approx(8 * 0.6 / 0.5, rel=1e-12)


def explanation(kind, beta, chi2=600.0, freedom=np.nan):
    """A converged stand-in at the constant β `beta` (variance 1e-4), dof 600."""
    from vojax._tracker._explanations import Explanation

    return Explanation(kind, np.full(40, float(beta)), np.full(40, 1e-4), chi2, 600.0, 0.0,
                       0.0, freedom=freedom)


def test_the_freedom_floor_counts_what_each_run_fits():
    """`chi2_floor`: with ``"chi2"`` every run's floor is its degrees of freedom; with
    ``"freedom"`` those less its own fitted freedom (never more than dof; dof where the
    freedom is unknown). On stand-ins: a tuned run fitting 150 beyond the constant fit
    leaves χ² 450 at dof 600: a held scale at χ² 455 whose drifts fit 141 (its floor 459)
    weighs exp(−Δ/2) with Δ = 459 − 450 = 9 against it, not alike (both floored at 600 by
    ``"chi2"``)."""
    from vojax._tracker._band import chi2_floor, level_spread

    tuned = explanation("tuned", 0.0, chi2=450.0, freedom=150.0)
    held = explanation("level", 0.5, chi2=455.0, freedom=141.0)
    assert chi2_floor(tuned) == chi2_floor(held) == 600.0
    assert chi2_floor(tuned, "freedom") == 450.0 and chi2_floor(held, "freedom") == 459.0
    assert chi2_floor(explanation("level", 0.0, freedom=-2.0), "freedom") == 600.0
    assert chi2_floor(explanation("level", 0.0), "freedom") == 600.0
    # by χ² the two weigh alike: the mixture's spread is half the squared shift
    alike = level_spread([tuned, held], tuned, "chi2")
    np.testing.assert_allclose(alike, 0.5 * 0.5**2, rtol=1e-12)
    # with the freedom floor the held scale lies 9 units above (459 against 450)
    apart = level_spread([tuned, held], tuned, "freedom")
    w = np.exp(-4.5) / (1 + np.exp(-4.5))
    np.testing.assert_allclose(apart, w * 0.25, rtol=1e-9)


def test_an_explanation_counts_the_freedom_beyond_the_constant_fit():
    """`smoothing_explanations` keeps each run's trace less the constant fit's n + 2 (here
    one input: 3 → 0, 10.5 → 7.5), and NaN where no freedom is given or the noise is
    coloured."""
    from types import SimpleNamespace

    from vojax._tracker._explanations import smoothing_explanations

    num = 20
    problem = SimpleNamespace(mask=np.ones(num), n=1, span=num)
    args = (np.zeros((2, num)), np.full((2, num), 1e-4), [0.0, 0.0], np.zeros((2, num)),
            np.ones((2, num, 1)), problem, 1.0)
    given = smoothing_explanations(["tuned", "level"], *args, freedoms=[3.0, 10.5])
    assert [e.freedom for e in given] == [0.0, 7.5]
    assert all(np.isnan(e.freedom) for e in smoothing_explanations(["tuned", "level"], *args))
    # under a coloured noise's whitening the χ² is not on the trace's scale: left unknown
    coloured = smoothing_explanations(["tuned", "level"], *args, whiten=lambda r: r,
                                      freedoms=[3.0, 10.5])
    assert all(np.isnan(e.freedom) for e in coloured)


def test_every_smoothing_of_a_fit_fits_between_the_constant_fit_and_the_samples(monkeypatch):
    """A linear smoother's hat matrix has its eigenvalues in [0, 1], so its trace lies
    between 0 and the fitted samples. Every smoothing the tracker weighs on a fit stated
    constant (`ramp_case(300)`'s first input: the tuned run, its alternatives, the level
    profile's held scales) fits at least the constant fit's 3 less the prior's pull
    (freedom ≥ −0.01) and at most the samples (≤ 300 − 3); the tuned run, whose order
    drifts with the ramp, fits more than the constant fit. A run at the tuned intensities
    from another start that reached the tuned mode (its χ² within 1e-6) carries the tuned
    run's freedom to 1e-6: the two are computed on separate paths (the tuned run's from its
    tuning, the starts' from their batch of intensities)."""
    seen = band_calls(monkeypatch, parameters="constant")
    smoothings = [e for e in seen[-1][0] if np.isfinite(e.evidence)]
    assert len(smoothings) >= 5 and {"tuned", "level"} <= {e.kind for e in smoothings}
    for e in smoothings:
        assert -0.01 <= e.freedom <= 300 - 3
    tuned = next(e for e in smoothings if e.kind == "tuned")
    assert tuned.freedom > 0.5
    same = [e for e in smoothings if e.kind == "start" and abs(e.chi2 - tuned.chi2) < 1e-6]
    assert same
    for e in same:
        assert e.freedom == pytest.approx(tuned.freedom, abs=1e-6)


def test_the_replay_of_saved_explanations_keeps_their_freedom():
    """`scripts/band_library.as_explanations` rebuilds each saved explanation with the
    freedom `band_explanations.py --dump` saved with it (under its earlier name ``edf`` in
    older dumps; NaN for a dump saved before it was kept), so a rule that reads it is scored
    on what the tracker weighed: the replayed
    band under ``"freedom"`` equals the library's on the same explanations, and differs
    from the band by χ² here."""
    from vojax._tracker._band import bands

    library = load_script("band_library")
    saved = [dict(kind=k, beta=np.full(40, b), var=np.full(40, 1e-4), chi2=c, dof=600.0,
                  evidence=0.0, drift=0.0, accepted=None, factor=None, freedom=f)
             for k, b, c, f in (("tuned", 0.0, 450.0, 150.0), ("level", 0.5, 455.0, 141.0))]
    rebuilt = library.as_explanations(dict(explanations=saved))
    assert [e.freedom for e in rebuilt] == [150.0, 141.0]
    old = library.as_explanations(dict(explanations=[
        {k: v for k, v in e.items() if k != "freedom"} for e in saved]))
    assert all(np.isnan(e.freedom) for e in old)
    renamed = library.as_explanations(dict(explanations=[
        {("edf" if k == "freedom" else k): v for k, v in e.items()} for e in saved]))
    assert [e.freedom for e in renamed] == [150.0, 141.0]
    direct = [explanation("tuned", 0.0, 450.0, 150.0), explanation("level", 0.5, 455.0, 141.0)]
    by_freedom = bands(rebuilt, (0.0, 1.0), 40, 0.0, level_weights="freedom").stated
    np.testing.assert_array_equal(
        by_freedom[2], bands(direct, (0.0, 1.0), 40, 0.0, level_weights="freedom").stated[2])
    by_chi2 = bands(rebuilt, (0.0, 1.0), 40, 0.0).stated
    assert np.median(by_chi2[2] - by_freedom[2]) > 0.05


def test_the_excess_rule_weighs_each_run_by_its_chi2_over_its_own_expectation():
    """`level_score` with ``"excess"``: each run's χ² plus its fitted freedom, floored at its
    degrees of freedom plus `excess_alike` × √(2 dof) (how far its χ² lies above ``dof −
    freedom``, what it leaves on average where it is the truth). Two runs below that weigh
    alike however their freedoms differ, where ``"freedom"`` gives the freer run the
    weight (`long` draw 17 with the offset stated: the tuned run at χ² 628.5 fitting 253.8, a
    held scale at 682.1 fitting 219.1, 34.7 apart by ``"freedom"``); above it a run weighs
    exp(−Δ/2). At dof 600 and `excess_alike` 0.5 the floor is 600 + 0.5 √1200."""
    from vojax._tracker._band import level_score, level_spread, reference_variance

    floor = 600.0 + 0.5 * np.sqrt(1200.0)
    tuned = explanation("tuned", 0.0, chi2=450.0, freedom=150.0)
    near = explanation("level", 0.5, chi2=455.0, freedom=160.0)  # 615 ≤ 617.3: alike
    assert level_score(tuned, "excess") == level_score(near, "excess") == floor
    np.testing.assert_allclose(level_spread([tuned, near], tuned, "excess"), 0.5 * 0.25,
                               rtol=1e-12)
    # at tolerance 0 the near one lies 15 units above its expectation
    assert level_score(near, "excess", 0.0) == 615.0
    w = np.exp(-7.5) / (1 + np.exp(-7.5))
    np.testing.assert_allclose(level_spread([tuned, near], tuned, "excess", excess_alike=0.0),
                               w * 0.25, rtol=1e-9)
    # and the tuned band's variance gets that tolerance: its own variance (1e-4) plus it
    np.testing.assert_allclose(
        reference_variance([tuned, near], tuned, 40, "excess", excess_alike=0.0),
        1e-4 + w * 0.25, rtol=1e-9)
    # 500 + 141 = 641 lies 641 − floor above the tuned run's score
    far = explanation("level", 0.5, chi2=500.0, freedom=141.0)
    assert level_score(far, "excess") == 641.0
    w = np.exp(-(641.0 - floor) / 2) / (1 + np.exp(-(641.0 - floor) / 2))
    np.testing.assert_allclose(level_spread([tuned, far], tuned, "excess"), w * 0.25,
                               rtol=1e-9)
    # the freer run earns nothing by its freedom: a tuned run fitting 60 more than a held
    # scale, both below their expectations, lie 60 apart by "freedom", alike here
    free_tuned = explanation("tuned", 0.0, chi2=400.0, freedom=180.0)
    held = explanation("level", 0.5, chi2=430.0, freedom=120.0)
    assert level_score(free_tuned, "freedom") == 420.0 and level_score(held, "freedom") == 480.0
    np.testing.assert_allclose(level_spread([free_tuned, held], free_tuned, "excess"),
                               0.5 * 0.25, rtol=1e-12)
    # the freedom unknown (a coloured noise) or negative counts as none
    assert level_score(explanation("level", 0.0, chi2=650.0), "excess") == 650.0
    assert level_score(explanation("level", 0.0, chi2=500.0, freedom=-2.0), "excess") == floor
