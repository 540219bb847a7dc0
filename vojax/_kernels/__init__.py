"""Memory of the variable-order Riemann–Liouville integral (docs/method.md §3–4).

The order ``b`` enters only through the readout of a memory state: the state update never
depends on ``b``. That split is what makes the order sensitivity a forward-mode derivative of
the readout alone (eq. 14), and what lets the exponential memory keep order-independent modes.
"""

from ._base import RULES as RULES
from ._base import AbstractMemory as AbstractMemory
from ._direct import DirectMemory as DirectMemory
from ._direct import GridDirectMemory as GridDirectMemory
from ._exponential import ExponentialMemory as ExponentialMemory
from ._exponential import design_modes as design_modes
from ._weights import (
    end_weights as end_weights,
)
from ._weights import (
    history_weights as history_weights,
)
from ._weights import (
    log_norm as log_norm,
)
