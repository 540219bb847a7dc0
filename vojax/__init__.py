"""vojax: identification of variable-order fractional systems in JAX."""

import importlib.metadata

from . import reference as reference
from ._adaptive import (
    LSFF as LSFF,
    AdaptiveLaw as AdaptiveLaw,
    OrderGradient as OrderGradient,
)
from ._identify import Identification as Identification, identify as identify
from ._integral import (
    fractional_integral as fractional_integral,
    order_sensitivity as order_sensitivity,
)
from ._kernels import (
    AbstractMemory as AbstractMemory,
    DirectMemory as DirectMemory,
    ExponentialMemory as ExponentialMemory,
)
from ._simulate import simulate as simulate
from ._study import simulate_study as simulate_study, study_signals as study_signals
from ._tune import Gains as Gains, tune_gains as tune_gains

try:
    __version__ = importlib.metadata.version("vojax")
except importlib.metadata.PackageNotFoundError:  # running from a source tree
    __version__ = "0.0.0"
