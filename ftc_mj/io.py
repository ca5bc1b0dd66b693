"""Atomic file and directory output: a killed process never leaves a half-written file under
its final name, and nothing that already exists is overwritten silently.

Temporaries are hidden and carry the writing process's id, ``.<name>.<pid>.<random>.tmp`` (files)
and ``.<name>.<pid>.<random>.partial`` (run directories), so that :func:`remove_stale_temporaries`
can delete the ones a killed process left behind without touching those of a live writer.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import tempfile
import time
from collections.abc import Collection, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import tomli_w


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


@contextmanager
def atomic_path(path: Path) -> Iterator[Path]:
    """Yield a temporary path next to ``path``; on success it is renamed onto ``path``."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.{os.getpid()}.", suffix=".tmp", dir=path.parent)
    os.close(fd)
    tmp_path = Path(tmp)
    try:
        yield tmp_path
        os.chmod(tmp_path, 0o666 & ~_umask())  # mkstemp makes 0600 files; give the usual permissions
        os.replace(tmp_path, path)
    finally:
        if tmp_path.exists():
            tmp_path.unlink()


def _json_default(o: Any) -> Any:
    if isinstance(o, np.generic):
        return o.item()
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, Path):
        return str(o)
    raise TypeError(f"not JSON serialisable: {type(o).__name__}")


def _finite(o: Any) -> Any:
    """Replace non-finite floats by None (JSON has no NaN)."""
    if isinstance(o, dict):
        return {k: _finite(v) for k, v in o.items()}
    if isinstance(o, (list, tuple)):
        return [_finite(v) for v in o]
    if isinstance(o, (float, np.floating)):
        return float(o) if np.isfinite(o) else None
    return o


def write_json(path: Path, data: dict[str, Any] | list[Any]) -> None:
    """Write ``data`` as indented JSON atomically (NaN/inf become null)."""
    with atomic_path(path) as tmp:
        tmp.write_text(json.dumps(_finite(data), indent=2, default=_json_default) + "\n")


def write_toml(path: Path, data: dict[str, Any]) -> None:
    with atomic_path(path) as tmp:
        tmp.write_bytes(tomli_w.dumps(data).encode())


def write_parquet(path: Path, columns: dict[str, np.ndarray], metadata: dict[str, str] | None = None,
                  integers: Collection[str] = ()) -> None:
    """Write equal-length numpy columns as a Parquet table atomically, with optional schema metadata.

    The columns named in ``integers`` (codes, flags, counts kept as floats with NaN for "no value" in
    memory) are stored as 64-bit integers with nulls where NaN — when every finite value is a whole
    number, else (nothing is rounded) as they are. Floats are stored byte-stream-split and zstd-compressed:
    lossless, and about 40 % smaller than the default for noisy simulation data (a 40 s trace: 1.0 MB
    instead of 1.6 MB)."""
    table = pa.table({k: _integer_array(v) if k in integers else pa.array(np.asarray(v)) for k, v in columns.items()})
    if metadata:
        table = table.replace_schema_metadata(metadata)
    floats = {f.name for f in table.schema if pa.types.is_floating(f.type)}
    others = [name for name in table.column_names if name not in floats]
    with atomic_path(path) as tmp:
        pq.write_table(table, tmp, compression="zstd", use_dictionary=others or False,
                       column_encoding=dict.fromkeys(floats, "BYTE_STREAM_SPLIT"))


def _integer_array(values: np.ndarray) -> pa.Array:
    """``values`` as a nullable int64 array (null where NaN), or unchanged if a finite value is not whole."""
    v = np.asarray(values)
    if v.dtype.kind in "iub":
        return pa.array(v.astype(np.int64))
    missing = ~np.isfinite(v)
    whole = np.where(missing, 0.0, v)
    if v.dtype.kind != "f" or np.any(whole != np.round(whole)) or np.any(np.abs(whole) > 2**53):
        return pa.array(v)
    return pa.array(whole.astype(np.int64), mask=missing)


@contextmanager
def atomic_dir(final: Path) -> Iterator[Path]:
    """Yield a fresh temporary directory beside ``final``; on success rename it to ``final``.

    ``final`` must not exist (the caller picks a new name); on failure the temporary directory is
    removed, so a killed or failed run leaves nothing under the final name.
    """
    final = Path(final)
    created = _missing_parents(final.parent)
    done = False
    try:
        final.parent.mkdir(parents=True, exist_ok=True)
        tmp = Path(tempfile.mkdtemp(prefix=f".{final.name}.{os.getpid()}.", suffix=".partial", dir=final.parent))
        try:
            yield tmp
            os.chmod(tmp, 0o777 & ~_umask())
            os.rename(tmp, final)
            done = True
        finally:
            if tmp.exists():
                shutil.rmtree(tmp, ignore_errors=True)
    finally:
        if not done:  # folders made for a run that was not kept go too (if still empty)
            for d in created:
                try:
                    d.rmdir()
                except OSError:
                    break


def _missing_parents(folder: Path) -> list[Path]:
    """The folders ``mkdir(parents=True)`` would create for ``folder``, deepest first."""
    out = []
    p = Path(folder)
    while not p.exists() and p != p.parent:
        out.append(p)
        p = p.parent
    return out


def unique_dir(parent: Path, name: str) -> Path:
    """``parent/name``, or ``parent/name-2``, ``-3`` … if taken (never overwrite a user's run)."""
    cand = Path(parent) / name
    i = 2
    while cand.exists():
        cand = Path(parent) / f"{name}-{i}"
        i += 1
    return cand


_TEMP_RE = re.compile(r"^\..+?(?:\.(?P<pid>\d+))?\.[a-z0-9_]{8}\.(?:tmp|partial)$")
LEGACY_TEMP_AGE_S = 600.0
"""A temporary without a process id (written before they carried one) is stale after this long (s);
a writer keeps its temporaries for seconds (the run's files are written after the simulation)."""


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # another user's live process
        return True
    return True


def remove_stale_temporaries(folder: Path) -> list[Path]:
    """Delete the temporaries of :func:`atomic_path`/:func:`atomic_dir` in ``folder`` whose writing
    process no longer runs on this machine (left by a kill); returns what was removed. A missing or
    unreadable folder has none."""
    folder = Path(folder)
    removed: list[Path] = []
    try:
        entries = list(os.scandir(folder))
    except OSError:
        return removed
    now = time.time()
    for e in entries:
        m = _TEMP_RE.match(e.name)
        if m is None:
            continue
        try:
            stale = (not _alive(int(m.group("pid"))) if m.group("pid")
                     else now - e.stat(follow_symlinks=False).st_mtime > LEGACY_TEMP_AGE_S)
            if not stale:
                continue
            if e.is_dir(follow_symlinks=False):
                shutil.rmtree(e.path)
            else:
                os.unlink(e.path)
        except OSError:
            continue
        removed.append(Path(e.path))
    return removed


_held_locks: dict[str, int] = {}
"""The folders this process holds the writer's lock of (real path → open descriptor)."""


@contextmanager
def writer_lock(folder: Path, option: str = "--out") -> Iterator[Path]:
    """Hold the one-writer lock of the output folder ``folder`` (created if missing) while the block runs.

    An advisory ``flock`` on the folder itself (no lock file to leave behind; released by the kernel
    when the process ends, also on SIGKILL). A second process asking for it gets :class:`BadInput`
    naming ``option`` at once instead of computing the same runs again; within one process the lock
    is re-entrant (``ftc-mj bench`` holds it around the study runner, which takes it too)."""
    import fcntl

    from .errors import BadInput

    folder = Path(folder)
    try:
        folder.mkdir(parents=True, exist_ok=True)
        key = os.path.realpath(folder)
        if key in _held_locks:
            yield folder
            return
        fd = os.open(folder, os.O_RDONLY | getattr(os, "O_DIRECTORY", 0))
    except OSError as err:
        raise BadInput(f"{option}: cannot use {str(folder)[:80]}: {err.strerror}") from None
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        os.close(fd)
        raise BadInput(f"{option}: {folder} is being written by another ftc-mj process (study or bench); wait "
                       "for it to finish or use another folder") from None
    _held_locks[key] = fd
    try:
        yield folder
    finally:
        del _held_locks[key]
        os.close(fd)


def output_failure(err: BaseException, folder: Path | None = None) -> str | None:
    """One line saying why results could not be written, if ``err`` is such a failure: an ``OSError`` (a
    full disk, a folder removed, no permission), or polars' or pyarrow's own error from a writer. Without
    ``folder`` (the error's origin unknown) such an error counts only when it names an OS error; with it
    (the error of writing into ``folder``) it always does, and a full file system there is said.
    ``None`` for anything else."""
    if isinstance(err, OSError):
        where = f": {err.filename}" if err.filename else ""
        return f"cannot write the results: {err.strerror or err}{where}"
    if not (type(err).__module__ or "").startswith(("polars", "pyarrow")):
        return None
    text = " ".join(str(err).split())[:200]
    if folder is None and not any(s in text for s in ("os error", "No space left", "I/O error")):
        return None
    full = ""
    if folder is not None and "No space left" not in text:
        try:
            full = "; no space left on device" if shutil.disk_usage(folder).free == 0 else ""
        except OSError:
            full = ""
    return f"cannot write the results: {type(err).__name__}: {text}{full}"
