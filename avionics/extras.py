"""The optional parts of the flight install (pyproject.toml's extras): a module that needs one is imported here, so
that a missing extra is one line naming it (exit 2, avionics/cli.py), not an ImportError's traceback."""

from __future__ import annotations

import importlib
from types import ModuleType

from avionics.base.params import ConfigError

# module of ours -> (the extra it needs, the package of that extra)
EXTRA_MODULES = {
    "avionics.monitor.tui": ("monitor", "rich"),  # avionics monitor --tui
    "avionics.io.feeds.beast": ("beast", "pyModeS"),  # --traffic beast:HOST:PORT
}


def import_extra(module: str, what: str) -> ModuleType:
    """importlib.import_module(module); where it needs an extra that is not installed, ConfigError naming it."""
    try:
        return importlib.import_module(module)
    except ModuleNotFoundError as exc:
        extra, package = EXTRA_MODULES.get(module, (None, None))
        if extra is None or exc.name is None or exc.name.split(".")[0] != package:
            raise
        raise ConfigError(f"{what} needs {package}, which is not installed: pip install 'avionics-daa[{extra}]' "
                          f"(from a clone: pip install '.[{extra}]')") from None
