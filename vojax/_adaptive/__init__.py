"""The adaptive law of Theorem 1 as components, each an ``init``/``step`` pair (docs/method.md §3)."""

from ._law import AdaptiveLaw as AdaptiveLaw
from ._law import LawOutput as LawOutput
from ._law import LawState as LawState
from ._lsff import LSFF as LSFF
from ._lsff import LSFFState as LSFFState
from ._order import OrderGradient as OrderGradient
