"""vojax's version, from the installed package's metadata ("0.0.0" in a source tree)."""

import importlib.metadata


def version() -> str:
    try:
        return importlib.metadata.version("vojax")
    except importlib.metadata.PackageNotFoundError:  # running from a source tree
        return "0.0.0"
