"""`identify`: the paper's law (Theorem 1) or the Bayesian tracker over a whole record."""

import dataclasses
import warnings

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jax import lax
from jaxtyping import Array, Float

from . import _validate as check
from ._adaptive import LSFF, AdaptiveLaw, OrderGradient
from ._integral import make_memory, scan_memory, scan_memory_orders
from ._kernels import RULES
from ._stats import (
    correlation_limit,
    lag1_correlation,
    noise_variance,
    prediction_error_correlation,
)
from ._tracker._blocks import block_size
from ._xla import to_device

DEFAULT_BOUNDS = (0.05, 0.95)  # the law's projection
KALMAN_BOUNDS = (0.01, 0.99)  # the tracker's logistic map
PAPER_LAM = 0.9


IDENTIFIED_HALFWIDTH = 0.1  # median ±2σ half-width of the order band above which it is "not identified"
# the most points `max_points` may ask for: the tracker costs about 4 ms a point (2-core CPU,
# 1e4 points, XLA's default loops; 1 ms with `use_fast_cpu_loops`), so this is about 3 min
TRACKER_MAX_POINTS = 50_000
# a longer record is fitted as the means of blocks of samples, at most this many points by
# default (`identify`'s `max_points`); see `vojax._tracker._blocks`
MAX_POINTS = 1_000
MIN_POINTS = 100  # the fewest points `max_points` may ask for
# the coarser clock's model error, over the noise of a block mean, above which the order is
# not reported identified
BLOCK_ERROR_LIMIT = 0.5
BOUND_TOL = 1e-3  # an order within this fraction of the range of a bound counts as at the bound
# the tracker's measurement-noise intensities (white; or white and coloured parts): at an edge
# of their search box (the lower edges of the two parts are named "… (lower edge)") the band
# is not a statement about the data
NOISE_EDGES = frozenset({"noise", "white_noise", "coloured_noise"})
# the law's band is its estimate's spread over the noise alone; on held-out simulations
# (scripts/bench_calibration.py) the truth lies outside it at most samples, whatever its width
LAW_BAND = (
    "the paper's law gives no confidence band (its ±2σ is the spread over the measurement "
    "noise, without its tracking error, and misses the truth on simulated records): use "
    "method='kalman' for an order with a confidence band"
)


class IdentifiabilityWarning(UserWarning):
    """The data do not pin the order down: its band is wide, or the estimate sits at a bound."""


@dataclasses.dataclass(frozen=True)
class Diagnostics:
    """What a user should know before trusting an identification.

    - `band_halfwidth`: median over the second half of the record of the ±2σ half-width of the
      order band (order units).
    - `at_bound_fraction`: fraction of samples whose order lies at a bound of `alpha_bounds`.
    - `converged`: the tracker's smoother (or the gain tuning) converged.
    - `at_edge`: names of automatically chosen settings that sit at the edge of their search box;
      a tracker's drift at the lower edge is named ``"order_drift (lower edge)"`` (or
      ``"parameter_drift (lower edge)"``): the data show no such drift, which is a finding,
      not a problem, and it is not in `message`.
    - `identified`: the band is a confidence band (the tracker's; never the paper's
      law's, whose band leaves out its tracking error), narrower than ±0.1, the order
      is at a bound for < 5 % of samples, the estimation converged, and the measurement noise
      was not tuned to the edge of its range (where the band would not be a statement about
      the data).
    - `message`: one sentence when something is wrong, else ``""``.
    - `innovation_correlation`: lag-1 autocorrelation of the one-step prediction errors
      (innovations) over the fitted samples; white noise and a right model give about 0.
      Above `correlation_limit` (3/√n for n innovations, within 0.1–0.25) the tracker's
      band is not trusted.
    - `block`: the tracker fitted a long record as the means of blocks of this many samples
      (1: every sample; see `identify`'s `max_points`), and `block_error` is the model
      error of that coarser clock, at the constant-order fit, over the noise of a block mean
      (NaN when there are no blocks). Above `BLOCK_ERROR_LIMIT` (0.5) the order is not
      reported identified.
    - `noise_correlation`: where the tracker modelled the measurement noise as coloured (an
      AR(1) part besides white noise, chosen by evidence), that part's correlation between
      consecutive samples (block means for a long record); NaN where the noise is white.
    """

    band_halfwidth: float
    at_bound_fraction: float
    converged: bool
    at_edge: tuple[str, ...]
    identified: bool
    message: str
    innovation_correlation: float = float("nan")
    block: int = 1
    block_error: float = float("nan")
    noise_correlation: float = float("nan")


class Identification(eqx.Module):
    """What `identify` returns: the estimates at every sample, their bands and the settings.

    - `alpha` (N,): the identified order α̂; `alpha_std` (N,): its standard deviation;
      `alpha_lower`, `alpha_upper` (N,): the ±2σ band (for ``method="kalman"`` taken on the
      unbounded scale and mapped back, so it stays inside `alpha_bounds`).
    - `p` (N, n): the identified parameters p̂; `p_std` (N, n): their standard deviations.
    - `x0`, `x0_std`: the output offset x(0) used (``"gradient"``) or estimated (``"kalman"``).
    - `y_hat` (N,): the identified output x0 + p̂ᵀφ(α̂, t) (eq. 25).
    - `y_pred` (N,): the a-priori prediction, made before y_k is used (for a long record
      fitted as block means, `diagnostics.block` > 1: the blocks' predictions, linear
      between block times).
    - `dp` (N, n): ∂p/∂β along a uniform order shift (26), and `Lambda` (N,): Λ of eq. (30);
      ``None`` for ``method="kalman"``.
    - `method`, `diagnostics` (`Diagnostics`), and the settings used: `gamma`, `lam`, `alpha0`,
      `dt` (the median step when the samples came with times `t`), `alpha_bounds`, `memory`
      (for ``"kalman"``, `gamma` and `lam` are NaN and `diagnostics`/`tuning` say what was
      chosen, and `parameters` whether the parameters were let drift).

    For ``method="gradient"`` the band is the law's spread over realisations of the
    measurement noise, by the delta method through its own recursion (see
    `vojax._adaptive._bands`); it does not include the law's tracking bias. For
    ``method="kalman"`` it is the posterior of the tracker's random-walk model, mixed over
    the explanations its evidence leaves open and widened to cover every explanation that
    fits the data (with ``parameters="drifting"``, those with a drifting parameter too).
    """

    alpha: Float[Array, " N"]
    alpha_std: Float[Array, " N"]
    alpha_lower: Float[Array, " N"]
    alpha_upper: Float[Array, " N"]
    p: Float[Array, "N n"]
    p_std: Float[Array, "N n"]
    y_hat: Float[Array, " N"]
    y_pred: Float[Array, " N"]
    x0: Float[Array, ""]
    x0_std: Float[Array, ""]
    dp: Float[Array, "N n"] | None
    Lambda: Float[Array, " N"] | None
    gamma: Float[Array, ""]
    lam: Float[Array, ""]
    alpha0: Float[Array, ""]
    dt: Float[Array, ""]
    alpha_bounds: tuple[float, float] = eqx.field(static=True)
    memory: str = eqx.field(static=True)
    method: str = eqx.field(static=True)
    diagnostics: Diagnostics = eqx.field(static=True)
    tuning: object = eqx.field(static=True, default=None)
    # the tracker's `parameters` setting ("drifting" or "constant"); None for the law
    parameters: str | None = eqx.field(static=True, default=None)

    def summary(self, names=None):
        """The headline numbers as a `vojax.Summary` (a dict that prints as a table): the final
        order with its standard deviation, the order's median over the second half, the band's
        half-width, each parameter's final value (named by `names`, default ``p1``, ``p2``…),
        the offset, and the verdict with its reason."""
        from ._results import Summary, row

        alpha, std = np.asarray(self.alpha), np.asarray(self.alpha_std)
        half = alpha.shape[0] // 2
        out = Summary()
        out["order (final)"] = row(alpha[-1], std[-1])
        out["order (median, second half)"] = row(np.median(alpha[half:]))
        out["band half-width (median)"] = row(self.diagnostics.band_halfwidth)
        p, p_std = np.asarray(self.p), np.asarray(self.p_std)
        names = list(names) if names is not None else [f"p{j + 1}" for j in range(p.shape[1])]
        if len(names) != p.shape[1]:
            raise ValueError(f"`names` must name the {p.shape[1]} parameters, got {len(names)}.")
        for j, name in enumerate(names):
            out[f"{name} (final)"] = row(p[-1, j], p_std[-1, j])
        out["x0"] = row(self.x0, self.x0_std)
        still = [
            name.split()[0].replace("_", " ") for name in self.diagnostics.at_edge
            if name.endswith("(lower edge)")
        ]
        note = self.diagnostics.message or (
            f"no {' or '.join(still)} found (tuned to its lower edge)" if still else ""
        )
        out["identified"] = row("yes" if self.diagnostics.identified else "no", None, note)
        return out

    def plot(self, ax=None, *, t=None):
        """The order with its ±2σ band against `t` (the sample times; default ``k·dt``), titled
        with the verdict. Returns the matplotlib Axes."""
        from ._results import plot_order

        n = np.asarray(self.alpha).shape[0]
        times = float(self.dt) * np.arange(n) if t is None else np.asarray(t, dtype=float)
        if times.shape != (n,):
            raise ValueError(f"`t` must have shape ({n},), got {times.shape}.")
        name = {"kalman": "tracker", "gradient": "paper's law"}.get(self.method, self.method)
        verdict = "identified" if self.diagnostics.identified else "not identified"
        return plot_order(
            times, self.alpha, self.alpha_lower, self.alpha_upper, ax=ax, label=name,
            xlabel="time (from the first sample)", title=f"order: {verdict}",
        )

    def to_dataframe(self, t=None, names=None):
        """The per-sample columns (``alpha`` with ``alpha_std`` and its band, each parameter
        and its standard deviation, ``y_hat``, ``y_pred``; ``time`` if `t` is given) as a
        pandas DataFrame (needs the optional pandas)."""
        from ._results import to_dataframe

        p, p_std = np.asarray(self.p), np.asarray(self.p_std)
        names = list(names) if names is not None else [f"p{j + 1}" for j in range(p.shape[1])]
        columns = {} if t is None else {"time": np.asarray(t, dtype=float)}
        columns.update(
            alpha=self.alpha, alpha_std=self.alpha_std, alpha_lower=self.alpha_lower,
            alpha_upper=self.alpha_upper,
        )
        for j, name in enumerate(names):
            columns[name] = p[:, j]
            columns[f"{name}_std"] = p_std[:, j]
        columns.update(y_hat=self.y_hat, y_pred=self.y_pred)
        return to_dataframe(columns)


TRACES = {"scan": 0}


@eqx.filter_jit
def run_law(law: AdaptiveLaw, u, y):
    """Runs ``law`` over samples ``u`` (N, n) and outputs ``y`` (N,) in one ``lax.scan``."""
    TRACES["scan"] += 1

    @jax.checkpoint
    def body(state, sample):
        return law.step(state, *sample)

    _, out = lax.scan(body, law.init(u.shape[1]), (u, y))
    return out


def build_law(
    dt, num_steps, *, lam, gamma, alpha0, alpha_bounds, memory, rule, r0=None, tol=1e-10,
    times=None,
):
    """The `AdaptiveLaw` of Theorem 1 with its memory designed for the order bounds; on the
    sample `times` when given (then `dt` is the nominal step, the steps come from the memory)."""
    mem = make_memory(
        memory, None if times is not None else dt, num_steps, rule=rule, tol=tol,
        order_range=alpha_bounds, times=times,
    )
    return assemble_law(mem, dt, lam, gamma, alpha0, alpha_bounds, r0)


def assemble_law(memory, dt, lam, gamma, alpha0, alpha_bounds, r0=None):
    """The `AdaptiveLaw` on a designed memory; numbers may be arrays (traced)."""
    dt_arr = jnp.asarray(dt, jnp.result_type(float))
    return AdaptiveLaw(
        memory,
        LSFF(jnp.asarray(lam, dt_arr.dtype), dt_arr, r0),
        OrderGradient(
            jnp.asarray(gamma, dt_arr.dtype),
            dt_arr,
            jnp.asarray(alpha0, dt_arr.dtype),
            alpha_bounds,
        ),
    )


def check_options(u, y, dt, lam, alpha0, alpha_bounds, memory, rule, x0, r0, *, t=None):
    """Validates the arguments shared by `identify`, `tune_gains` and `refit` (the grid: the
    step `dt`, or the sample times `t` where given); returns prepared arrays."""
    u = check.samples(u, "u")
    u2 = check.columns(u)
    y = check.samples(y, "y")
    if y.ndim != 1:
        raise ValueError(f"`y` must have shape (N,), got shape {y.shape}.")
    if y.shape[0] != u2.shape[0]:
        raise ValueError(
            f"`u` and `y` must have the same number of samples, got {u2.shape[0]} and {y.shape[0]}."
        )
    if u2.shape[0] < 3:
        raise ValueError(f"`u` and `y` must hold at least 3 samples, got {u2.shape[0]}.")
    check.grid(dt, t, u2.shape[0])
    if lam is not None and not isinstance(lam, str):
        check.positive(lam, "lam")
    bounds = check.interval(alpha_bounds, "alpha_bounds")
    a0 = (
        float(np.asarray(check.step(alpha0, "alpha0")))
        if not isinstance(alpha0, jax.core.Tracer)
        else None
    )
    if a0 is not None and not bounds[0] <= a0 <= bounds[1]:
        raise ValueError(f"`alpha0` must lie inside `alpha_bounds` {bounds}, got {a0}.")
    check.choice(memory, check.MEMORIES, "memory")
    check.choice(rule, RULES, "rule")
    if x0 is None:  # (NumPy on concrete data: an eager slice would compile per length)
        x0 = y[0] if isinstance(y, jax.core.Tracer) else to_device(np.asarray(y)[0])
    else:
        x0 = _scalar(x0, "x0")
    if isinstance(r0, str):
        if r0 != "auto":
            raise ValueError(f"`r0` must be 'auto', None or an (n, n) matrix, got {r0!r}.")
    elif r0 is not None:
        r0 = jnp.asarray(r0, jnp.result_type(float))
        n = u2.shape[1]
        if r0.shape != (n, n):
            raise ValueError(f"`r0` must have shape ({n}, {n}), got {r0.shape}.")
        if not isinstance(r0, jax.core.Tracer) and (
            not np.all(np.isfinite(np.asarray(r0)))
            or np.any(np.linalg.eigvalsh(np.asarray(r0)) <= 0)
        ):
            raise ValueError("`r0` must be symmetric positive definite.")
    return u2, y, bounds, x0, r0


def nominal_step(dt, t):
    """The step that sets the scale of gains and forgetting: `dt`, or the median step of `t`."""
    return float(np.asarray(dt)) if t is None else float(np.median(np.diff(np.asarray(t))))


def auto_r0(u2, dt, alpha0, memory, rule, tol, bounds, *, num=None, mem=None, times=None):
    """``R_0`` worth one sample of information at the initial order: ``h·diag(mean φ²)`` with
    ``φ = Φ(α̂(0), t)``. It scales with the inputs, so the law does not depend on their units.
    With `num`, ``u2`` is a record of `num` samples padded after its end (the mean covers the
    real samples; the memory is causal); `mem` is a memory already designed for ``u2``."""
    size = u2.shape[0]
    num = size if num is None else int(num)
    if mem is None:
        mem = make_memory(
            memory, None if times is not None else dt, size, rule=rule, tol=tol,
            order_range=bounds, times=times,
        )
    phi = np.asarray(scan_memory(mem, jnp.asarray(u2), jnp.full((size,), float(alpha0)), False))
    with np.errstate(over="ignore"):
        power = np.mean(phi[:num] ** 2, axis=0)
    if not np.all(np.isfinite(power)):
        raise ValueError(
            "the inputs' fractional integrals overflow float64 when squared (values near "
            "1e154 or beyond): rescale the inputs (another unit) or give `r0`."
        )
    if not np.all(power > 0):
        j = int(np.argmin(power))
        raise ValueError(f"input column {j} of `u` is zero everywhere: its parameter is undefined.")
    return jnp.asarray(float(dt) * np.diag(power))


def check_mask(mask, num, num_inputs):
    """A 0/1 mask of shape (N,) with enough fitted samples; returns it as a NumPy array."""
    arr = np.asarray(mask, dtype=float)
    if arr.shape != (num,):
        raise ValueError(f"`mask` must have shape ({num},), got {arr.shape}.")
    if not np.all((arr == 0) | (arr == 1)):
        raise ValueError("`mask` must hold only 0 (not fitted) and 1 (fitted).")
    if arr.sum() < num_inputs + 3:
        raise ValueError(
            f"`mask` leaves {int(arr.sum())} fitted samples; at least {num_inputs + 3} are needed."
        )
    return arr


def known_offset(x0) -> float:
    """`x0` as a finite Python float (the tracker's known output offset), checked as the
    law's is (`_scalar`)."""
    return float(_scalar(x0, "x0"))


def _scalar(x, name):
    try:
        arr = jnp.asarray(x, jnp.result_type(float))
    except (TypeError, ValueError):
        raise ValueError(f"`{name}` must be a number, got {x!r}.") from None
    if arr.ndim != 0:
        raise ValueError(f"`{name}` must be a scalar, got shape {arr.shape}.")
    if not isinstance(arr, jax.core.Tracer) and not np.isfinite(float(arr)):
        raise ValueError(f"`{name}` must be finite, got {float(arr)}.")
    return arr


def _first_bad(*arrays):
    """Index of the first sample at which any of the arrays is not finite, or None."""
    bad = np.zeros(np.shape(arrays[0])[0], bool)
    for a in arrays:
        a = np.asarray(a)
        bad |= ~np.isfinite(a.reshape(a.shape[0], -1)).all(axis=1)
    return int(np.argmax(bad)) if bad.any() else None


def diagnose(
    alpha, lower, upper, bounds, converged, at_edge, held_shift=None, *, calibrated=True,
    correlation=float("nan"), unstable_from=None, trade=None, samples=None,
    drift_covered=False, block=1, block_error=None, noise_correlation=None,
) -> Diagnostics:
    """The `Diagnostics` of an order trajectory and its band. `held_shift`: how far the order
    moves (median over the second half) when the tracker's drifting parameters are held.
    ``calibrated=False``: the band is not a confidence band (the paper's law: the spread of its
    estimate over the measurement noise, without its tracking error), so nothing is
    identified by it. `correlation`: the innovations' lag-1 autocorrelation (see
    `Diagnostics`). `unstable_from`: the first sample at which the law's spread passes the
    order's range (its linearisation is unstable), or None. `trade`: the constant orders
    ``(lo, hi)`` with which a drifting parameter explains the data as well, which the band
    was widened to cover, or None; `drift_covered`: the band was widened to cover the
    tracker's drifting-parameter alternatives that explain the data. `samples`: how many
    innovations `correlation` is over (see `correlation_limit`); `noise_correlation`: the
    coloured noise part's correlation between samples, or None for white noise."""
    alpha, lower, upper = (np.asarray(a) for a in (alpha, lower, upper))
    lo, hi = bounds
    half = alpha.shape[0] // 2
    width = float(np.median((upper - lower)[half:]) / 2)
    tol = BOUND_TOL * (hi - lo)
    at_bound = float(np.mean((alpha <= lo + tol) | (alpha >= hi - tol)))
    problems = []
    if (trade is not None or drift_covered) and width > IDENTIFIED_HALFWIDTH:
        where = (
            f" with any constant order from {trade[0]:.2f} to {trade[1]:.2f}"
            if trade is not None else ""
        )
        problems.append(
            f"the order band is ±{width:.2g} wide because a drifting parameter explains the "
            f"data as well{where}: an order and a drifting parameter can trade off (with one "
            "input they always do), and the band covers both; if the parameters are known not "
            "to drift, say so (parameters='constant', --parameters constant), and the output's "
            "offset where it is measured (x0=, --x0); otherwise "
            "another input or a test with another loading would separate them"
        )
    elif width > IDENTIFIED_HALFWIDTH:
        problems.append(
            f"the order band is ±{width:.2g} wide: these data do not determine the order "
            "(a test with a longer hold or a second input would, or the output's offset where "
            "it is measured (x0=, --x0), or a refit with fewer free parameters: a constant "
            "order or a few knots)"
        )
    if at_bound >= 0.05:
        problems.append(
            f"the order sits at a bound of {bounds} for {100 * at_bound:.0f} % of samples "
            "(widen `alpha_bounds`, or check that the model's inputs are the right ones)"
        )
    if not converged:
        problems.append(
            "the estimation did not converge (look for steps or outliers in the data, or give "
            "`noise=` with the known noise level)"
        )
    noise_edge = bool(NOISE_EDGES & set(at_edge))
    if noise_edge:
        problems.append(
            "the measurement noise was tuned to the edge of its range (an output almost free "
            "of noise, or drifting states that absorb the misfit): the band is not a "
            "statement about the data; give `noise=` with the instrument's noise level"
        )
    traded = held_shift is not None and held_shift > width
    if traded:
        problems.append(
            f"the order trades off with the parameters' drift: with the parameters held it "
            f"moves by {held_shift:.2g}, more than its band (±{width:.2g}); a second input or "
            "a test with another loading would separate them"
        )
    # a tracker's drift at its lower edge (the data show none) is no problem: not in the
    # message; at its upper edge the states move as fast as the search allows
    drifts = [name for name in at_edge if name in ("order_drift", "parameter_drift")]
    if drifts:
        problems.append(
            f"{', '.join(drifts)} at the upper edge of the search box: the states move as fast "
            "as the model allows, which suggests the model misses part of the physics (another "
            "element, a nonlinearity; compare models with vojax.compare)"
        )
    others = [
        name for name in at_edge
        if name not in NOISE_EDGES | {"order_drift", "parameter_drift"}
        and not name.endswith("(lower edge)")
    ]
    if others:
        problems.append(
            f"{', '.join(others)} at the edge of the search box (give the gains yourself, or "
            "use method='kalman')"
        )
    limit = correlation_limit(samples)
    coloured = calibrated and correlation > limit
    if coloured:
        problems.append(
            f"the prediction errors are correlated (lag-1 autocorrelation {correlation:.2f} > "
            f"{limit:.2g}): the model misses part of the signal, or the measurement noise is "
            "coloured in a way that neither white noise nor white plus AR(1) noise explains, "
            "and the band is too narrow; resample to a coarser clock, on which the noise "
            "decorrelates between samples, or give `noise=` with the known noise level"
        )
    coarse = block_error is not None and block_error > BLOCK_ERROR_LIMIT
    if coarse:
        problems.append(
            f"the record was averaged in blocks of {block} samples, and the coarser clock "
            f"misrepresents it (its model error is {block_error:.2g} times the noise of a "
            "block mean): pass a larger `max_points` (--max-points) for finer blocks"
        )
    if unstable_from is not None:
        problems.append(
            f"the law is unstable at these gains: from sample {unstable_from} its spread over the "
            "measurement noise is wider than the order's range (a change of the data in their "
            "last digits moves the order); use a smaller `gamma`"
        )
    if not calibrated:
        problems.append(LAW_BAND)
    identified = (
        width <= IDENTIFIED_HALFWIDTH and at_bound < 0.05 and bool(converged)
        and not noise_edge and not traded and calibrated and not coloured
        and unstable_from is None and not coarse
    )
    message = "; ".join(problems)
    return Diagnostics(
        width, at_bound, bool(converged), tuple(at_edge), identified, message, correlation,
        int(block), float("nan") if block_error is None else float(block_error),
        float("nan") if noise_correlation is None else float(noise_correlation),
    )


def identify(
    u,
    y,
    dt=None,
    *,
    t=None,
    method: str = "kalman",
    smooth: bool = True,
    lam=None,
    gamma=None,
    alpha0=None,
    alpha_bounds=None,
    memory: str = "exponential",
    rule: str = "trapezoid",
    x0=None,
    r0=None,
    noise=None,
    parameters=None,
    mask=None,
    max_points: int | None = None,
    tol: float = 1e-10,
    warn: bool = True,
) -> Identification:
    """Identifies the order α(t) and parameters p of ``D^{α(t)} x = pᵀu`` with a band for each.

    Two methods over the same memory kernels (the same names as the CLI's ``--method`` and
    the keys of its ``summary.json``):

    - ``method="kalman"`` (default): a joint Bayesian tracker of ``(α, p, x0)`` — order
      (through a logistic map of `alpha_bounds`) and parameters as random walks, the offset
      estimated — whose noise intensities are chosen by maximising the innovation likelihood,
      started from a constant-order least-squares fit. ``smooth=True`` returns the posterior
      mode of the whole trajectory (iterated extended Kalman smoother: Gauss–Newton) with its
      Laplace bands; ``smooth=False`` the online iterated EKF's causal estimates.
    - ``method="gradient"``: the paper's adaptive law (Theorem 1) in the exact discrete form,
      one jit-compiled `lax.scan` — LSFF with forgetting ``λ`` for ``p``, the order-gradient
      law with gain ``γ`` and projection onto `alpha_bounds`, ``∂p/∂β`` (26) by forward-mode
      autodiff. The law sees ``y − x0`` with ``x0 = y[0]`` unless given (Remark 4). Its band
      is its spread over the measurement noise, not a confidence band: it never reports
      the order identified.

    With one input a variable order is not determined by the data alone: a rescaled ``p`` has
    an order trajectory that fits as well, and what settles it is the regularity assumed (the
    law's gains, the tracker's drift intensities). The bands say how well the data pin the
    estimate down *under that assumption*; `diagnostics` flags wide bands, orders at a bound
    and settings at the edge of their search, and an `IdentifiabilityWarning` is issued then
    (``warn=False`` to silence it).

    **Arguments:**

    - `u`: inputs, ``(N,)`` or ``(N, n)``; `y`: measured output ``(N,)``.
    - `dt`: the step; or `t`: the sample times ``(N,)``, strictly increasing (exactly one).
      On a non-uniform grid the memory uses exact weights for every step and the law
      integrates over the local step ``t_k − t_{k−1}`` (LSFF's forgetting ``e^{−λh_k}``, the
      order law's ``h_k γ``); gains and forgetting keep their units (1/time).
    - `method`, `smooth`: see above.
    - `gamma`, `lam`, `alpha0`, `r0`: the law's settings (``method="gradient"`` only;
      given with the tracker they are an error, never ignored).
    - `gamma`: the law's order gain γ > 0, or ``"auto"`` (the default, None) to choose it by
      `tune_gains` from normalised signals (unit-free). A number is taken literally, as the
      paper's 0.01.
    - `lam`: forgetting factor λ > 0; ``None`` (default): tuned with γ when ``gamma="auto"``,
      the paper's 0.9 otherwise. A number with ``gamma="auto"`` tunes γ alone at that λ.
    - `alpha0`: α̂(0) of the law, inside `alpha_bounds` (default 0.5).
    - `alpha_bounds`: the order range ⊂ (0, 1); default (0.05, 0.95) for the law (its
      projection), (0.01, 0.99) for the tracker.
    - `memory`: ``"exponential"`` (O(1) per sample) or ``"direct"``; `rule`: the quadrature.
    - `x0`: the output's offset, in the units of `y`: the output the system gives before
      any input (the reading of a tared sensor at rest, often 0). The law's initial output
      (default ``y[0]``). The tracker estimates it unless given (None, the default); given,
      the tracker holds it there. A known offset removes a trade-off that one input leaves:
      a lower order with larger parameters and a shifted offset can fit a record almost as
      well. On the calibration suite, with the parameters stated constant as well, it
      identifies more records with narrower bands and the order closer to the truth; with
      the parameters free to drift, 3 of the 69 records it then identified had the truth
      outside the band (`docs/identifiability.md`). Give it only where it is measured: a
      wrong offset moves the order.
    - `r0`: the law's initial information ``R_0``: ``"auto"`` (the default, None: one sample's worth at
      α̂(0), scaled to the inputs), or an ``(n, n)`` matrix taken literally (the paper's
      ``P(0) = I`` is ``np.eye(n)``).
    - `noise`: the tracker's noise intensities, instead of tuning them: a dict with
      ``order_drift`` (variance of the logistic order coordinate's change over the record),
      ``parameter_drift`` (variance of each normalised parameter's change over the record;
      1e-6 or less states the parameters constant, as ``parameters="constant"`` does) and
      ``noise_std`` (of the measurement, in the units of `y`).
    - `parameters`: ``method="kalman"`` only. ``"drifting"`` (the default, None): the
      parameters may drift, their drift tuned with the order's; since with one input a
      drifting parameter can stand in for a moving order, the band also covers every
      constant order with which a parameter free to drift explains the data as well, and the
      order is reported not identified when that makes the band wide. ``"constant"``: the
      parameters are known not to drift (a calibrated instrument, a test short against any
      ageing); their drift is held, and the band holds under that assumption only. It
      also covers the orders that the parameters held at another scale (0.5–2 × the tuned
      ones) give where those fit the data: with constant parameters the order's level and
      the parameters' scale can still trade off.
    - `mask`: ``method="kalman"`` only: an ``(N,)`` array of 0 and 1; samples with 0 are not
      fitted (the tracker still estimates the states there, from its random-walk model). Used
      to pad records to a common length so that one compiled program serves many lengths;
      the diagnostics cover the samples up to the last one fitted.
    - `max_points`: ``method="kalman"`` only: the most points the tracker fits (None: 1,000;
      from 100 to 50,000). A longer record is fitted as the means of blocks of ``B``
      consecutive samples (its first sample kept alone, so that the integral starts where the
      record does): block means of time, input and output, on that coarser clock. The
      estimates are brought back to every sample (linear between block times, ``y_hat`` from
      one memory run over the whole record at that order), and `diagnostics` gives ``B`` and
      the coarse clock's model error against the noise of a block mean (above 0.5 the order
      is not reported identified). The tracker's cost grows with its points, not the
      record's length: about 1.7 s for 1,000 points on a 2-core CPU after its first call
      (0.4 s with `use_fast_cpu_loops`), and a few µs a sample for the averaging and the two
      memory runs over the record.
    - `tol`: accuracy of the exponential memory; `warn`: issue `IdentifiabilityWarning`.

    **Returns:** an `Identification`. **Raises:** `ValueError` for bad input, and when the
    estimate is not finite (the law diverged), naming the sample.
    """
    check.choice(method, ("kalman", "gradient"), "method")
    if alpha_bounds is None:
        alpha_bounds = DEFAULT_BOUNDS if method == "gradient" else KALMAN_BOUNDS
    if method == "kalman":
        x0 = None if x0 is None else known_offset(x0)
        law = dict(gamma=gamma, lam=lam, alpha0=alpha0, r0=r0)
        given = [f"`{k}`" for k, v in law.items() if v is not None]
        if given:
            raise ValueError(
                f"{', '.join(given)} set the paper's law, which method='kalman' (the default) "
                "does not use; add method='gradient', or leave them out."
            )
        parameters = "drifting" if parameters is None else parameters
        check.choice(parameters, ("drifting", "constant"), "parameters")
        if parameters == "constant" and noise is not None:
            raise ValueError(
                "`noise` sets the parameters' drift itself (its 'parameter_drift'); give it, "
                "or parameters='constant', not both."
            )
        return _identify_kalman(
            u, y, dt, t, smooth, alpha_bounds, memory, rule, noise, mask, tol, warn, parameters,
            max_points, x0,
        )
    if max_points is not None:
        raise ValueError(
            "`max_points` sets the tracker (method='kalman'); the paper's law does not use it."
        )
    if parameters is not None:
        raise ValueError(
            "`parameters` sets the tracker (method='kalman'); the paper's law does not use it."
        )
    if mask is not None:
        raise ValueError("`mask` is for method='kalman'; the paper's law fits every sample.")
    if noise is not None or not smooth:
        name = "`noise`" if noise is not None else "`smooth=False`"
        raise ValueError(
            f"{name} sets the tracker (method='kalman'); the paper's law does not use it."
        )
    gamma = "auto" if gamma is None else gamma
    alpha0 = 0.5 if alpha0 is None else alpha0
    r0 = "auto" if r0 is None else r0
    if isinstance(gamma, str) and gamma != "auto":
        raise ValueError(f"`gamma` must be a positive number or 'auto', got {gamma!r}.")
    if isinstance(lam, str):
        raise ValueError(f"`lam` must be a positive number or None, got {lam!r}.")
    # validate once, before any (possibly long) tuning; the law and the tuner share the settings
    u2, y, bounds, x0, r0 = check_options(
        u, y, dt, lam, alpha0, alpha_bounds, memory, rule, x0, r0, t=t
    )
    step = nominal_step(dt, t)
    if isinstance(r0, str):
        r0 = auto_r0(u2, step, alpha0, memory, rule, tol, bounds, times=t)
    shared = dict(alpha0=alpha0, alpha_bounds=bounds, memory=memory, rule=rule, r0=r0, tol=tol)
    at_edge = ()
    if isinstance(gamma, str):  # "auto", checked above
        from ._tune import tune_gains

        gains = tune_gains(u2, y, dt, t=t, x0=x0, lam=lam, **shared)
        gamma, lam = gains.gamma, gains.lam
        at_edge = gains.at_edge
    elif lam is None:
        lam = PAPER_LAM
    check.positive(gamma, "gamma")
    law = build_law(step, u2.shape[0], lam=lam, gamma=gamma, times=t, **shared)
    out = run_law(law, u2, y - x0)
    bad = _first_bad(out.alpha, out.p, out.dp, out.y_hat)
    if bad is not None:
        raise ValueError(
            f"the adaptive law diverged at sample {bad} (non-finite estimate): the inputs do not "
            f"excite every parameter within the forgetting horizon 1/λ = {1 / float(lam):.3g}; "
            "use a smaller `lam`, fewer inputs, or r0='auto'."
        )
    from ._adaptive._bands import law_covariance

    var_alpha, var_p = law_covariance(law, u2, y - x0, jnp.asarray(noise_variance(y - x0)))
    res = law_identification(
        out, var_alpha, var_p, x0, law.order.gamma, law.lsff.lam, law.order.alpha0,
        law.lsff.dt, bounds, memory, at_edge, y=y,
    )
    if warn and res.diagnostics.message:
        warnings.warn(
            f"vojax.identify: {res.diagnostics.message}.", IdentifiabilityWarning, stacklevel=2
        )
    return res


def law_identification(
    out, var_alpha, var_p, x0, gamma, lam, alpha0, dt, bounds, memory, at_edge=(), host=False,
    y=None,
) -> Identification:
    """An `Identification` from the law's outputs (of ``y − x0``) and the variances of its
    estimates (`vojax._adaptive._bands.law_covariance`); shared by `identify` and the batch.
    With the measured `y`, the diagnostics hold the correlation of its prediction errors.
    ``host=True`` keeps its arrays in NumPy (the batch: each new record length would compile
    the conversions to device arrays)."""
    # on the host, in NumPy: eager JAX operations would compile once per record length
    alpha = np.asarray(out.alpha)
    alpha_std = np.sqrt(np.maximum(np.asarray(var_alpha), 0.0))
    lo, hi = bounds
    lower = np.clip(alpha - 2 * alpha_std, lo, hi)
    upper = np.clip(alpha + 2 * alpha_std, lo, hi)
    correlation = float("nan")
    if y is not None:
        pred = np.asarray(out.y_pred) + float(x0)
        correlation = lag1_correlation((np.asarray(y)[: pred.shape[0]] - pred)[1:])
    # the law's sampling spread passes the order's whole range: its linearisation is unstable
    wild = np.flatnonzero(~(alpha_std <= hi - lo))
    diagnostics = diagnose(
        alpha, lower, upper, bounds, True, at_edge, calibrated=False, correlation=correlation,
        unstable_from=int(wild[0]) if wild.size else None,
    )
    dtype = alpha.dtype
    x0 = np.asarray(x0, dtype)
    put = (lambda a, dtype=None: np.asarray(a, dtype)) if host else jnp.asarray
    return Identification(
        alpha=put(alpha),
        alpha_std=put(alpha_std),
        alpha_lower=put(lower),
        alpha_upper=put(upper),
        p=put(out.p),
        p_std=put(np.sqrt(np.maximum(np.asarray(var_p), 0.0))),
        y_hat=put(np.asarray(out.y_hat) + x0),
        y_pred=put(np.asarray(out.y_pred) + x0),
        x0=put(x0, dtype),
        x0_std=put(0.0, dtype),
        dp=put(out.dp),
        Lambda=put(out.Lambda),
        gamma=put(gamma, dtype),
        lam=put(lam, dtype),
        alpha0=put(alpha0, dtype),
        dt=put(dt, dtype),
        alpha_bounds=bounds,
        memory=memory,
        method="gradient",
        diagnostics=diagnostics,
    )


def _track_blocks(u2, y, dt, t, bounds, smooth, memory, rule, tol, noise, mask, parameters,
                  size, span, x0=None):
    """The tracker on the means of blocks of `size` samples of the record's first `span`
    samples (padding after them is not the record's; see `vojax._tracker._blocks`), its
    estimates brought back to every sample: the order, its band and the parameters linear
    between block times, the output ``y_hat`` from one memory run over the whole record at
    that order. Returns ``(TrackResult, fit)``, `fit` what the tracker fitted, for the
    diagnostics, with the coarse clock's model error (`block_error`)."""
    from ._tracker import track
    from ._tracker._blocks import (
        BATCHED_BLOCK, SCAN_UNROLL, block_average, block_means, to_samples,
    )
    from ._tracker._smoother import batch_pays
    from ._tracker._track import _least_squares

    num = u2.shape[0]
    dtype = np.dtype(u2.dtype)
    times = np.asarray(t, float) if t is not None else float(dt) * np.arange(num)
    u_np, y_np = np.asarray(u2), np.asarray(y)
    mask_np = None if mask is None else np.asarray(mask)[:span]
    t_b, u_b, y_b, mask_b = block_means(times[:span], u_np[:span], y_np[:span], mask_np, size)
    if noise is not None:  # the noise of a block mean
        noise = dict(noise, noise_std=float(noise["noise_std"]) / np.sqrt(size))
    mem_b = make_memory(memory, None, t_b.shape[0], rule=rule, tol=tol, order_range=bounds,
                        times=t_b)
    res = track(
        mem_b, to_device(u_b), to_device(y_b), None, bounds, smooth=smooth, hyper=noise,
        mask=None if mask is None else to_device(mask_b), times=t_b, parameters=parameters,
        x0=x0, batched=size >= BATCHED_BLOCK,
    )
    mem = make_memory(memory, dt, num, rule=rule, tol=tol, order_range=bounds, times=t)
    # everything at every sample: linear between block times
    at_samples = lambda v: to_samples(t_b, np.asarray(v), times)  # noqa: E731
    alpha, p = at_samples(res.alpha), at_samples(res.p)
    # the two runs over every sample, at the constant-order fit and at the tracked order, as
    # one batched scan
    constant = np.full((num,), res.constant_order, dtype)
    phi_c, phi = np.asarray(scan_memory_orders(mem, u2, to_device(
        np.stack([constant, alpha.astype(dtype)])), SCAN_UNROLL if batch_pays() else 1))
    # the coarse clock's model error at the constant-order fit, against a block mean's noise
    # (from the samples' own second differences: on the coarse clock those see more of the
    # signal)
    phi_b = np.asarray(scan_memory(mem_b, to_device(u_b), to_device(constant[: t_b.shape[0]]),
                                   False))
    coef = _least_squares(phi_b, y_b - (x0 or 0.0), mask_b, offset=x0 is None)[1]
    error = (block_average(phi_c[:span], size) - phi_b) @ coef[:-1]
    fitted = np.ones(span, bool) if mask_np is None else mask_np > 0
    block_noise = max(noise_variance(y_np[:span][fitted]) / size, 1e-300)
    block_error = float(np.sqrt(np.mean(error[mask_b > 0][1:] ** 2) / block_noise))
    full = dataclasses.replace(
        res,
        alpha=to_device(alpha),
        alpha_std=to_device(at_samples(res.alpha_std)),
        alpha_lower=to_device(at_samples(res.alpha_lower)),
        alpha_upper=to_device(at_samples(res.alpha_upper)),
        p=to_device(p),
        p_std=to_device(at_samples(res.p_std)),
        y_hat=to_device(float(np.asarray(res.x0)) + np.sum(p * phi, axis=1)),
        y_pred=to_device(at_samples(res.y_pred)),
        alpha_held=None if res.alpha_held is None else to_device(at_samples(res.alpha_held)),
    )
    fit = dict(alpha=res.alpha, lower=res.alpha_lower, upper=res.alpha_upper,
               held=res.alpha_held, y=y_b, y_pred=res.y_pred, span=t_b.shape[0],
               mask=None if mask is None else mask_b, block_error=block_error)
    return full, fit


def _identify_kalman(
    u, y, dt, t, smooth, alpha_bounds, memory, rule, noise, mask, tol, warn,
    parameters="drifting", max_points=None, x0=None,
):
    from ._tracker import track

    u2, y, bounds, _, _ = check_options(
        u, y, dt, None, sum(check.interval(alpha_bounds, "alpha_bounds")) / 2, alpha_bounds,
        memory, rule, None, None, t=t,
    )
    if noise is not None:
        keys = {"order_drift", "parameter_drift", "noise_std"}
        if not isinstance(noise, dict) or set(noise) != keys:
            raise ValueError(f"`noise` must be a dict with keys {sorted(keys)}, got {noise!r}.")
        for k, v in noise.items():
            check.positive(v, f"noise[{k!r}]")
    if mask is not None:
        mask = check_mask(mask, u2.shape[0], u2.shape[1])
    max_points = MAX_POINTS if max_points is None else check.count(
        max_points, "max_points", low=MIN_POINTS, high=TRACKER_MAX_POINTS
    )
    # the record's length up to its last fitted sample (padding after it is not the record's)
    length = u2.shape[0] if mask is None else int(np.flatnonzero(np.asarray(mask))[-1]) + 1
    size = block_size(length, max_points)
    if size > 1:
        res, fit = _track_blocks(
            u2, y, dt, t, bounds, smooth, memory, rule, tol, noise, mask, parameters, size,
            length, x0,
        )
    else:
        mem = make_memory(memory, dt, u2.shape[0], rule=rule, tol=tol, order_range=bounds, times=t)
        res = track(
            mem, u2, y, dt, bounds, smooth=smooth, hyper=noise, mask=mask, times=t,
            parameters=parameters, x0=x0,
        )
        fit = dict(alpha=res.alpha, lower=res.alpha_lower, upper=res.alpha_upper,
                   held=res.alpha_held, y=y, y_pred=res.y_pred, span=length, mask=mask)
    bad = _first_bad(res.alpha, res.p, res.y_hat, res.alpha_std, res.p_std)
    if bad is not None:
        raise ValueError(f"the tracker diverged at sample {bad} (non-finite estimate).")
    # the diagnostics see what the tracker fitted (the block means of a long record); cut in
    # NumPy: an eager slice of a JAX array compiles anew for every record length
    fit_mask, span = fit["mask"], fit["span"]
    alpha, lower, upper = (np.asarray(fit[k])[:span] for k in ("alpha", "lower", "upper"))
    shift = None
    if fit["held"] is not None:
        held = np.asarray(fit["held"])[:span]
        shift = float(np.median(np.abs(held - alpha)[span // 2 :]))
    y_np, pred = np.asarray(fit["y"])[:span], np.asarray(fit["y_pred"])[:span]
    fitted = np.ones(span, bool) if fit_mask is None else np.asarray(fit_mask)[:span] > 0
    correlation, samples = prediction_error_correlation(y_np, pred, fitted)
    diagnostics = diagnose(
        alpha, lower, upper, bounds, res.converged, res.tuning.at_edge, shift,
        correlation=correlation, trade=res.trade, samples=samples, drift_covered=res.drift_covered,
        block=size, block_error=fit.get("block_error"),
        noise_correlation=res.tuning.noise_correlation,
    )
    if warn and diagnostics.message:
        warnings.warn(f"vojax.identify: {diagnostics.message}.", IdentifiabilityWarning, stacklevel=3)
    nan = to_device(np.nan)
    return Identification(
        alpha=res.alpha,
        alpha_std=res.alpha_std,
        alpha_lower=res.alpha_lower,
        alpha_upper=res.alpha_upper,
        p=res.p,
        p_std=res.p_std,
        y_hat=res.y_hat,
        y_pred=res.y_pred,
        x0=res.x0,
        x0_std=res.x0_std,
        dp=None,
        Lambda=None,
        gamma=nan,
        lam=nan,
        alpha0=nan,
        dt=to_device(nominal_step(dt, t)),
        alpha_bounds=bounds,
        memory=memory,
        method="kalman",
        diagnostics=diagnostics,
        tuning=res.tuning,
        parameters=parameters,
    )
