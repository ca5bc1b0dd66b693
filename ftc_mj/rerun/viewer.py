"""Opening a recording in the native Rerun viewer (``ftc-mj view``).

The viewer is the ``rerun`` executable of the installed rerun-sdk, started as ``rerun FILE --bind
127.0.0.1``: like any native Rerun viewer it also starts its local gRPC server (port 9876 by
default), which Rerun binds to ``0.0.0.0`` (every interface) unless ``--bind`` is given.
"""

from __future__ import annotations

import os
import shlex
import shutil
import subprocess
import sys
from collections.abc import Iterable
from pathlib import Path

from ftc_mj.errors import BadInput, RunFailed


def _rerun_executable() -> str:
    """The ``rerun`` CLI of the installed rerun-sdk (next to the interpreter, else on PATH)."""
    cand = Path(sys.executable).parent / "rerun"
    if cand.exists():
        return str(cand)
    found = shutil.which("rerun")
    if found is None:
        raise RunFailed("the rerun viewer executable was not found (is rerun-sdk installed?)")
    return found


def check_recording(path: Path) -> Path:
    """The ``.rrd`` of a run directory (its ``run.rrd``) or the file itself, if Rerun can read a recording
    from it; else :class:`~ftc_mj.errors.BadInput` naming ``RUN_DIR``."""
    from rerun.chunk import RrdReader

    p = Path(path)
    try:
        if p.is_dir():
            p = p / "run.rrd"
        found = p.is_file()
    except (OSError, ValueError) as err:
        raise BadInput(f"RUN_DIR: cannot use {str(path)[:80]}: {getattr(err, 'strerror', None) or err}") from None
    if not found:
        raise BadInput(f"RUN_DIR: recording not found: {p}")
    try:
        ok = bool(RrdReader(str(p)).recordings())
    except (RuntimeError, OSError, ValueError) as err:
        raise BadInput(f"RUN_DIR: {p} is not a Rerun recording ({str(err).splitlines()[0][:100]})") from None
    if not ok:
        raise BadInput(f"RUN_DIR: {p} holds no recording")
    return p


def check_display(headless_hint: str) -> None:
    """Raise :class:`~ftc_mj.errors.RunFailed` (one line naming ``headless_hint``, the command that renders
    a screenshot instead) when the native viewer has no display to open on (Linux without ``DISPLAY``
    or ``WAYLAND_DISPLAY``)."""
    if sys.platform.startswith("linux") and not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
        raise RunFailed(f"no display for the Rerun viewer (DISPLAY is not set); for a headless screenshot run: "
                        f"{headless_hint}")


VIEWER_HOST = "127.0.0.1"
"""The address the viewer's gRPC server listens on: this machine only."""


def viewer_command(rrd: Path, extra_args: Iterable[str] = ()) -> list[str]:
    """The command line opening ``rrd`` in the native viewer, its server bound to :data:`VIEWER_HOST`."""
    return [_rerun_executable(), str(rrd), "--bind", VIEWER_HOST, *extra_args]


def screenshot_command(rrd: str, out: str = "OUT.png") -> str:
    """The shell command that renders a headless screenshot of ``rrd`` with the script shipped in the
    package (``ftc_mj/data/screenshot.sh``: Xvfb and software Vulkan), for machines without a display."""
    from ..resources import resource_path

    try:
        rerun = _rerun_executable()
    except RunFailed:
        rerun = "rerun"
    script = resource_path("screenshot.sh")
    return f"RERUN_BIN={shlex.quote(rerun)} bash {shlex.quote(str(script))} {shlex.quote(rrd)} {shlex.quote(out)}"


def open_viewer(path: Path, *, wait: bool = True, extra_args: Iterable[str] = ()) -> None:
    """Open a recording in the native Rerun viewer.

    ``path`` is a ``.rrd`` file or a run directory (its ``run.rrd`` is opened). Raises
    :class:`~ftc_mj.errors.BadInput` if the file does not exist. With ``wait`` (default) blocks until
    the viewer is closed and raises :class:`~ftc_mj.errors.RunFailed` if it exits with an error.
    """
    p = Path(path)
    if p.is_dir():
        p = p / "run.rrd"
    if not p.is_file():
        raise BadInput(f"recording not found: {p}")
    cmd = viewer_command(p, extra_args)
    if not wait:
        subprocess.Popen(cmd, start_new_session=True)
        return
    rc = subprocess.run(cmd, check=False).returncode
    if rc != 0:
        raise RunFailed(f"the Rerun viewer exited with code {rc} (no display?)")
