"""The adaptive law of Theorem 1 as components, each an ``init``/``step`` pair (NOTES §3)."""

from ._law import AdaptiveLaw as AdaptiveLaw, LawOutput as LawOutput, LawState as LawState
from ._lsff import LSFF as LSFF, LSFFState as LSFFState
from ._order import OrderGradient as OrderGradient
