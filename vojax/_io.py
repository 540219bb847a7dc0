"""Output files: written atomically (beside the target, then renamed over it), with the
permissions the user's umask gives new files, and JSON that strict parsers accept."""

import contextlib
import json
import math
import os
import tempfile
from pathlib import Path


def _file_mode() -> int:
    """``0o666`` less the process's umask (read without changing it where the OS allows)."""
    mask = os.umask(0o022)
    os.umask(mask)
    return 0o666 & ~mask


@contextlib.contextmanager
def atomic_path(path):
    """Yields a temporary path in the target's folder; renames it onto ``path`` on success
    (a reader never sees a partial file; a crash leaves at most a hidden ``.tmp`` file)."""
    path = Path(path)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    os.close(fd)
    try:
        yield tmp
        os.chmod(tmp, _file_mode())  # mkstemp creates 0600 whatever the umask
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
        raise


def strict_json(data):
    """``data`` with every non-finite float replaced by ``None`` (JSON has no NaN/Infinity)."""
    if isinstance(data, float):
        return data if math.isfinite(data) else None
    if isinstance(data, dict):
        return {k: strict_json(v) for k, v in data.items()}
    if isinstance(data, (list, tuple)):
        return [strict_json(v) for v in data]
    return data


def json_text(data) -> str:
    """``data`` as strict JSON text (non-finite numbers become ``null``), keys sorted; a
    `TypeError` or `ValueError` where JSON cannot hold it."""
    return json.dumps(strict_json(data), indent=2, sort_keys=True, allow_nan=False)


def write_json(path, data) -> None:
    """Writes ``data`` as strict JSON (`json_text`), atomically."""
    text = json_text(data)
    with atomic_path(path) as tmp, open(tmp, "w") as f:
        f.write(text + "\n")
