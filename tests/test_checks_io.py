"""Gradient cross-checks for users (`vojax.testing`, `vojax check`) and the public file API
(`vojax.io`): they pass on correct closed forms and shipped data, and fail (raise, exit 1)
on a deliberately wrong closed form."""

import functools
import json

import numpy as np
import pytest

import vojax
import vojax.testing as vt
from vojax import reference
from vojax._cli import build_parser, main

T = np.arange(200) * 0.02
U = np.stack([np.sin(3 * T) + 0.2, np.exp(-T)], axis=1)
ORDER = 0.35 + 0.3 * T / T[-1]


_CLOSED_FORM_14 = reference.order_sensitivity


def _psi_dropped(u, order, dt, **kw):
    """A plausible wrong closed form of (14): the −ψ(b)Φ term forgotten."""
    from vojax._kernels._special import digamma

    phi = reference.fractional_integral(u, order, dt, **kw)
    dphi = _CLOSED_FORM_14(u, order, dt, **kw)
    b = np.broadcast_to(order, (u.shape[0],))
    shape = (-1,) + (1,) * (np.ndim(u) - 1)
    return dphi + np.reshape(np.asarray(digamma(b)), shape) * phi


@pytest.mark.parametrize("memory", ["direct", "exponential"])
def test_check_gradients_passes_and_its_numbers_are_real(memory):
    report = vt.check_gradients(U, ORDER, 0.02, memory=memory)
    assert report.passed
    auto, closed = report.rows[0], report.rows[1]
    assert auto.relative < 1e-12  # autodiff and (14) agree to rounding
    # the finite difference's error is truncation, O(step²): far above rounding, below 1e-6
    assert 1e-13 < closed.relative < 1e-7
    # the scale is the largest |∂φ/∂β| computed independently
    dphi = reference.order_sensitivity(U, ORDER, 0.02, memory=memory)
    assert closed.scale == pytest.approx(np.max(np.abs(dphi)), rel=1e-12)
    assert "autodiff vs closed form (14)" in report.table()


def test_check_gradients_fails_on_a_wrong_closed_form():
    with pytest.raises(vt.GradientCheckError, match="FAILED"):
        vt.check_gradients(U, ORDER, 0.02, closed_form=_psi_dropped)
    report = vt.check_gradients(U, ORDER, 0.02, closed_form=_psi_dropped, raise_on_failure=False)
    assert not report.passed and report.rows[0].relative > 1e-3


def test_check_parameter_sensitivity_passes_and_catches_the_printed_misprint():
    y = U @ np.array([1.5, -0.5]) + 0.05 * T
    report = vt.check_parameter_sensitivity(U, y, 0.6, 0.02, lam=0.9, r0=np.diag([2.0, 0.5]))
    assert report.passed and report.rows[1].relative < 1e-12
    # the paper's printed (26) (φ ∂pᵀ/∂β for φ ∂φᵀ/∂β) disagrees with autodiff
    printed = functools.partial(reference.lsff_sensitivity, printed=True)
    with pytest.raises(vt.GradientCheckError):
        vt.check_parameter_sensitivity(U, y, 0.6, 0.02, lam=0.9, closed_form=printed)



def test_check_parameter_sensitivity_fails_on_a_recursion_that_is_not_23(monkeypatch):
    """The check's first row compares the recursion's p with the explicit sums of (23), an
    independent computation: a recursion off by 1e-6 of p (a constant, so that its
    derivative, and the rows that check it, are unchanged) fails that row alone."""
    y = U @ np.array([1.5, -0.5]) + 0.05 * T
    exact = vt._lsff_p
    monkeypatch.setattr(vt, "_lsff_p", lambda *a: exact(*a) + 1e-6)
    report = vt.check_parameter_sensitivity(U, y, 0.6, 0.02, raise_on_failure=False)
    assert not report.passed
    assert report.rows[0].compared.startswith("recursion vs batch")
    assert report.rows[0].relative > 1e-7 and report.rows[1].relative < 1e-10
    with pytest.raises(vt.GradientCheckError, match="recursion vs batch"):
        vt.check_parameter_sensitivity(U, y, 0.6, 0.02)


@pytest.mark.parametrize(
    "call, match",
    [
        (lambda: vt.check_gradients(U, 1.2, 0.02), "order"),
        (lambda: vt.check_gradients(U, 0.5, -1.0), "dt"),
        (lambda: vt.check_gradients(np.full((10, 1), np.nan), 0.5, 0.1), "NaN"),
        (lambda: vt.check_gradients(U, 0.5, 0.02, max_samples=50), "max_samples=50"),
        (lambda: vt.check_parameter_sensitivity(U, T[:-1], 0.5, 0.02), "`y`"),
        (lambda: vt.check_parameter_sensitivity(U, T, 0.5, 0.02, lam=0.0), "lam"),
    ],
)
def test_check_validation(call, match):
    with pytest.raises(ValueError, match=match):
        call()


ADHESIVE = ["--time", "time_s", "--input", "nominal_shear_stress_kPa", "--output", "shear_strain"]


def test_vojax_check_passes_on_the_shipped_example_and_fails_on_a_wrong_form(monkeypatch, capsys):
    path = str(vojax.io.example_file("adhesive"))
    args = ["check", path, *ADHESIVE, "--order", "0.3,0.7", "--max-samples", "150"]
    # its clock is irregular (steps of 2.4 to 6 s): the closed forms need a uniform one
    assert main(args) == 1
    assert "add --resample STEP (its median step is 2.4)" in capsys.readouterr().err
    args += ["--resample", "2.4"]
    assert main(args) == 0
    out = capsys.readouterr().out
    assert out.count("ok") == 12 and "FAILED" not in out and "first 150 of" in out
    monkeypatch.setattr(reference, "order_sensitivity", _psi_dropped)
    assert main(args) == 1
    captured = capsys.readouterr()
    assert "FAILED" in captured.out and "beyond tolerance" in captured.err


def test_vojax_check_option_errors(capsys):
    path = str(vojax.io.example_file("adhesive"))
    with pytest.raises(SystemExit):
        main(["check", path, *ADHESIVE, "--order", "1.5"])
    assert "(0, 1)" in capsys.readouterr().err
    assert main(["check", path, *ADHESIVE, "--max-samples", "2"]) == 1
    assert "--max-samples" in capsys.readouterr().err


def test_io_loads_identifies_and_writes_the_shipped_example(tmp_path):
    path = vojax.io.example_file("adhesive")
    (record,) = vojax.load_records(
        path, time="time_s", inputs=["nominal_shear_stress_kPa"], output="shear_strain"
    )
    assert not record.uniform  # used on its own clock
    columns, summary = vojax.io.identify_record(record, method="refit")
    # η = 1/p of the springpot, from the refit's p written independently here
    assert summary["refit"]["parameters"]["eta"] == pytest.approx(1 / summary["refit"]["p"][0])
    folder = vojax.write_results(tmp_path / "out", columns, summary, record, figure_format="svg")
    assert sorted(p.name for p in folder.iterdir()) == [
        "identification.csv", "identification.svg", "summary.json",
    ]
    written = json.loads((folder / "summary.json").read_text())
    prov = written["provenance"]
    assert prov["vojax"] == vojax.__version__ and prov["settings"]["figure_format"] == "svg"
    data = np.genfromtxt(folder / "identification.csv", delimiter=",", names=True)
    np.testing.assert_array_equal(data["refit_y_hat"], np.asarray(columns["refit_y_hat"]))
    with pytest.raises(ValueError, match="examples are"):
        vojax.io.example_file("beef")
    with pytest.raises(ValueError, match="`method`"):
        vojax.io.identify_record(record, method="kalmann")


@pytest.mark.parametrize("call, error, words", [
    (dict(folder=None), TypeError, "`folder` must be a path, got None"),
    (dict(columns=None), TypeError, "`columns` must be a mapping of column names to samples"),
    (dict(columns={}), ValueError, "`columns` is empty"),
    (dict(columns={"a": [1.0, 2.0], "b": [1.0]}), ValueError,
     r"`columns` must all have one length, got lengths \[1, 2\]"),
    (dict(columns={"a": "abc"}), TypeError, r"`columns\['a'\]` must be a number or an array"),
    (dict(columns={"a": [[1.0, 2.0]]}), ValueError, r"must be one column of samples \(N,\)"),
    (dict(columns={1: [1.0]}), TypeError, "`columns`' names must be non-empty text, got 1"),
    (dict(summary=None), TypeError, "`summary` must be a mapping"),
    (dict(summary={"k": object()}), TypeError, "`summary` must hold what JSON can"),
    (dict(summary={1: 2, "b": 3}), TypeError, "`summary` must hold what JSON can"),
    (dict(record="x"), TypeError, "`record` must be a vojax.io.Record or None, got str"),
    (dict(folder="FILE"), ValueError, "is a file, not a folder"),
])
def test_bad_results_are_refused_before_anything_is_written(tmp_path, call, error, words):
    """`write_results` checks what it is given before it writes: the folder's earlier
    outputs stay as they were (a summary JSON cannot hold removed the old ``summary.json``
    and left a new table under no summary)."""
    folder = tmp_path / "out"
    good = dict(folder=folder, columns={"a": [1.0, float("nan")]}, summary={"x": 1.5})
    vojax.write_results(**good)
    before = {p.name: p.read_bytes() for p in folder.iterdir()}
    assert sorted(before) == ["identification.csv", "summary.json"]
    args = good | call
    if args["folder"] == "FILE":  # the path of a file, not a folder
        args["folder"] = tmp_path / "table.csv"
        args["folder"].write_text("a\n1\n")
    with pytest.raises(error, match=words):
        vojax.write_results(args.pop("folder"), args.pop("columns"), args.pop("summary"),
                            **args)
    assert {p.name: p.read_bytes() for p in folder.iterdir()} == before
    assert json.loads(before["summary.json"]) == {"x": 1.5}


def test_identify_takes_one_record_of_a_long_file(tmp_path, capsys):
    rows = ["time,stress,strain,specimen"]
    for name in ("a", "b"):
        t = np.arange(40) * 0.1
        x = np.asarray(vojax.simulate(np.minimum(t, 1.0), 0.4, np.array([0.5]), 0.1))
        rows += [f"{ti},{si},{xi},{name}" for ti, si, xi in zip(t, np.minimum(t, 1.0), x)]
    path = tmp_path / "long.csv"
    path.write_text("\n".join(rows) + "\n")
    base = ["identify", str(path), "--time", "time", "--input", "stress", "--output", "strain",
            "--group-by", "specimen", "--method", "refit"]
    assert main([*base, "--out", str(tmp_path / "o1")]) == 1
    assert "--record NAME" in capsys.readouterr().err
    assert main([*base, "--out", str(tmp_path / "o2"), "--record", "zz"]) == 1
    assert "no record 'zz'" in capsys.readouterr().err
    assert main([*base, "--out", str(tmp_path / "o3"), "--record", "b"]) == 0
    summary = json.loads((tmp_path / "o3" / "summary.json").read_text())
    assert summary["record"] == "b"
    assert summary["refit"]["order"] == pytest.approx(0.4, abs=1e-4)


def test_every_cli_option_says_its_default():
    parser = build_parser()
    sub = next(a for a in parser._actions if a.dest == "command")
    for name, command in sub.choices.items():
        for action in command._actions:
            if action.dest in ("help",) or action.required or not action.option_strings:
                continue
            text = (action.help or "").lower()
            assert text, f"vojax {name} {action.option_strings[0]} has no help"
            if action.default not in (None, False) or action.choices:
                assert "default" in text, f"vojax {name} {action.option_strings[0]}: no default"


def test_json_outputs_hold_no_non_finite_number_at_any_depth():
    """`vojax._io.json_text`: NaN and ±inf become null inside dicts, lists and tuples alike
    (a band's edges or a trade-off's interval are tuples), finite numbers and text stay, and
    a strict parser (no NaN, no Infinity) reads it back."""
    from vojax._io import json_text

    data = {"band": (0.25, float("nan")), "drifts": [float("inf"), 0.5],
            "nested": {"pair": (float("-inf"), (1.0, float("nan")))}, "name": "r1", "n": 3}
    text = json_text(data)

    def refuse(token):
        raise ValueError(f"non-strict JSON: {token}")

    back = json.loads(text, parse_constant=refuse)
    assert back == {"band": [0.25, None], "drifts": [None, 0.5],
                    "nested": {"pair": [None, [1.0, None]]}, "name": "r1", "n": 3}
