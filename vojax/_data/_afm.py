"""AFM force files (JPK force and force-map files, Igor binary waves, afmformats HDF5) read
through `afmformats` (an optional extra: ``pip install "vojax[afm]"``), with the contact
point, the indentation and the Hertz contact strain that turn a force curve into the input and
output of σ = η D^{q(t)} ε.

The indentation is ``δ = [h(t_c) − h(t)] − [F(t) − F₀]/k``: the piezo's travel since the
contact time ``t_c`` (the measured height when the file has it, else the commanded one) less
the cantilever's deflection, with ``F₀`` the force before contact and ``k`` the spring constant
in the file. With a tip geometry the output can be the contact strain ``x`` of a
Lee–Radok (Hertz) contact, for which the force is the shear relaxation modulus convolved with
``ẋ``: a springpot fitted to ``(F − F₀, x)`` has its η and q in shear units:

- sphere of radius R: ``x = 8 √R δ^{3/2} / (3 (1 − ν))``;
- cone of half-angle θ: ``x = 4 tan θ δ² / (π (1 − ν))``;

with ν the Poisson ratio (0.5, incompressible, by default); ``x = 0`` before contact.
"""

import math
from pathlib import Path

import numpy as np

from ._errors import DataError

AFM_SUFFIXES = (".jpk-force", ".jpk-force-map", ".jpk-qi-data", ".jpk-qi-series", ".ibw", ".h5")
BASELINE_FRACTION = 0.2  # F₀ and its spread from the first 20 % of the loading part
CONTACT_SIGMAS = 5.0  # contact: the force stays more than 5 spreads above F₀ up to its peak
AFM_COLUMNS = ("time_s", "segment", "force_N", "height_measured_m", "height_piezo_m",
               "force_rise_N", "indentation_m", "contact_strain")


def is_afm(path) -> bool:
    return Path(path).suffix.lower() in AFM_SUFFIXES


SPHERE_RADIUS_M = (1e-10, 1e-2)  # a sphere's radius outside these (m) is a unit mistake


def check_tip(tip, poisson=0.5):
    """``None``, ``("sphere", R)`` (R in m) or ``("cone", θ)`` (θ the half-angle in degrees),
    checked; also accepts the command line's ``"sphere:R"`` / ``"cone:θ"``."""
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
                f"a tip is sphere:RADIUS_m or cone:HALF_ANGLE_deg, got {tip!r}."
            ) from None
    if not (isinstance(tip, (tuple, list)) and len(tip) == 2):
        raise ValueError(f"a tip is ('sphere', radius in m) or ('cone', half-angle in degrees), got {tip!r}.")
    shape, size = tip[0], float(tip[1])
    if shape == "sphere":
        lo, hi = SPHERE_RADIUS_M
        if not lo <= size <= hi:
            raise ValueError(
                f"a sphere's radius is in metres, from {lo:g} to {hi:g} (an AFM tip's), got "
                f"{size:g} m."
            )
    elif shape == "cone":
        if not 0 < size < 90:
            raise ValueError(f"a cone's half-angle must lie in (0, 90) degrees, got {size}.")
    else:
        raise ValueError(f"the tip must be a sphere or a cone, got {shape!r}.")
    return shape, size


def contact_strain(indentation, tip, poisson=0.5):
    """The Hertz (Lee–Radok) contact strain of an indentation (m) under `tip` (`check_tip`)."""
    shape, size = check_tip(tip, poisson)
    d = np.clip(np.asarray(indentation, float), 0.0, None)
    if shape == "sphere":
        return 8.0 * math.sqrt(size) * d**1.5 / (3.0 * (1.0 - poisson))
    return 4.0 * math.tan(math.radians(size)) * d**2 / (math.pi * (1.0 - poisson))


def contact_index(force):
    """``(index of the contact point, F₀)``. The loading part is the curve up to its largest
    force (the end of the approach, or in the hold); F₀ and its spread σ (1.4826 × the median
    absolute deviation) come from its first `BASELINE_FRACTION`, and the contact is the first
    sample after which the force stays above ``F₀ + CONTACT_SIGMAS·σ`` up to the largest
    force. None where the force never leaves its baseline."""
    peak = int(np.argmax(force))
    loading = force[: peak + 1]
    head = loading[: max(5, int(BASELINE_FRACTION * loading.size))]
    f0 = float(np.median(head))
    if loading.size < 10:
        return None, f0
    spread = 1.4826 * float(np.median(np.abs(head - f0)))
    above = loading > f0 + CONTACT_SIGMAS * max(spread, 1e-12 * abs(f0), 1e-300)
    if not above[-1]:
        return None, f0
    below = np.flatnonzero(~above)
    return (0 if below.size == 0 else int(below[-1]) + 1), f0


def read_afm(path, *, tip=None, poisson=0.5):
    """The force curves of an AFM file, each as a dict of columns (`AFM_COLUMNS`; the last
    three NaN where no contact is found, ``contact_strain`` NaN without a tip) and a dict of
    metadata (``name``, ``spring_constant``, ``contact_time``, ``modality``)."""
    try:
        import afmformats
    except ImportError:
        raise DataError(
            f'{path}: AFM files are read with afmformats: pip install "vojax[afm]".'
        ) from None
    tip = check_tip(tip, poisson)
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
        out = []
        for k, curve in enumerate(curves):
            name = path.name[: -len(path.suffix)] if len(curves) == 1 else f"{path.stem}-{k}"
            try:
                out.append(_curve(path, k, curve, name, tip, poisson))
            except DataError:
                raise
            except fatal as e:  # noqa: BLE001 - a damaged channel: this file's error
                raise DataError(
                    f"{path}, curve {k}: a damaged channel ({_first_line(e)})."
                ) from None
    finally:
        log.setLevel(level)
    return out


def _first_line(error) -> str:
    return str(error).splitlines()[0] if str(error) else type(error).__name__


def _curve(path, k, curve, name, tip, poisson):
    """One force curve's columns and metadata (see `read_afm`)."""
    columns = set(curve.columns)
    for need in ("time", "force", "segment"):
        if need not in columns:
            raise DataError(f"{path}, curve {k}: has no {need!r} column.")
    height = "height (measured)" if "height (measured)" in columns else "height (piezo)"
    if height not in columns:
        raise DataError(f"{path}, curve {k}: has no height column.")
    t = np.asarray(curve["time"], float)
    force = np.asarray(curve["force"], float)
    segment = np.asarray(curve["segment"], float)
    h = np.asarray(curve[height], float)
    cols = {
        "time_s": t,
        "segment": segment,
        "force_N": force,
        "height_measured_m": np.asarray(curve["height (measured)"], float)
        if "height (measured)" in columns else np.full(t.size, np.nan),
        "height_piezo_m": np.asarray(curve["height (piezo)"], float)
        if "height (piezo)" in columns else np.full(t.size, np.nan),
    }
    sizes = {key: v.shape for key, v in cols.items()}
    if len(set(sizes.values())) > 1 or h.shape != t.shape:
        raise DataError(
            f"{path}, curve {k}: its channels differ in length "
            f"({', '.join(f'{key} {v[0]}' for key, v in sizes.items())}): a damaged file."
        )
    spring = float(curve.metadata.get("spring constant", np.nan))
    c, f0 = contact_index(force)
    nan = np.full(t.size, np.nan)
    if c is None or not (0 < spring < math.inf):
        cols.update(force_rise_N=nan, indentation_m=nan, contact_strain=nan)
        contact = None
    else:
        cols["force_rise_N"] = force - f0
        cols["indentation_m"] = (h[c] - h) - (force - f0) / spring
        cols["contact_strain"] = nan if tip is None else contact_strain(
            cols["indentation_m"], tip, poisson
        )
        contact = c
    meta = dict(
        name=name,
        spring_constant=spring,
        contact_index=contact,
        contact_time=None if contact is None else float(t[contact]),
        modality=curve.modality,
    )
    return cols, meta
