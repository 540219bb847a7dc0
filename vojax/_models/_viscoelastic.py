"""The springpot and the fractional Kelvin–Voigt law as regressions of eq. (11)."""

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


class AbstractViscoelasticModel(eqx.Module):
    """A constitutive law ``σ ↔ ε`` written as ``D^{q} ε = pᵀ u`` (output ``x = ε``)."""

    names: eqx.AbstractClassVar[tuple[str, ...]]

    @abc.abstractmethod
    def inputs(self, stress, strain):
        """The regressors ``u`` (N, n) of eq. (11) built from the stress and the strain."""

    @abc.abstractmethod
    def parameters(self, p) -> dict:
        """The physical parameters (in the user's units) from ``p`` (…, n)."""

    @abc.abstractmethod
    def regression(self, **physical):
        """``p`` from the physical parameters; the inverse of `parameters`."""

    def parameters_stderr(self, p, cov) -> dict:
        """Standard errors of the physical parameters at ``p`` (n,) given the covariance
        ``cov`` (n, n) of ``p`` (e.g. `Refit.p_cov`), by the delta method."""
        from .._stats import delta_stderr

        return delta_stderr(self.parameters, p, cov)


class Springpot(AbstractViscoelasticModel):
    """``σ = η D^{q(t)} ε``: ``u = σ``, ``p = 1/η`` (section 6 of the paper)."""

    names = ("eta",)

    def inputs(self, stress, strain=None):
        return np.asarray(check.samples(stress, "stress")).reshape(-1, 1)  # host side

    def parameters(self, p):
        p = _array(p)
        with np.errstate(divide="ignore", invalid="ignore"):  # p̂ = 0 at the first sample
            return {"eta": 1.0 / p[..., 0]}

    def regression(self, *, eta):
        return jnp.array([1.0 / eta])


class KelvinVoigt(AbstractViscoelasticModel):
    """``σ = k ε + η D^{q(t)} ε``: ``u = [σ, ε]``, ``p = [1/η, −k/η]`` (docs/method.md §6)."""

    names = ("eta", "k")

    def inputs(self, stress, strain):
        stress = check.samples(stress, "stress")
        strain = check.samples(strain, "strain")
        if stress.shape != strain.shape or stress.ndim != 1:
            raise ValueError(
                f"`stress` and `strain` must both have shape (N,), got {stress.shape} and {strain.shape}."
            )
        return np.stack([np.asarray(stress), np.asarray(strain)], axis=1)  # host side

    def parameters(self, p):
        p = _array(p)
        with np.errstate(divide="ignore", invalid="ignore"):  # p̂ = 0 at the first sample
            eta = 1.0 / p[..., 0]
            return {"eta": eta, "k": -p[..., 1] * eta}

    def regression(self, *, eta, k):
        return jnp.array([1.0 / eta, -k / eta])
