"""Modules imported on first use: a command imports only what it runs.

Importing the package's settings models (``import ftc_mj.config``, ``ftc-mj --help``, validating a config)
reaches the modules that declare them beside their components, and those import their heavy libraries —
CasADi (≈ 0.1 s), SciPy's linear algebra (≈ 0.3 s). :func:`lazy_module` gives such a module as a stand-in
that runs the real import on its first attribute access (:class:`importlib.util.LazyLoader`), so a
process that validates a config and exits never pays for a solver library it does not call. The module is
the real one once loaded; nothing but the time of the import changes.
"""

from __future__ import annotations

import importlib.util
import sys
from types import ModuleType


def lazy_module(name: str) -> ModuleType:
    """The module ``name`` (``"casadi"``), executed on the first access to one of its attributes; the loaded
    module itself when it has been imported already."""
    if name in sys.modules:
        return sys.modules[name]
    spec = importlib.util.find_spec(name)
    if spec is None or spec.loader is None:
        raise ModuleNotFoundError(f"No module named {name!r}", name=name)
    spec.loader = importlib.util.LazyLoader(spec.loader)
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    spec.loader.exec_module(module)
    return module
