"""Viscoelastic laws written in the form of eq. (11): D^{q(t)} x = pᵀu (docs/method.md §6)."""

from ._viscoelastic import (
    AbstractViscoelasticModel as AbstractViscoelasticModel,
)
from ._viscoelastic import (
    FractionalMaxwell as FractionalMaxwell,
)
from ._viscoelastic import (
    FractionalZener as FractionalZener,
)
from ._viscoelastic import (
    KelvinVoigt as KelvinVoigt,
)
from ._viscoelastic import (
    Springpot as Springpot,
)
from ._viscoelastic import (
    stress_strain as stress_strain,
)
