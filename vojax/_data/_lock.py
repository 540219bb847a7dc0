"""The batch's lock on its output folder, and the leftovers of interrupted writes."""


import contextlib
import os
from pathlib import Path

LOCK_NAME = ".vojax-batch.lock"


class BatchBusy(RuntimeError):
    """Another batch holds the output folder's lock."""


@contextlib.contextmanager
def _locked(out_dir: Path):
    """An exclusive, non-blocking lock on ``out_dir`` for the whole run (POSIX ``flock``;
    released by the OS if the process dies)."""
    path = out_dir / LOCK_NAME
    try:  # never through a link: the lock would create or touch a file elsewhere
        fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_APPEND | getattr(os, "O_NOFOLLOW", 0))
    except OSError:
        if path.is_symlink():
            raise BatchBusy(
                f"{path} is a symbolic link; vojax does not follow links in --out: remove it."
            ) from None
        raise
    f = os.fdopen(fd, "a")
    try:
        try:
            import fcntl

            fcntl.flock(f, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except ImportError:  # not POSIX: no lock
            pass
        except OSError:
            raise BatchBusy(
                f"another vojax batch is writing to {out_dir}; wait for it or use another --out."
            ) from None
        yield
    finally:
        f.close()


def _remove_orphans(out_dir: Path):
    """Temporary files left by a killed run (the lock is held: no one else writes here)."""
    for tmp in list(out_dir.glob(".*.tmp")) + list(out_dir.glob("*/.*.tmp")):
        with contextlib.suppress(OSError):
            tmp.unlink()
