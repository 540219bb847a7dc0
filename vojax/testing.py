"""Gradient cross-checks for your own data and your own CI.

The order sensitivities vojax uses are forward-mode autodiff through its kernels. These
functions set them beside two computations that share no code with autodiff:

- the closed forms written by hand in NumPy (`vojax.reference`): eq. (14) for ``∂φ/∂β`` and
  the corrected eq. (26) for ``∂p/∂β`` (docs: *The paper's misprints*), on the same
  quadrature, so they agree with autodiff to rounding;
- central finite differences of the same kernels in the order, which agree to the
  truncation error of the difference (about ``step²``).

Each check returns a `GradientCheck` (a table of the comparisons) and raises
`GradientCheckError` when a comparison exceeds its tolerance (``raise_on_failure=False``
returns the failing report instead). In a test suite:

```python
import jax
import numpy as np
import vojax.testing

jax.config.update("jax_enable_x64", True)


def test_order_sensitivities_on_our_signal():
    t = np.arange(300) * 0.01
    u = np.stack([np.sin(3 * t), np.exp(-t)], axis=1)
    vojax.testing.check_gradients(u, 0.4 + 0.2 * t / t[-1], 0.01)
    y = u @ np.array([1.5, -0.5]) + 0.1 * t
    vojax.testing.check_parameter_sensitivity(u, y, 0.6, 0.01, lam=0.9)
```

The closed forms are O(N²) sums: the checks refuse records longer than `max_samples`
(default 4000); take a part of a longer record.
"""

import dataclasses
from collections.abc import Callable

import jax
import jax.numpy as jnp
import numpy as np
from jax import lax

from . import _validate as check
from . import reference
from ._adaptive import LSFF
from ._integral import fractional_integral, order_sensitivity
from ._validate import check_finite, samples

__all__ = [
    "GradientCheck",
    "GradientCheckError",
    "check_gradients",
    "check_parameter_sensitivity",
]

MAX_SAMPLES = 4000


class GradientCheckError(AssertionError):
    """A gradient cross-check exceeded its tolerance; the message is the table."""


@dataclasses.dataclass(frozen=True)
class Comparison:
    """One row: ``max |a − b|`` over all samples and inputs, relative to ``max |b|``."""

    quantity: str
    compared: str
    max_abs: float
    scale: float
    relative: float
    tolerance: float

    @property
    def passed(self) -> bool:
        return bool(np.isfinite(self.relative) and self.relative <= self.tolerance)


@dataclasses.dataclass(frozen=True)
class GradientCheck:
    """The comparisons of one check; `passed` is true when every row is within tolerance."""

    rows: tuple[Comparison, ...]
    label: str = ""

    @property
    def passed(self) -> bool:
        return all(r.passed for r in self.rows)

    def table(self) -> str:
        head = f"{'quantity':<10} {'compared':<34} {'max |diff|':>11} {'relative':>10} {'tolerance':>10}  "
        lines = [self.label] if self.label else []
        lines.append(head + "result")
        for r in self.rows:
            lines.append(
                f"{r.quantity:<10} {r.compared:<34} {r.max_abs:>11.3e} {r.relative:>10.3e} "
                f"{r.tolerance:>10.1e}  {'ok' if r.passed else 'FAILED'}"
            )
        return "\n".join(lines)

    def __str__(self) -> str:
        return self.table()


def _compare(quantity, compared, a, b, tolerance) -> Comparison:
    a, b = np.asarray(a, float), np.asarray(b, float)
    diff = float(np.max(np.abs(a - b))) if a.size else 0.0
    scale = float(np.max(np.abs(b))) if b.size else 0.0
    rel = diff / scale if scale > 0 else (0.0 if diff == 0 else float("inf"))
    if not (np.all(np.isfinite(a)) and np.all(np.isfinite(b))):
        rel = float("nan")
    return Comparison(quantity, compared, diff, scale, rel, float(tolerance))


def _options(rtol, fd_rtol, step, max_samples, raise_on_failure, closed_form):
    """The check's own settings: the tolerances and the step positive numbers, `max_samples`
    a whole number from 3, `raise_on_failure` True or False, `closed_form` None or a
    function. Returns ``(rtol, fd_rtol, step)`` as floats."""
    out = tuple(float(check.positive(v, name))
                for v, name in ((rtol, "rtol"), (fd_rtol, "fd_rtol"), (step, "step")))
    check.count(max_samples, "max_samples", 3, 10**9)
    check.flag(raise_on_failure, "raise_on_failure")
    if closed_form is not None and not callable(closed_form):
        raise TypeError(f"`closed_form` must be a function or None, got {closed_form!r}.")
    return out


def _inputs(u, order, dt, max_samples):
    u = samples(u, "u")
    check_finite(u, "u")
    num = u.shape[0]
    if num < 3:
        raise ValueError(f"`u` needs at least 3 samples, got {num}.")
    if num > max_samples:
        raise ValueError(
            f"`u` has {num} samples; the closed forms are O(N²) sums, so the check takes at "
            f"most max_samples={max_samples}: pass a part of the record (e.g. u[:{max_samples}])."
        )
    order = np.asarray(check.order(order, num))  # as `vojax.simulate` and the estimators
    return u, order, float(check.step(dt))


def _finish(report: GradientCheck, raise_on_failure: bool) -> GradientCheck:
    if raise_on_failure and not report.passed:
        raise GradientCheckError("\n" + report.table())
    return report


def check_gradients(
    u,
    order,
    dt,
    *,
    rule: str = "trapezoid",
    memory: str = "direct",
    rtol: float = 1e-8,
    fd_rtol: float = 1e-6,
    step: float = 1e-5,
    closed_form: Callable | None = None,
    max_samples: int = MAX_SAMPLES,
    raise_on_failure: bool = True,
) -> GradientCheck:
    """Checks ``∂φ/∂β`` (`vojax.order_sensitivity`, autodiff) against the closed form (14)
    and against central finite differences of `vojax.fractional_integral` in the order.

    **Arguments:**

    - `u` (N,) or (N, n), `order` (scalar or (N,), in (0, 1)), `dt`, `rule`, `memory`: as in
      `vojax.fractional_integral`.
    - `rtol`: tolerance of autodiff against the closed form, relative to the largest
      ``|∂φ/∂β|`` (default 1e-8; they agree to about 1e-13 in float64).
    - `fd_rtol`, `step`: tolerance of the central difference with order step `step`
      (default 1e-6 and 1e-5: truncation ≈ step², rounding ≈ 1e-16/step).
    - `closed_form`: a function ``(u, order, dt, *, rule, memory) → ∂φ/∂β`` to check instead
      of `vojax.reference.order_sensitivity` (e.g. your own derivation).
    - `max_samples`: refuse longer records (the closed form is an O(N²) sum).
    - `raise_on_failure`: raise `GradientCheckError` (default) or return the report.

    **Returns:** a `GradientCheck`. **Raises:** `GradientCheckError` beyond tolerance,
    `TypeError` or `ValueError` for bad input (named).
    """
    rtol, fd_rtol, step = _options(rtol, fd_rtol, step, max_samples, raise_on_failure,
                                   closed_form)
    u, order, dt = _inputs(u, order, dt, max_samples)
    kw = dict(rule=rule, memory=memory)
    closed_form = closed_form or reference.order_sensitivity
    auto = np.asarray(order_sensitivity(u, order, dt, **kw))
    closed = np.asarray(closed_form(np.asarray(u), order, dt, **kw))
    up = np.asarray(fractional_integral(u, order + step, dt, **kw))
    down = np.asarray(fractional_integral(u, order - step, dt, **kw))
    fd = (up - down) / (2 * step)
    report = GradientCheck(
        (
            _compare("dphi/dbeta", "autodiff vs closed form (14)", auto, closed, rtol),
            _compare("dphi/dbeta", "finite differences vs closed form", fd, closed, fd_rtol),
            _compare("dphi/dbeta", "finite differences vs autodiff", fd, auto, fd_rtol),
        ),
        label=f"order sensitivity, {u.shape[0]} samples, memory={memory}, rule={rule}",
    )
    return _finish(report, raise_on_failure)


def _lsff_p(phi, y, lam, dt, r0):
    lsff = LSFF(jnp.asarray(lam, phi.dtype), jnp.asarray(dt, phi.dtype), r0)

    def body(state, sample):
        return lsff.step(state, *sample)

    _, p = lax.scan(body, lsff.init(phi.shape[1]), (phi, y))
    return p


def check_parameter_sensitivity(
    u,
    y,
    order,
    dt,
    *,
    lam: float = 0.9,
    r0=None,
    rule: str = "trapezoid",
    memory: str = "direct",
    rtol: float = 1e-8,
    fd_rtol: float = 1e-6,
    step: float = 1e-5,
    closed_form: Callable | None = None,
    max_samples: int = MAX_SAMPLES,
    raise_on_failure: bool = True,
) -> GradientCheck:
    """Checks ``p`` and ``∂p/∂β`` of the least squares with forgetting (23) along a uniform
    shift of the order: the recursion against the batch sums (23), its autodiff derivative
    (what `identify` uses) against the corrected closed form (26) and against central finite
    differences.

    **Arguments:** `u` (N, n) inputs, `y` (N,) the output the law sees (``y − x0``), `order`,
    `dt`, `lam` (λ > 0), `r0` (``R_0``, symmetric positive definite; default the
    identity), `rule`, `memory`, tolerances as in `check_gradients`; `closed_form` a function
    ``(phi, dphi, y, dt, lam, r0) → ∂p/∂β`` to check instead of
    `vojax.reference.lsff_sensitivity`.

    **Returns:** a `GradientCheck`. **Raises:** `GradientCheckError` beyond tolerance,
    `TypeError` or `ValueError` for bad input (named).
    """
    rtol, fd_rtol, step = _options(rtol, fd_rtol, step, max_samples, raise_on_failure,
                                   closed_form)
    u, order, dt = _inputs(u, order, dt, max_samples)
    u2 = u[:, None] if u.ndim == 1 else u
    y = samples(y, "y")
    check_finite(y, "y")
    if y.ndim != 1 or y.shape[0] != u2.shape[0]:
        raise ValueError(f"`y` must have shape ({u2.shape[0]},) like `u`'s samples, got {y.shape}.")
    lam = float(check.positive(lam, "lam"))
    n = u2.shape[1]
    r0 = np.eye(n) if r0 is None else check.spd_matrix(r0, "r0", n)
    kw = dict(rule=rule, memory=memory)
    base = jnp.asarray(order)
    r0j = jnp.asarray(r0)

    def p_of(shift):
        phi = fractional_integral(u2, base + shift, dt, **kw)
        return _lsff_p(phi, y, lam, dt, r0j)

    p, dp_auto = jax.jvp(p_of, (jnp.zeros((), base.dtype),), (jnp.ones((), base.dtype),))
    fd = (np.asarray(p_of(step)) - np.asarray(p_of(-step))) / (2 * step)
    phi_ref = np.asarray(reference.fractional_integral(np.asarray(u2), order, dt, **kw))
    dphi_ref = np.asarray(reference.order_sensitivity(np.asarray(u2), order, dt, **kw))
    closed_form = closed_form or reference.lsff_sensitivity
    dp_closed = np.asarray(closed_form(phi_ref, dphi_ref, np.asarray(y), dt, lam, r0))
    p_batch = reference.lsff(phi_ref, np.asarray(y), dt, lam, r0)
    report = GradientCheck(
        (
            _compare("p", "recursion vs batch sums (23)", p, p_batch, rtol),
            _compare("dp/dbeta", "autodiff vs closed form (26)", dp_auto, dp_closed, rtol),
            _compare("dp/dbeta", "finite differences vs closed form", fd, dp_closed, fd_rtol),
        ),
        label=f"parameter sensitivity, {u2.shape[0]} samples, λ = {lam:g}, memory={memory}",
    )
    return _finish(report, raise_on_failure)
