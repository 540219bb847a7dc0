"""`vojax._linalg`: the small SPD solve the filter, the smoother and LSFF's step share."""

import jax.numpy as jnp
import numpy as np


def test_small_spd_solve_equals_lapack():
    """`cholesky_solve` (unrolled inside the filter and smoother scans and LSFF's step, LAPACK
    beyond 6 unknowns) against NumPy's LU solve, for d = 1…8, right-hand sides (d,) and (d, d),
    conditioning up to 1e8."""
    from vojax._linalg import cholesky_solve as solve_spd

    rng = np.random.default_rng(11)
    for d in range(1, 9):
        for cond in (1.0, 1e4, 1e8):
            q, _ = np.linalg.qr(rng.standard_normal((d, d)))
            a = q @ np.diag(np.geomspace(1.0, 1.0 / cond, d)) @ q.T
            a = 0.5 * (a + a.T)
            for b in (rng.standard_normal(d), rng.standard_normal((d, d))):
                want = np.linalg.solve(a, b)
                got = np.asarray(solve_spd(jnp.asarray(a), jnp.asarray(b)))
                assert got.shape == want.shape
                np.testing.assert_allclose(got, want, rtol=0, atol=1e-13 * cond * np.max(np.abs(want)))
