"""vojax: identification of variable-order fractional systems in JAX."""

import importlib.metadata

from . import reference as reference
from ._integral import (
    fractional_integral as fractional_integral,
    order_sensitivity as order_sensitivity,
)
from ._kernels import (
    AbstractMemory as AbstractMemory,
    DirectMemory as DirectMemory,
    ExponentialMemory as ExponentialMemory,
)

try:
    __version__ = importlib.metadata.version("vojax")
except importlib.metadata.PackageNotFoundError:  # running from a source tree
    __version__ = "0.0.0"
