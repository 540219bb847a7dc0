"""`vojax.compare`'s first call on a real record, in a fresh process: the rheometer creep
(../shared/data/rheometer-creep-hermes, 483 log-spaced samples) with its first 0.5 s of
inertial ringing left out of the fit (`window=(0.5, None)`), every model (the variable order
and the four constant-order laws). Each case runs in its own process: the compilation cache
empty (cold) and then warm, with XLA's default loops and with `vojax.use_fast_cpu_loops()`
(what the `vojax` command uses). Times are wall-clock seconds; the second call in the same
process is the warm cost without compilation.

    python scripts/bench_compare_first_call.py [--data ../shared/data] [--repeats 3] [--out FILE]
"""

import argparse
import statistics
import tempfile

from _bench import fresh_process, publish

CHILD = r"""
import json, sys, time
started = time.perf_counter()
import jax
jax.config.update("jax_enable_x64", True)
import vojax
if sys.argv[2] == "fast":
    vojax.use_fast_cpu_loops()
vojax.use_compilation_cache(sys.argv[3])
imported = time.perf_counter()
rec, = vojax.load_records(sys.argv[1] + "/rheometer-creep-hermes/creep_experiment.csv",
                          time="time_s", inputs=["stress_Pa"], output="strain")
begun = time.perf_counter()
first = vojax.compare(rec, window=(0.5, None))
done = time.perf_counter()
second = vojax.compare(rec, window=(0.5, None))
again = time.perf_counter()
print(json.dumps(dict(imported=imported - started, first=done - begun, second=again - done,
                      ranking=[r["model"] for r in first.rows])))
"""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", default="../shared/data")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--out")
    args = parser.parse_args()
    results = {}
    for _ in range(args.repeats):
        for loops in ("default", "fast"):
            with tempfile.TemporaryDirectory() as cache:
                for state in ("cold", "warm"):
                    out = fresh_process(CHILD, args.data, loops, cache)
                    results.setdefault((loops, state), []).append(out)
    lines = ["# vojax.compare on the rheometer creep, window (0.5 s, end), every model; "
             f"median (min–max) of {args.repeats} fresh processes, seconds", "",
             "| loops | compilation cache | import | first call | second call | ranking |",
             "|---|---|---|---|---|---|"]

    def cell(values):
        return f"{statistics.median(values):.2f} ({min(values):.2f}–{max(values):.2f})"

    for (loops, state), runs in results.items():
        rankings = {" > ".join(r["ranking"]) for r in runs}
        lines.append(f"| {loops} | {state} | {cell([r['imported'] for r in runs])} | "
                     f"{cell([r['first'] for r in runs])} | {cell([r['second'] for r in runs])} "
                     f"| {' / '.join(sorted(rankings))} |")
    publish(lines, args.out)


if __name__ == "__main__":
    main()
