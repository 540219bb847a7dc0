"""`vojax.mittag_leffler` against `pymittagleffler` (Garrappa's algorithm, the reference the
field uses) over the orders and arguments of the laws' closed forms: E_{α,β}(−x) for
α from 0.05 to 0.99, β = 1, 2, 1 + α, 2 + α, and x from 1e-6 to 1e6 (a model's argument
(t/τ)^α over twelve decades of t/τ). Where the two differ by more than 1e-10 relative, mpmath's
power series at enough digits says which is right. Needs `pip install pymittagleffler mpmath`.

    python scripts/check_mittag_leffler.py [--out FILE]
"""

import argparse

import numpy as np
import pymittagleffler
from _bench import publish

import vojax

ALPHAS = (0.05, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 0.95, 0.99)
X = np.geomspace(1e-6, 1e6, 241)
TOLERANCE = 1e-10


def series(alpha, x, beta, digits=60):
    """E_{α,β}(−x) by mpmath's power series with `digits` (raised until the terms' size is
    absorbed); None where that would need more than 4,000 digits."""
    import mpmath

    need = int(x ** (1 / alpha) / 2.3) + 30 if x > 1 else digits
    if need > 4000:
        return None
    with mpmath.workdps(max(digits, need)):
        xs, a, b = mpmath.mpf(float(x)), mpmath.mpf(alpha), mpmath.mpf(beta)
        total, k = mpmath.mpf(0), 0
        while True:
            term = (-xs) ** k / mpmath.gamma(a * k + b)
            total += term
            if k > 10 and abs(term) < mpmath.mpf(10) ** (-digits) * max(abs(total), 1e-300):
                break
            k += 1
        return float(total)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out")
    args = parser.parse_args()
    lines = ["# vojax.mittag_leffler against pymittagleffler, E_{α,β}(−x), x in [1e-6, 1e6] "
             f"({X.size} points per row); relative difference", "",
             "| α | β | max rel. difference | x at the max | there, vojax's error (mpmath) | "
             "pymittagleffler's | above 1e-10 | of those, vojax closer to mpmath |",
             "|---|---|---|---|---|---|---|---|"]
    worst = 0.0
    for alpha in ALPHAS:
        for name, beta in (("1", 1.0), ("2", 2.0), ("1+α", 1.0 + alpha), ("2+α", 2.0 + alpha)):
            ours = vojax.mittag_leffler(alpha, X, beta)
            ref = np.real(np.asarray(pymittagleffler.mittag_leffler(-X + 0j, alpha, beta)))
            rel = np.abs(ours - ref) / np.maximum(np.abs(ref), 1e-300)
            above = np.flatnonzero(rel > TOLERANCE)
            ours_closer = 0
            for i in above:
                exact = series(alpha, X[i], beta)
                if exact is not None and abs(ours[i] - exact) <= abs(ref[i] - exact):
                    ours_closer += 1
            worst = max(worst, float(rel.max()))
            i = rel.argmax()
            exact = series(alpha, X[i], beta)
            errors = (" | ".join(f"{abs(v - exact) / abs(exact):.1e}" for v in (ours[i], ref[i]))
                      if exact is not None else "– | –")
            lines.append(f"| {alpha} | {name} | {rel.max():.1e} | {X[i]:.3g} | {errors} | "
                         f"{above.size} | {ours_closer}/{above.size} |")
    lines += ["", f"largest relative difference: {worst:.1e}"]
    publish(lines, args.out)


if __name__ == "__main__":
    main()
