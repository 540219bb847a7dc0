"""Experiment design: the Fisher information of a planned test, from the exact order
sensitivities.

For the model ``y = x0 + Σ_j p_j Φ_j(b, t) + ε`` with white measurement noise of standard
deviation σ, the information about ``θ = (c_1 … c_K, p_1 … p_n, x0)`` is ``F = JᵀJ / σ²``,
``J`` the model's Jacobian. The order is the hypothesised trajectory plus a deviation
``Σ_k c_k h_k(t)`` on `knots` hat functions (one knot: a constant shift); since ``Φ_k``
depends on the order at ``t_k`` only (the integral form of the model), the order's columns
are ``(Σ_j p_j ∂Φ_j/∂b)(t) h_k(t)`` with ``∂Φ/∂b`` from `vojax.order_sensitivity`. ``F⁻¹``
is the Cramér–Rao bound: no unbiased estimator of these quantities from such a test does
better, and a least-squares fit (`vojax.refit`) reaches it for small noise.

With ``order_drift=q`` the order is instead free at every sample under the tracker's prior:
its logistic coordinate ``β`` (``α = lo + (hi − lo)·sigmoid(β)``) a random walk whose change
over the whole test has variance q, starting from a spread of `PRIOR_BETA_VAR`; the
parameters and the offset constant, with flat priors. The prior's precision, carried to the
order's units at the hypothesised trajectory (``dβ = dα / α'(β)``), is added to ``F``, and
``(F + Λ)⁻¹`` is the Bayesian (van Trees) bound: the posterior covariance of the order that
the tracker (`vojax.identify`) reports at these intensities, for small noise.
"""

import math

import equinox as eqx
import jax.numpy as jnp
import numpy as np

from . import _validate as check
from ._integral import DEFAULT_TOL, _prepare
from ._settings import TrackerSettings

# the tracker's spread of β at the first sample
PRIOR_BETA_VAR = TrackerSettings().prior_beta_var


class Undetermined(ValueError):
    """The planned test does not determine a quantity (its information is singular): a
    `ValueError` about the plan, not about an argument (`settling_test` tries the next)."""


# `pad_to` runs the model on at most twice the samples, or on this many (a padding that
# shares a program among short plans, not one that costs more than the plan)
MAX_PAD_FLOOR = 1024

# the prior of `order_drift` puts the order at every sample: its covariance is dense (N, N)
MAX_DRIFT_SAMPLES = 5000

# the parameters' hat functions of the design `TrackerSettings.protocol_factor` was
# calibrated on (`Design.expected`): the tracker's band is that factor × this design's bound
PROTOCOL_KNOTS = 8


class Design:
    """What a planned test can tell, before it is run (`fisher_information`).

    - `names`: the quantities, ``order`` (or ``order_knot_1`` … ``order_knot_K``, or with
      ``order_drift`` ``order_at_1`` … ``order_at_N``), ``p_1`` … ``p_n``, ``x0`` (when
      estimated);
    - `information` (P, P), `covariance` (P, P) = its inverse, `stderr` (P,): the best
      standard errors any unbiased estimator can reach;
    - `times` (N,), `order` (N,): the hypothesised order; `order_stderr` (N,): the predicted
      standard error of the order at each sample; `knot_times` (K,);
    - `expected`: the ±2σ half-width `vojax.identify`'s default tracker is expected to give
      on this test, `order_band` × `TrackerSettings.protocol_factor` (the tracker's band also
      covers parameters drifting faster than the design's hat functions can follow). Set
      for the design the factor was calibrated on (one order shift, ``knots=1``; the offset
      estimated; the parameters free on ``parameter_knots=8``; no ``order_drift``), else None.
    """

    def __init__(self, names, information, covariance, times, order, order_stderr, knot_times):
        self.names = tuple(names)
        self.information = information
        self.covariance = covariance
        self.stderr = np.sqrt(np.maximum(np.diag(covariance), 0.0))
        self.times = times
        self.order = order
        self.order_stderr = order_stderr
        self.knot_times = knot_times
        self.expected = None  # set by `fisher_information` where the factor applies

    @property
    def order_band(self) -> float:
        """The predicted ±2σ half-width of the order, median over the second half of the
        test (where `vojax.identify`'s diagnostics measure its band)."""
        return float(2.0 * np.median(self.order_stderr[self.order_stderr.size // 2 :]))

    def summary(self) -> str:
        """The quantities with their predicted standard errors, one per line."""
        lines = [f"{'quantity':<16}{'± 1 SE (best possible)':>24}"]
        lines += [f"{n:<16}{s:>24.4g}" for n, s in zip(self.names, self.stderr)
                  if not n.startswith("order_at_")]  # an order at every sample: its band
        lines.append(f"{'order band ±2σ':<16}{self.order_band:>24.4g}")
        if self.expected is not None:
            lines.append(f"{'tracker ±2σ':<16}{self.expected:>24.4g}  (expected)")
        return "\n".join(lines)

    def __repr__(self):
        tracker = "" if self.expected is None else f", tracker ±{self.expected:.3g} expected"
        return (f"Design(order band ±{self.order_band:.3g}{tracker}, "
                f"{len(self.names)} quantities)")


def _hats(times, knots):
    """(N, K) hat functions on `knots` knots spread evenly over the times (K = 1: ones)."""
    if knots == 1:
        return np.ones((times.size, 1)), np.array([times[0]])
    places = np.linspace(times[0], times[-1], knots)
    return np.stack([np.interp(times, places, np.eye(knots)[k]) for k in range(knots)], 1), places


def fisher_information(
    u,
    order,
    p,
    dt=None,
    *,
    t=None,
    noise_std,
    knots: int = 1,
    x0: bool = True,
    rule: str = "trapezoid",
    memory: str = "direct",
    order_range=(0.01, 0.99),
    order_drift: float | None = None,
    parameter_knots: int | None = None,
    pad_to: int | None = None,
) -> Design:
    """The Fisher information of a planned test of ``D^{α(t)} x = pᵀu`` (a `Design`).

    - `u` (N,) or (N, n): the planned inputs, at ``t_k = k·dt`` or at the times `t`;
    - `order`: the hypothesised order, a number or a trajectory (N,); `p` (n,): the
      hypothesised parameters; `noise_std`: the measurement noise's standard deviation, in
      the output's units;
    - `knots`: the order's free shape, 1 (a constant order: one number) or K ≥ 2 hat
      functions spread evenly over the test (a variable order, as K values);
    - `x0`: the output's offset estimated too (True) or known (False);
    - `order_drift`: instead of knots, the order free at every sample under the tracker's
      random-walk prior of this intensity (the variance of its logistic coordinate's change
      over the test, as `vojax.identify`'s ``noise={"order_drift": …}``), the parameters
      constant; `order_stderr` is then the tracker's predicted band at these intensities
      (at most 5,000 samples: the covariance is dense).
    - `parameter_knots`: the parameters free to drift, as a gain on the memory term (a
      stiffening tissue: ``p_j(t) = p_j + Σ_k d_jk h_k(t)`` on this many hat functions,
      K ≥ 2) instead of constant: the band the test gives whatever the parameters do
      (`names` gain ``drift_j_k``). With one slowly varying input the order is then hardly
      determined; an oscillation superposed on the load (`settling_test`) determines it,
      since a springpot's phase lag depends on its order alone. At 8 (with ``knots=1``
      and `x0`), `Design.expected` is the band the tracker is expected to give.
    - `pad_to`: run the model on the grid continued to this many samples (zero input, the
      last order and step) and keep the real samples' rows: the result is the same (the
      memory is causal; with the exponential memory, to its tolerance), and plans of different lengths padded alike share one compiled
      program (the batch pads each record's `settling_test`). At most N: no padding; at
      most ``max(2N, 1024)``.

    **Raises:** `ValueError` when the test determines the quantities not at all (the
    information is singular: e.g. an input that is zero, or more knots than the test can
    tell apart), naming the least-determined one.
    """
    u2 = check.samples(u, "u")
    u2 = np.asarray(u2).reshape(u2.shape[0], -1)
    num, n = u2.shape
    p, order_drift = _check_design(p, n, num, noise_std, knots, order_drift, parameter_knots)
    check.flag(x0, "x0")
    order_range = check.interval(order_range, "order_range")
    check.order(order, num, bounds=order_range)
    order = np.broadcast_to(np.asarray(order, float), (num,)).copy()
    # the grid, the orders and the memory checked and built as `fractional_integral` does;
    # Φ and ∂Φ/∂b from one scan
    check.grid(dt, t, num)
    times = np.asarray(t, float) if t is not None else float(dt) * np.arange(num)
    u2, order_j, mem, _ = _prepare(*_padded(u2, order, dt, times if t is not None else None,
                                            _check_pad(pad_to, num)),
                                   rule, memory, DEFAULT_TOL, order_range)
    if order_drift is None:
        hats, places = _hats(times, int(knots))
        names = (["order"] if knots == 1 else [f"order_knot_{k + 1}" for k in range(knots)])
    else:
        hats, places = np.eye(num), times
        names = [f"order_at_{k + 1}" for k in range(num)]
    drift_hats = None
    if parameter_knots is not None:  # the constant part is p itself: the other hats' shifts
        drift_hats = _rows(_hats(times, int(parameter_knots))[0][:, 1:], u2.shape[0])
    jac = np.asarray(_jacobian(mem, u2, order_j, jnp.asarray(p), _rows(hats, u2.shape[0]), x0,
                               drift_hats))[:num]  # the real samples' rows
    names += [f"p_{j + 1}" for j in range(n)] + (["x0"] if x0 else [])
    if drift_hats is not None:
        names += [f"drift_{j + 1}_{k + 2}" for j in range(n)
                  for k in range(drift_hats.shape[1])]
    variance = np.float64(noise_std) ** 2
    with np.errstate(over="ignore", invalid="ignore"):  # an overflow is refused below
        information = jac.T @ jac / variance
    if order_drift is not None:
        information[:num, :num] += _drift_precision(times, order, order_range, order_drift)
    if not np.all(np.isfinite(information)):
        raise ValueError(
            f"the information overflows float64 at `noise_std` = {noise_std!r} and these "
            "inputs: express the output and the inputs in other units."
        )
    covariance = _inverse(information, names)
    k = hats.shape[1]
    order_cov = covariance[:k, :k]
    order_stderr = np.sqrt(np.maximum(np.einsum("ni,ij,nj->n", hats, order_cov, hats), 0.0))
    design = Design(names, information, covariance, times, order, order_stderr, places)
    if knots == 1 and x0 and parameter_knots == PROTOCOL_KNOTS and order_drift is None:
        design.expected = TrackerSettings().protocol_factor * design.order_band
    return design


def _check_design(p, n, num, noise_std, knots, order_drift, parameter_knots):
    """`fisher_information`'s arguments checked; returns `p` (n,) and `order_drift` (a float
    or None)."""
    p = np.atleast_1d(check.reals(p, "p"))
    if p.shape != (n,) or not np.all(np.isfinite(p)):
        raise ValueError(f"`p` must be {n} finite number(s), one per input, got {p!r}.")
    if not (isinstance(noise_std, (int, float)) and not isinstance(noise_std, bool)
            and 0 < noise_std < math.inf):
        raise ValueError(f"`noise_std` must be a positive finite number, got {noise_std!r}.")
    if isinstance(knots, bool) or not isinstance(knots, (int, np.integer)) or not 1 <= knots <= num // 2:
        raise ValueError(f"`knots` must be an integer from 1 to {num // 2}, got {knots!r}.")
    if order_drift is not None:
        order_drift = float(check.positive(order_drift, "order_drift"))
        if knots != 1:
            raise ValueError("give either `knots` or `order_drift`, not both.")
        if num > MAX_DRIFT_SAMPLES:
            raise ValueError(
                f"`order_drift` takes at most {MAX_DRIFT_SAMPLES} samples (a dense covariance "
                f"of the order at every sample), got {num}: plan on a coarser grid."
            )
    if parameter_knots is not None and (
            isinstance(parameter_knots, bool) or not isinstance(parameter_knots, (int, np.integer))
            or not 2 <= parameter_knots <= num // 2):
        raise ValueError(f"`parameter_knots` must be an integer from 2 to {num // 2}, got "
                         f"{parameter_knots!r}.")
    # in units of the noise's variance until the end, so that no noise level a float64
    # holds overflows on the way (1e-300 squared does)
    if not 1e-150 < noise_std < 1e150:
        raise ValueError(
            f"`noise_std` must lie in (1e-150, 1e150) (its square is taken), got {noise_std!r}: "
            "express the output in other units."
        )
    return p, order_drift


def _check_pad(pad_to, num):
    """`pad_to` checked: the padded length (at least `num`)."""
    if pad_to is None:
        return num
    most = max(2 * num, MAX_PAD_FLOOR)
    if (isinstance(pad_to, bool) or not isinstance(pad_to, (int, np.integer))
            or not 1 <= pad_to <= most):
        raise ValueError(f"`pad_to` must be a positive integer (the padded length) of at most "
                         f"{most} (twice the samples, or {MAX_PAD_FLOOR}) or None, got "
                         f"{pad_to!r}.")
    return max(int(pad_to), num)


def _padded(u2, order, dt, t, length):
    """The grid continued to `length` samples after its end: zero inputs, the last order, the
    last step. ``(u, order, dt, t)`` for `_prepare`."""
    extra = length - u2.shape[0]
    if extra == 0:
        return u2, order, dt, t
    u2 = np.concatenate([np.asarray(u2), np.zeros((extra, u2.shape[1]))])
    order = np.concatenate([order, np.full(extra, order[-1])])
    if t is not None:
        t = np.concatenate([t, t[-1] + (t[-1] - t[-2]) * np.arange(1, extra + 1)])
    return u2, order, dt, t


def _rows(hats, length):
    """The hat functions (N, K) with zero rows down to `length` (the padding's)."""
    return jnp.asarray(np.concatenate([hats, np.zeros((length - hats.shape[0], hats.shape[1]))]))


def _inverse(information, names):
    """The covariance, the information inverted in the columns' own scales (the units of p and
    of the order differ by orders of magnitude); a direction below 1e-12 of the largest is
    not determined by the test, and is refused naming the quantity it mostly moves."""
    scale = np.sqrt(np.diag(information))
    if np.any(scale == 0):
        zero = ", ".join(name for name, s in zip(names, scale) if s == 0)
        raise Undetermined(
            f"the planned test does not determine {zero} at all (the model does not change "
            "with them: an input that is zero throughout)."
        )
    unit = information / np.outer(scale, scale)
    values, vectors = np.linalg.eigh(unit)
    if values[0] < 1e-12 * values[-1]:
        worst = names[int(np.argmax(np.abs(vectors[:, 0])))]
        raise Undetermined(
            f"the planned test does not determine {worst} (its information is singular to "
            "1e-12): fewer knots, another input, or a longer test."
        )
    covariance = (vectors / values) @ vectors.T / np.outer(scale, scale)
    return covariance


def _drift_precision(times, order, order_range, order_drift):
    """The precision (N, N) of the tracker's random-walk prior on the order's logistic
    coordinate, in the order's units at the trajectory `order`: the change of β over each
    step has variance ``q·(t_{k+1} − t_k)/T`` (T the test's span), β at the first sample
    `PRIOR_BETA_VAR`, and ``dβ = dα / α'(β)``."""
    lo, hi = (float(v) for v in order_range)
    z = (order - lo) / (hi - lo)
    slope = (hi - lo) * z * (1.0 - z)  # dα/dβ
    step_var = order_drift * np.diff(times) / (times[-1] - times[0])
    diff = np.diff(np.eye(times.size), axis=0) / slope  # β_{k+1} − β_k in the order's units
    precision = (diff.T / step_var) @ diff
    precision[0, 0] += 1.0 / (slope[0] ** 2 * PRIOR_BETA_VAR)
    return precision


@eqx.filter_jit
def _jacobian(memory, u2, order, p, hats, x0, drift_hats=None):
    """The model's Jacobian (N, P) in JAX: the order's columns, Φ, the offset's, and with
    `drift_hats` (N, K) each parameter's drifting gain ``Φ_j h_k``."""
    from ._integral import scan_memory

    phi, dphi = scan_memory(memory, u2, order, True)
    cols = [(dphi @ p)[:, None] * hats, phi]
    if x0:
        cols.append(jnp.ones((u2.shape[0], 1), u2.dtype))
    if drift_hats is not None:
        cols.append((phi[:, :, None] * drift_hats[:, None, :]).reshape(u2.shape[0], -1))
    return jnp.concatenate(cols, axis=1)
