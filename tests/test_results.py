"""The result objects as a user reads them: scalar accessors where the order is constant,
`summary()` tables, `.plot()` and `.to_dataframe()` carrying the same numbers as the arrays."""

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402

import vojax  # noqa: E402

DT = 0.05
T = np.arange(400) * DT
U = np.stack([np.sin(0.7 * T) + 0.3 * np.sin(1.9 * T), 1 + 0.5 * np.cos(0.25 * T)], axis=1)


def _y(order=0.45, seed=0):
    x = np.asarray(vojax.simulate(U, order, np.array([2.0, -1.0]), DT))
    return x + 0.01 * np.random.default_rng(seed).standard_normal(x.shape)


def test_a_constant_refit_reads_as_numbers():
    fit = vojax.refit(U, _y(), DT)
    assert fit.constant
    assert fit.order_value == float(fit.order[0]) and isinstance(fit.order_value, float)
    assert fit.order_value_stderr == float(fit.order_stderr[0])
    assert abs(fit.order_value - 0.45) < 5 * fit.order_value_stderr
    s = fit.summary(names=["a", "b"])
    assert s["order"]["value"] == fit.order_value and s["order"]["stderr"] == fit.order_value_stderr
    assert s["a"]["value"] == float(fit.p[0]) and s["b"]["stderr"] == float(fit.p_stderr[1])
    assert s["converged"]["value"] == "yes"
    text = str(s)
    assert len(text.splitlines()) == len(s) + 1 and f"{fit.order_value:.6g}" in text
    with pytest.raises(ValueError, match="`names` must be 2 non-empty strings"):
        fit.summary(names=["a"])


def test_a_varying_refit_refuses_a_single_number():
    fit = vojax.refit(U, _y(0.3 + 0.3 * T / T[-1]), DT, order=3)
    assert not fit.constant
    with pytest.raises(ValueError, match="the order varies along the record"):
        fit.order_value
    rows = [k for k in fit.summary() if k.startswith("order at knot")]
    assert len(rows) == 3
    assert fit.summary()[rows[1]]["value"] == float(fit.knots[1])


def test_plot_and_table_carry_the_arrays():
    pd = pytest.importorskip("pandas")
    fit = vojax.refit(U, _y(), DT)
    res = vojax.identify(U, _y(), DT, method="gradient", gamma=0.5, lam=0.9, warn=False)
    for result, alpha, lower in ((fit, fit.order, fit.order_lower),
                                 (res, res.alpha, res.alpha_lower)):
        ax = result.plot(t=T)
        (line,) = [ln for ln in ax.get_lines()]
        np.testing.assert_array_equal(line.get_xdata(), T)
        np.testing.assert_array_equal(line.get_ydata(), np.asarray(alpha))
        plt.close(ax.figure)
        frame = result.to_dataframe(t=T)
        assert isinstance(frame, pd.DataFrame) and len(frame) == T.size
        np.testing.assert_array_equal(frame["time"], T)
        key = "order_lower" if result is fit else "alpha_lower"
        np.testing.assert_array_equal(frame[key], np.asarray(lower))
    frame = res.to_dataframe(names=["a", "b"])
    np.testing.assert_array_equal(frame["b_std"], np.asarray(res.p_std)[:, 1])
    # the identification's summary: the final values and the verdict with its reason
    s = res.summary()
    assert s["order (final)"]["value"] == float(res.alpha[-1])
    assert s["p2 (final)"]["stderr"] == float(res.p_std[-1, 1])
    assert s["identified"]["value"] == "no" and "method='kalman'" in s["identified"]["note"]
    ax = res.plot()  # default clock k·dt
    np.testing.assert_allclose(ax.get_lines()[0].get_xdata(), T, rtol=1e-12)
    assert ax.get_title() == "order: not identified"
    plt.close(ax.figure)
    with pytest.raises(ValueError, match="`t` must have shape"):
        res.plot(t=T[:-1])


def test_the_summary_table_prints_tiny_and_huge_numbers_as_they_are():
    """The printed table keeps six significant digits whatever the scale: a modulus of 2e9 Pa
    and a compliance of 1.2e-7 1/Pa with its error print as such, never as 0.000000 or a
    row of digits; NaN and an infinite error print as words."""
    from vojax._results import Summary, row

    s = Summary()
    s["eta"] = row(2.345678e9, 1.2e7)
    s["compliance"] = row(1.2e-7, 3.4e-9)
    s["undetermined"] = row(float("nan"), float("inf"))
    lines = str(s).splitlines()
    assert "2.34568e+09" in lines[1] and "1.2e+07" in lines[1]
    assert "1.2e-07" in lines[2] and "3.4e-09" in lines[2]
    assert "nan" in lines[3] and "inf" in lines[3]
    for line in lines[1:]:
        for number in line.split()[1:3]:
            assert float(number) != 0.0 or number == "0"


def test_names_and_times_given_to_a_result_are_checked_in_one_sentence():
    """`names` of the wrong length (IndexError before), repeated or not strings, and `t` of
    the wrong length are refused by `to_dataframe` and `summary` alike, for both result
    kinds; a lone string names a single parameter."""
    pytest.importorskip("pandas")
    fit = vojax.refit(U, _y(), DT)
    res = vojax.identify(U, _y(), DT, method="gradient", gamma=0.5, lam=0.9, warn=False)
    for names, words in [(["a"], "`names` must be 2 non-empty strings"),
                         (["a", "b", "c"], "`names` must be 2 non-empty strings"),
                         (["a", 1], "`names` must be 2 non-empty strings"),
                         (["a", "a"], "`names` must be distinct")]:
        with pytest.raises(ValueError, match=words):
            res.to_dataframe(names=names)
        with pytest.raises(ValueError, match=words):
            res.summary(names=names)
        with pytest.raises(ValueError, match=words):
            fit.summary(names=names)
    for result in (res, fit):
        with pytest.raises(ValueError, match="`t` must be 400 finite times, one per sample"):
            result.to_dataframe(t=T[:-1])
    one = vojax.refit(U[:, :1], np.asarray(vojax.simulate(U[:, 0], 0.4, 1.0, DT)), DT)
    assert "stiffness" in one.summary(names="stiffness")
