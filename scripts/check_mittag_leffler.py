"""`vojax.mittag_leffler` against `pymittagleffler` (Garrappa's algorithm, the reference the
field uses) over the orders and arguments of the laws' closed forms: E_{α,β}(−x) for
α from 0.05 to 0.99, β = 1, 2, 1 + α, 2 + α, and x from 1e-6 to 1e6 (a model's argument
(t/τ)^α over twelve decades of t/τ). Where the two differ by more than 1e-10 relative, mpmath's
power series at enough digits says which is right. Needs `pip install pymittagleffler mpmath`.

    python scripts/check_mittag_leffler.py [--out FILE]
"""

import argparse
import sys
from pathlib import Path

import numpy as np
import pymittagleffler
from _bench import publish

import vojax

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from tests.helpers import mittag_leffler_series  # noqa: E402

ALPHAS = (0.05, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 0.95, 0.99)
X = np.geomspace(1e-6, 1e6, 241)
TOLERANCE = 1e-10


def series(alpha, x, offset, plus_alpha):
    """The project's high-precision reference (the tests' `mittag_leffler_series`), or None
    where it would need more than 4,000 digits."""
    if x ** (1 / alpha) / 2.3 > 4000:
        return None
    return mittag_leffler_series(alpha, x, offset, plus_alpha)


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
        for name, offset, plus in (("1", 1, False), ("2", 2, False), ("1+α", 1, True),
                                   ("2+α", 2, True)):
            beta = offset + (alpha if plus else 0.0)
            ours = vojax.mittag_leffler(alpha, X, beta)
            ref = np.real(np.asarray(pymittagleffler.mittag_leffler(-X + 0j, alpha, beta)))
            rel = np.abs(ours - ref) / np.maximum(np.abs(ref), 1e-300)
            above = np.flatnonzero(rel > TOLERANCE)
            ours_closer = 0
            for i in above:
                exact = series(alpha, X[i], offset, plus)
                if exact is not None and abs(ours[i] - exact) <= abs(ref[i] - exact):
                    ours_closer += 1
            worst = max(worst, float(rel.max()))
            i = rel.argmax()
            exact = series(alpha, X[i], offset, plus)
            errors = (" | ".join(f"{abs(v - exact) / abs(exact):.1e}" for v in (ours[i], ref[i]))
                      if exact is not None else "– | –")
            lines.append(f"| {alpha} | {name} | {rel.max():.1e} | {X[i]:.3g} | {errors} | "
                         f"{above.size} | {ours_closer}/{above.size} |")
    lines += ["", f"largest relative difference: {worst:.1e}"]
    publish(lines, args.out)


if __name__ == "__main__":
    main()
