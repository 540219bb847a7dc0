"""The contact point and the Young's modulus of an AFM force curve, found with nanite (the
AFM field's library for force-distance analysis; installed with ``pip install "vojax[afm]"``).

Each curve goes through nanite's preprocessing (the tip position ``z_cant + F/k``, the force
offset, the tip offset) and then, with a tip, nanite's Hertz fit of the loading segment
(sphere: ``hertz_para``; cone: ``hertz_cone``; three-sided pyramid: ``hertz_pyr3s``) with the
contact point and the force baseline free. The contact point is either that fit's
(``contact="fit"``, the default with a tip) or one of nanite's estimators named in
`POC_METHODS` (``"deviation_from_baseline"``, the default without a tip).

From the contact point ``z_c`` and the force baseline ``F₀``: the indentation is
``δ = z_c − z_tip`` and the force rise ``F − F₀``, which `_afm.contact_strain` turns into the
Lee–Radok strain.
"""

import math

import numpy as np

from ._errors import DataError

# nanite's contact-point estimators (nanite.poc), by the names nanite gives them
POC_METHODS = (
    "deviation_from_baseline",
    "fit_constant_line",
    "fit_constant_polynomial",
    "fit_line_polynomial",
    "frechet_direct_path",
    "gradient_zero_crossing",
)
CONTACT_METHODS = ("fit", *POC_METHODS)
# the tip's shape → nanite's model and the name of its size parameter
TIP_MODELS = {"sphere": ("hertz_para", "R"), "cone": ("hertz_cone", "alpha"),
              "pyramid": ("hertz_pyr3s", "alpha")}
PREPROCESSING = ["compute_tip_position", "correct_force_offset", "correct_tip_offset"]
# how the force's baseline is corrected before the contact point is found: its offset only,
# or a slope as well, "tilt" (nanite's `correct_force_slope`: a line against the tip position
# fitted to the baseline before contact and subtracted over the approach, an optical lever's
# virtual deflection). nanite's temporal "drift" strategy is not offered: on a synthetic
# curve with a linear drift in time it moved the contact point 19 samples from the truth
BASELINES = {"offset": None, "tilt": {"region": "approach", "strategy": "shift"}}


def check_baseline(baseline):
    """The baseline correction, checked: one of `BASELINES` (None gives ``"offset"``)."""
    if baseline is None:
        return "offset"
    if not isinstance(baseline, str) or baseline not in BASELINES:
        raise ValueError(
            f"the baseline correction must be one of {', '.join(BASELINES)}, got {baseline!r}."
        )
    return baseline


def check_contact(contact, tip):
    """The contact method, checked: ``None`` gives ``"fit"`` with a tip and
    ``"deviation_from_baseline"`` without; ``"fit"`` needs a tip."""
    if contact is None:
        return "deviation_from_baseline" if tip is None else "fit"
    if contact not in CONTACT_METHODS:
        raise ValueError(
            f"the contact method must be one of {', '.join(CONTACT_METHODS)}, got {contact!r}."
        )
    if contact == "fit" and tip is None:
        raise ValueError(
            "the contact method 'fit' fits a Hertz contact and needs a tip (sphere:RADIUS_m, "
            "cone:HALF_ANGLE_deg or pyramid:FACE_ANGLE_deg)."
        )
    return contact


def _nanite():
    try:
        import nanite
    except ImportError:
        raise DataError(
            'the contact point of AFM curves is found with nanite: pip install "vojax[afm]".'
        ) from None
    return nanite


def loading_segment(force, segment):
    """The segment that holds the first sample at which the force has risen half-way from
    its first value to its largest: the loading, whatever pause precedes it."""
    rise = force - force[0]
    first = int(np.flatnonzero(rise >= 0.5 * rise.max())[0])
    return segment[first]


def analyse(curve, label, tip, poisson, contact, baseline="offset"):
    """nanite's analysis of one curve (an afmformats force-distance object) under `tip`
    (checked, or None), `contact` and `baseline` (checked, see `BASELINES`).

    **Returns:** ``(force_rise, indentation, contact_index, block)``, with `block` the
    summary's ``afm`` part: the contact method, index and point, the segment fitted and, with
    a tip, the Young's modulus and its standard error (Pa), the model, and whether the fit
    converged."""
    nanite = _nanite()
    data = {k: np.asarray(curve[k], float) for k in curve.columns}
    if "height (measured)" not in data:  # the commanded height stands in for it
        data["height (measured)"] = data["height (piezo)"]
    idnt = nanite.Indentation(data, curve.metadata)
    slope = BASELINES[baseline]
    idnt.apply_preprocessing(
        PREPROCESSING + ([] if slope is None else ["correct_force_slope"]),
        options={} if slope is None else {"correct_force_slope": dict(slope)},
    )
    force = np.asarray(idnt["force"], float)
    z = np.asarray(idnt["tip position"], float)
    segment = np.asarray(idnt["segment"], float)
    if not np.ptp(force) > 0:
        raise DataError(f"{label}: the force is constant, there is no contact to find.")
    seg = loading_segment(force, segment)
    part = np.flatnonzero(segment == seg)
    block = {"contact_method": contact, "segment_fitted": int(seg), "poisson": poisson,
             "baseline": baseline}
    if tip is not None:
        block.update(_hertz(idnt, seg, tip, poisson))
    if contact == "fit":
        if not block["fit_success"]:
            raise DataError(
                f"{label}: nanite's Hertz fit did not converge; name a contact method "
                f"({', '.join(POC_METHODS)})."
            )
        z_c, f0 = block["contact_point_m"], block["force_baseline_N"]
        inside = np.flatnonzero(z[part] <= z_c)
        if inside.size == 0:
            raise DataError(f"{label}: the fitted contact point lies beyond the loading.")
        c = int(part[inside[0]])
    else:
        c = int(part[_poc(nanite, force[part], contact, label)])
        z_c, f0 = float(z[c]), float(np.mean(force[part[0] : c + 1]))
        if tip is not None:  # the fit's own contact and baseline, kept beside the record's
            block.update(fit_contact_point_m=block["contact_point_m"],
                         fit_force_baseline_N=block["force_baseline_N"])
        block.update(contact_point_m=z_c, force_baseline_N=f0)
    block.update(contact_index=c)
    return force - f0, z_c - z, c, block


def _poc(nanite, force, method, label):
    """The index of the contact point by nanite's estimator `method`; an error where it
    finds none (nanite itself would return the middle of the curve)."""
    for func in nanite.poc.POC_METHODS:
        if func.identifier == method:
            f = np.array(force, copy=True)
            if "clip_approach" in func.preprocessing:
                f = f[: int(np.argmax(f))]
            c = func(f)
            if not np.isfinite(c):
                raise DataError(f"{label}: nanite's {method!r} found no contact point.")
            return int(c)
    raise DataError(f"{label}: this nanite has no contact method {method!r}.")


def _hertz(idnt, seg, tip, poisson):
    """nanite's Hertz fit of the loading segment, the contact point and baseline free."""
    shape, size = tip
    model, key = TIP_MODELS[shape]
    params = idnt.get_initial_fit_parameters(model_key=model)
    params[key].set(value=size, min=0.0, max=math.inf)  # nanite caps a pyramid's at 30°
    params["nu"].set(value=poisson, min=-1.0)  # nanite stops at 0; the formula holds above −1
    idnt.fit_model(model_key=model, params_initial=params, segment=int(seg),
                   x_axis="tip position", y_axis="force")
    fp = idnt.fit_properties
    fitted = fp["params_fitted"]
    stderr = fitted["E"].stderr
    ok = bool(fp["success"] and stderr is not None and np.isfinite(stderr))
    return {
        "model": model,
        "tip": f"{shape}:{size:g}",
        "youngs_modulus_Pa": float(fitted["E"].value) if ok else None,
        "youngs_modulus_stderr_Pa": float(stderr) if ok else None,
        "contact_point_m": float(fitted["contact_point"].value),
        "force_baseline_N": float(fitted["baseline"].value),
        "fit_success": ok,
    }
