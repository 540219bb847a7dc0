"""Viscoelastic laws with a springpot as regressions of eq. (11): the springpot, the fractional
Kelvin–Voigt, Maxwell and Zener (standard linear solid) laws."""

import abc

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from .. import _validate as check


def stress_strain(force, displacement, area, length):
    """Eq. (35): ``σ = F/a`` and ``ε = d/l``, in the units of the arguments."""
    force = check.samples(force, "force")
    displacement = check.samples(displacement, "displacement")
    if force.shape != displacement.shape:
        raise ValueError(
            f"`force` and `displacement` must have the same shape, got {force.shape} and {displacement.shape}."
        )
    area = float(np.asarray(check.positive(area, "area")))
    length = float(np.asarray(check.positive(length, "length")))
    return force / area, displacement / length


def _array(p):
    """``p`` as an array of its own kind: NumPy on the host (eager JAX operations would compile
    once per record length), JAX under tracing (`parameters_stderr` differentiates it)."""
    if isinstance(p, jax.Array):
        return p
    return np.asarray(p, dtype=float)


def _stress_and_strain(stress, strain):
    """``[σ, ε]`` (N, 2) on the host, after checking both."""
    stress = check.samples(stress, "stress")
    strain = check.samples(strain, "strain")
    if stress.shape != strain.shape or stress.ndim != 1:
        raise ValueError(
            f"`stress` and `strain` must both have shape (N,), got {stress.shape} and {strain.shape}."
        )
    return np.stack([np.asarray(stress), np.asarray(strain)], axis=1)


class AbstractViscoelasticModel(eqx.Module):
    """A constitutive law ``σ ↔ ε`` written as ``D^{q} ε = pᵀ u`` (output ``x = ε``)."""

    names: eqx.AbstractClassVar[tuple[str, ...]]
    # the sign of each coefficient (of `inputs`, then of `direct`) that keeps the physical
    # parameters physical: +1 (≥ 0), −1 (≤ 0); for `refit(..., p_signs=model.p_signs)`
    p_signs: eqx.AbstractClassVar[tuple[int, ...]]

    @abc.abstractmethod
    def inputs(self, stress, strain):
        """The regressors ``u`` (N, n) of eq. (11) built from the stress and the strain."""

    def direct(self, stress, strain=None):
        """Regressors that enter without integration (order 0), ``(N, m)``, or ``None``: for
        `refit(..., direct=...)`; the adaptive law and the tracker take models without them."""
        return None

    @abc.abstractmethod
    def parameters(self, p) -> dict:
        """The physical parameters (in the user's units) from ``p`` (…, n)."""

    @abc.abstractmethod
    def regression(self, **physical):
        """``p`` from the physical parameters; the inverse of `parameters`."""

    def relaxation_modulus(self, t, *, q, **parameters):
        """``G(t)`` at the times `t` (> 0) after a unit step of strain, for the constant
        order `q` in (0, 1) and the law's physical parameters (`names`), e.g.
        ``FractionalMaxwell().relaxation_modulus(t, q=0.3, eta=2.0, E=5.0)``. Where `t`, `q`
        or a parameter is a JAX array, computed in JAX (`vojax.mittag_leffler_jax`): `jax.grad`
        and `jax.jit` go through it, for a refit of the closed form by gradient."""
        from ._closed import relaxation_modulus

        return relaxation_modulus(self, t, q, parameters)

    def creep_compliance(self, t, *, q, **parameters):
        """``J(t)`` at the times `t` (> 0) after a unit step of stress (as
        `relaxation_modulus`)."""
        from ._closed import creep_compliance

        return creep_compliance(self, t, q, parameters)

    def complex_modulus(self, omega, *, q, **parameters):
        """``G*(ω) = G′ + iG″`` at the angular frequencies `omega` (> 0) (as
        `relaxation_modulus`)."""
        from ._closed import complex_modulus

        return complex_modulus(self, omega, q, parameters)

    def coefficients(self, **physical) -> tuple[float, float, float]:
        """``(a, b, c)`` of the law written as ``ε = c σ + I^q(a σ + b ε)`` from rest, for its
        physical parameters as Python floats (the entries of `regression`, with 0 for those
        the law lacks; in double precision on the host, whatever JAX's setting)."""
        raise NotImplementedError

    def strain_response(self, stress, dt=None, *, t=None, q, **parameters):
        """The strain of the law under the `stress` history (N,) sampled every `dt` or at the
        times `t`, for the constant order `q` in (0, 1) and the physical parameters (`names`),
        from rest: exact for a stress linear between its samples (a step from 0 to its first
        value at the first sample), through the law's step and ramp responses in closed form
        (`vojax._models._respond`): at N lags on a uniform step (a convolution), at N²/2 on
        other clocks (summed in chunks; a convolution again where the clock turns uniform)."""
        from ._respond import STRESS, respond

        return respond(self, stress, dt, t, q, parameters, STRESS)

    def stress_response(self, strain, dt=None, *, t=None, q, **parameters):
        """The stress of the law under the `strain` history (as `strain_response`). A strain
        that starts away from 0 is a jump, which a law without a spring in series
        (`Springpot`, `KelvinVoigt`) meets with an infinite stress: the first value is then
        ``inf``."""
        from ._respond import STRAIN, respond

        return respond(self, strain, dt, t, q, parameters, STRAIN)

    def fitted_strain(self, fit, stress, dt=None, *, t=None, origin=None):
        """The strain the law fitted by `fit` predicts under `stress`, solved exactly.

        `fit` is a constant-order `vojax.refit` of ``inputs(stress, strain)`` (with
        ``direct=direct(stress)`` where the law has a spring in series); `stress` (N,) is
        sampled every `dt` or at the times `t`, and `origin` is the refit's (the test's start
        before the first sample, the stress held at its first value). Where the law feeds the
        strain back through its memory (Kelvin–Voigt, Zener) the refit's ``y_hat`` carries the
        measured strain inside the integral; this is the strain of the fitted law itself,
        ``ε = x0 E_q(b τ^q) + `` its response to the stress from rest (τ the time since the
        start, ``(a, b, c)`` as in `coefficients`), exact for a stress linear between its
        samples (`strain_response`), and its residual is the fit's honest error. For a
        springpot or Maxwell fit it equals ``y_hat`` up to the refit's quadrature. A
        coefficient held at 0 solves the law it leaves (Kelvin–Voigt with k = 0: a springpot);
        an unphysical fit (η ≤ 0, a negative spring) is a `ValueError`."""
        from ._fitted import fitted_strain

        return fitted_strain(self, fit, stress, dt, t, origin)

    def _law_coefficients(self, p):
        """``(a, b, c)`` of ``ε = c σ + I^q(a σ + b ε)`` from the regression's ``p``."""
        return p[0], 0.0, 0.0

    def parameters_stderr(self, p, cov) -> dict:
        """Standard errors of the physical parameters at ``p`` (n,) given the covariance
        ``cov`` (n, n) of ``p`` (e.g. `Refit.p_cov`), by the delta method."""
        from .._stats import delta_stderr

        return delta_stderr(self.parameters, p, cov)


class Springpot(AbstractViscoelasticModel):
    """``σ = η D^{q(t)} ε``: ``u = σ``, ``p = 1/η`` (section 6 of the paper)."""

    names = ("eta",)
    p_signs = (1,)

    def inputs(self, stress, strain=None):
        return np.asarray(check.samples(stress, "stress")).reshape(-1, 1)  # host side

    def parameters(self, p):
        p = _array(p)
        with np.errstate(divide="ignore", invalid="ignore"):  # p̂ = 0 at the first sample
            return {"eta": 1.0 / p[..., 0]}

    def regression(self, *, eta):
        return jnp.array([1.0 / eta])

    def coefficients(self, *, eta):
        return 1.0 / eta, 0.0, 0.0


class KelvinVoigt(AbstractViscoelasticModel):
    """``σ = k ε + η D^{q(t)} ε``: ``u = [σ, ε]``, ``p = [1/η, −k/η]`` (docs/method.md §6)."""

    names = ("eta", "k")
    p_signs = (1, -1)

    def inputs(self, stress, strain):
        return _stress_and_strain(stress, strain)

    def parameters(self, p):
        p = _array(p)
        with np.errstate(divide="ignore", invalid="ignore"):  # p̂ = 0 at the first sample
            eta = 1.0 / p[..., 0]
            return {"eta": eta, "k": -p[..., 1] * eta}

    def regression(self, *, eta, k):
        return jnp.array([1.0 / eta, -k / eta])

    def coefficients(self, *, eta, k):
        return 1.0 / eta, -k / eta, 0.0

    def _law_coefficients(self, p):
        return p[0], p[1], 0.0


class FractionalMaxwell(AbstractViscoelasticModel):
    """A spring in series with a springpot, ``ε = σ/E + I^{q(t)} σ / η``: ``u = σ`` and the
    order-0 regressor ``v = σ`` (`direct`), ``p = [1/η, 1/E]``. `refit` only (the jump of the
    spring at loading is the instantaneous compliance of a creep test)."""

    names = ("eta", "E")
    p_signs = (1, 1)

    def inputs(self, stress, strain=None):
        return np.asarray(check.samples(stress, "stress")).reshape(-1, 1)

    def direct(self, stress, strain=None):
        return self.inputs(stress)

    def parameters(self, p):
        p = _array(p)
        with np.errstate(divide="ignore", invalid="ignore"):
            return {"eta": 1.0 / p[..., 0], "E": 1.0 / p[..., 1]}

    def regression(self, *, eta, E):
        return jnp.array([1.0 / eta, 1.0 / E])

    def coefficients(self, *, eta, E):
        return 1.0 / eta, 0.0, 1.0 / E

    def _law_coefficients(self, p):
        return p[0], 0.0, p[1]


class FractionalZener(AbstractViscoelasticModel):
    """The standard linear solid with a springpot: a spring ``E0`` in parallel with a spring
    ``E1`` in series with a springpot ``(η, q)``, ``σ + (η/E1) D^q σ = E0 ε + η (E0+E1)/E1 D^q ε``.
    Integrated ``q`` times (a test starting from rest) it is
    ``ε = [E1 I^q σ − E0 E1 I^q ε]/(η (E0+E1)) + σ/(E0+E1)``: ``u = [σ, ε]``, ``v = σ``,
    ``p = [E1/(η(E0+E1)), −E0 E1/(η(E0+E1)), 1/(E0+E1)]``. `refit` only.

    `p_signs` keeps η, E0 and E0 + E1 positive; E1 > 0 is not a sign of one coefficient
    (``E1 = 1/p[2] − E0``): check it in `parameters`."""

    names = ("eta", "E0", "E1")
    p_signs = (1, -1, 1)

    def inputs(self, stress, strain):
        return _stress_and_strain(stress, strain)

    def direct(self, stress, strain=None):
        return np.asarray(check.samples(stress, "stress")).reshape(-1, 1)

    def parameters(self, p):
        p = _array(p)
        with np.errstate(divide="ignore", invalid="ignore"):
            e0 = -p[..., 1] / p[..., 0]
            total = 1.0 / p[..., 2]
            e1 = total - e0
            return {"eta": e1 / (p[..., 0] * total), "E0": e0, "E1": e1}

    def regression(self, *, eta, E0, E1):
        return jnp.array(self.coefficients(eta=eta, E0=E0, E1=E1))

    def coefficients(self, *, eta, E0, E1):
        total = E0 + E1
        return E1 / (eta * total), -E0 * E1 / (eta * total), 1.0 / total

    def _law_coefficients(self, p):
        return p[0], p[1], p[2]
