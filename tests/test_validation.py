import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import vojax

U = np.linspace(0.0, 1.0, 10)


@pytest.mark.parametrize("fn", [vojax.fractional_integral, vojax.order_sensitivity])
@pytest.mark.parametrize(
    "kwargs, exc, match",
    [
        (dict(order=1.2), ValueError, "`order` must lie in"),
        (dict(order=0.0), ValueError, "`order` must lie in"),
        (dict(order=np.full(9, 0.5)), ValueError, "`order` must be a scalar or have shape"),
        (dict(order=np.r_[np.full(9, 0.5), np.nan]), ValueError, "`order` contains NaN"),
        (dict(dt=0.0), ValueError, "`dt` must be a positive"),
        (dict(dt=np.inf), ValueError, "`dt` must be a positive"),
        (dict(dt=[0.1, 0.1]), ValueError, "`dt` must be a scalar"),
        (dict(u=np.r_[U[:-1], np.inf]), ValueError, "`u` contains NaN or inf"),
        (dict(u=np.arange(10)), TypeError, "`u` must have a real floating-point dtype"),
        (dict(u=np.zeros((10, 2, 2))), ValueError, "`u` must have shape"),
        (dict(u=np.zeros((0,))), ValueError, "`u` must hold at least one sample"),
        (dict(order=np.full(10, 1, dtype=int)), TypeError, "`order` must have a real"),
        (dict(rule="simpson"), ValueError, "`rule` must be one of"),
        (dict(memory="fft"), ValueError, "`memory` must be one of"),
        (
            dict(memory="exponential", order=0.995),
            ValueError,
            r"`order` must lie in \[0.01, 0.99\]",
        ),
        (
            dict(memory="exponential", order_range=(0.2, 1.0)),
            ValueError,
            "`order_range` must satisfy",
        ),
        (dict(memory="exponential", tol=0.5), ValueError, "`tol` must be below"),
    ],
)
def test_bad_input_is_named(fn, kwargs, exc, match):
    args = dict(u=U, order=0.5, dt=0.1)
    args.update(kwargs)
    with pytest.raises(exc, match=match):
        fn(args.pop("u"), args.pop("order"), args.pop("dt"), **args)


def test_order_outside_design_range_inside_jit_is_an_error():
    import equinox as eqx
    import jax

    @jax.jit
    def f(order):
        return vojax.fractional_integral(
            U, order, 0.1, memory="exponential", order_range=(0.2, 0.8)
        )

    # eqx.error_if surfaces as EquinoxRuntimeError or as the XLA runtime error that wraps it
    # (older JAX has no JaxRuntimeError: it raises XlaRuntimeError, a RuntimeError)
    runtime = getattr(jax.errors, "JaxRuntimeError", RuntimeError)
    with pytest.raises((eqx.EquinoxRuntimeError, runtime), match="design range"):
        f(np.full(10, 0.9))


def test_float32_is_refused_and_version_printed(tmp_path):
    """Without jax_enable_x64 the library refuses to run (it never flips the setting itself);
    `vojax --version` prints the installed version."""
    code = (
        "import numpy as np, vojax\n"
        "try:\n"
        "    vojax.fractional_integral(np.ones(5), 0.5, 0.1)\n"
        "except RuntimeError as e:\n"
        "    print(e)\n"
    )
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert "vojax needs float64" in proc.stdout, proc.stderr
    proc = subprocess.run([sys.executable, "-m", "vojax", "--version"], capture_output=True, text=True)
    assert proc.returncode == 0 and proc.stdout.strip() == f"vojax {vojax.__version__}"


@pytest.mark.slow
def test_the_cli_fuzz_corpus_is_clean():
    """`scripts/fuzz_cli.py`: about 1,950 hostile files and options through the command,
    every outcome clean (status 0, 1 with one line, or 2 with failures.csv; nothing written
    outside --out; no NaN in what is written). In a process of its own: this one has the
    tests' compilation cache switched on, which the corpus must not write to."""
    script = Path(__file__).resolve().parents[1] / "scripts" / "fuzz_cli.py"
    proc = subprocess.run([sys.executable, str(script)], capture_output=True, text=True)
    text = proc.stdout
    assert proc.returncode == 0, text + proc.stderr[-2000:]
    total = int(text.split(" cases")[0].split()[-1])
    assert total >= 500 and f"clean: {total}/{total}" in text


def test_a_number_given_as_text_is_refused_not_parsed():
    """``x0='0'`` was taken as 0 (``jnp.asarray`` parses text): every route refuses it in
    one sentence, as it refuses True."""
    import vojax.io

    n, dt = 40, 0.1
    u = np.ones(n)
    y = np.asarray(vojax.simulate(u, 0.4, 1.0, dt))
    for bad in ("0", b"0", True):
        with pytest.raises(ValueError, match="`x0` must be a number, got"):
            vojax.identify(u, y, dt, x0=bad, warn=False)
        with pytest.raises(ValueError, match="`x0` must be a number, got"):
            vojax.identify(u, y, dt, x0=bad, method="gradient", gamma=0.5, warn=False)
    rec = vojax.io.Record("r", "r.csv", np.arange(n) * dt, u[:, None], y, ("u",), "y", dt)
    from vojax._data._batch import run_batch  # the command line's route

    with pytest.raises(ValueError, match="`x0` must be a number, got '0'"):
        run_batch([rec], "never-written", model="springpot", method="kalman", gamma=None,
                  lam=None, x0="0")


def test_an_order_bound_at_zero_or_one_is_refused():
    """The order lives strictly inside (0, 1) (its logistic coordinate is infinite at the
    ends, 1/Γ(0) = 0 kills the memory): bounds reaching 0 or 1 are refused by every route."""
    n, dt = 40, 0.1
    u = np.ones(n)
    y = np.asarray(vojax.simulate(u, 0.4, 1.0, dt))
    for bounds in [(0.0, 0.9), (0.1, 1.0), (-0.1, 0.5)]:
        with pytest.raises(ValueError, match=r"must satisfy 0.0 < lo < hi < 1.0"):
            vojax.refit(u, y, dt, order_bounds=bounds)
        with pytest.raises(ValueError, match=r"must satisfy 0.0 < lo < hi < 1.0"):
            vojax.identify(u, y, dt, alpha_bounds=bounds, warn=False)
        with pytest.raises(ValueError, match=r"must satisfy 0.0 < lo < hi < 1.0"):
            vojax.fisher_information(u, 0.4, [1.0], dt, noise_std=0.1, order_range=bounds)


def test_signals_whose_squares_leave_float64_are_refused_by_every_estimator():
    """u or y of 1e300 (the refit returned p = inf with success) or of 1e-300, and a known
    offset of 1e300 (the law returned NaN), are refused in one sentence that says to change
    the units; an offset of 1e-200 is an offset of 0 in effect and is taken."""
    n, dt = 40, 0.1
    u = np.minimum(np.arange(n) * dt, 1.0) + 0.1
    y = np.asarray(vojax.simulate(u, 0.4, 1.0, dt))
    calls = [lambda a, b, **kw: vojax.refit(a, b, dt, warn=False, **kw),
             lambda a, b, **kw: vojax.identify(a, b, dt, warn=False, **kw),
             lambda a, b, **kw: vojax.identify(a, b, dt, method="gradient", gamma=0.5,
                                               warn=False, **kw)]
    for call in calls:
        for a, b, name in [(1e300 * u, y, "u"), (1e-300 * u, y, "u"), (u, 1e300 * y, "y"),
                           (u, 1e-300 * y, "y")]:
            with pytest.raises(ValueError, match=f"`{name}`'s largest magnitude is .* outside "
                                                 r"\[1e-100, 1e\+100\]: express it in other"):
                call(a, b)
        with pytest.raises(ValueError, match="`x0`'s largest magnitude is 1e\\+300"):
            call(u, y, x0=1e300)
        for flat in (0 * y, 0 * y + 2.5):  # the refit's interval was NaN with success
            with pytest.raises(ValueError, match="`y` is .* at every sample: there is no "
                                                 "response to fit"):
                call(u, flat)
    res = vojax.identify(u, y, dt, method="gradient", gamma=0.5, warn=False, x0=1e-200)
    assert np.all(np.isfinite(np.asarray(res.alpha)))


@pytest.mark.parametrize("dt, duration, error, words", [
    (0.0, 10.0, ValueError, "`dt` and `duration` must be positive finite numbers, got 0.0"),
    (float("inf"), 10.0, ValueError, "must be positive finite numbers, got inf"),
    (0.1, float("inf"), ValueError, "must be positive finite numbers, got 0.1 and inf"),
    (-0.1, 10.0, ValueError, "must be positive finite numbers"),
    (1e-300, 10.0, ValueError, r"`duration` / `dt` must be at most 2,000,000 steps, got 1e\+301"),
    (True, 10.0, TypeError, "`dt` must be a number, got True"),
    (0.1, "10", TypeError, "`duration` must be a number"),
])
def test_the_studys_signals_refuse_a_grid_they_cannot_draw(dt, duration, error, words):
    """`study_signals` on a step of 0 (ZeroDivisionError before), an infinite step or
    duration (a NaN clock, or OverflowError) or 10^301 steps: one sentence naming them."""
    with pytest.raises(error, match=words):
        vojax.study_signals(dt, duration)
    t, u, alpha, p = vojax.study_signals(0.5, 2.0)  # the grid k·dt up to the duration
    np.testing.assert_array_equal(t, [0.0, 0.5, 1.0, 1.5, 2.0])
    assert u.shape == (5, 2) and alpha.shape == (5,) and p.shape == (5, 2)


def test_the_study_and_the_gain_search_refuse_what_they_cannot_run():
    """`simulate_study` with a step of 0 (ZeroDivisionError before), 2**63 (OverflowError) or
    a NaN noise (a NaN record returned), and `tune_gains` asked for a 10^9-point grid (a
    60 GiB allocation), each refused in one sentence."""
    for dt in (0.0, 2**63, -1.0, float("nan"), True):
        with pytest.raises(ValueError, match="`dt` must be a step from 0.00015 to 10 s"):
            vojax.simulate_study(dt)
    for noise in (float("nan"), float("inf"), -1.0):
        with pytest.raises(ValueError, match="`noise_std` must be a finite number ≥ 0"):
            vojax.simulate_study(0.5, noise_std=noise)
    with pytest.raises(ValueError, match="`seed` must be a whole number ≥ 0"):
        vojax.simulate_study(0.5, seed=-1)
    n, dt = 60, 0.1
    u = np.sin(np.arange(n) * dt) + 1.2
    y = np.asarray(vojax.simulate(u, 0.4, 1.0, dt))
    with pytest.raises(ValueError, match="`num_gamma` must be from 2 to 200"):
        vojax.tune_gains(u, y, dt, num_gamma=10**9)
    with pytest.raises(TypeError, match="`num_lam` must be a whole number"):
        vojax.tune_gains(u, y, dt, num_lam=2.5)


def test_the_tracker_refuses_more_inputs_than_it_can_carry():
    """Fifty input columns ran for more than 20 minutes without a word: above 16 the tracker
    refuses in one sentence naming the count and the refit, before any computation."""
    n, dt = 40, 0.1
    u = 1.0 + np.sin(np.outer(np.arange(n) * dt, np.arange(1, 18) * 0.3))
    y = np.asarray(vojax.simulate(u, 0.4, np.ones(17), dt))
    with pytest.raises(ValueError, match="the tracker takes at most 16 inputs .* got 17: use "
                                         "vojax.refit"):
        vojax.identify(u, y, dt, warn=False)


@pytest.mark.slow
def test_the_api_fuzz_corpus_is_clean():
    """`scripts/fuzz_api.py`: about 4,590 hostile arguments through the public functions,
    every outcome clean: vojax's own one-line error (never NumPy's or Python's, which name
    no argument) or a finite answer, within the time limit."""
    script = Path(__file__).resolve().parents[1] / "scripts" / "fuzz_api.py"
    proc = subprocess.run([sys.executable, str(script)], capture_output=True, text=True,
                          cwd=script.parent)
    text = proc.stdout
    assert proc.returncode == 0, text[-4000:] + proc.stderr[-2000:]
    total, clean = (int(w) for w in text.split(" cases, ")[0].split()[-1:]
                    + text.split(" cases, ")[1].split()[:1])
    assert total >= 4500 and clean == total


T20 = 0.1 * np.arange(20)
Y20 = np.linspace(0.0, 1.0, 20)


@pytest.mark.parametrize("call, error, words", [
    # before: NumPy's or Python's own message ("'<=' not supported between instances of
    # 'int' and 'str'", "could not convert string to float", "only 0-dimensional arrays
    # can be converted", "'int' object is not iterable"…), naming no argument
    (lambda: vojax.tune_gains(np.ones(20), Y20, 0.1, lag="a"), TypeError, "`lag` must be"),
    (lambda: vojax.tune_gains(np.ones(20), Y20, 0.1, burn_in=None), TypeError, "`burn_in` must"),
    (lambda: vojax.tune_gains(np.ones(20), Y20, 0.1, lam="x"), ValueError, "`lam` must be"),
    (lambda: vojax.compare(np.ones(20), Y20, 0.1, holdout="a"), TypeError, "`holdout` must"),
    (lambda: vojax.compare(np.ones(20), Y20, 0.1, models=3), TypeError, "`models` must"),
    (lambda: vojax.compare([[1.0, 2.0], [3.0]], Y20, 0.1), TypeError, "`stress` must be"),
    (lambda: vojax.refit(np.ones(20), Y20, 0.1, origin=[1.0, 2.0], x0="estimate"), TypeError,
     "`origin` must be one number"),
    (lambda: vojax.refit(np.ones(20), Y20, 0.1, p_signs="a"), TypeError, "`p_signs` must"),
    (lambda: vojax.simulate(np.ones(20), 0.4, 1.0, 0.1, x0="x"), TypeError, "`x0` must"),
    (lambda: vojax.simulate(np.ones(20), 0.4, 1.0, 0.1, x0=[1.0, 2.0]), TypeError, "`x0` must"),
    (lambda: vojax.simulate(np.ones(20), [[0.4], [0.4, 0.4]], 1.0, 0.1), TypeError,
     "`order` must"),
    (lambda: vojax.fisher_information(np.ones(20), 0.4, "x", 0.1, noise_std=0.1), TypeError,
     "`p` must"),
    (lambda: vojax.identify(np.ones(20), Y20, 0.1, mask="abc", warn=False), TypeError,
     "`mask` must"),
    (lambda: vojax.identify(np.ones(20), Y20, 0.1, method="gradient", gamma=0.5, r0=1 + 1j,
                            warn=False), TypeError, "`r0` must"),
    (lambda: vojax.mittag_leffler(0.5, [[1.0], [1.0, 2.0]]), ValueError, "the argument x"),
    (lambda: vojax.mittag_leffler_jax(0.5, T20, beta=np.array([1, 2])), ValueError,
     "beta must be 1 or 2"),
    (lambda: vojax.mittag_leffler(1.5, T20), ValueError, r"`alpha` \(the order\) must lie"),
    (lambda: vojax.KelvinVoigt().creep_compliance(T20[1:], q=2.0, eta=1.0, k=1.0),
     ValueError, r"`q` \(the order\) must lie"),
    (lambda: vojax.KelvinVoigt().creep_compliance("abc", q=0.4, eta=1.0, k=1.0), TypeError,
     "`t` must"),
    # flags: a truthy string or number was taken as True (smooth="no" smoothed)
    (lambda: vojax.identify(np.ones(20), Y20, 0.1, smooth="no"), TypeError,
     "`smooth` must be True or False, got 'no'"),
    (lambda: vojax.Tracker(smooth=1), TypeError, "`smooth` must be True or False, got 1"),
    (lambda: vojax.identify(np.ones(20), Y20, 0.1, method="gradient", smooth="no"), TypeError,
     "`smooth` must be True or False, got 'no'"),
    (lambda: vojax.identify(np.ones(20), Y20, 0.1, warn=2), TypeError,
     "`warn` must be True or False, got 2"),
    (lambda: vojax.identify(np.ones(20), Y20, 0.1, method="gradient", warn="no"), TypeError,
     "`warn` must be True or False, got 'no'"),
])
def test_a_bad_argument_is_named_not_left_to_numpy(call, error, words):
    with pytest.raises(error, match=words):
        call()


def test_the_named_refusals_keep_what_was_accepted():
    """A single model's name and a NumPy number for `x0` are taken: the checks above refuse
    only what was never a valid value."""
    assert [r["model"] for r in vojax.compare(np.ones(20), Y20, 0.1, models="springpot").rows] \
        == ["springpot"]
    sim = vojax.simulate(np.ones(20), 0.4, 1.0, 0.1, x0=np.float64(0.5))
    assert float(sim[0]) == pytest.approx(0.5)


def _short_record():
    t = 0.1 * np.arange(40)
    u = np.minimum(t, 1.0) + 0.1
    return u, np.asarray(vojax.simulate(u, 0.4, 1.0, 0.1)) + 1e-3 * np.sin(7 * t)


@pytest.mark.parametrize("call, error, words", [
    (lambda u, y: vojax.reference.fractional_integral("abc", 0.4, 0.1), TypeError, "`u` must"),
    (lambda u, y: vojax.reference.fractional_integral(u, "x", 0.1), TypeError, "`order`"),
    (lambda u, y: vojax.reference.order_sensitivity(u, 0.4, None), (TypeError, ValueError), "`dt`"),
    (lambda u, y: vojax.reference.order_sensitivity(u, 1e-20, 0.1), ValueError,
     r"`order` must be at least 1e-06 for the closed form \(14\)"),
    (lambda u, y: vojax.reference.lsff(u[:, None], y[:-1], 0.1, 0.9), ValueError,
     r"`y` must have shape \(40,\), one value per row of `phi`"),
    (lambda u, y: vojax.reference.lsff(u[:, None], y, 0.1, float("nan")), ValueError, "`lam`"),
    (lambda u, y: vojax.reference.lsff(np.column_stack([u, u * u]), y, 0.1, 0.9,
                                       r0=[[1.0, 2.0], [2.0, 1.0]]), ValueError,
     "`r0` must be symmetric positive definite"),
    (lambda u, y: vojax.reference.lsff_sensitivity(u[:, None], None, y, 0.1, 0.9), TypeError,
     "`dphi` .* must be given"),
    (lambda u, y: vojax.reference.lsff_sensitivity(u[:, None], u[:-1, None], y, 0.1, 0.9),
     ValueError, r"`dphi` must have the shape of `phi`, \(40, 1\)"),
    (lambda u, y: vojax.testing.check_gradients(u, 0.4, None), (TypeError, ValueError), "`dt`"),
    (lambda u, y: vojax.testing.check_gradients(u, "x", 0.1), TypeError, "`order`"),
    # a one-element order is refused, as `vojax.simulate` refuses it (it took it as a number)
    (lambda u, y: vojax.testing.check_gradients(u, [0.4], 0.1), ValueError,
     r"`order` must be a scalar or have shape \(40,\)"),
    (lambda u, y: vojax.testing.check_gradients(u, np.full(40, np.nan), 0.1), ValueError,
     "`order` contains NaN"),
    (lambda u, y: vojax.testing.check_gradients(u, np.linspace(0.2, 1.0, 40), 0.1), ValueError,
     r"`order` must lie in \(0.0, 1.0\), got 1.0 at sample 39"),
    (lambda u, y: vojax.simulate(u, [0.4], 1.0, 0.1), ValueError,
     r"`order` must be a scalar or have shape \(40,\)"),
    (lambda u, y: vojax.testing.check_gradients(u, 0.4, 0.1, rtol="x"), TypeError, "`rtol`"),
    (lambda u, y: vojax.testing.check_gradients(u, 0.4, 0.1, max_samples=None), TypeError,
     "`max_samples` must be a whole number"),
    (lambda u, y: vojax.testing.check_gradients(u, 0.4, 0.1, raise_on_failure=2), TypeError,
     "`raise_on_failure` must be True or False"),
    (lambda u, y: vojax.testing.check_gradients(u, 0.4, 0.1, closed_form=3), TypeError,
     "`closed_form` must be a function or None"),
    (lambda u, y: vojax.testing.check_parameter_sensitivity(u, y, 0.4, 0.1, lam="x"),
     TypeError, "`lam`"),
    # an integer step of 2**63 overflowed a traced int; as a float it leaves (0, 1)
    (lambda u, y: vojax.testing.check_parameter_sensitivity(u, y, 0.4, 0.1, step=2**63),
     ValueError, "`order` must lie in"),
])
def test_the_cross_checks_name_a_bad_argument(call, error, words):
    """`vojax.reference` and `vojax.testing` (the closed forms and the CI's cross-checks)
    check their arguments as the library's functions do: before, text, None or a complex
    number met NumPy's own "could not convert string to float", a missing `dphi` an
    IndexError, and an order of 1e-20 gave ∓4096 for (14)'s closed form (its two terms
    cancel)."""
    u, y = _short_record()
    with pytest.raises(error, match=words):
        call(u, y)


def test_the_closed_forms_hold_down_to_their_least_order_and_need_no_float64_setting():
    """At the least order the closed form (14) takes (1e-6) it agrees with autodiff; and the
    NumPy reference gives the same numbers with JAX's float64 off (its checks run in a
    float64 scope of their own)."""
    from vojax._xla import x64_scope

    u, y = _short_record()
    closed = vojax.reference.order_sensitivity(u, 1e-6, 0.1)
    auto = np.asarray(vojax.order_sensitivity(u, 1e-6, 0.1))
    np.testing.assert_allclose(closed, auto, rtol=1e-7, atol=1e-9 * np.max(np.abs(auto)))
    on = vojax.reference.fractional_integral(u, 0.4, 0.1)
    p_on = vojax.reference.lsff(on[:, None], y, 0.1, 0.9)
    with x64_scope(False):
        off = vojax.reference.fractional_integral(u, 0.4, 0.1)
        p_off = vojax.reference.lsff(on[:, None], y, 0.1, 0.9)
    assert off.dtype == np.float64
    np.testing.assert_array_equal(off, on)
    np.testing.assert_array_equal(p_off, p_on)
