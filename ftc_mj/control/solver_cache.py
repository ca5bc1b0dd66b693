"""Build each IPOPT ``nlpsol`` once per machine: a disk cache of serialised CasADi solvers.

Creating an ``nlpsol`` derives the gradient, the constraint Jacobian and the Lagrangian Hessian of the
SX graph symbolically; for the path-following and robust NMPCs that is 1–5 s per process. CasADi can
serialise the finished solver (``Function.serialize``) and rebuild it from that text without
differentiating again. The loaded solver is the same instruction sequence with the same options, so
its results are bitwise those of a fresh build (``tests/control/test_solver_cache.py``).

Key: SHA-256 of the CasADi version, the solver name, the serialised problem (``x``, ``p`` → ``f``,
``g``: every symbol, operation and constant) and the options. A changed problem, option or CasADi
version is a new key; a file that cannot be read or loaded is rebuilt and replaced. Files are
written atomically (a temporary name, then ``os.replace``), so concurrent processes never read half a
file. Each entry is the zlib-compressed serialisation (a few MB); loading an entry sets its
modification time, so the oldest files are the least recently used (:func:`prune`).

Where: ``$FTC_MJ_CACHE_DIR/solvers`` if set, else ``$XDG_CACHE_HOME/ftc-mj/solvers`` (default
``~/.cache/ftc-mj/solvers``). ``FTC_MJ_SOLVER_CACHE=off`` builds every solver afresh. Deleting the
folder is always safe.
"""

from __future__ import annotations

import hashlib
import os
import tempfile
import time
import zlib
from pathlib import Path

import casadi as ca

CACHE_ENV = "FTC_MJ_CACHE_DIR"
"""Environment variable naming the cache root (the solvers go to its ``solvers/`` folder)."""
SWITCH_ENV = "FTC_MJ_SOLVER_CACHE"
"""Environment variable: ``off``/``0``/``no`` disables the solver cache."""

stats = {"built": 0, "loaded": 0}
"""This process's counts of solvers built afresh and loaded from the cache."""


def cache_dir() -> Path | None:
    """The folder of cached solvers, or ``None`` when the cache is switched off."""
    if os.environ.get(SWITCH_ENV, "").strip().lower() in ("off", "0", "no", "false"):
        return None
    root = os.environ.get(CACHE_ENV)
    if root:
        return Path(root) / "solvers"
    xdg = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(xdg) / "ftc-mj" / "solvers"


def problem_key(name: str, nlp: dict, opts: dict) -> str:
    """32 hex digits identifying the solver ``name`` of ``nlp`` (``x``, ``p``, ``f``, ``g``) with ``opts``."""
    problem = ca.Function("key", [nlp["x"], nlp["p"]], [nlp["f"], nlp["g"]]).serialize()
    h = hashlib.sha256()
    for part in (ca.__version__, name, problem, repr(sorted(opts.items()))):
        h.update(part.encode())
        h.update(b"\0")
    return h.hexdigest()[:32]


def _load(path: Path) -> ca.Function | None:
    try:
        solver = ca.Function.deserialize(zlib.decompress(path.read_bytes()).decode())
    except FileNotFoundError:
        return None
    except (OSError, zlib.error, UnicodeDecodeError, RuntimeError):
        return None  # unreadable or from an incompatible build: rebuilt and replaced
    try:
        os.utime(path)  # the modification time is the last use: old entries can be pruned by age
    except OSError:
        pass
    return solver


def _store(path: Path, solver: ca.Function) -> None:
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", dir=path.parent)
        with os.fdopen(fd, "wb") as f:
            f.write(zlib.compress(solver.serialize().encode(), 1))
        os.replace(tmp, path)
    except OSError:
        pass  # a read-only or full disk costs the next process a build, nothing else


def ipopt_solver(name: str, nlp: dict, opts: dict) -> ca.Function:
    """``ca.nlpsol(name, "ipopt", nlp, opts)``, loaded from the cache when this machine built it before.

    ``nlp`` must hold SX expressions ``x``, ``p``, ``f`` and ``g``."""
    folder = cache_dir()
    if folder is None:
        stats["built"] += 1
        return ca.nlpsol(name, "ipopt", nlp, opts)
    path = folder / f"{name}-{problem_key(name, nlp, opts)}.casadi.z"
    solver = _load(path)
    if solver is not None:
        stats["loaded"] += 1
        return solver
    solver = ca.nlpsol(name, "ipopt", nlp, opts)
    stats["built"] += 1
    _store(path, solver)
    return solver


def prune(folder: Path, max_age_s: float) -> int:
    """Delete the cached solvers in ``folder`` not used (built or loaded) for ``max_age_s`` seconds;
    return how many were deleted."""
    cutoff = time.time() - max_age_s
    gone = 0
    for path in Path(folder).glob("*.casadi.z"):
        try:
            if path.stat().st_mtime < cutoff:
                path.unlink()
                gone += 1
        except OSError:
            pass
    return gone
