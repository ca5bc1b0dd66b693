"""Whether a folder can take a run directory, checked before simulating: a usage error
(:class:`~ftc_mj.errors.BadInput` naming ``--out``) instead of a run lost at the end."""

from __future__ import annotations

import os
import shutil
import tempfile
from pathlib import Path

from ..config import RunConfig
from ..errors import BadInput


def output_bytes(cfg: RunConfig, rrd: bool) -> int:
    """Generous estimate (bytes) of a run directory: 8 bytes per trace cell, twice with a recording, plus
    the predicted paths of the solves and 1 MB of headroom."""
    rows = cfg.n_estimator_steps
    cells = rows * 64
    solves = round(cfg.duration * cfg.controller.rate) * getattr(cfg.controller, "nodes", 0) * 3 * 4  # no plan: 0
    return cells * 8 * (2 if rrd else 1) + (solves if rrd else 0) + 2**20


def _limits(folder: Path) -> tuple[int, int]:
    """(NAME_MAX, PATH_MAX) of the file system holding ``folder`` (255, 4096 if not reported)."""
    try:
        return int(os.pathconf(folder, "PC_NAME_MAX")), int(os.pathconf(folder, "PC_PATH_MAX"))
    except (OSError, ValueError):
        return 255, 4096


def check_output_root(out_root: Path | str, run_id: str, need_bytes: int = 0) -> None:
    """Raise :class:`BadInput` (naming ``--out``) unless ``out_root`` can take a run directory named
    ``run_id``: a path the OS accepts (no NUL, components and whole path within the file system's
    limits, counting the temporary names), no file where a folder must be, the nearest existing
    folder writable (checked by creating and deleting a probe file there), and ``need_bytes`` free.
    Writes nothing that stays."""
    text = str(out_root)
    if not text.strip() or "\0" in text:
        raise BadInput(f"--out: expected a folder path, got {text[:60]!r}")
    p = Path(text).absolute()
    _check_lengths(p, run_id)
    existing = p
    try:
        while not existing.exists():
            existing = existing.parent
    except OSError as err:  # e.g. a folder on the way that may not be searched
        raise BadInput(f"--out: cannot use {text[:80]}: {err.strerror}") from None
    if not existing.is_dir():
        raise BadInput(f"--out: {existing} is a file, not a folder")
    try:
        fd, probe = tempfile.mkstemp(prefix=".ftc-mj-probe.", dir=existing)
        os.close(fd)
        os.unlink(probe)
    except OSError as err:
        raise BadInput(f"--out: cannot write in {existing}: {err.strerror}") from None
    free = shutil.disk_usage(existing).free
    if free < need_bytes:
        raise BadInput(f"--out: {free / 1e6:.1f} MB free in {existing}; the run needs about {need_bytes / 1e6:.1f} MB")


def _check_lengths(p: Path, run_id: str) -> None:
    """Path components and the longest path a run writes (its temporaries) within NAME_MAX/PATH_MAX."""
    name_max, path_max = _limits(Path("/"))
    for part in p.parts[1:]:
        if len(os.fsencode(part)) > name_max:
            raise BadInput(f"--out: a path component is longer than {name_max} bytes ({part[:40]}…)")
    temp_leaf = f".{run_id}-99.{os.getpid()}.abcdefgh.partial"
    if len(os.fsencode(temp_leaf)) > name_max:
        raise BadInput(f"--out: the run's folder name would exceed {name_max} bytes; use a shorter name")
    extra = len(os.fsencode(f"/{temp_leaf}/.trace.parquet.{os.getpid()}.abcdefgh.tmp"))
    if len(os.fsencode(str(p))) + extra >= path_max:
        raise BadInput(f"--out: the path is too long ({len(os.fsencode(str(p)))} bytes; the run's files need it "
                       f"under {path_max - extra})")
