"""The ``vojax`` command: argument types (`_types`), shared options (`_options`), the commands
(`_commands`, `_demo`) and the parser with its entry point (`_main`)."""

from ._main import build_parser as build_parser
from ._main import main as main
from ._types import CLIError as CLIError
from ._types import _count as _count
from ._types import _finite as _finite
from ._types import _fraction as _fraction
from ._types import _positive as _positive
