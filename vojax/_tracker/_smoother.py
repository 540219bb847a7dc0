"""The iterated extended Kalman smoother: Gauss–Newton on the posterior mode of the whole
trajectory, with the bands from the curvature at the mode.

Each iteration linearises the measurement at the nominal trajectory θ̄ (one memory scan gives
``Φ`` and ``∂Φ/∂b`` at every sample's order), runs the linear filter and the RTS smoother of the
linearised model — whose smoothed mean is the Gauss–Newton point of the negative log posterior
— and moves towards it, damped (Levenberg–Marquardt) until the posterior improves. At
convergence the linearised model's smoothed covariances are the Laplace approximation of the
posterior marginals, and its innovation likelihood that of the marginal likelihood used to
tune the noise intensities.
"""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jax import lax
from jaxtyping import Array, Bool, Float, Int

from .._integral import order_map
from .._xla import to_device
from . import _damping
from ._damping import MU_MAX, MU_START, REL_TOL, damping, progress, shortfall
from ._explanations import freedom
from ._kalman import kalman_filter, rts_smoother
from ._model import Hyper, linearise, model_output, objective, order_of, posterior_cost
from ._parallel import parallel_filter, parallel_smoother

TRACES = {"smoother": 0}  # incremented only while tracing: tests count compilations
# how the linear filter and smoother run over the samples: "sequential" (two scans, N steps
# each) or parallel in time (`_parallel`: "associative", "chunked"); `resolve_schedule(None)`
# is sequential on a CPU and ACCELERATOR_SCHEDULE on a GPU or TPU, where each step of a scan
# is a kernel launch (docs/benchmarks.md has the H200's figures). A compiled program keeps
# the schedule it was traced with: it is a static argument of each.
ACCELERATOR_SCHEDULE = "chunked"


def resolve_schedule(schedule=None) -> str:
    """`schedule`, or where None the default of this backend (see `ACCELERATOR_SCHEDULE`)."""
    if schedule is not None:
        return schedule
    return "sequential" if jax.default_backend() == "cpu" else ACCELERATOR_SCHEDULE


def _filter(h, z, r, q, m0, p0, mask=None, anchor=None, damping=None, f=None,
            schedule="sequential"):
    """`kalman_filter`, or `parallel_filter` on a parallel `schedule`."""
    if schedule == "sequential":
        return kalman_filter(h, z, r, q, m0, p0, mask, anchor, damping, f)
    return parallel_filter(h, z, r, q, m0, p0, mask, anchor, damping, f, schedule=schedule)


def _smooth(filtered, q, f=None, schedule="sequential"):
    """`rts_smoother`, or `parallel_smoother` on a parallel `schedule`."""
    if schedule == "sequential":
        return rts_smoother(filtered, q, f)
    return parallel_smoother(filtered, q, f, schedule=schedule)


class Smoothed(eqx.Module):
    theta: Float[Array, "N d"]  # the posterior mode
    cov: Float[Array, "N d d"]  # smoothed covariances at the mode (linearised)
    filtered_mean: Float[Array, "N d"]  # causal estimates of the final linearised filter
    filtered_cov: Float[Array, "N d d"]
    y_pred: Float[Array, " N"]  # one-step predictions of the final linearised filter
    phi: Float[Array, "N n"]  # Φ at the mode's orders
    objective: Float[Array, ""]
    log_likelihood: Float[Array, ""]  # innovation log-likelihood of the linearised model
    jacobian: Float[Array, "N d"]  # H at the mode
    pseudo: Float[Array, " N"]  # the linearised measurements z = y − h(θ̄) + H θ̄
    converged: Bool[Array, ""]
    iterations: Int[Array, ""]


def _regressors(evaluate, theta, bounds):
    alpha, _ = order_of(theta[:, 0], bounds)
    return evaluate(alpha, True)


def _linear_pass(theta, phi, dphi, y, mask, r, q, f, m0, p0, bounds, damping=None,
                 schedule="sequential"):
    h0, jac = linearise(theta, phi, dphi, bounds)
    z = y - h0 + jnp.sum(jac * theta, axis=-1)
    anchor = None if damping is None else theta
    filtered = _filter(jac, z, r, q, m0, p0, mask, anchor, damping, f, schedule)
    return filtered, _smooth(filtered, q, f, schedule), jac, z


def iterated_smoother(
    memory, u, y, mask, steps, horizon, hyper: Hyper, m0, p0, nominal, bounds, max_iter: int,
    schedule=None,
) -> Smoothed:
    """See `_iterate`; one run. Every smoothing of the tracker runs this one compiled program
    (`smooth_compiled`, the iteration budget an argument, not a constant of the program):
    the first call in a process compiles the smoother once, not once per way of running it.
    `schedule`: see `resolve_schedule`."""
    return smooth_compiled(
        memory, u, y, mask, steps, horizon, hyper, m0, p0, nominal, bounds,
        to_device(np.int32(max_iter)),  # a host value: no conversion program
        resolve_schedule(schedule),
    )


@eqx.filter_jit
def smooth_compiled(memory, u, y, mask, steps, horizon, hyper, m0, p0, nominal, bounds, max_iter,
                    schedule="sequential"):
    return _iterate(memory, u, y, mask, steps, horizon, hyper, m0, p0, nominal, bounds, max_iter,
                    schedule)


# a pass's runs can go through one vmapped program of `RUN_BATCH` runs (the last chunk padded
# with copies of its last run) instead of one after another. Where XLA launches one kernel per
# operation and step (its default CPU loops, or a GPU), B runs in lockstep cost about what one
# costs: 2.9–3.7× less than one after another on 1,000 block means (9 runs of 60 and of up to
# 400 iterations), for one more program compiled (about 1–1.5 s on a first call). Under
# `use_fast_cpu_loops` a step is one kernel and the batch saves nothing (0.99–1.3×).
RUN_BATCH = 9


def batch_pays() -> bool:
    """Whether batched runs are faster here: not on a CPU under `use_fast_cpu_loops`."""
    from .._xla import fast_cpu_loops_threshold

    return fast_cpu_loops_threshold() is None or jax.default_backend() != "cpu"


@eqx.filter_jit
def smooth_batched(memory, u, y, mask, steps, horizon, hyper, m0, p0, nominal, bounds, max_iter,
                   schedule="sequential"):
    """`_iterate` for the runs along the leading axis of `hyper` and `nominal` (B, N, d), as
    one vmapped program: the while loop steps every run until the last one stops (a stopped
    run is held where it stopped). Equal to one run at a time to rounding."""
    return jax.vmap(
        lambda h, start: _iterate(memory, u, y, mask, steps, horizon, h, m0, p0, start, bounds,
                                  max_iter, schedule)
    )(hyper, nominal)


def _runs(memory, u, y, mask, steps, horizon, hyper, m0, p0, starts, bounds, max_iter,
          batched=False, schedule=None):
    """Each run of a batch (leading axis B of `hyper` and of the constant starts `starts`
    (B, d)) in order: one `iterated_smoother` after another, or with `batched` in chunks of
    `RUN_BATCH` through `smooth_batched` (then each run's fields are NumPy arrays)."""
    num = u.shape[0]
    schedule = resolve_schedule(schedule)
    if not batched:
        for h, nominal in _rows(hyper, starts, num):
            yield iterated_smoother(memory, u, y, mask, steps, horizon, h, m0, p0, nominal,
                                    bounds, max_iter, schedule)
        return
    values = [np.asarray(a) for a in jax.tree_util.tree_leaves(hyper)]
    starts = np.asarray(starts)
    count = starts.shape[0]
    budget = to_device(np.int32(max_iter))  # a host value: no conversion program
    for lo in range(0, count, RUN_BATCH):
        index = np.minimum(np.arange(lo, lo + RUN_BATCH), count - 1)
        h = Hyper(*(to_device(v[index]) for v in values))
        nominal = to_device(np.broadcast_to(starts[index][:, None, :],
                                              (RUN_BATCH, num, starts.shape[1])))
        out = jax.tree_util.tree_map(np.asarray, smooth_batched(
            memory, u, y, mask, steps, horizon, h, m0, p0, nominal, bounds, budget, schedule))
        for k in range(min(RUN_BATCH, count - lo)):
            yield jax.tree_util.tree_map(lambda a: a[k], out)  # noqa: B023


def _rows(hyper, starts, num):
    """The runs of a batch: each row's intensities (a `Hyper` of scalars) and its constant
    starting trajectory (N, d), made on the host (no program compiled for them)."""
    values = [np.asarray(a) for a in jax.tree_util.tree_leaves(hyper)]
    starts = np.asarray(starts)
    for b in range(starts.shape[0]):
        h = Hyper(*(to_device(v[b]) for v in values))
        yield h, to_device(np.broadcast_to(starts[b], (num, starts.shape[1])))


def host_score(sm):
    """`score` of one run, on the host (an eager JAX expression would compile a program)."""
    ll, value = float(sm.log_likelihood), float(sm.objective)
    ok = bool(sm.converged) and np.isfinite(ll) and np.isfinite(value)
    return ll if ok else -np.inf


def smoother_batch(
    memory, u, y, mask, steps, horizon, hyper: Hyper, m0, p0, starts, bounds, max_iter: int,
    batched: bool = False, schedule=None,
):
    """`iterated_smoother` for a batch of noise intensities `hyper` (leading axis B), each
    from the constant trajectory of its row of `starts` (B, d), in order (`_runs`). Keeps
    one run, not B: the best by `score` (the evidence of a converged run; the first of equal
    ones); of the rest only the scores and the index of the best by objective (for when none
    converges). Returns ``(best, its index, index of the best by objective, scores (B,),
    iterations (B,), −objectives (B,))``; an index is −1 where no run qualifies (then `best`
    is the last run)."""
    best, i_best, s_best, i_alt, a_best = None, -1, -np.inf, -1, -np.inf
    scores, alts, iterations = [], [], []
    runs = _runs(memory, u, y, mask, steps, horizon, hyper, m0, p0, starts, bounds, max_iter,
                 batched, schedule)
    for b, sm in enumerate(runs):
        s, value = host_score(sm), float(sm.objective)
        a = -value if np.isfinite(value) else -np.inf
        if s > s_best:
            best, i_best, s_best = sm, b, s
        if a > a_best:
            i_alt, a_best = b, a
        scores.append(s)
        alts.append(a)
        iterations.append(int(sm.iterations))
    if best is None:
        best = sm
    best = jax.tree_util.tree_map(to_device, best)  # a run of a batch: NumPy fields
    return best, i_best, i_alt, np.array(scores), np.array(iterations), np.array(alts)


def smoother_modes(
    memory, u, y, mask, steps, horizon, hyper: Hyper, m0, p0, starts, bounds, max_iter: int,
    batched: bool = False, schedule=None,
):
    """`iterated_smoother` for a batch of noise intensities `hyper` (leading axis C), each from
    the constant trajectory of its row of `starts` (C, d), in order (`_runs`). Returns, per
    run, only what a mixture of them needs: the order coordinate β of the mode (C, N), its
    smoothed variance (C, N), the run's `score` (C,), its residuals from the noise-free
    output (C, N), its parameters (C, N, n) and its fitted freedom (C,)
    (`vojax._tracker._explanations.freedom`)."""
    n, yy = u.shape[1], np.asarray(y)
    rs = np.broadcast_to(np.exp(np.asarray(hyper.log_r, float)).reshape(-1), (len(starts),))
    out = []
    for sm, r in zip(_runs(memory, u, y, mask, steps, horizon, hyper, m0, p0, starts, bounds,
                           max_iter, batched, schedule), rs):
        theta, phi = np.asarray(sm.theta), np.asarray(sm.phi)
        res = yy - model_output(theta, phi, n)
        out.append((theta[:, 0], np.asarray(sm.cov)[:, 0, 0], host_score(sm), res,
                    theta[:, 1 : 1 + n], freedom(sm, r, mask)))
    return tuple(np.array([o[k] for o in out]) for k in range(6))


def score(sm):
    """Laplace evidence of a smoothing run (its innovation log-likelihood at the mode); −∞
    unless it converged to a finite mode."""
    ok = sm.converged & jnp.isfinite(sm.log_likelihood) & jnp.isfinite(sm.objective)
    return jnp.where(ok, sm.log_likelihood, -jnp.inf)


def _iterate(
    memory, u, y, mask, steps, horizon, hyper: Hyper, m0, p0, nominal, bounds, max_iter: int,
    schedule="sequential",
) -> Smoothed:
    """Runs the damped Gauss–Newton (Levenberg–Marquardt) iteration from the trajectory
    `nominal` (N, d): each step is the smoothed mean of the model linearised at the current
    trajectory, with every state also observed at its current value with precision μ. The
    damping follows Nielsen's rule: after a step that lowers the posterior, μ is scaled by
    ``max(1/3, 1 − (2ρ − 1)³)``, where ρ is the decrease achieved over the decrease the
    linearised model predicted (so μ falls where the linearisation holds and rises, up to 2×,
    where it does not); after a step that does not, μ is scaled by ν, and ν doubles (ν = 2
    after an accepted step). A fixed tenfold fall and rise instead makes μ alternate between
    two values in a curved valley, every other step rejected and the accepted ones damped
    too much (docs/calibration.md, "The tracker's settings")."""
    TRACES["smoother"] += 1
    n = u.shape[1]
    q = hyper.process(steps, horizon, n)
    f = hyper.transition(steps, horizon, n)
    p0 = hyper.initial(p0)
    r = hyper.r
    p0_inv = jnp.linalg.inv(p0)

    def cost(theta, phi):
        return objective(theta, phi, y, mask, r, q, m0, p0_inv, f)

    evaluate = order_map(memory, u)  # the order-free history, once for all the iterations
    phi, dphi = _regressors(evaluate, nominal, bounds)
    mu0, nu0 = jnp.asarray(MU_START, y.dtype), jnp.asarray(2.0, y.dtype)
    start = (nominal, phi, dphi, cost(nominal, phi), mu0, nu0, jnp.asarray(jnp.inf, y.dtype), 0)

    def cond(carry):
        *_, mu, _, rel, i = carry
        return (i < max_iter) & (rel > REL_TOL) & (mu < MU_MAX)

    def body(carry):
        theta, phi, dphi, value, mu, nu, rel, i = carry
        _, (ms, ps), jac, z = _linear_pass(theta, phi, dphi, y, mask, r, q, f, m0, p0, bounds,
                                           mu, schedule)
        phic, dphic = _regressors(evaluate, ms, bounds)
        valc = cost(ms, phic)
        ok = jnp.isfinite(valc) & (valc <= value)
        # the cost the linearised model predicts for the step
        linear = posterior_cost(ms, z - jnp.sum(jac * ms, -1), mask, r, q, m0, p0_inv, f)
        pick = lambda a, b: jnp.where(ok, a, b)  # noqa: E731
        # the share is read when the program is traced: 0 computes no shortfall
        share = _damping.BARELY_DAMPED
        short = shortfall(mu, ps) if share > 0 else None
        new_rel = progress(ok, mu, value, valc, rel, short, share)
        new_mu, new_nu = damping(mu, nu, ok, value, valc, linear)
        return (
            pick(ms, theta),
            pick(phic, phi),
            pick(dphic, dphi),
            pick(valc, value),
            new_mu,
            new_nu,
            new_rel,
            i + 1,
        )

    theta, phi, dphi, value, mu, _, rel, iters = lax.while_loop(cond, body, start)
    filtered, (_, cov), jac, z = _linear_pass(theta, phi, dphi, y, mask, r, q, f, m0, p0, bounds,
                                              schedule=schedule)
    y_pred = y - filtered.innovation
    return Smoothed(
        theta=theta,
        cov=cov,
        filtered_mean=filtered.mean,
        filtered_cov=filtered.cov,
        y_pred=y_pred,
        phi=phi,
        objective=value,
        log_likelihood=filtered.log_likelihood,
        jacobian=jac,
        pseudo=z,
        # no further decrease, or none possible along the Gauss–Newton direction
        converged=(rel <= REL_TOL) | (mu >= MU_MAX),
        iterations=iters,
    )


def linearised_log_likelihood(hyper: Hyper, jac, z, mask, steps, horizon, m0, p0,
                              schedule="sequential"):
    """Innovation log-likelihood of the model linearised at a fixed trajectory, as a function
    of the noise intensities (differentiable: one filter scan)."""
    n = jac.shape[1] - (3 if hyper.coloured else 2)
    q, f = hyper.process(steps, horizon, n), hyper.transition(steps, horizon, n)
    return _filter(jac, z, hyper.r, q, m0, hyper.initial(p0), mask, f=f,
                   schedule=schedule).log_likelihood


def mix_modes(betas, variances, scores, best, span, same=0.25):
    """An evidence-weighted mixture of smoothing runs, on the order's β scale (NumPy).

    `betas`, `variances` (C, N): each run's mode and smoothed variance; `scores` (C,): its
    Laplace evidence (−∞ where it did not converge); `best`: the index of the reported run.
    Runs that reached the same mode as a run of higher evidence (their β within `same` of its
    standard deviation, median over the first `span` samples) are dropped, so that a mode
    found from several starts counts once. Weights ``w_c ∝ exp(score_c)``; the mixture's
    variance about the reported run is ``Σ w_c (var_c + (β_c − β_best)²)``: its band covers
    the other modes and intensities in proportion to their evidence.

    **Returns:** ``(variance (N,), weights (C,))``, the weights 0 for dropped runs."""
    betas, variances, scores = (np.asarray(a, float) for a in (betas, variances, scores))
    if not np.isfinite(scores[best]):  # the reported run did not converge: no mixture
        weights = np.zeros(scores.shape)
        weights[best] = 1.0
        return variances[best], weights
    order = [int(best)] + [
        int(i) for i in np.argsort(-scores) if int(i) != int(best) and np.isfinite(scores[i])
    ]
    kept = []
    for i in order:
        sd = np.sqrt(np.maximum(variances[i, :span], 0.0))
        if all(
            np.median(np.abs(betas[i, :span] - betas[j, :span]) / np.maximum(sd, 1e-300)) >= same
            for j in kept
        ):
            kept.append(i)
    weights = np.zeros(scores.shape)
    top = scores[kept].max()
    weights[kept] = np.exp(scores[kept] - top)
    weights /= weights.sum()
    spread = (betas - betas[best]) ** 2 + variances
    return np.einsum("c,cn->n", weights, spread), weights
