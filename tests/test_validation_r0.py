"""One rule for `R_0`, the law's initial information matrix, wherever it is taken."""

import numpy as np
import pytest

import vojax

# (n, n) matrices that are not symmetric positive definite: the upper triangle differs (the
# lower one alone, which an eigenvalue routine for symmetric matrices reads, is definite),
# indefinite, a NaN, the wrong shape
BAD_R0 = [
    ([[1.0, 0.5], [0.0, 1.0]], "`r0` must be symmetric"),
    ([[1.0, 0.0], [0.9, 1.0]], "`r0` must be symmetric"),
    ([[1.0, 2.0], [2.0, 1.0]], "`r0` must be symmetric positive definite"),
    ([[1.0, np.nan], [np.nan, 1.0]], "`r0` must be finite"),
    (np.eye(3), r"`r0` must have shape \(2, 2\)"),
]


@pytest.mark.parametrize("r0, words", BAD_R0)
@pytest.mark.parametrize("where", ["identify", "tune_gains", "reference", "testing"])
def test_one_rule_for_r0_wherever_it_is_taken(where, r0, words):
    """`R_0` (the law's initial information matrix) is refused by one rule in the law, its
    tuning, the NumPy reference and the CI's cross-check: before, the law read only the
    lower triangle of a matrix that is not symmetric and ran (its order then depended on
    the upper triangle it did not check), and the cross-check computed its autodiff side
    before the reference refused the matrix."""
    t = 0.1 * np.arange(40)
    u = np.column_stack([np.minimum(t, 1.0) + 0.1, 1.0 + 0.5 * np.sin(t)])
    y = np.asarray(vojax.simulate(u, 0.4, np.array([1.0, 0.5]), 0.1))
    calls = {
        "identify": lambda: vojax.identify(u, y, 0.1, gamma=0.01, method="gradient", r0=r0),
        "tune_gains": lambda: vojax.tune_gains(u, y, 0.1, r0=r0),
        "reference": lambda: vojax.reference.lsff(u, y, 0.1, 0.9, r0=r0),
        "testing": lambda: vojax.testing.check_parameter_sensitivity(
            u, y, 0.4, 0.1, r0=r0, raise_on_failure=False),
    }
    with pytest.raises(ValueError, match=words):
        calls[where]()


def test_a_symmetric_r0_built_by_rounding_is_taken():
    """A covariance computed as A·Aᵀ in floating point is symmetric to rounding, and a tiny
    one (entries of 1e-12) is judged relative to its own size."""
    from vojax._validate import spd_matrix

    a = np.random.default_rng(3).normal(size=(3, 3))
    for scale in (1.0, 1e-12, 1e12):
        m = (scale * a) @ a.T + scale * np.eye(3)
        np.testing.assert_array_equal(spd_matrix(m, "r0", 3), m)
    with pytest.raises(ValueError, match="`r0` must be symmetric"):
        spd_matrix(1e-12 * np.array([[1.0, 0.5], [0.0, 1.0]]), "r0", 2)
