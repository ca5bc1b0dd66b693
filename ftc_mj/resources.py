"""The files shipped inside the package: the MJCF robot, the built-in scenarios and studies.

They live in ``ftc_mj/data/`` and are read through :mod:`importlib.resources`, so a non-editable
install or a wheel finds them wherever it is installed, from any working directory:

- ``data/models/*.xml``: MJCF models. A config names one as ``"builtin:<file name>"``
  (:data:`BUILTIN_PREFIX`; the default ``plant.model_file`` is ``"builtin:diffdrive.xml"``), which
  means the same robot on every machine, whatever the install location.
- ``data/scenarios/*.toml``: the paper's scenarios, by name (``scenario1`` … ``scenario4``).
- ``data/studies/*.toml``: the built-in studies, by name (``observability``, ``severity``, …).

:func:`resource_path` gives a file-system path for a shipped file (MuJoCo and the TOML readers
take paths); from a zipped install it extracts the file once per process.
"""

from __future__ import annotations

import atexit
import contextlib
import functools
import hashlib
from importlib import resources
from importlib.resources.abc import Traversable
from pathlib import Path

BUILTIN_PREFIX = "builtin:"
"""Prefix of a ``plant.model_file`` value that names a model shipped in the package."""

DEFAULT_MODEL = BUILTIN_PREFIX + "diffdrive.xml"
"""The paper's robot (suspended and rigid variants)."""

_DATA = ("data",)
_extracted = contextlib.ExitStack()
atexit.register(_extracted.close)


def _data(*parts: str) -> Traversable:
    node = resources.files("ftc_mj")
    for p in (*_DATA, *parts):
        node = node.joinpath(p)
    return node


def _names(folder: str, suffix: str) -> tuple[str, ...]:
    node = _data(folder)
    return tuple(sorted(e.name.removesuffix(suffix) if suffix == ".toml" else e.name
                        for e in node.iterdir() if e.is_file() and e.name.endswith(suffix)))


@functools.cache
def builtin_models() -> tuple[str, ...]:
    """File names of the shipped MJCF models (``diffdrive.xml``)."""
    return _names("models", ".xml")


@functools.cache
def builtin_scenarios() -> tuple[str, ...]:
    """Names of the built-in scenarios (``scenario1`` … ``scenario4``)."""
    return _names("scenarios", ".toml")


@functools.cache
def builtin_studies() -> tuple[str, ...]:
    """Names of the built-in studies (``excitation``, ``observability``, …)."""
    return _names("studies", ".toml")


def resource_path(*parts: str) -> Path:
    """A file-system path of the shipped file ``data/<parts…>`` (extracted once per process when the
    package is imported from a zip)."""
    node = _data(*parts)
    if isinstance(node, Path):
        return node
    return _extracted.enter_context(resources.as_file(node))


def scenario_file(name: str) -> Path:
    """Path of the built-in scenario ``name`` (one of :func:`builtin_scenarios`)."""
    return resource_path("scenarios", f"{name}.toml")


def study_file(name: str) -> Path:
    """Path of the built-in study ``name`` (one of :func:`builtin_studies`)."""
    return resource_path("studies", f"{name}.toml")


def is_builtin_model(value: str) -> bool:
    """``value`` names a shipped model (``builtin:<file name>``)."""
    return value.startswith(BUILTIN_PREFIX)


def model_path(value: str) -> Path:
    """The file a ``plant.model_file`` value names: a shipped model for ``builtin:<name>``, else the
    path itself. ``ValueError`` for an unknown built-in name."""
    if not is_builtin_model(value):
        return Path(value)
    name = value[len(BUILTIN_PREFIX):]
    if name not in builtin_models():
        raise ValueError(f"no built-in model {name!r} (built-in: {', '.join(builtin_models())})")
    return resource_path("models", name)


@functools.lru_cache(maxsize=64)
def _digest(path: str, mtime_ns: int, size: int) -> str:
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def model_digest(value: str) -> str:
    """SHA-256 (hex) of the contents of the model file ``value`` names (:func:`model_path`): the robot
    a run simulates, whatever path it is reached by. Files the MJCF includes are not covered (the
    shipped model includes none)."""
    p = model_path(value)
    st = p.stat()
    return _digest(str(p.resolve()), st.st_mtime_ns, st.st_size)


@functools.cache
def sources_digest() -> str:
    """16 hex digits of the SHA-256 of every ``ftc_mj`` Python source (relative path and bytes, in path
    order): the package's code when no clean git revision names it, and the code part of a disk-cache key
    (computed once per process, 13 ms here)."""
    root = Path(__file__).resolve().parent
    h = hashlib.sha256()
    for f in sorted(root.rglob("*.py")):
        h.update(str(f.relative_to(root)).encode() + b"\0" + f.read_bytes() + b"\0")
    return h.hexdigest()[:16]
