"""The hostile files of `fuzz_cli.py`'s corpus, written into a folder (`make_files`)."""

import io
import math
import zipfile
from pathlib import Path

import numpy as np

FOREIGN = ("summary.csv", "identification.csv")  # in foreign_out/, written by the user


def _csv(path, t, u, y, header="time_s,stress,strain", extra=None):
    rows = [header + ("" if extra is None else ",note")]
    for k, (a, b, c) in enumerate(zip(t, u, y)):
        rows.append(f"{a!r},{b!r},{c!r}" + ("" if extra is None else f",{extra(k)}"))
    path.write_text("\n".join(rows) + "\n")


def csv_fast(path, t, u, y):
    np.savetxt(path, np.column_stack([t, u, y]), delimiter=",", header="time_s,stress,strain",
               comments="", fmt="%.17g")


def _good(n=40):
    t = np.arange(n) * 0.1
    u = np.minimum(t, 1.0) + 0.1
    y = np.cumsum(u) * 0.05
    return [float(v) for v in t], [float(v) for v in u], [float(v) for v in y]


def _npz_header(path, shape, real=50):
    buffer = io.BytesIO()
    np.lib.format.write_array_header_1_0(
        buffer, {"descr": "<f8", "fortran_order": False, "shape": shape}
    )
    with zipfile.ZipFile(path, "w") as z:
        z.writestr("time_s.npy", buffer.getvalue() + b"\0" * 64)
        for name in ("stress", "strain"):
            out = io.BytesIO()
            np.save(out, np.zeros(real))
            z.writestr(f"{name}.npy", out.getvalue())


def _damaged_jpk(source, path):
    """The JPK file with the force channel of its second segment cut at an odd byte."""
    with zipfile.ZipFile(source) as z, zipfile.ZipFile(path, "w") as out:
        for name in z.namelist():
            data = z.read(name)
            if name == "segments/1/channels/vDeflection.dat":
                data = data[: len(data) // 2 + 1]
            out.writestr(name, data)


def make_files(folder: Path) -> list[str]:
    """The hostile (and a few good) input files; returns their names."""
    t, u, y = _good()
    files = {}

    def add(name, writer):
        writer(folder / name)
        files[name] = None

    add("good.csv", lambda p: _csv(p, t, u, y))
    add("good_long_format.csv", lambda p: p.write_text(
        "specimen,time_s,stress,strain\n" + "".join(
            f"{s},{a!r},{b!r},{c!r}\n" for s in ("=HYPERLINK(1)", "+cmd", "a") for a, b, c in zip(t, u, y)
        )))
    add("empty.csv", lambda p: p.write_text(""))
    add("header_only.csv", lambda p: p.write_text("time_s,stress,strain\n"))
    add("one_row.csv", lambda p: _csv(p, t[:1], u[:1], y[:1]))
    add("two_rows.csv", lambda p: _csv(p, t[:2], u[:2], y[:2]))
    add("text_cell.csv", lambda p: p.write_text(
        "time_s,stress,strain\n" + "".join(f"{a!r},{b!r},{'x' if k == 7 else repr(c)}\n"
                                           for k, (a, b, c) in enumerate(zip(t, u, y)))))
    add("nan_cell.csv", lambda p: _csv(p, t, u, [math.nan if k == 5 else v for k, v in enumerate(y)]))
    add("inf_cell.csv", lambda p: _csv(p, t, [math.inf if k == 3 else v for k, v in enumerate(u)], y))
    add("decreasing.csv", lambda p: _csv(p, t[::-1], u, y))
    add("repeated.csv", lambda p: _csv(p, [0.0] * len(t), u, y))
    add("dup_columns.csv", lambda p: _csv(p, t, u, y, header="time_s,stress,stress"))
    add("missing_column.csv", lambda p: _csv(p, t, u, y, header="time_s,force,strain"))
    add("bom_comments.csv", lambda p: p.write_bytes(
        b"\xef\xbb\xbf# a comment\n" + "\n".join(
            ["time_s,stress,strain"] + [f"{a!r},{b!r},{c!r}" for a, b, c in zip(t, u, y)]
        ).encode()))
    add("big_field.csv", lambda p: _csv(p, t, u, y, extra=lambda k: "x" * (200_000 if k == 3 else 1)))
    add("binary.csv", lambda p: p.write_bytes(bytes(range(256)) * 8))
    add("latin1.csv", lambda p: p.write_bytes("temps_é,stress,strain\n1,2,3\n".encode("latin-1")))
    add("ragged.csv", lambda p: p.write_text("time_s,stress,strain\n0,1\n0.1,1,2\n0.2,1,2,3\n"))
    add("huge_numbers.csv", lambda p: _csv(p, t, [1e308] * len(t), [1e-308] * len(t)))
    add("constant_output.csv", lambda p: _csv(p, t, u, [1.0] * len(t)))
    add("zero_input.csv", lambda p: _csv(p, t, [0.0] * len(t), y))
    add("irregular.csv", lambda p: _csv(p, list(np.cumsum(np.r_[0, np.linspace(0.05, 0.3, len(t) - 1)])), u, y))
    # the newer surface's hostile inputs
    add("quoted_names.csv", lambda p: p.write_text(
        "specimen,time_s,stress,strain\n" + "".join(
            f"{s},{a!r},{b!r},{c!r}\n" for s in ("'=1", "''x", "'") for a, b, c in zip(t, u, y)
        )))
    add("line_separators.csv", lambda p: _csv(
        p, t, u, y, extra=lambda k: "x\u2028y" if k == 5 else ("a\fb" if k == 7 else "n")))
    add("far_clock.csv", lambda p: _csv(p, list(np.linspace(0, 1e308, len(t))), u, y))
    add("zero_stress.csv", lambda p: _csv(p, t, [0.0] * len(t), y))
    add("same_series.csv", lambda p: _csv(p, t, y, y))
    add("tiny_numbers.csv", lambda p: _csv(p, t, [1e-200 * v for v in u], [1e-200 * v for v in y]))
    jpk = Path(__file__).resolve().parents[1] / "tests" / "data" / "afm" / "brain_creep.jpk-force"
    if jpk.is_file():
        raw = jpk.read_bytes()
        add("good.jpk-force", lambda p: p.write_bytes(raw))
        add("cut.jpk-force", lambda p: p.write_bytes(raw[: len(raw) // 2]))
        add("channel.jpk-force", lambda p: _damaged_jpk(jpk, p))
    (folder / "folder.csv").mkdir()
    files["folder.csv"] = None
    # an output folder holding files of the user's named like vojax's outputs
    (folder / "foreign_out").mkdir()
    for name in FOREIGN:
        (folder / "foreign_out" / name).write_text("mine\n")

    def npz(name, **arrays):
        base = {"time_s": np.asarray(t), "stress": np.asarray(u), "strain": np.asarray(y)}
        np.savez(folder / name, **{**base, **arrays})

    add("good.npz", lambda p: npz("good.npz"))
    add("complex.npz", lambda p: npz("complex.npz", stress=np.asarray(u) + 1j))
    add("dates.npz", lambda p: npz("dates.npz", time_s=np.arange(len(t)).astype("datetime64[s]")))
    add("cube.npz", lambda p: npz("cube.npz", strain=np.zeros((4, 5, 2))))
    add("empty.npz", lambda p: p.write_bytes(b""))
    add("cut.npz", lambda p: (npz("cut.npz"), p.write_bytes(p.read_bytes()[:300])))
    add("huge_header.npz", lambda p: _npz_header(p, (2**40,)))
    add("short_data.npz", lambda p: _npz_header(p, (1000,)))
    add("empty_arrays.npz", lambda p: npz("empty_arrays.npz", time_s=np.zeros(0), stress=np.zeros(0), strain=np.zeros(0)))
    return sorted(files)
