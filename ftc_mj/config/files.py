"""Reading config files: built-in scenario names or paths, TOML files with a size bound and every
failure (missing, unreadable, not UTF-8, bad syntax, nested too deeply) as a one-line
:class:`~ftc_mj.errors.BadInput` naming the file."""

from __future__ import annotations

import tomllib
from pathlib import Path
from typing import Any

from .. import resources
from ..errors import BadInput
from ..suggest import did_you_mean

BUILTIN_SCENARIOS = resources.builtin_scenarios()
"""Names of the scenarios shipped in the package (``scenario1`` … ``scenario4``)."""
MAX_TOML_BYTES = 4 * 2**20
"""Largest scenario or study file read (bytes): config files are a few kB."""


def scenario_path(name_or_path: str | Path) -> Path:
    """Resolve a built-in scenario name or a TOML path."""
    s = str(name_or_path)
    if s in BUILTIN_SCENARIOS:
        return resources.scenario_file(s)
    return existing_file(s, "scenario", "no such built-in scenario or file", did_you_mean(s, BUILTIN_SCENARIOS))


def existing_file(s: str, what: str, missing: str = "no such file", hint: str = "") -> Path:
    """``Path(s)`` if it names a readable regular file; else :class:`BadInput` (``what: why``, then ``hint``
    when there is no such file, e.g. a "did you mean"), also for names the OS rejects (NUL bytes, too long)."""
    shown = s if len(s) <= 120 else s[:120] + "…"
    if not s or "\0" in s:
        raise BadInput(f"{what}: expected a file path, got {shown!r}")
    p = Path(s)
    try:
        found = p.is_file()
    except OSError as err:
        raise BadInput(f"{what}: {shown}: {err.strerror}") from None
    if not found:
        raise BadInput(f"{what}: {missing}: {shown}{hint}")
    return p


def read_toml(path: Path, what: str = "config") -> dict[str, Any]:
    """The TOML file ``path`` as data (at most :data:`MAX_TOML_BYTES`, UTF-8); every failure a one-line
    :class:`BadInput` starting ``<what> <path>:``."""
    try:
        with open(path, "rb") as fh:
            raw = fh.read(MAX_TOML_BYTES + 1)
    except OSError as err:
        raise BadInput(f"{what} {path}: cannot read: {err.strerror}") from None
    if len(raw) > MAX_TOML_BYTES:
        raise BadInput(f"{what} {path}: larger than {MAX_TOML_BYTES // 2**20} MiB; not a config file")
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as err:
        raise BadInput(f"{what} {path}: {not_utf8(raw, err.start)}") from None
    return parse_toml(text, f"{what} {path}")


def not_utf8(raw: bytes, at: int) -> str:
    """Where a file stops being UTF-8 text, so the user can find and fix it: the byte, its line and
    column (1-based), and what to do (save as UTF-8; or the file is not text at all)."""
    line = raw.count(b"\n", 0, at) + 1
    column = at - (raw.rfind(b"\n", 0, at) + 1) + 1
    binary = b"\0" in raw[:4096]
    fix = ("it is not a text file (it holds NUL bytes)" if binary
           else "save it with the UTF-8 encoding (e.g. a Latin-1 'é' is the byte 0xe9)")
    return f"not UTF-8 text: byte 0x{raw[at]:02x} at line {line}, column {column}; {fix}"


def parse_toml(text: str, what: str) -> dict[str, Any]:
    """``tomllib.loads`` with every failure as a one-line :class:`BadInput` naming ``what``."""
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as err:
        raise BadInput(f"{what}: invalid TOML: {str(err).splitlines()[0]}") from None
    except RecursionError:
        raise BadInput(f"{what}: invalid TOML: nested too deeply") from None

