"""Where ftc-mj keeps what it computes once per machine, and the small value entries of that cache.

The root is ``$FTC_MJ_CACHE_DIR`` if set, else ``$XDG_CACHE_HOME/ftc-mj`` (default ``~/.cache/ftc-mj``);
``FTC_MJ_SOLVER_CACHE=off`` (also ``0``, ``no``, ``false``) switches the whole cache off. Its folders:
``solvers/`` (serialised IPOPT solvers, :mod:`ftc_mj.control.solver_cache`) and ``thresholds/`` (the change
detectors' calibrated thresholds, :func:`ftc_mj.estimation.calibration.null_threshold`). Deleting the root is
always safe: everything in it is computed again when next asked for.

A *value entry* (:func:`read_value`, :func:`write_value`) is one float under a key: a file ``<key>.json``
holding the key and the float's exact hexadecimal form (``float.hex``), so a read returns the stored number
to the bit. It is written atomically (a temporary name, then a rename); an entry that is damaged, is
not a regular file or names another key is not used, with one warning line on stderr, and is rewritten.
A value computed on this machine may differ in its last bits on another CPU or with other numpy or numba
versions, so a key meant to stand for a computation includes :func:`machine_tag`.
"""

from __future__ import annotations

import functools
import json
import os
import platform
import stat
import sys
import time
from pathlib import Path

from .io import atomic_path

CACHE_ENV = "FTC_MJ_CACHE_DIR"
"""Environment variable naming the cache root."""
SWITCH_ENV = "FTC_MJ_SOLVER_CACHE"
"""Environment variable: ``off``/``0``/``no``/``false`` switches the disk cache off."""
MAX_VALUE_BYTES = 4096
"""Largest value entry read (bytes); a real one is under 100."""


def cache_root() -> Path | None:
    """The cache's root folder (module docstring), or ``None`` when the cache is switched off."""
    if os.environ.get(SWITCH_ENV, "").strip().lower() in ("off", "0", "no", "false"):
        return None
    root = os.environ.get(CACHE_ENV)
    if root:
        return Path(root)
    xdg = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(xdg) / "ftc-mj"


@functools.cache
def machine_tag() -> str:
    """What a computed number's last bits may depend on besides its inputs: the architecture, the CPU model and
    its SIMD flags (numpy's kernels differ by them), and the numpy and numba versions (read from the installed
    distributions: numba is not imported for it)."""
    from importlib.metadata import version

    cpu, flags = "", ""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            key, _, value = line.partition(":")
            if key.strip() == "model name" and not cpu:
                cpu = value.strip()
            elif key.strip() == "flags" and not flags:
                flags = " ".join(sorted(f for f in value.split() if f.startswith(("avx", "fma", "sse4"))))
    except OSError:
        pass
    return (f"{platform.machine()}|{cpu or platform.processor()}|{flags}|numpy {version('numpy')}"
            f"|numba {version('numba')}")


def _warn(path: Path, why: str) -> None:
    print(f"ftc-mj: warning: cache entry {path} cannot be used ({why}); computing it again", file=sys.stderr)


def read_value(path: Path, key: str) -> float | None:
    """The float stored under ``key`` in the entry ``path``; ``None`` when there is none or (one warning line)
    when it cannot be used."""
    try:
        st = os.stat(path, follow_symlinks=False)
    except FileNotFoundError:
        return None
    except OSError as err:
        _warn(path, err.strerror or str(err))
        return None
    if not stat.S_ISREG(st.st_mode) or st.st_size > MAX_VALUE_BYTES:
        _warn(path, "not a small regular file")
        return None
    try:
        entry = json.loads(path.read_text())
        if entry.get("key") != key:
            raise ValueError("another key")
        value = float.fromhex(entry["value"])
    except (OSError, ValueError, TypeError, KeyError, AttributeError) as err:
        _warn(path, str(err) or type(err).__name__)
        return None
    mark_used(path)
    return value


def mark_used(path: Path) -> None:
    """Set the entry's modification time to now: it is the last use, so old entries can be pruned by age."""
    try:
        os.utime(path)
    except OSError:
        pass


def write_value(path: Path, key: str, value: float) -> None:
    """Store ``value`` under ``key`` in the entry ``path`` atomically (:func:`~ftc_mj.io.atomic_path`); a failure (a
    read-only or full disk, a folder in the entry's place) leaves no temporary file and costs the next process a
    computation, nothing else."""
    try:
        with atomic_path(path) as tmp:
            tmp.write_text(json.dumps({"key": key, "value": float(value).hex()}))
    except OSError:
        pass


def prune_values(folder: Path, max_age_s: float) -> int:
    """Delete the value entries in ``folder`` not written or read for ``max_age_s`` seconds (those of an older
    code or machine are never read again), and temporaries that old; return how many entries were deleted."""
    cutoff = time.time() - max_age_s
    gone = 0
    for path in Path(folder).glob("*.json*"):
        try:
            if path.is_file() and path.stat().st_mtime < cutoff:
                path.unlink()
                gone += not path.name.startswith(".")
        except OSError:
            pass
    return gone
