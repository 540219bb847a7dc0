"""A record as the model sees it: stress and strain from force, displacement, area
and length (eq. 35), the regressors of each model and the refit's options."""

import numpy as np

from .._models import FractionalMaxwell, FractionalZener, KelvinVoigt, Springpot

MODELS = {
    "springpot": Springpot(),
    "kelvin-voigt": KelvinVoigt(),
    "maxwell": FractionalMaxwell(),
    "zener": FractionalZener(),
}


class _Columns:
    """``p ↦ {name: p[..., i]}``: the linear model's parameters, named by their columns;
    hashable, so that derived standard errors compile once per batch."""

    def __init__(self, names):
        self.names = names

    def __call__(self, p):
        return {n: p[..., i] for i, n in enumerate(self.names)}

    def __eq__(self, other):
        return isinstance(other, _Columns) and other.names == self.names

    def __hash__(self):
        return hash(self.names)


def regressors(record, model: str, area=None, length=None):
    """``(u, y, parameter names, to_physical)`` for `model` (``linear`` keeps the columns)."""
    if model == "linear":
        names = [f"p_{c}" for c in record.input_names]
        return record.inputs, record.output, names, _Columns(tuple(names))
    stress, strain = _stress_strain(record, model, area, length)
    law = MODELS[model]
    return np.asarray(law.inputs(stress, strain)), strain, list(law.names), law.parameters


def output_scale(model, length) -> float:
    """What the file's output column is divided by to give the model's output: the strain
    ``d/length`` of a law (1 when `length` is not given), the column itself for ``linear``."""
    return 1.0 if model == "linear" else (length or 1.0)


def _stress_strain(record, model, area, length):
    """Eq. (35) on a record: ``σ = F/area``, ``ε = d/length`` (either 1 when not given)."""
    if record.inputs.shape[1] != 1:
        raise ValueError(
            f"--model {model} takes one --input (the stress or force), got {record.inputs.shape[1]}; "
            "use --model linear for several inputs."
        )
    with np.errstate(over="ignore", under="ignore"):
        stress = record.inputs[:, 0] / (area or 1.0)
        strain = record.output / output_scale(model, length)
    for option, value, signal in (("--area", area, stress), ("--length", length, strain)):
        big = float(np.max(np.abs(signal))) if signal.size else 0.0
        if value is not None and not big < 1e150:  # squares must stay finite
            raise ValueError(
                f"{option} {value:g} makes the {'stress' if option == '--area' else 'strain'} "
                f"reach {big:.3g}, beyond what float64 arithmetic can square; give {option} "
                "in the units of the data's columns."
            )
    return stress, strain


# the refit's own options (a window and the test's start, in the file's time unit), which
# the comparison takes too
FIT_OPTIONS = ("origin", "fit_from", "fit_to")


def refit_options(record, model, area=None, length=None, origin=None, fit_from=None, fit_to=None):
    """The `refit` keywords for a record: the model's order-0 regressors and signs, and the
    test's origin and fit window given in the file's time unit (the record's clock starts at 0
    at its first sample, ``time_offset`` in the file)."""
    options = {}
    if model in MODELS:
        law = MODELS[model]
        options["p_signs"] = law.p_signs
        direct = law.direct(*_stress_strain(record, model, area, length))
        if direct is not None:
            options["direct"] = np.asarray(direct)
    shift = record.time_offset
    if origin is not None:
        options["origin"] = float(origin) - shift
    if fit_from is not None or fit_to is not None:
        options["window"] = (
            -np.inf if fit_from is None else float(fit_from) - shift,
            np.inf if fit_to is None else float(fit_to) - shift,
        )
    return options


def stress_strain(record, area=None, length=None):
    """A one-input record's stress σ = F/a and strain ε = d/l (eq. 35; a and l 1 if None)."""
    stress, strain = record.inputs[:, 0], record.output
    return (stress if area is None else stress / area), (strain if length is None else strain / length)
