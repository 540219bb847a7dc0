"""A refusal's next steps: numbered, each an option that exists in the interface the user is
in (Python or the `vojax` command), and none the call already gave."""

import argparse
import inspect
import re

import numpy as np
import pytest

import vojax
from vojax._cli._main import build_parser
from vojax._diagnostics import diagnose
from vojax._steps import Step, say

CONTEXT = dict(width=0.2, trade=(0.1, 0.3), bounds=(0.01, 0.99), at_bound=0.1,
               held_shift=0.3, drifts=["order_drift"], others=["gamma"], correlation=0.5,
               limit=0.1, block=10, block_error=1.0, unstable_from=5, clock=0.6,
               span_order=0.3)


def _identify_options():
    """Every option string of `vojax identify` and `vojax batch`."""
    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return {s for name in ("identify", "batch") for a in sub.choices[name]._actions
            for s in a.option_strings}


def _python_names():
    """The keywords of the functions a Python user calls, and vojax's public names."""
    names = set()
    for f in (vojax.identify, vojax.load_records, vojax.refit, vojax.settling_test):
        names |= set(inspect.signature(f).parameters)
    return names


@pytest.mark.parametrize("reason", list(vojax.Reason))
def test_each_step_is_an_option_of_the_interface_it_is_said_in(reason):
    python, cli = reason.render(**CONTEXT), reason.render("cli", **CONTEXT)
    steps = reason.steps(**CONTEXT)
    assert steps, f"{reason.value} suggests nothing"
    assert python.startswith(reason.finding(**CONTEXT) + ". Next: (1) ")
    # numbered in order, one number per step said
    numbers = [int(n) for n in re.findall(r"\((\d+)\) ", python.split(". Next: ")[1])]
    assert numbers == list(range(1, len(steps) + 1))
    for keyword in re.findall(r"\b([a-z_0-9]+)=", python):
        assert keyword in _python_names(), f"{reason.value}: no Python keyword {keyword!r}"
    for name in re.findall(r"\bvojax\.([a-z_]+)", python):
        assert hasattr(vojax, name), f"{reason.value}: vojax has no {name!r}"
    assert " --" not in python
    options = _identify_options()
    for option in re.findall(r"(--[a-z][a-z0-9-]*)", cli):
        assert option in options, f"{reason.value}: the command has no {option}"
    assert "=" not in cli.split(". Next: ")[-1] and "vojax." not in cli


def test_every_step_is_said_in_both_interfaces_numbered_in_order():
    """Each step has its words in Python and on the command line (the noise intensities
    too: ``--noise``), numbered in the order given."""
    from vojax._steps import _WORDS

    assert set(_WORDS) == set(Step) and all(p and c for p, c in _WORDS.values())
    python = say("f", (Step.OUTLIERS, Step.NOISE))
    cli = say("f", (Step.NOISE, Step.OUTLIERS), "cli")
    assert python.count("(2)") == 1 and "(2) give the noise intensities" in python and "noise=" in python
    assert cli == ("f. Next: (1) give the noise intensities yourself, the instrument's noise "
                   "level among them: --noise; (2) look for steps or outliers in the data")
    with pytest.raises(ValueError, match="`interface` must be 'python' or 'cli'"):
        say("f", (Step.X0,), "R")


def _trade_off(**kw):
    n = 100
    alpha = np.full(n, 0.4)
    return diagnose(alpha, alpha - 0.3, alpha + 0.3, (0.01, 0.99), True, (),
                    trade=(0.1, 0.7), samples=n, **kw)


def test_steps_the_call_already_took_are_not_suggested_again():
    free = _trade_off()
    assert free.reasons == ("trade_off",)
    assert free.next_steps == ("parameters_constant", "time_scale", "x0", "settling_test")
    told = _trade_off(given=(Step.PARAMETERS_CONSTANT, Step.X0))
    assert told.next_steps == ("time_scale", "settling_test")
    assert told.message == told.finding + ". Next: (1) " + told.message.split("(1) ")[1]
    assert "parameters='constant'" not in told.message and "x0=" not in told.message
    assert free.say("cli") == say(free.finding, free.next_steps, "cli")
    assert "--parameters constant" in free.say("cli")


def test_steps_of_several_reasons_are_said_once_each():
    """A band both wide and traded off, with correlated prediction errors: each step once, in
    the order of the reasons."""
    n = 100
    alpha = np.full(n, 0.4)
    d = diagnose(alpha, alpha - 0.3, alpha + 0.3, (0.01, 0.99), True, (), held_shift=0.5,
                 trade=(0.1, 0.7), samples=n, correlation=0.9)
    assert d.reasons == ("trade_off", "held_shift", "correlated")
    assert d.next_steps == ("parameters_constant", "time_scale", "x0", "settling_test",
                            "compare", "coarser_clock", "noise")
    assert d.message.count("parameters='constant'") == 1


def test_the_tracker_names_what_its_options_already_said():
    assert vojax.Tracker()._given() == ()
    assert set(vojax.Tracker(parameters="constant", x0=0.0)._given()) == {
        Step.PARAMETERS_CONSTANT, Step.X0}
    assert vojax.Tracker(parameters=0.2)._given() == (Step.PARAMETERS_CONSTANT,)
    noise = {"order_drift": 1.0, "parameter_drift": 1e-3, "noise_std": 0.01}
    assert vojax.Tracker(noise=noise)._given() == (Step.NOISE,)
    assert vojax.Tracker(time_scale=1.0)._given() == (Step.TIME_SCALE,)
