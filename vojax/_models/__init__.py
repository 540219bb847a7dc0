"""Viscoelastic laws written in the form of eq. (11): D^{q(t)} x = pᵀu (NOTES §6)."""

from ._viscoelastic import (
    AbstractViscoelasticModel as AbstractViscoelasticModel,
    KelvinVoigt as KelvinVoigt,
    Springpot as Springpot,
    stress_strain as stress_strain,
)
