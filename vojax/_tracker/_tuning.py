"""The noise intensities by the marginal likelihood: a first pass over starting orders and
order drifts, then a climb that alternates a BFGS refinement of the linearised model's
likelihood with a re-smoothing, while the evidence rises (and a second climb from another
order drift where the first ends with drifting parameters explaining everything)."""

import dataclasses

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from .._xla import to_device
from . import _bfgs as bfgs
from ._model import Hyper
from ._smoother import host_score, linearised_log_likelihood
from ._threads import host_hyper, run_batch_shares

LOWER_EDGE = " (lower edge)"  # suffix of a drift tuned to the bottom of its search box


@dataclasses.dataclass(frozen=True)
class Tuning:
    """How the noise intensities were chosen: their values (normalised units), whether each
    sits at the edge of the search box, and the likelihood."""

    order_drift: float
    parameter_drift: float
    noise: float  # the white measurement variance
    at_edge: tuple[str, ...]
    log_likelihood: float
    tuned: bool
    # a coloured measurement noise's AR(1) part: its stationary variance and its correlation
    # time (a fraction of the record's span); None for white noise
    coloured_noise: float | None = None
    noise_time: float | None = None
    # that part's correlation between consecutive samples (at the median step), or None
    noise_correlation: float | None = None

    @property
    def values(self) -> tuple[float, ...]:
        """The intensities in `Hyper`'s order (five with a coloured noise, else three)."""
        extra = () if self.coloured_noise is None else (self.coloured_noise, self.noise_time)
        return (self.order_drift, self.parameter_drift, self.noise, *extra)

    @classmethod
    def of(cls, x, at_edge, log_likelihood, tuned):
        """From the log-intensities `x` (three or five, in `Hyper`'s order)."""
        v = [float(a) for a in np.exp(np.asarray(x, float))]
        extra = v[3:] if len(v) == 5 else [None, None]
        return cls(*v[:3], tuple(at_edge), float(log_likelihood), bool(tuned), *extra)


def box(settings, noise_floor, hold=False, time_min=None):
    """The search box (natural logs) of the settings' ranges, with the noise's lower end
    raised to the floor; `hold`: the parameters' drift held at `constant_drift` (a box of
    zero width). With `time_min` (the shortest correlation time, a fraction of the span) the
    box of a coloured noise, in `Hyper`'s order: the white part (from the floor), the AR(1)
    part (from `noise_min`) and its correlation time (up to `noise_time_max` of the span)."""
    s = settings
    noise = (float(np.log(s.noise_min)), float(np.log(s.noise_max)))
    out = {
        "order_drift": tuple(float(np.log(v)) for v in s.order_drift_range),
        "parameter_drift": tuple(float(np.log(v)) for v in s.parameter_drift_range),
    }
    if hold:
        out["parameter_drift"] = (float(np.log(s.constant_drift)),) * 2
    floor = (max(noise[0], float(np.log(noise_floor))), noise[1])
    if time_min is None:
        out["noise"] = floor
    else:
        out["white_noise"] = floor
        out["coloured_noise"] = noise
        out["noise_time"] = (float(np.log(time_min)), float(np.log(s.noise_time_max)))
    return out


def at_edges(x, limits, edge) -> tuple[str, ...]:
    """The names of the log-intensities `x` (in the order of `limits`) within `edge` of the
    width of their box `limits` from an end (a box of zero width holds its coordinate: never
    at an edge). A drift at the lower edge is a finding (the data show no drift) and is named
    as such; the noise at either edge, or a drift at the upper one, is a problem. The
    noise's box starts at its floor, so its lower edge is relative to that floor."""
    out = []
    for name, v in zip(limits, x):
        lo, hi = limits[name]
        if hi > lo and min(v - lo, hi - v) < edge * (hi - lo):
            out.append(name + (LOWER_EDGE if name != "noise" and v - lo < hi - v else ""))
    return tuple(out)


def _refine(problem, hyper, smoothed, limits):
    """Maximises the linearised innovation likelihood over the log-intensities in `limits`."""
    s = problem.settings
    dtype = smoothed.pseudo.dtype
    lo = to_device(np.asarray([v[0] for v in limits.values()], dtype))
    hi = to_device(np.asarray([v[1] for v in limits.values()], dtype))
    # a strongly typed start: a weakly typed one (from Python numbers) would compile anew
    return _refine_compiled(
        to_device(np.asarray(host_hyper(hyper), dtype)), smoothed.jacobian, smoothed.pseudo,
        problem.mask, problem.steps, problem.horizon, problem.m0, problem.p0, lo, hi,
        s.refine_steps, s.refine_rtol, s.refine_atol, problem.schedule,
    )


@eqx.filter_jit
def _refine_compiled(x0, jac, z, mask, steps, horizon, m0, p0, lo, hi, max_steps, rtol, atol,
                     schedule):
    count = jnp.sum(mask)

    def loss(zeta):
        # box by a smooth squashing, so that BFGS works unconstrained
        x = lo + (hi - lo) * jax.nn.sigmoid(zeta)
        return -linearised_log_likelihood(Hyper.from_array(x), jac, z, mask, steps, horizon, m0,
                                          p0, schedule) / count

    # inside the box (a box of zero width holds its coordinate: ζ = 0, x = lo)
    margin = jnp.minimum(1e-3, (hi - lo) / 2)
    x0 = jnp.clip(x0, lo + margin, hi - margin)
    zeta0 = jnp.where(hi > lo, jnp.log((x0 - lo) / jnp.where(hi > lo, hi - x0, 1.0)), 0.0)
    # optimistix's BFGS at the settings' tolerances, written as one small loop (`_bfgs`)
    zeta, _ = bfgs.minimise(loss, zeta0, max_steps, rtol=rtol, atol=atol)
    zeta = jnp.where(jnp.all(jnp.isfinite(zeta)), zeta, zeta0)
    return Hyper.from_array(lo + (hi - lo) * jax.nn.sigmoid(zeta))


def tune(problem, starts, noises, noise_floor, hold=False):
    """Maximises the marginal likelihood (Laplace evidence at the posterior mode) over the
    noise intensities and over starting trajectories, since the posterior of a variable order
    can have several modes. One compiled smoothing of every start × order drift of
    `grid_order` (parameter drift `constant_drift`, noise ``noises[0]``), each given
    `grid_max_iter` iterations; if none converges, the same at each further level of `noises`
    in turn, then each level again with `max_iter` iterations. From the best run, `climb`;
    where that ends `collapsed` (`second_climb`), climb also from the best run at another
    order drift and keep the higher evidence.
    Returns ``(Hyper, Smoothed, Tuning)``. The measurement noise is kept above `noise_floor`:
    smooth records otherwise reach a higher likelihood by explaining every wiggle with
    drifting states and no noise at all, with meaningless, vanishing bands. `hold`: the
    parameters' drift held at `constant_drift` (the parameters known to be constant)."""
    s = problem.settings
    limits = box(s, noise_floor, hold)
    # each run's start on the host as well: indexing the device array outside a compiled
    # program would compile a slice for every record length
    rows_start = np.repeat(np.asarray(starts), len(s.grid_order), axis=0)
    first = to_device(rows_start)
    # the full budget at every level too: a level whose runs converge only past
    # `grid_max_iter` (the constant fit's misfit, where the data's noise stalls) is not lost
    budgets = (s.grid_max_iter,) + ((s.max_iter,) if s.max_iter > s.grid_max_iter else ())
    passes = [(noise, budget) for budget in budgets for noise in noises]
    for noise, budget in passes:
        rows = [(qo, s.constant_drift, noise) for _ in starts for qo in s.grid_order]
        sm, i, i_alt, scores = run_batch_shares(problem, rows, first, budget)
        if np.any(np.isfinite(np.asarray(scores))):
            break
    i = i if i >= 0 else i_alt
    if i < 0:
        raise ValueError("the tracker diverged from every starting order; check the data.")
    hyper = _hyper(rows[i])
    if not np.isfinite(np.asarray(scores)[i]):
        # none converged: fall back on the best finite objective rather than giving up (the
        # pass kept only its index: run it again, the same computation)
        sm = problem.smooth_from(hyper, rows_start[i])
    out = climb(problem, limits, hyper, sm, s.climb_rounds)
    j = second_start(rows, scores, i)
    if s.second_climb and not hold and j >= 0 and collapsed(out[2], s):
        hyper = _hyper(rows[j])
        other = climb(problem, limits, hyper, problem.smooth_from(hyper, rows_start[j]),
                      s.climb_rounds)
        if host_score(other[1]) > host_score(out[1]):
            out = other
    return out


def _hyper(row) -> Hyper:
    """The intensities of a first-pass row ``(order drift, parameter drift, noise)``."""
    return Hyper(*(to_device(np.log(float(v))) for v in row))


def second_start(rows, scores, i) -> int:
    """The best first-pass run (by score) at an order drift other than run `i`'s, or -1."""
    scores = np.asarray(scores, float)
    other = [k for k, r in enumerate(rows) if r[0] != rows[i][0] and np.isfinite(scores[k])]
    return max(other, key=lambda k: scores[k]) if other else -1


def collapsed(tuning, settings) -> bool:
    """Whether the climb ended in the mode where drifting parameters explain everything: the
    order's drift at the lower edge of its box (as `at_edges` named it) while the parameters
    drift."""
    s = settings
    return ("order_drift" + LOWER_EDGE in tuning.at_edge
            and tuning.parameter_drift > s.held_ratio * s.constant_drift)


def climb(problem, limits, hyper, sm, rounds, radius=None, fatal=None):
    """From the smoothing `sm` at the intensities `hyper`, alternates a BFGS refinement of the
    intensities (within `limits`) on the likelihood of the model linearised at the mode and a
    re-smoothing from the mode, while the re-smoothed mode's own evidence rises. With
    `radius`, a trust region: each refinement stays within ``exp(±radius)`` of the current
    intensities, and a refinement that lowers the evidence halves the radius (down to a
    tenth of it) instead of ending the climb. With `fatal`, the name of an intensity whose
    edge disqualifies the result, the climb ends once `fatal_edge_rounds` accepted rounds in
    a row left that intensity at the top of `limits` (the caller rejects it there). Returns
    ``(Hyper, Smoothed, Tuning)``."""
    s = problem.settings
    cand = (host_score(sm), hyper, sm)
    step = radius
    edged = 0
    for _ in range(rounds):
        if edged >= s.fatal_edge_rounds:
            break
        local = limits
        if step is not None:
            x = host_hyper(cand[1])
            local = {k: (max(lo, v - step), min(hi, v + step)) if hi > lo else (lo, hi)
                     for (k, (lo, hi)), v in zip(limits.items(), x)}
        hyper = _refine(problem, cand[1], cand[2], local)
        sm = problem.smooth(hyper, cand[2].theta)
        ll = host_score(sm)
        if not ll > cand[0]:
            if step is None or step / 2 < radius / 10:
                break
            step /= 2
            continue
        cand = (ll, hyper, sm)
        if fatal is not None:
            edged = edged + 1 if fatal in at_edges(host_hyper(hyper), limits, s.edge) else 0
    _, hyper, sm = cand
    x = host_hyper(hyper)
    return hyper, sm, Tuning.of(x, at_edges(x, limits, s.edge), sm.log_likelihood, True)
