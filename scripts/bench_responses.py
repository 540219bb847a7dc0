"""The laws' exact responses (`strain_response`, hence `fitted_strain` and the residuals
`compare` and the batch report) on four clocks, two ways in the same run:

- *direct*: the Mittag-Leffler function by its quadrature at every lag, every ramp summed
  at its own lags (the way the responses were computed before the table);
- *tabulated*: as shipped (the function tabulated once an order where many arguments need
  it, a clock's uniform part summed as a convolution).

Both give the same strain to about 1e-12 of its scale (the table's 1.5e-14, grown by the
differences of nearby ramps); the largest difference is printed. A fractional Zener (η 1, E0 0.5, E1 2, q 0.4) under a ramp to 1 in
1 s, held. Times are wall-clock seconds of one call each.

    python scripts/bench_responses.py [--out FILE]
"""

import argparse
import time

import numpy as np
from _bench import publish

import vojax
from vojax._models import _closed, _respond

LAW, PARAMS, Q = vojax.FractionalZener(), dict(eta=1.0, E0=0.5, E1=2.0), 0.4


def _clocks():
    uniform = 0.01 * np.arange(10_000)
    blocks = np.r_[-0.003, 0.05 * np.arange(1, 500)]  # block means: a first sample alone
    return {"log-spaced, 483 samples": np.r_[0.0, np.geomspace(1e-3, 100.0, 482)],
            "log-spaced, 1,000 samples": np.r_[0.0, np.geomspace(1e-3, 100.0, 999)],
            "block means, 500 samples": blocks,
            "uniform (dt), 10,000 samples": uniform}


def _run(times, direct):
    saved = _respond.pair, _respond._uniform_from
    if direct:  # the quadrature at every lag, no uniform part
        _respond.pair = _closed.mittag_leffler_pair
        _respond._uniform_from = lambda t: t.shape[0] - 1
    try:
        load = np.minimum(times - times[0], 1.0)
        uniform = np.allclose(np.diff(times), times[1] - times[0])
        grid = dict(dt=times[1] - times[0]) if uniform else dict(t=times)  # dt: N lags both ways
        start = time.perf_counter()
        out = LAW.strain_response(load, **grid, q=Q, **PARAMS)
        return time.perf_counter() - start, out
    finally:
        _respond.pair, _respond._uniform_from = saved


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=None)
    args = parser.parse_args()
    lines = ["# the laws' exact responses, direct against tabulated (one call each, seconds)", "",
             "| clock | direct | tabulated | direct / tabulated | largest difference / scale |",
             "|---|---|---|---|---|"]
    for name, times in _clocks().items():
        slow, a = _run(times, True)
        fast, b = _run(times, False)
        diff = float(np.max(np.abs(a - b)) / np.max(np.abs(a)))
        lines.append(f"| {name} | {slow:.3g} | {fast:.3g} | {slow / fast:.0f} | {diff:.1e} |")
        print(lines[-1], flush=True)
    publish(lines, args.out)


if __name__ == "__main__":
    main()
