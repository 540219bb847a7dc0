"""Stand-in explanations for the band's rules (`vojax._tracker._band`): constant orders on β
with a known variance, χ² and evidence, whose bands are closed forms."""

import numpy as np

from vojax._tracker._explanations import Explanation

N = 60
BOUNDS = (0.0, 1.0)
DOF = 50.0
FITS, FAILS = 40.0, 200.0  # χ² that passes the 2σ test at 50 dof (≤ 70), and one that fails


def ex(kind, beta, var=0.01, chi2=FITS, evidence=0.0, drift=0.0, accepted=None,
       freedom=np.nan):
    """An explanation of `kind` at the constant β `beta`, its variance `var` at every point
    (`freedom`: the effective parameters its drifts fit, unknown by default)."""
    return Explanation(kind, np.full(N, float(beta)), np.full(N, float(var)), chi2, DOF,
                       evidence, drift, accepted, None, float(freedom))


def halfwidth(band):
    """A band's half-width, its median over the second half."""
    _, lower, upper, _ = band
    return float(np.median((upper - lower)[N // 2 :]) / 2)
