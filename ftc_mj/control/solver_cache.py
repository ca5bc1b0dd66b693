"""Build each IPOPT ``nlpsol`` once per machine: a disk cache of serialised CasADi solvers.

Creating an ``nlpsol`` derives the gradient, the constraint Jacobian and the Lagrangian Hessian of the
SX graph symbolically; for the path-following and robust NMPCs that is 1–5 s per process. CasADi can
serialise the finished solver (``Function.save``) and rebuild it from that file (``Function.load``,
streamed: :func:`_load_function`) without differentiating again. The loaded solver is the same instruction
sequence with the same options, so its results are bitwise those of a fresh build
(``tests/control/test_solver_cache.py``).

Key: SHA-256 of the CasADi version, the solver name, the serialised problem (``x``, ``p`` → ``f``,
``g``: every symbol, operation and constant) and the options. A changed problem, option or CasADi
version is a new key. An entry is :data:`MAGIC`, one JSON header line recording what it was built from
(the CasADi version, the key, the function's name, its inputs' and outputs' shapes, the payload's size
and SHA-256), then the zlib-compressed serialisation (a few MB; 10 MB for the path-following NLP). An entry is
used only when all of that matches the problem asked for and the loaded function has the name and the shapes
that problem's ``nlpsol`` has; anything else (an old-format or damaged file, another problem's solver under the key,
an empty function, a folder, a named pipe, a device, a link out of the folder, a file over
:data:`MAX_ENTRY_BYTES`) is rebuilt and replaced, with one warning line on stderr. Files are written
atomically (a temporary name, then ``os.replace``; the temporary is removed when that fails), so
concurrent processes never read half a file. Loading an entry sets its modification time, so the
oldest files are the least recently used (:func:`prune`).

A process keeps the solvers it loaded or built in memory (:data:`_in_memory`), one per structure (the
solver's name and its inputs' and outputs' shapes): a controller built again for a problem of the same
structure and the same key (a bench worker's next draw, a run after :func:`ftc_mj.sim.cache.clear`) gets
the same ``Function`` back instead of deserialising it again (0.3–3 s a draw). A ``Function`` keeps no
state between calls (warm starts are its inputs), so sharing it does not change a result; a problem of
the same structure under a new key (other constants) replaces the kept one, so the memory a process holds
does not grow with the problems it has seen.

Where: ``solvers/`` of the cache root (:mod:`ftc_mj.disk_cache`: ``$FTC_MJ_CACHE_DIR`` if set, else
``~/.cache/ftc-mj``). ``FTC_MJ_SOLVER_CACHE=off`` builds every solver afresh. Deleting the folder is always
safe.
"""

from __future__ import annotations

import hashlib
import json
import os
import stat
import sys
import tempfile
import time
import zlib
from pathlib import Path

from ..disk_cache import cache_root, mark_used
from ..lazy import lazy_module

ca = lazy_module("casadi")

MAGIC = b"ftc-mj solver cache 3\n"
"""First line of an entry (format 3: then one JSON header line, then the compressed file of ``Function.save``;
format 2 held ``Function.serialize``'s text, which loads only from a string: three copies of it in memory)."""
CHUNK = 2**20
"""Bytes decompressed at a time when an entry is loaded (:func:`_load_function`)."""
MAX_ENTRY_BYTES = 256 * 2**20
"""Largest entry read (bytes); the largest solver of the package compresses to a few MB."""

stats = {"built": 0, "loaded": 0, "reused": 0}
"""This process's counts of solvers built afresh, loaded from the cache and reused from memory."""
_in_memory: dict[str, tuple[str, ca.Function]] = {}
"""This process's solvers: structure (name and shapes) → (key, solver), the one most recently asked for."""
_asked: dict[str, int] = {}
"""When each kept solver was last asked for: the value of :func:`asked_count` then."""


class EntryRejected(Exception):
    """A cache entry that must not be used; ``str()`` says why in a few words."""


def cache_dir() -> Path | None:
    """The folder of cached solvers (``solvers/`` of :func:`~ftc_mj.disk_cache.cache_root`), or ``None`` when the
    cache is switched off."""
    root = cache_root()
    return None if root is None else root / "solvers"


def problem_key(name: str, nlp: dict, opts: dict) -> str:
    """32 hex digits identifying the solver ``name`` of ``nlp`` (``x``, ``p``, ``f``, ``g``) with ``opts``."""
    problem = ca.Function("key", [nlp["x"], nlp["p"]], [nlp["f"], nlp["g"]]).serialize()
    h = hashlib.sha256()
    for part in (ca.__version__, name, problem, repr(sorted(opts.items()))):
        h.update(part.encode())
        h.update(b"\0")
    return h.hexdigest()[:32]


def expected_signature(nlp: dict) -> dict[str, list]:
    """The ``[name, rows, columns, nonzeros]`` of every input and output an IPOPT ``nlpsol`` of ``nlp`` has
    (dense vectors: the decision variables ``x``, the parameters ``p``, the constraints ``g``)."""
    x, p = tuple(nlp["x"].shape), tuple(nlp["p"].shape)
    g = (int(nlp["g"].numel()), 1)
    shape = {"x0": x, "p": p, "lbx": x, "ubx": x, "lbg": g, "ubg": g, "lam_x0": x, "lam_g0": g,
             "x": x, "f": (1, 1), "g": g, "lam_x": x, "lam_g": g, "lam_p": p}
    return {"in": [[n, *shape[n], shape[n][0] * shape[n][1]] for n in ca.nlpsol_in()],
            "out": [[n, *shape[n], shape[n][0] * shape[n][1]] for n in ca.nlpsol_out()]}


def signature(f: ca.Function) -> dict[str, list]:
    """The ``[name, rows, columns, nonzeros]`` of every input and output of ``f``."""
    return {"in": [[f.name_in(i), f.size1_in(i), f.size2_in(i), f.nnz_in(i)] for i in range(f.n_in())],
            "out": [[f.name_out(i), f.size1_out(i), f.size2_out(i), f.nnz_out(i)] for i in range(f.n_out())]}


def header(key: str, name: str, nlp: dict, payload: bytes) -> dict:
    """What an entry records about itself: format, CasADi version, key, function name, the shapes of
    its inputs and outputs, the payload's size (bytes) and SHA-256."""
    return {"casadi": ca.__version__, "key": key, "name": name, "signature": expected_signature(nlp),
            "payload_bytes": len(payload), "sha256": hashlib.sha256(payload).hexdigest()}


def _read_regular(path: Path) -> bytes | None:
    """The bytes of the entry ``path`` if it is a regular file in its folder (a link is followed only to
    a regular file inside the same folder) of at most :data:`MAX_ENTRY_BYTES`; ``None`` if there is
    none. Opened non-blocking and checked again after opening, so a named pipe or a device never
    blocks the process."""
    try:
        st = os.lstat(path)
    except FileNotFoundError:
        return None
    if stat.S_ISLNK(st.st_mode):
        target = path.resolve()
        if target.parent != path.parent.resolve():
            raise EntryRejected("a link out of the cache folder")
        st = os.lstat(target)
        path = target
    if not stat.S_ISREG(st.st_mode):
        raise EntryRejected("not a regular file")
    if st.st_size > MAX_ENTRY_BYTES:
        raise EntryRejected(f"larger than {MAX_ENTRY_BYTES} bytes")
    fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_NOFOLLOW", 0))
    with os.fdopen(fd, "rb") as fh:
        if not stat.S_ISREG(os.fstat(fd).st_mode):
            raise EntryRejected("not a regular file")
        return fh.read(MAX_ENTRY_BYTES + 1)


def _load_function(payload: bytes, folder: Path) -> ca.Function:
    """The function whose ``Function.save`` file ``payload`` compresses: decompressed a :data:`CHUNK` at a time
    into a temporary file (in ``folder``, else the system's temporary folder) that ``Function.load`` streams
    from, so the process never holds the uncompressed text (≈ 70 MB for the path-following NLP: as a string
    it cost a worker 200 MB of peak memory a load). The temporary is always removed."""
    dec = zlib.decompressobj()
    for where in (folder, None):
        try:
            fd, tmp = tempfile.mkstemp(prefix=".load-", dir=where)
        except OSError:
            continue
        try:
            with os.fdopen(fd, "wb") as fh:
                for k in range(0, len(payload), CHUNK):
                    fh.write(dec.decompress(payload[k:k + CHUNK]))
                fh.write(dec.flush())
            if not dec.eof:
                raise zlib.error("incomplete payload")
            return ca.Function.load(tmp)
        finally:
            os.unlink(tmp)
    raise RuntimeError("no folder to load the solver from")


def _verified(data: bytes, key: str, name: str, nlp: dict, folder: Path) -> ca.Function:
    """The solver in the entry ``data`` once its header, payload and function match the problem (``key``,
    ``name``, ``nlp``); :class:`EntryRejected` saying what does not (``folder``: where it is loaded from)."""
    if not data.startswith(MAGIC):
        raise EntryRejected("not an entry of this format")
    line, sep, payload = data[len(MAGIC):].partition(b"\n")
    try:
        head = json.loads(line) if sep else None
    except (UnicodeDecodeError, json.JSONDecodeError):
        head = None
    if not isinstance(head, dict):
        raise EntryRejected("unreadable header")
    want = header(key, name, nlp, payload)
    for field in ("casadi", "key", "name", "signature", "payload_bytes", "sha256"):
        if head.get(field) != want[field]:
            raise EntryRejected(f"{field} does not match")
    try:
        solver = _load_function(payload, folder)
    except (zlib.error, RuntimeError) as err:
        raise EntryRejected(f"cannot be loaded ({type(err).__name__})") from None
    if solver.is_null() or solver.name() != name or signature(solver) != want["signature"]:
        raise EntryRejected("the function is not this problem's solver")
    return solver


def _load(path: Path, key: str, name: str, nlp: dict) -> ca.Function | None:
    """The verified solver of ``path``; ``None`` when there is no entry or (one warning line) when it
    cannot be used."""
    try:
        data = _read_regular(path)
        if data is None:
            return None
        solver = _verified(data, key, name, nlp, path.parent)
    except (EntryRejected, OSError) as err:
        why = err.strerror if isinstance(err, OSError) and err.strerror else str(err)
        print(f"ftc-mj: warning: solver cache entry {path} cannot be used ({why}); rebuilding it",
              file=sys.stderr)
        return None
    mark_used(path)
    return solver


def _store(path: Path, solver: ca.Function, key: str, name: str, nlp: dict) -> None:
    """Write the entry of ``solver`` atomically; a failure (a read-only or full disk, a folder in the
    entry's place) leaves no temporary file and costs the next process a build, nothing else."""
    tmp: str | None = None
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", dir=path.parent)
        os.close(fd)
        solver.save(tmp)
        with open(tmp, "rb") as f:
            payload = zlib.compress(f.read(), 1)
        head = json.dumps(header(key, name, nlp, payload), sort_keys=True).encode() + b"\n"
        with open(tmp, "wb") as f:
            f.write(MAGIC + head + payload)
        os.replace(tmp, path)
        tmp = None
    except (OSError, RuntimeError):  # RuntimeError: CasADi could not write the file
        pass
    finally:
        if tmp is not None:
            try:
                os.unlink(tmp)
            except OSError:
                pass


def disk_cached_solver(name: str, nlp: dict, opts: dict, key: str | None = None) -> ca.Function:
    """``ca.nlpsol(name, "ipopt", nlp, opts)``, loaded from the disk cache when this machine built it before,
    else built and stored (the disk layer of :func:`ipopt_solver`; ``key``: the problem's
    :func:`problem_key` when the caller has it).

    ``nlp`` must hold SX expressions ``x``, ``p``, ``f`` and ``g``."""
    folder = cache_dir()
    if folder is None:
        stats["built"] += 1
        return ca.nlpsol(name, "ipopt", nlp, opts)
    key = key or problem_key(name, nlp, opts)
    path = folder / f"{name}-{key}.casadi.z"
    solver = _load(path, key, name, nlp)
    if solver is not None:
        stats["loaded"] += 1
        return solver
    solver = ca.nlpsol(name, "ipopt", nlp, opts)
    stats["built"] += 1
    _store(path, solver, key, name, nlp)
    return solver


def ipopt_solver(name: str, nlp: dict, opts: dict) -> ca.Function:
    """``ca.nlpsol(name, "ipopt", nlp, opts)``: the solver this process keeps for the problem's structure
    when it has the same key, else :func:`disk_cached_solver`'s (then kept); with the cache switched off,
    always a new build.

    ``nlp`` must hold SX expressions ``x``, ``p``, ``f`` and ``g``."""
    if cache_dir() is None:
        return disk_cached_solver(name, nlp, opts)
    key = problem_key(name, nlp, opts)
    structure = json.dumps([name, expected_signature(nlp)])
    kept = _in_memory.pop(structure, None)  # not kept while another one loads (freed unless a controller holds it)
    if kept is not None and kept[0] == key:
        stats["reused"] += 1
        solver = kept[1]
    else:
        del kept
        solver = disk_cached_solver(name, nlp, opts, key)
    _in_memory[structure] = (key, solver)
    _asked[structure] = asked_count()
    return solver


def asked_count() -> int:
    """How many times this process has asked :func:`ipopt_solver` for a kept solver (with the cache on): a clock
    for :func:`forget_solvers`."""
    return sum(stats.values())


def forget_solvers(not_asked_since: int | None = None) -> int:
    """Drop the solvers this process keeps in memory (the next controller loads its solver from the disk
    cache again); with ``not_asked_since`` (an earlier :func:`asked_count`) only those not asked for since then.
    A controller that holds a solver keeps it all the same. Returns how many were dropped."""
    gone = [s for s in _in_memory if not_asked_since is None or _asked.get(s, 0) <= not_asked_since]
    for structure in gone:
        _in_memory.pop(structure)
        _asked.pop(structure, None)
    return len(gone)


def prune(folder: Path, max_age_s: float) -> int:
    """Delete the cached solvers in ``folder`` not used (built or loaded) for ``max_age_s`` seconds, and the
    temporaries of loads that older (a process killed while loading leaves one, :func:`_load_function`);
    return how many solvers were deleted."""
    cutoff = time.time() - max_age_s
    for tmp in Path(folder).glob(".load-*"):
        try:
            if tmp.stat().st_mtime < cutoff:
                tmp.unlink()
        except OSError:
            pass
    gone = 0
    for path in Path(folder).glob("*.casadi.z"):
        try:
            if path.stat().st_mtime < cutoff:
                path.unlink()
                gone += 1
        except OSError:
            pass
    return gone
