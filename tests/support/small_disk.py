"""A real small file system for the full-disk tests: a tmpfs of a few MB (root may mount one here)."""

from __future__ import annotations

import os
import subprocess
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path


@contextmanager
def small_tmpfs(mnt: Path, size: str = "4m") -> Iterator[Path | None]:
    """Mount a ``size`` tmpfs on the new folder ``mnt`` and yield it (unmounted afterwards); ``None``
    where this process may not mount one (not root, or no mount permission in the container)."""
    mnt.mkdir()
    ok = os.geteuid() == 0 and subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs", str(mnt)],
                                              capture_output=True).returncode == 0
    try:
        yield mnt if ok else None
    finally:
        if ok:
            subprocess.run(["umount", "-l", str(mnt)], check=False)


def fill(folder: Path) -> None:
    """Write zeros into ``folder/filler`` until its file system is full (to the last byte)."""
    with open(folder / "filler", "ab", buffering=0) as fh:
        for chunk in (65536, 1):
            try:
                while True:
                    fh.write(b"\0" * chunk)
            except OSError:
                pass
