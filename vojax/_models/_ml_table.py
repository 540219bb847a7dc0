"""``E_{α,β}(−x)`` at many arguments for the laws' responses (`vojax._models._respond`):
tabulated once an order by Chebyshev series in ``ln x``.

The direct evaluation (`vojax._models._closed`) costs one graded quadrature, about 1,500
nodes, for each argument between its two series (``0.5 < x < 10⁴``); a response on a clock
that is not uniform needs it at every distinct lag, N²/2 of them. Between the series both
``E_α(−x)`` and ``E_{α,2}(−x)`` are smooth, bounded functions of ``u = ln x`` (their
oscillating exponential part, for α near 1, decays below 1e-16 before it turns faster than
a few radians per unit of u), so `PANELS` panels of width ``ln(2·10⁴)/PANELS`` with `NODES`
Chebyshev points each reproduce the quadrature to 1.5e-14 absolute, its own rounding
(measured over α 0.01–0.999, `tests/test_ml_table.py`). That error is relative to the
function's scale, 1, not to a value that has decayed towards 0, which is why
`vojax.mittag_leffler` itself, held to 1e-10 relative, never uses the table; a response
built on it agrees with the quadrature's to about 1e-12 of the response's scale. The table
is built at ``PANELS · NODES`` arguments and is used where more arguments than that fall
between the series.
"""

import functools
import math

import numpy as np

from ._closed import ASYMPTOTIC_LIMIT, SERIES_LIMIT, _integral, mittag_leffler_pair

PANELS = 10  # equal panels of ln x over (SERIES_LIMIT, ASYMPTOTIC_LIMIT), about one e-fold each
NODES = 24  # Chebyshev points a panel: 12 reach 5e-11, 20 and more the quadrature's rounding
LOW, HIGH = math.log(SERIES_LIMIT), math.log(ASYMPTOTIC_LIMIT)

_K = np.arange(NODES)
_POINTS = np.cos(np.pi * (_K + 0.5) / NODES)  # the Chebyshev points of the first kind
_BASIS = np.cos(np.outer(_K, np.arccos(_POINTS)))  # T_j at the points: (j, point)
_EDGES = np.linspace(LOW, HIGH, PANELS + 1)


@functools.lru_cache(maxsize=64)
def _coefficients(alpha, base):
    """The Chebyshev coefficients (PANELS, NODES) of ``E_{α,base}(−e^u)`` on each panel."""
    lo, hi = _EDGES[:-1, None], _EDGES[1:, None]
    u = 0.5 * (hi + lo) + 0.5 * (hi - lo) * _POINTS
    values = _integral(alpha, np.exp(u).ravel(), base).reshape(PANELS, NODES)
    coef = (2.0 / NODES) * values @ _BASIS.T
    coef[:, 0] *= 0.5
    coef.setflags(write=False)
    return coef


def _tabulated(alpha, x, base):
    """``E_{α,base}(−x)`` for ``x`` strictly between the series, from the table (Clenshaw)."""
    coef = _coefficients(alpha, base)
    u = np.log(x)
    width = (HIGH - LOW) / PANELS
    panel = np.clip(((u - LOW) / width).astype(np.intp), 0, PANELS - 1)
    s = 2.0 * (u - _EDGES[panel]) / width - 1.0
    c = coef[panel]
    b1, b2 = np.zeros_like(u), np.zeros_like(u)
    for j in range(NODES - 1, 0, -1):
        b1, b2 = 2.0 * s * b1 - b2 + c[:, j], b1
    return s * b1 - b2 + c[:, 0]


def pair(alpha, x, base):
    """``(E_{α,base}(−x), E_{α,base+α}(−x))`` as `mittag_leffler_pair`, with the arguments
    between the series taken from the table where there are more of them than it costs."""
    x = np.asarray(x, dtype=float)
    middle = (x > SERIES_LIMIT) & (x < ASYMPTOTIC_LIMIT)
    if alpha == 1.0 or np.count_nonzero(middle) <= PANELS * NODES:
        return mittag_leffler_pair(alpha, x, base)
    plain, shifted = np.empty_like(x), np.empty_like(x)
    plain[~middle], shifted[~middle] = mittag_leffler_pair(alpha, x[~middle], base)
    xm = x[middle]
    plain[middle] = _tabulated(float(alpha), xm, float(base))
    shifted[middle] = (1.0 / math.gamma(base) - plain[middle]) / xm
    return plain, shifted
