"""Record names (from the data: file stems or `--group-by` values) as safe folder names.

`record_folder` is injective and never yields a separator, ``.``, ``..``, an empty name, a
name over `MAX_LEN` characters, or a name reserved by the batch's own files or by Windows:

- letters, digits, ``-``, ``_`` and (not leading) ``.`` are kept; every other character,
  ``%`` included, becomes ``%XX`` (UTF-8 bytes in hex), so distinct names stay distinct;
- a name that had to be shortened, contains an upper-case letter (two names differing only
  in case would share a folder on a case-insensitive file system) or is reserved gets
  ``~`` and 10 hex digits of its SHA-256 inserted before its first ``.`` (at its end where it
  has none; ``~`` is otherwise always encoded), so that a reserved device name with an
  extension (``con.1``) is no longer one.

The original name is kept in the record's ``summary.json`` and in ``summary.csv``.
"""

import hashlib
import re
from pathlib import Path

MAX_LEN = 120
_KEEP = re.compile(r"[A-Za-z0-9_\-.]")
RESERVED = {
    "summary.csv",
    "failures.csv",
    "summary.json",
    "identification.csv",
    "identification.png",
    "identification.svg",
    "identification.pdf",
    "overview.png",
    "maps.png",
    ".vojax-batch.lock",
    "con",
    "prn",
    "aux",
    "nul",
    *(f"com{i}" for i in range(10)),
    *(f"lpt{i}" for i in range(10)),
}


def _encode(name: str) -> str:
    out = []
    for i, ch in enumerate(name):
        if _KEEP.fullmatch(ch) and not (ch == "." and i == 0):
            out.append(ch)
        else:
            out.append("".join(f"%{b:02x}" for b in ch.encode("utf-8")))
    return "".join(out)


def record_folder(name: str) -> str:
    """The folder name of the record called `name` (see the module's docstring)."""
    if not isinstance(name, str):
        raise TypeError(f"a record name must be a string, got {type(name).__name__}.")
    encoded = _encode(name)
    stem = encoded.split(".")[0].lower()
    needs_hash = (
        not encoded
        or len(encoded) > MAX_LEN
        or encoded != encoded.lower()
        or encoded.lower() in RESERVED
        or stem in RESERVED
    )
    if not needs_hash:
        return encoded
    digest = hashlib.sha256(name.encode("utf-8")).hexdigest()[:10]
    # before the first dot: Windows reserves a device's name with any extension (con.1)
    head, dot, rest = encoded[:MAX_LEN].partition(".")
    return f"{head}~{digest}{dot}{rest}"


def inside(root: Path, component: str) -> Path:
    """``root/component``, checked to resolve inside ``root`` (never a path outside it)."""
    root = Path(root).resolve()
    target = (root / component).resolve()
    if target.parent != root:
        raise ValueError(f"record folder {component!r} would leave the output folder {root}.")
    return target


def check_out_holds_no_input(out, inputs) -> None:
    """`ValueError` when the output folder `out` is an input file, or holds one of `inputs`
    (in it or below it): vojax would write its tables and folders beside the data, and a
    file of the same name as an output (``summary.csv``, ``identification.csv``…) would be
    overwritten. Paths are compared resolved (links followed)."""
    root = Path(out).resolve()
    for source in inputs:
        if not source:
            continue
        path = Path(source).resolve()
        if path == root or root in path.parents:
            where = "is" if path == root else "holds"
            raise ValueError(
                f"the output folder {str(out)!r} {where} the input {str(source)!r}: vojax "
                "would write beside (or over) your data; choose a new folder for --out."
            )


MANIFEST = ".vojax-outputs"  # the files vojax wrote in an output folder, one per line


def _written(out: Path) -> set[str]:
    path = out / MANIFEST
    if path.is_symlink() or (path.exists() and not path.is_file()):
        raise ValueError(f"{str(path)!r} is not a file vojax wrote; choose a new folder for --out.")
    if not path.exists():
        return set()
    return {line for line in path.read_text(encoding="utf-8").splitlines() if line}


def claim_outputs(out, names) -> None:
    """Declares that vojax is about to write the files `names` (paths relative to the output
    folder `out`) and records them in the folder's manifest (`MANIFEST`) first. `ValueError`
    when one of them already exists there and is not in the manifest: a file vojax did not
    write (the user's own ``summary.csv``, say) is never overwritten. A name is refused too
    if it would leave `out`."""
    from .._io import atomic_path

    out = Path(out)
    root = out.resolve()
    names = [str(n) for n in names]
    known = _written(out)
    for name in names:
        target = out / name
        if root not in (root / name).resolve().parents and not target.is_symlink():
            raise ValueError(f"output {name!r} would leave the output folder {str(out)!r}.")
        if name not in known and (target.exists() or target.is_symlink()):
            raise ValueError(
                f"{str(target)!r} exists and was not written by vojax: vojax never overwrites "
                "a file it did not write; choose a new folder for --out, or move that file."
            )
    new = known | set(names)
    if new != known:
        with atomic_path(out / MANIFEST) as tmp:
            Path(tmp).write_text("".join(f"{n}\n" for n in sorted(new)), encoding="utf-8")
