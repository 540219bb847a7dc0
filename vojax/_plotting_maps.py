"""Maps of a force map's curves: the Young's modulus, the order, its band and the verdict over
the grid, from the rows of a batch's ``summary.csv``."""

import numpy as np

from ._plotting import _figure, _save

VERDICTS = ("not identified", "conditional", "identified")
MAX_MAPS = 6  # map files drawn in one figure; the rest are in summary.csv only


def map_rows(rows) -> dict:
    """The rows of curves with grid indices, by source file (the files that are maps)."""
    maps = {}
    for row in rows:
        if row.get("afm_grid_index_x") is None or row.get("afm_grid_index_y") is None:
            continue
        maps.setdefault(row["source"], []).append(row)
    return maps


def _number(row, key):
    value = row.get(key)
    try:
        return float(value)
    except (TypeError, ValueError):
        return np.nan


def _panels(rows):
    """``(title, key → value of a row, colour map)`` for each quantity the rows carry."""
    tracker = any("kalman_alpha_final" in r for r in rows)
    order = "kalman_alpha_final" if tracker else "refit_order"
    panels = [("Young's modulus E (Pa)", lambda r: _number(r, "afm_youngs_modulus_Pa"),
               "viridis")]
    if tracker:
        panels.append(("final order α", lambda r: _number(r, order), "magma"))
        panels.append(("band half-width (±2σ)",
                       lambda r: 2 * _number(r, "kalman_alpha_final_std"), "cividis"))
        panels.append(("verdict",
                       lambda r: float(VERDICTS.index(r["verdict"]))
                       if r.get("verdict") in VERDICTS else np.nan, "RdYlGn"))
    elif any("refit_order" in r for r in rows):
        panels.append(("refit order q", lambda r: _number(r, order), "magma"))
        panels.append(("refit 95 % half-width", lambda r: (
            _number(r, "refit_order_upper") - _number(r, "refit_order_lower")) / 2, "cividis"))
    return panels


def map_figure(rows, path) -> list:
    """Draws the maps of every map file among `rows` (at most `MAX_MAPS`), each cut to the
    part of the grid measured (NaN where no curve is).

    **Returns:** ``[(source, title, image, (x0, y0)), ...]``, the images drawn with the grid
    indices of their first pixel; ``[]``, drawing nothing, where no row has grid indices."""
    maps = map_rows(rows)
    drawn = []
    if not maps:
        return drawn
    files = sorted(maps)[:MAX_MAPS]
    panels = _panels([r for f in files for r in maps[f]])
    fig = _figure(figsize=(3.6 * len(panels), 3.4 * len(files)), layout="constrained")
    for sub, source in zip(np.atleast_1d(fig.subfigures(len(files), 1)), files):
        curves = maps[source]
        ix = np.array([int(float(r["afm_grid_index_x"])) for r in curves])
        iy = np.array([int(float(r["afm_grid_index_y"])) for r in curves])
        shape = [_number(curves[0], f"afm_grid_shape_{a}") for a in ("x", "y")]
        grid = (f"{int(shape[0])} × {int(shape[1])} grid" if np.all(np.isfinite(shape))
                else "grid")
        sub.suptitle(f"{source.replace(chr(92), '/').rpartition('/')[2]}: {len(curves)} "
                     f"curves of a {grid} (the part measured)")
        x0, y0 = ix.min(), iy.min()
        extent = (x0 - 0.5, ix.max() + 0.5, y0 - 0.5, iy.max() + 0.5)
        for ax, (title, value, cmap) in zip(np.atleast_1d(sub.subplots(1, len(panels))), panels):
            image = np.full((iy.max() - y0 + 1, ix.max() - x0 + 1), np.nan)
            image[iy - y0, ix - x0] = [value(r) for r in curves]
            drawn.append((source, title, image, (int(x0), int(y0))))
            shown = ax.imshow(image, origin="lower", cmap=cmap, interpolation="nearest",
                              extent=extent,
                              **({"vmin": 0, "vmax": 2} if title == "verdict" else {}))
            bar = sub.colorbar(shown, ax=ax, shrink=0.8)
            if title == "verdict":
                bar.set_ticks([0, 1, 2], labels=list(VERDICTS))
            ax.set(title=title, xlabel="grid x", ylabel="grid y")
    if len(maps) > len(files):
        fig.suptitle(f"{len(files)} of {len(maps)} maps drawn; every curve is in summary.csv")
    _save(fig, path)
    return drawn
