"""AFM force files (JPK force and force-map files, Igor binary waves, afmformats HDF5) read
through `afmformats`, with the contact point, the Young's modulus, the indentation and the
Hertz contact strain found by nanite (`_contact`), which turn a force curve into the input and
output of σ = η D^{q(t)} ε. Both are the optional extra ``pip install "vojax[afm]"``.

The indentation is ``δ = z_c − z_tip``: the tip position ``z_tip = z_cant + F/k`` (the
measured height when the file has it, else the commanded one, plus the cantilever's
deflection, ``k`` the spring constant in the file) below the contact point ``z_c``. With a tip
geometry the output can be the contact strain ``x`` of a Lee–Radok (Hertz) contact, for which
the force is the shear relaxation modulus convolved with ``ẋ``: a springpot fitted to
``(F − F₀, x)`` has its η and q in shear units (η = E/(2(1 + ν)) for an elastic sample):

- sphere of radius R: ``x = 8 √R δ^{3/2} / (3 (1 − ν))``;
- cone of half-angle θ: ``x = 4 tan θ δ² / (π (1 − ν))``;
- three-sided pyramid of face angle θ: ``x = 2 c tan θ δ² / (1 − ν)`` with nanite's
  ``c = 0.8887`` (Bilodeau's approximation; its docstring prints 0.887);

with ν the Poisson ratio (0.5, incompressible, by default); ``x = 0`` before contact.
"""

import math
from pathlib import Path

import numpy as np

from ._errors import DataError

AFM_SUFFIXES = (".jpk-force", ".jpk-force-map", ".jpk-qi-data", ".jpk-qi-series", ".ibw", ".h5")
PYRAMID_FACTOR = 0.8887  # nanite's hertz_pyr3s: F = c tan θ E δ² / (1 − ν²)
AFM_COLUMNS = ("time_s", "segment", "force_N", "height_measured_m", "height_piezo_m",
               "force_rise_N", "indentation_m", "contact_strain")


# a force map's curve: where it lies (the summary's afm block, the batch's maps)
GRID_KEYS = {"grid_index_x": "grid index x", "grid_index_y": "grid index y",
             "grid_shape_x": "grid shape x", "grid_shape_y": "grid shape y",
             "position_x_m": "position x", "position_y_m": "position y"}


def is_afm(path) -> bool:
    return Path(path).suffix.lower() in AFM_SUFFIXES


SPHERE_RADIUS_M = (1e-10, 1e-2)  # a sphere's radius outside these (m) is a unit mistake


def check_tip(tip, poisson=0.5):
    """``None``, ``("sphere", R)`` (R in m), ``("cone", θ)`` (θ the half-angle in degrees) or
    ``("pyramid", θ)`` (a three-sided pyramid, θ its face angle in degrees), checked; also
    accepts the command line's ``"sphere:R"``, ``"cone:θ"``, ``"pyramid:θ"``."""
    if not (isinstance(poisson, (int, float)) and not isinstance(poisson, bool)
            and -1.0 < poisson < 0.5 + 1e-12):
        raise ValueError(f"the Poisson ratio must lie in (−1, 0.5], got {poisson!r}.")
    if tip is None:
        return None
    if isinstance(tip, str):
        shape, _, value = tip.partition(":")
        try:
            tip = (shape, float(value))
        except ValueError:
            raise ValueError(
                f"a tip is sphere:RADIUS_m, cone:HALF_ANGLE_deg or pyramid:FACE_ANGLE_deg, got "
                f"{tip!r}."
            ) from None
    if not (isinstance(tip, (tuple, list)) and len(tip) == 2):
        raise ValueError(
            "a tip is ('sphere', radius in m), ('cone', half-angle in degrees) or ('pyramid', "
            f"face angle in degrees), got {tip!r}."
        )
    shape, size = tip[0], float(tip[1])
    if shape == "sphere":
        lo, hi = SPHERE_RADIUS_M
        if not lo <= size <= hi:
            raise ValueError(
                f"a sphere's radius is in metres, from {lo:g} to {hi:g} (an AFM tip's), got "
                f"{size:g} m."
            )
    elif shape in ("cone", "pyramid"):
        if not 0 < size < 90:
            what = "a cone's half-angle" if shape == "cone" else "a pyramid's face angle"
            raise ValueError(f"{what} must lie in (0, 90) degrees, got {size}.")
    else:
        raise ValueError(f"the tip must be a sphere, a cone or a pyramid, got {shape!r}.")
    return shape, size


def contact_strain(indentation, tip, poisson=0.5):
    """The Hertz (Lee–Radok) contact strain of an indentation (m) under `tip` (`check_tip`)."""
    shape, size = check_tip(tip, poisson)
    d = np.clip(np.asarray(indentation, float), 0.0, None)
    if shape == "sphere":
        return 8.0 * math.sqrt(size) * d**1.5 / (3.0 * (1.0 - poisson))
    if shape == "cone":
        return 4.0 * math.tan(math.radians(size)) * d**2 / (math.pi * (1.0 - poisson))
    return 2.0 * PYRAMID_FACTOR * math.tan(math.radians(size)) * d**2 / (1.0 - poisson)


def read_afm(path, *, tip=None, poisson=0.5, contact=None, analyse=True, baseline=None):
    """The force curves of an AFM file, each as a dict of columns (`AFM_COLUMNS`) and a dict of
    metadata (``name``, ``spring_constant``, ``contact_index``, ``contact_time``,
    ``modality``, ``afm``: nanite's analysis, see `_contact.analyse`). `contact` names the
    contact method (`_contact.check_contact`), `baseline` the force baseline's correction
    (`_contact.BASELINES`: ``"offset"``, the default, or ``"tilt"``).
    ``analyse=False`` reads the file's own
    columns only (the last three NaN, no contact, nanite not needed).

    Returns ``(curves, failures)``: a curve that cannot be read or analysed (a damaged
    channel, no contact point, a Hertz fit that does not converge) is left out, its name and
    reason in `failures`."""
    try:
        import afmformats
    except ImportError:
        raise DataError(
            f'{path}: AFM files are read with afmformats: pip install "vojax[afm]".'
        ) from None
    from ._contact import check_baseline, check_contact

    tip = check_tip(tip, poisson)
    contact = check_contact(contact, tip)
    baseline = check_baseline(baseline)
    path = Path(path)
    import logging

    from afmformats import errors

    # afmformats' own errors derive from BaseException, it logs a traceback of its own
    # before raising, and it reads a curve's channels only when they are first used (a
    # damaged channel fails there, with NumPy's words): the reason is said once, in one
    # line naming the file and the curve
    fatal = (Exception, errors.AFMFileFormatError, errors.MissingMetaDataError)
    log = logging.getLogger("afmformats")
    level = log.level
    log.setLevel(logging.CRITICAL)
    try:
        try:
            curves = afmformats.load_data(path)
        except fatal as e:  # noqa: BLE001 - a damaged or unknown file: one line
            raise DataError(f"{path}: not a readable AFM file ({_first_line(e)}).") from None
        if not curves:
            raise DataError(f"{path}: holds no force curve.")
        out, failures = [], []
        for k, curve in enumerate(curves):
            name = path.name[: -len(path.suffix)] if len(curves) == 1 else f"{path.stem}-{k}"
            try:
                out.append(_curve(path, k, curve, name, tip, poisson, contact, analyse,
                                  baseline))
            except DataError as e:  # this curve's reason; the others are read
                failures.append((name, str(e)))
            except fatal as e:  # noqa: BLE001 - a damaged channel: this curve's error
                failures.append(
                    (name, f"{path}, curve {k}: a damaged channel ({_first_line(e)})."))
    finally:
        log.setLevel(level)
    return out, failures


def _first_line(error) -> str:
    return str(error).splitlines()[0] if str(error) else type(error).__name__


def _curve(path, k, curve, name, tip, poisson, contact, analyse, baseline="offset"):
    """One force curve's columns and metadata (see `read_afm`)."""
    columns = set(curve.columns)
    for need in ("time", "force", "segment"):
        if need not in columns:
            raise DataError(f"{path}, curve {k}: has no {need!r} column.")
    if not {"height (measured)", "height (piezo)"} & columns:
        raise DataError(f"{path}, curve {k}: has no height column.")
    t = np.asarray(curve["time"], float)
    nan = np.full(t.size, np.nan)
    cols = {
        "time_s": t,
        "segment": np.asarray(curve["segment"], float),
        "force_N": np.asarray(curve["force"], float),
        "height_measured_m": np.asarray(curve["height (measured)"], float)
        if "height (measured)" in columns else nan,
        "height_piezo_m": np.asarray(curve["height (piezo)"], float)
        if "height (piezo)" in columns else nan,
    }
    sizes = {key: v.shape for key, v in cols.items()}
    if len(set(sizes.values())) > 1:
        raise DataError(
            f"{path}, curve {k}: its channels differ in length "
            f"({', '.join(f'{key} {v[0]}' for key, v in sizes.items())}): a damaged file."
        )
    spring = float(curve.metadata.get("spring constant", np.nan))
    grid = {key: curve.metadata.get(name) for key, name in GRID_KEYS.items()}
    grid = {key: (int(v) if key.startswith("grid") else float(v)) for key, v in grid.items()
            if v is not None and np.isfinite(float(v))}
    meta = dict(name=name, spring_constant=spring, contact_index=None, contact_time=None,
                modality=curve.modality, afm=grid or None)
    cols.update(force_rise_N=nan, indentation_m=nan, contact_strain=nan)
    if analyse:
        if not 0 < spring < math.inf:
            raise DataError(f"{path}, curve {k}: the file gives no spring constant.")
        from ._contact import analyse as nanite_analysis

        label = f"{path}, curve {k}"
        try:
            rise, delta, c, block = nanite_analysis(curve, label, tip, poisson, contact,
                                                    baseline)
        except DataError:
            raise
        except Exception as e:  # noqa: BLE001 - nanite's own failure on this curve: one line
            raise DataError(f"{label}: nanite's analysis failed ({_first_line(e)}).") from None
        cols.update(force_rise_N=rise, indentation_m=delta)
        if tip is not None:
            cols["contact_strain"] = contact_strain(delta, tip, poisson)
        meta.update(contact_index=c, contact_time=float(t[c]),
                    afm={**block, "contact_time": float(t[c]), **grid})
    return cols, meta
