"""Replays hostile arguments through vojax's Python functions and counts clean outcomes.

Each case is one public call with one argument replaced by a hostile value (None, text,
a bool, NaN, ±inf, 0, negatives, 1e±300, empty, wrong shapes and dtypes, ragged lists,
objects), the rest a small valid call. A case is clean when:

- it raises vojax's own error (`vojax.io.DataError`), `ValueError` or `TypeError` (or
  `ImportError` for a missing extra) with a message of one non-empty line that is vojax's
  own (not one of Python's or NumPy's, `LEAKS`, which name no argument); or
- it returns, and every number of what it returns (the result's arrays) is finite;
- within the time limit (no hang).

Anything else — another exception type (IndexError, KeyError, LinAlgError, OverflowError,
ZeroDivisionError, AttributeError…), a traceback-sized message, NumPy's "could not convert
string to float", a NaN in a result that
reports success, or a hang — is dirty, and listed.

    python scripts/fuzz_api.py [--limit N] [--show-dirty] [--out results.txt]
"""

import argparse
import contextlib
import io
import math
import signal
import sys
import tempfile
import time
import warnings
from pathlib import Path

import jax
import numpy as np
from _bench import leaks, publish

jax.config.update("jax_enable_x64", True)
import vojax  # noqa: E402
import vojax.io  # noqa: E402
import vojax.reference  # noqa: E402
import vojax.testing  # noqa: E402

N, DT = 40, 0.1
T = DT * np.arange(N)
U = np.minimum(T, 1.0) + 0.1
Y = np.asarray(vojax.simulate(U, 0.4, 1.0, DT)) + 1e-3 * np.sin(7 * T)
CASE_LIMIT_S = 120
# a result's answer: these attributes must be finite where a call returns
ANSWER = ("alpha", "alpha_lower", "alpha_upper", "p", "y_hat", "order", "order_lower",
          "order_upper", "x0", "order_stderr", "covariance", "information")


class _Hang(Exception):
    pass


def _arrays(good):
    """Hostile replacements for an array argument shaped like `good`."""
    good = np.asarray(good, float)
    bad = [None, "abc", "0", b"0", True, object(), [], np.array([]), good[:2], good[:-1],
           np.full_like(good, np.nan), np.full_like(good, np.inf), good.astype(complex),
           good[..., None, None], np.array(["a"] * good.shape[0]), 1e300 * good,
           1e-300 * good, np.zeros_like(good), -good, good.tolist(), [[1.0, 2.0], [3.0]]]
    one_nan = good.copy()
    one_nan.flat[good.size // 2] = np.nan
    return bad + [one_nan]


SCALARS = [None, "0", "x", b"1", True, math.nan, math.inf, -math.inf, -1.0, 0.0, 1e-300,
           1e300, [1.0], np.array([1.0, 2.0]), 1 + 1j, object(), 2**63]
TEXTS = [None, "", "unknown", 3, ["a"], b"x", "constant "]
PAIRS = [None, (0.9, 0.1), (math.nan, 0.5), (0.0, 1.0), (-1.0, 2.0), "ab", (0.1,), 5,
         (0.1, 0.2, 0.3), (math.inf, 1.0)]
COUNTS = [None, -1, 0, 1, 2.5, True, "3", 10**9, math.nan]


def _calls():
    """``(name, thunk)`` for every case."""
    cases = []

    def vary(name, fn, base, hostile):
        for key, values in hostile.items():
            for k, value in enumerate(values):
                kwargs = dict(base, **{key: value})
                cases.append((f"{name}({key}=#{k})", lambda fn=fn, kw=kwargs: fn(**kw), key))

    two = np.column_stack([U, np.cos(T)])
    vary("simulate", vojax.simulate, dict(u=U, order=0.4, p=1.0, dt=DT),
         dict(u=_arrays(U), order=SCALARS + _arrays(U), p=SCALARS, dt=SCALARS,
              x0=SCALARS, rule=TEXTS, memory=TEXTS))
    vary("fractional_integral", vojax.fractional_integral, dict(u=U, order=0.4, dt=DT),
         dict(u=_arrays(U), order=SCALARS, dt=SCALARS, t=_arrays(T), rule=TEXTS))
    vary("order_sensitivity", vojax.order_sensitivity, dict(u=U, order=0.4, dt=DT),
         dict(u=_arrays(U), order=SCALARS, dt=SCALARS))
    law = dict(u=U, y=Y, dt=DT, method="gradient", gamma=0.5, warn=False)
    vary("identify[law]", vojax.identify, law,
         dict(y=_arrays(Y), gamma=SCALARS, lam=SCALARS, alpha0=SCALARS,
              alpha_bounds=PAIRS, x0=SCALARS, r0=SCALARS, method=TEXTS))
    vary("LawEstimator", lambda **kw: vojax.LawEstimator(**kw).fit(U, Y, DT, warn=False),
         dict(gamma=0.5),
         dict(gamma=SCALARS + TEXTS, lam=SCALARS + TEXTS, alpha0=SCALARS, alpha_bounds=PAIRS,
              memory=TEXTS, rule=TEXTS, x0=SCALARS, r0=SCALARS + TEXTS, tol=SCALARS))
    vary("LawEstimator.fit", lambda **kw: vojax.LawEstimator(gamma=0.5).fit(**kw),
         dict(u=U, y=Y, dt=DT, warn=False),
         dict(u=_arrays(U), y=_arrays(Y), dt=SCALARS, t=_arrays(T)))
    vary("Tracker", lambda **kw: vojax.Tracker(**kw), {},
         dict(parameters=TEXTS + SCALARS, x0=SCALARS, alpha_bounds=PAIRS, memory=TEXTS,
              rule=TEXTS, max_points=COUNTS, tol=SCALARS, time_scale=SCALARS,
              noise=[None, {}, {"order_drift": 1.0}, 5, "x"], settings=TEXTS))
    tracker = dict(u=U, y=Y, dt=DT, warn=False)
    vary("identify[tracker]", vojax.identify, tracker,
         dict(u=_arrays(U), dt=SCALARS, t=_arrays(T), x0=SCALARS[:8],
              parameters=TEXTS + [-1.0, math.nan], time_scale=SCALARS[:10],
              max_points=COUNTS, mask=_arrays(U)[:12], window=PAIRS + [(None, 1.0), (2.0, 2.05)]))
    vary("refit", vojax.refit, dict(u=U, y=Y, dt=DT, warn=False),
         dict(u=_arrays(U), y=_arrays(Y), order=TEXTS + COUNTS, order_bounds=PAIRS,
              order0=SCALARS, x0=SCALARS, window=PAIRS, weights=_arrays(U)[:12],
              origin=SCALARS, p_signs=TEXTS, max_steps=COUNTS))
    vary("compare", vojax.compare,
         dict(stress=U, strain=Y, dt=DT, models=("springpot",)),
         dict(stress=_arrays(U), strain=_arrays(Y), models=TEXTS + [("springpot", "x")],
              knots=COUNTS, holdout=SCALARS, max_points=COUNTS, window=PAIRS,
              x0=SCALARS + TEXTS, origin=SCALARS, relative=[None, "yes", 1, math.nan]))
    vary("fisher_information", vojax.fisher_information,
         dict(u=U, order=0.4, p=[1.0], dt=DT, noise_std=0.01),
         dict(u=_arrays(U), order=SCALARS, p=SCALARS, noise_std=SCALARS, knots=COUNTS,
              order_range=PAIRS, order_drift=SCALARS, parameter_knots=COUNTS, pad_to=COUNTS))
    vary("settling_test", vojax.settling_test,
         dict(u=U, order=0.4, p=[1.0], dt=DT, noise_std=0.01, cycles=(4,), starts=(0.0,)),
         dict(amplitude=SCALARS, cycles=[None, (), (0,), (-1,), ("a",), (1e9,), 5],
              starts=[None, (), (1.5,), (-0.1,), (math.nan,), 0.2],
              parameter_knots=COUNTS, noise_std=SCALARS, pad_to=COUNTS, band_now=SCALARS))
    settling = vojax.settling_test(U, 0.4, [1.0], DT, noise_std=0.01, cycles=(4,), starts=(0.0,))
    vary("SettlingTest.expect", lambda **kw: settling.expect(**kw), dict(band_now=0.2),
         dict(band_now=SCALARS, exponent=SCALARS))
    vary("settling_test[chirp]", vojax.settling_test,
         dict(u=U, order=0.4, p=[1.0], dt=DT, noise_std=0.01, cycles=(2, 8), starts=(0.0,),
              chirp=True),
         dict(chirp=[None, "yes", 1, 0.0, math.nan],
              cycles=[None, (), (4,), (8, 2), (0, 4), (2, math.inf), (2, 8, 16), ("a", 4)],
              amplitude=SCALARS, starts=[None, (), (1.5,), (math.nan,)]))

    def sine(params, t):  # a load with an oscillation of `params` = (amplitude, cycles)
        import jax.numpy as jnp
        return 1.0 + params[0] * jnp.sin(2 * jnp.pi * params[1] * t / (N * DT))

    protocol = dict(protocol=sine, start=np.array([0.1, 3.0]), lower=np.array([0.0, 0.5]),
                    upper=np.array([0.3, 10.0]), order=0.4, p=[1.0], dt=DT, noise_std=0.01,
                    num_samples=N, max_steps=5)
    vary("optimal_protocol", vojax.optimal_protocol, protocol,
         dict(protocol=[None, 3, "x", lambda params, t: t[:2], lambda params, t: t * np.nan,
                        lambda params, t: np.ones((N, 2))],
              start=_arrays(np.array([0.1, 3.0])) + [np.array([[0.1, 3.0], [0.2]], object),
                                                       np.array([[0.1, 3.0], [0.4, 3.0]])],
              lower=_arrays(np.array([0.0, 0.5])), upper=_arrays(np.array([0.3, 10.0])),
              order=SCALARS, p=SCALARS, dt=SCALARS, noise_std=SCALARS, knots=COUNTS,
              num_samples=COUNTS, criterion=TEXTS + ["D", "A"], x0=SCALARS[:6],
              parameter_knots=COUNTS, max_steps=COUNTS, order_range=PAIRS))
    vary("TrackerSettings", lambda **kw: vojax.TrackerSettings(**kw), {},
         {name: SCALARS + TEXTS[:3] for name in (
             "max_iter", "noise_min", "order_drift_range", "level_ratios", "level_step",
             "level_weights", "band_scale", "identified_halfwidth", "run_threads",
             "schedule", "trade_knots", "held_order_drift")})
    vary("tune_gains", vojax.tune_gains, dict(u=U, y=Y, dt=DT),
         dict(y=_arrays(Y), alpha0=SCALARS, alpha_bounds=PAIRS, lam=SCALARS,
              burn_in=SCALARS, lag=SCALARS, num_gamma=COUNTS))
    vary("simulate_study", vojax.simulate_study, dict(dt=0.05),
         dict(dt=SCALARS, seed=COUNTS + ["a"], noise_std=SCALARS))

    kv = vojax.KelvinVoigt()
    law_params = dict(q=0.4, eta=2.0, k=3.0)
    # a strain from 0 (a jump of strain is an infinite stress in this law, by design)
    for method, name, load in (("strain_response", "stress", U), ("stress_response", "strain", T)):
        vary(f"KelvinVoigt.{method}", getattr(kv, method), dict(law_params, **{name: load, "dt": DT}),
             {name: _arrays(load), "dt": SCALARS, "t": _arrays(T), "q": SCALARS, "eta": SCALARS,
              "k": SCALARS})
    kv_fit = vojax.refit(kv.inputs(U, T), T, DT, p_signs=kv.p_signs, warn=False)
    vary("KelvinVoigt.fitted_strain", kv.fitted_strain, dict(fit=kv_fit, stress=U, dt=DT),
         dict(fit=[None, 3, "x", vojax.refit(two, T, DT, warn=False)],
              stress=_arrays(U), dt=SCALARS, t=_arrays(T), origin=SCALARS + TEXTS))
    vary("KelvinVoigt.creep_compliance", kv.creep_compliance, dict(law_params, t=T[1:]),
         dict(t=_arrays(T[1:]), q=SCALARS, eta=SCALARS))
    for model, values in ((vojax.Springpot(), dict(eta=2.0)),
                          (vojax.FractionalMaxwell(), dict(eta=2.0, E=5.0)),
                          (vojax.FractionalZener(), dict(eta=2.0, E0=1.0, E1=5.0))):
        label = type(model).__name__
        hostile = dict(q=SCALARS, **{k: SCALARS for k in values})
        vary(f"{label}.strain_response", model.strain_response,
             dict(values, stress=U, dt=DT, q=0.4), dict(hostile, stress=_arrays(U), dt=SCALARS))
        for method, axis in (("complex_modulus", "omega"), ("relaxation_modulus", "t"),
                             ("creep_compliance", "t")):
            vary(f"{label}.{method}", getattr(model, method), dict(values, q=0.4, **{axis: T[1:]}),
                 dict(hostile, **{axis: _arrays(T[1:])}))
    checks = dict(u=U, order=0.4, dt=DT, raise_on_failure=False)
    vary("testing.check_gradients", vojax.testing.check_gradients, checks,
         dict(u=_arrays(U), order=SCALARS, dt=SCALARS, rtol=SCALARS, fd_rtol=SCALARS,
              step=SCALARS, max_samples=COUNTS, rule=TEXTS, memory=TEXTS,
              raise_on_failure=SCALARS[:6], closed_form=[3, "x"]))
    vary("testing.check_parameter_sensitivity", vojax.testing.check_parameter_sensitivity,
         dict(checks, y=Y), dict(y=_arrays(Y), lam=SCALARS, r0=SCALARS, step=SCALARS,
                                 max_samples=COUNTS))
    for name in ("fractional_integral", "order_sensitivity"):
        vary(f"reference.{name}", getattr(vojax.reference, name), dict(u=U, order=0.4, dt=DT),
             dict(u=_arrays(U), order=SCALARS, dt=SCALARS, tol=SCALARS, order_range=PAIRS,
                  rule=TEXTS, memory=TEXTS))
    phi = U[:, None]
    vary("reference.lsff", vojax.reference.lsff, dict(phi=phi, y=Y, dt=DT, lam=0.9),
         dict(phi=_arrays(phi), y=_arrays(Y), dt=SCALARS, lam=SCALARS, r0=SCALARS))
    vary("reference.lsff_sensitivity", vojax.reference.lsff_sensitivity,
         dict(phi=phi, dphi=0.1 * phi, y=Y, dt=DT, lam=0.9),
         dict(dphi=_arrays(phi), y=_arrays(Y), lam=SCALARS, printed=SCALARS[:6]))
    vary("refit_lbfgsb", vojax.refit_lbfgsb, dict(u=U, y=Y, dt=DT, max_steps=30),
         dict(u=_arrays(U), y=_arrays(Y), dt=SCALARS, order=TEXTS + COUNTS, order_bounds=PAIRS,
              order0=SCALARS, x0=SCALARS, memory=TEXTS, max_steps=COUNTS, tol=SCALARS))
    vary("stress_strain", vojax.stress_strain, dict(force=U, displacement=T, area=2.0, length=3.0),
         dict(force=_arrays(U), displacement=_arrays(T), area=SCALARS, length=SCALARS))
    vary("study_signals", vojax.study_signals, dict(duration=5.0),
         dict(dt=SCALARS, duration=SCALARS))
    vary("mittag_leffler", vojax.mittag_leffler, dict(alpha=0.4, x=T, beta=1.0),
         dict(alpha=SCALARS, x=_arrays(T), beta=SCALARS + [2.0, 1.4, 2.4, 1.5]))
    vary("mittag_leffler_jax", vojax.mittag_leffler_jax, dict(alpha=0.4, x=T, beta=1),
         dict(alpha=SCALARS, x=_arrays(T), beta=SCALARS + [2, 1.4, 3]))

    # methods of the results
    fit = vojax.refit(two, np.asarray(vojax.simulate(two, 0.4, [1.0, 0.5], DT)), DT, warn=False)
    res = vojax.identify(two, np.asarray(vojax.simulate(two, 0.4, [1.0, 0.5], DT)), DT,
                         method="gradient", gamma=0.5, warn=False)
    comparison = vojax.compare(U, Y, DT, models=("springpot", "maxwell"))
    names = [None, "a", ["a"], ["a", "b", "c"], ["a", "a"], [1, 2], [None, "b"], 5, ["", "b"]]
    for obj, label in ((fit, "Refit"), (res, "Identification")):
        vary(f"{label}.summary", lambda obj=obj, **kw: obj.summary(**kw), {}, dict(names=names))
        vary(f"{label}.to_dataframe", lambda obj=obj, **kw: obj.to_dataframe(**kw), {},
             dict(t=_arrays(T)[:12]))
        vary(f"{label}.plot", lambda obj=obj, **kw: _closed(obj.plot(**kw)), {},
             dict(t=_arrays(T)[:12]))
    vary("Identification.to_dataframe[names]", lambda **kw: res.to_dataframe(**kw), {},
         dict(names=names))
    vary("Comparison.bayes_factor", lambda **kw: comparison.bayes_factor(**kw),
         dict(a="springpot", b="maxwell"), dict(a=TEXTS + ["zener"], b=TEXTS))

    # files
    tmp = Path(tempfile.mkdtemp(prefix="vojax-fuzz-api-"))
    good = tmp / "r.csv"
    good.write_text("time_s,stress,strain\n" + "".join(
        f"{a!r},{b!r},{c!r}\n" for a, b, c in zip(T.tolist(), U.tolist(), Y.tolist())))
    vary("load_records", vojax.io.load_records,
         dict(path=good, time="time_s", inputs=["stress"], output="strain"),
         dict(path=[None, 3, tmp / "missing.csv", tmp, "", b"r.csv"],
              time=TEXTS + ["stress"], inputs=TEXTS + [[], ["stress", "stress"], ["strain"]],
              output=TEXTS + ["time_s"], group_by=TEXTS, resample=SCALARS,
              delimiter=TEXTS + [";", "\t", ",,"], decimal=TEXTS + [","],
              units=[None, 3, {"x": "s"}, {"stress": ""}, {"stress": "k" * 100}, "kPa"],
              strain_from_length=SCALARS, length_column=TEXTS + ["strain", "time_s"],
              area_column=TEXTS + ["stress"],
              segments=[None, 3, [0], ["a"], "0"], tip=[None, "sphere", ("sphere",),
                                                        ("cube", 1.0)],
              contact=TEXTS + ["fit", "frechet_direct_path"], spring_constant=SCALARS))
    vary("write_results", vojax.write_results,
         dict(folder=tmp / "written", columns={"a": U}, summary={"x": 1.0}),
         dict(folder=[None, 3, "", b"x", True, good],
              columns=[None, {}, [U], {1: U}, {"a": U, "b": U[:-1]}]
              + [{"a": bad} for bad in _arrays(U)],
              summary=[None, 3, [("x", 1.0)], {"k": object()}, {1: 2, "b": 3}, {"k": math.nan}],
              record=[None, 3, "x", object()], figure_format=TEXTS))
    jpk = Path(__file__).resolve().parents[1] / "tests" / "data" / "afm" / "brain_creep.jpk-force"
    vary("load_records(AFM)", vojax.io.load_records,
         dict(path=jpk, time="time_s", inputs=["force_rise_N"], output="indentation_m"),
         dict(contact=TEXTS + ["fit", "gradient_zero_crossing", 3],
              tip=[("sphere", 5e-6), ("pyramid", 89.99), ("pyramid", 0.0), ("cone", "20"),
                   "pyramid:35", ("sphere", math.inf)],
              poisson=SCALARS + [-0.999, 0.5, 0.0], spring_constant=SCALARS + [0.061],
              segments=[[9], [2], ["0"], [0.5]], from_contact=[0, "yes", None],
              output=["contact_strain", "force_rise_N"]))
    return cases


def _closed(ax):
    import matplotlib.pyplot as plt

    plt.close(ax.figure)
    return None


def _numbers(value, depth=0):
    """Every float array reachable in a result (its arrays and its public attributes)."""
    if depth > 2 or value is None:
        return
    if isinstance(value, (float, np.floating)):
        yield np.asarray(value)
    elif isinstance(value, (np.ndarray, jax.Array)):
        if np.issubdtype(np.asarray(value).dtype, np.inexact):
            yield np.asarray(value)
    elif isinstance(value, (tuple, list)):
        for v in value:
            yield from _numbers(v, depth + 1)
    elif isinstance(value, dict):
        for v in value.values():
            yield from _numbers(v, depth + 1)
    elif hasattr(value, "rows") and hasattr(value, "verdict"):  # a Comparison
        for row in value.rows:
            yield from _numbers({k: v for k, v in row.items() if k != "refit"}, depth + 1)
    else:  # a result object: the numbers it reports as its answer (NaN elsewhere can mean
        # "not measured", as a white noise's correlation)
        for k in ANSWER:
            v = getattr(value, k, None)
            if v is not None and not callable(v):
                yield from _numbers(v, depth + 1)


def _run(thunk):
    """``(clean, what)`` of one case."""
    from vojax.io import DataError

    def alarm(*_):
        raise _Hang()

    signal.signal(signal.SIGALRM, alarm)
    signal.alarm(CASE_LIMIT_S)
    try:
        with warnings.catch_warnings(), contextlib.redirect_stdout(io.StringIO()):
            warnings.simplefilter("ignore")
            result = thunk()
    except _Hang:
        return False, f"no answer within {CASE_LIMIT_S} s"
    except (DataError, ValueError, TypeError, ImportError) as e:
        text = str(e)
        if not text.strip() or "\n" in text.strip():
            return False, f"{type(e).__name__} not in one line: {text[:120]!r}"
        return True, f"{type(e).__name__}: {text[:300]}"
    except BaseException as e:  # noqa: BLE001 - the point: anything else is dirty
        if isinstance(e, KeyboardInterrupt):
            raise
        return False, f"{type(e).__name__}: {str(e)[:160]}"
    finally:
        signal.alarm(0)
    for arr in _numbers(result):
        if not np.all(np.isfinite(arr)):
            return False, "returned a non-finite number"
    return True, "returned"


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--limit", type=int)
    parser.add_argument("--show-dirty", action="store_true")
    parser.add_argument("--out")
    parser.add_argument("--only", help="the cases whose name starts with this")
    args = parser.parse_args()
    cases = [c for c in _calls() if not args.only or c[0].startswith(args.only)][: args.limit]
    started = time.perf_counter()
    dirty, by_function = [], {}
    for name, thunk, key in cases:
        clean, what = _run(thunk)
        if clean and leaks(what):
            clean, what = False, f"NumPy's or Python's own message, naming nothing: {what}"
        function = name.split("(")[0]
        total, ok = by_function.get(function, (0, 0))
        by_function[function] = (total + 1, ok + clean)
        if not clean:
            dirty.append((name, what))
            if args.show_dirty:
                print(f"DIRTY {name}: {what}", flush=True)
    took = time.perf_counter() - started
    lines = [f"# fuzz_api: {len(cases)} cases, {len(cases) - len(dirty)} clean, "
             f"{len(dirty)} dirty, {took:.0f} s", "",
             "| function | cases | clean |", "|---|---|---|"]
    lines += [f"| {f} | {n} | {ok} |" for f, (n, ok) in by_function.items()]
    if dirty:
        lines += ["", "| dirty case | what happened |", "|---|---|"]
        lines += [f"| {n} | {w.replace('|', '/')} |" for n, w in dirty]
    publish(lines, args.out)
    return 1 if dirty else 0


if __name__ == "__main__":
    sys.exit(main())
