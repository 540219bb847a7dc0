"""What to do next when an order is not identified: typed steps (`Step`), each said in the
words of the interface in use, Python or the ``vojax`` command."""

import enum


class Step(enum.StrEnum):
    """A next step a refusal can suggest: a name a program can branch on
    (`Diagnostics.next_steps`), said by `say` in Python's or the command line's words."""

    PARAMETERS_CONSTANT = "parameters_constant"  # state that the parameters do not drift
    X0 = "x0"  # give the measured offset of the output
    TIME_SCALE = "time_scale"  # state the unit of time in which the parameters are constant
    SETTLING_TEST = "settling_test"  # a test with an oscillation on the load
    LONGER_TEST = "longer_test"  # a longer hold or a second input
    REFIT = "refit"  # a refit with fewer free parameters
    ALPHA_BOUNDS = "alpha_bounds"  # widen the order's range
    INPUTS = "inputs"  # check the model's inputs
    OUTLIERS = "outliers"  # look for steps or outliers in the data
    NOISE = "noise"  # give the known noise level
    COMPARE = "compare"  # compare the laws the record supports
    GAINS = "gains"  # give the law's gains, or use the tracker
    SMALLER_GAMMA = "smaller_gamma"  # the law unstable: a smaller gain
    KALMAN = "kalman"  # the tracker, for a band that is a confidence band
    COARSER_CLOCK = "coarser_clock"  # resample: coloured noise decorrelates
    MAX_POINTS = "max_points"  # finer blocks for a long record


# each step in Python's words and in the command line's; None where that interface has no
# such option (the step is then not said there)
_WORDS = {
    Step.PARAMETERS_CONSTANT: (
        "if the parameters are known not to drift, say so: parameters='constant'",
        "if the parameters are known not to drift, say so: --parameters constant",
    ),
    Step.X0: (
        "give the output's offset where it is measured: x0=",
        "give the output's offset where it is measured: --x0",
    ),
    Step.TIME_SCALE: (
        "where the parameters are constant in a known unit of time (not the record's span, "
        "the default), state it: time_scale= (1 for seconds where t is in seconds)",
        "where the parameters are constant in a known unit of time (not the record's span, "
        "the default), state it: --time-scale SECONDS",
    ),
    Step.SETTLING_TEST: (
        "run a test with an oscillation superposed on the load, which separates the order "
        "from a drifting parameter (vojax.settling_test gives its frequency and the band it "
        "would give; with band_now=diagnostics.band_halfwidth, the band the tracker would)",
        "run a test with an oscillation superposed on the load, which separates the order "
        "from a drifting parameter (the next line gives it, where one can)",
    ),
    Step.LONGER_TEST: (
        "a test with a longer hold or a second input would determine it",
        "a test with a longer hold or a second input would determine it",
    ),
    Step.REFIT: (
        "refit with fewer free parameters: vojax.refit with a constant order or a few knots",
        "refit with fewer free parameters: --method kalman+refit (a constant order)",
    ),
    Step.ALPHA_BOUNDS: (
        "widen the order's range: alpha_bounds=",
        "widen the order's range: --alpha-bounds LO,HI",
    ),
    Step.INPUTS: (
        "check that the model's inputs are the right ones",
        "check that the model's inputs are the right ones: --input",
    ),
    Step.OUTLIERS: (
        "look for steps or outliers in the data",
        "look for steps or outliers in the data",
    ),
    Step.NOISE: (
        "give the noise intensities yourself, the instrument's noise level among them: noise=",
        "give the noise intensities yourself, the instrument's noise level among them: --noise",
    ),
    Step.COMPARE: (
        "compare the laws the record supports: vojax.compare",
        "compare the laws the record supports: vojax compare, or fit another with --model",
    ),
    Step.GAINS: (
        "give the gains yourself (gamma=, lam=), or use method='kalman'",
        "give the gains yourself (--gamma, --lam), or use --method kalman",
    ),
    Step.SMALLER_GAMMA: ("use a smaller gamma=", "use a smaller --gamma"),
    Step.KALMAN: (
        "use method='kalman' for an order with a confidence band",
        "use --method kalman for an order with a confidence band",
    ),
    Step.COARSER_CLOCK: (
        "resample to a coarser clock, on which the noise decorrelates between samples: "
        "vojax.load_records(..., resample=)",
        "resample to a coarser clock, on which the noise decorrelates between samples: "
        "--resample",
    ),
    Step.MAX_POINTS: (
        "fit finer blocks: a larger max_points=",
        "fit finer blocks: a larger --max-points",
    ),
}

INTERFACES = ("python", "cli")


def say_block(answer: str, finding: str, steps, interface: str = "cli") -> list[str]:
    """The verdict as a block of lines for a terminal: the `answer` (the verdict line), then
    ``why:`` and the `finding`, then each of the `steps` on a line of its own, numbered, in
    the words of `interface`."""
    if interface not in INTERFACES:
        raise ValueError(f"`interface` must be 'python' or 'cli', got {interface!r}.")
    lines = [answer]
    if finding:
        lines.append(f"  why: {finding}.")
    words = [_WORDS[Step(s)][INTERFACES.index(interface)] for s in steps]
    if words:
        lines.append("  next steps:")
        lines += [f"    ({i}) {w}" for i, w in enumerate(words, 1)]
    return lines


def say(finding: str, steps, interface: str = "python") -> str:
    """`finding` followed by the numbered `steps` in the words of `interface` ("python" or
    "cli")."""
    if interface not in INTERFACES:
        raise ValueError(f"`interface` must be 'python' or 'cli', got {interface!r}.")
    words = [_WORDS[Step(s)][INTERFACES.index(interface)] for s in steps]
    if not finding or not words:
        return finding
    return finding + ". Next: " + "; ".join(f"({i}) {w}" for i, w in enumerate(words, 1))
