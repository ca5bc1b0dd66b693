"""Two real ``ftc-mj`` processes on one output folder: the second started while the first computes."""

from __future__ import annotations

import os
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


@dataclass
class Race:
    """What the two processes did."""

    first: subprocess.CompletedProcess
    """The first process, run to its end."""
    second: subprocess.CompletedProcess
    """The second, started once the first had written ``ready``."""
    overlapped: bool
    """The first was still running when the second ended: otherwise nothing was tested."""


def second_while_first_runs(args: list[str], ready: Path, timeout: float) -> Race:
    """Start ``ftc-mj ARGS``, wait (at most ``timeout`` s) until it has written the file ``ready``, run the same
    command again to its end, then let the first finish (each at most ``timeout`` s more)."""
    env = {**os.environ, "PYTHONPATH": str(ROOT), "OMP_NUM_THREADS": "1"}
    cmd = [sys.executable, "-m", "ftc_mj.cli", *args]
    first = subprocess.Popen(cmd, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + timeout
        while not ready.is_file() and first.poll() is None and time.monotonic() < deadline:
            time.sleep(0.05)
        second = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=timeout)
        overlapped = first.poll() is None
        out1, err1 = first.communicate(timeout=2 * timeout)
    finally:
        first.kill()
    return Race(subprocess.CompletedProcess(cmd, first.returncode, out1, err1), second, overlapped)
